#version 430 core
// One level of the baked images' colour mips (methods/colour_mips.py explains the averages and
// the layout, the depth pyramid's): level 1 from the atlas's colour, every coarser level from the
// one below. Colours are premultiplied by coverage (A).

layout(local_size_x = 8, local_size_y = 8) in;

// Each slot's image in the atlas: (x, y, width, height), in slot order.
layout(std430, binding = STORAGE_PYRAMID_TILES) readonly buffer Tiles {
    ivec4 u_tiles[];
};
uniform int u_tile_count;
uniform int u_columns;     // slots per row, as in the atlas
uniform int u_slot_pitch;  // level-1 texels per slot and axis
uniform int u_level;       // the level written (1 = the texture's mip 0)

layout(rgba8, binding = IMAGE_COLOUR_ATLAS) uniform readonly image2D u_atlas;       // level 1's source
layout(rgba16f, binding = IMAGE_PYRAMID_SOURCE) uniform readonly image2D u_source;  // level u_level - 1
layout(rgba16f, binding = IMAGE_PYRAMID_TARGET) uniform writeonly image2D u_target;  // level u_level

// Texels of an image of `size` at `level`: every level halves, rounding up.
ivec2 level_size(ivec2 size, int level) {
    return (size + (1 << level) - 1) >> level;
}

// The (up to) 2 x 2 children of `cell` that exist at the level below (`below` texels), averaged:
// a child beyond an odd image's edge is left out rather than counted as empty background.
vec4 children_average(ivec2 origin, ivec2 cell, ivec2 below) {
    vec4 sum = vec4(0.0);
    float count = 0.0;
    for (int dy = 0; dy < 2; ++dy) {
        for (int dx = 0; dx < 2; ++dx) {
            ivec2 child = 2 * cell + ivec2(dx, dy);
            if (any(greaterThanEqual(child, below))) continue;
            vec4 texel;
            if (u_level == 1) {
                texel = imageLoad(u_atlas, origin + child);
                texel.rgb *= texel.a;  // the atlas's alpha: 1 where an object was drawn
            } else {
                texel = imageLoad(u_source, origin + child);
            }
            sum += texel;
            count += 1.0;
        }
    }
    return count > 0.0 ? sum / count : vec4(0.0);
}

void main() {
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(texel, imageSize(u_target)))) return;
    int pitch = u_slot_pitch >> (u_level - 1);
    ivec2 slot = texel / pitch;
    int index = slot.y * u_columns + slot.x;
    ivec2 cell = texel - slot * pitch;
    vec4 color = vec4(0.0);
    if (slot.x < u_columns && index < u_tile_count) {
        ivec4 tile = u_tiles[index];
        if (all(lessThan(cell, level_size(tile.zw, u_level)))) {
            ivec2 origin = u_level == 1 ? tile.xy : slot * (u_slot_pitch >> (u_level - 2));
            color = children_average(origin, cell, level_size(tile.zw, u_level - 1));
        }
    }
    imageStore(u_target, texel, color);
}
