#version 430 core
// One level of the min/max depth pyramid (methods/pyramid.py explains the footprints and the
// layout): level 1 from the depth images' texels, every coarser level from the one below.
#include "lib/solid_run.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

// Each slot's depth image in the atlas: (x, y, width, height), in slot order.
layout(std430, binding = STORAGE_PYRAMID_TILES) readonly buffer Tiles {
    ivec4 u_tiles[];
};
uniform int u_tile_count;
uniform int u_columns;     // slots per row, as in the atlas
uniform int u_slot_pitch;  // level-1 texels per slot and axis
uniform int u_level;       // the level written (1 = the texture's mip 0)

layout(rg32f, binding = IMAGE_PYRAMID_SOURCE) uniform readonly image2D u_source;   // level 1: the depth atlas; else level - 1
layout(rg32f, binding = IMAGE_PYRAMID_TARGET) uniform writeonly image2D u_target;  // level u_level

const vec2 EMPTY_SPAN = vec2(EMPTY_SPAN_MIN, EMPTY_SPAN_MAX);

vec2 combine(vec2 a, vec2 b) {
    return vec2(min(a.x, b.x), max(a.y, b.y));
}

// Texels of an image of `size` at `level`: every level halves, rounding up.
ivec2 level_size(ivec2 size, int level) {
    return (size + (1 << level) - 1) >> level;
}

vec2 texel_span(ivec2 texel) {
    vec2 layers = imageLoad(u_source, texel).rg;
    return layers.x >= BACKGROUND_DEPTH ? EMPTY_SPAN : solid_run(layers);
}

// Level 1: the image's texels [2c - 1, 2c + 2] on each axis, clipped to the image.
vec2 first_level_span(ivec4 tile, ivec2 cell) {
    ivec2 low = max(2 * cell - 1, ivec2(0));
    ivec2 high = min(2 * cell + 2, tile.zw - 1);
    vec2 span = EMPTY_SPAN;
    for (int y = low.y; y <= high.y; ++y) {
        for (int x = low.x; x <= high.x; ++x) span = combine(span, texel_span(tile.xy + ivec2(x, y)));
    }
    return span;
}

// Coarser levels: the (up to) 2 x 2 children of the level below that exist. A child beyond the
// image's edge (odd sizes) would cover no texel of it that its sibling does not: skipping it
// is exact.
vec2 coarse_span(ivec4 tile, ivec2 slot, ivec2 cell) {
    ivec2 below = level_size(tile.zw, u_level - 1);
    ivec2 origin = slot * (u_slot_pitch >> (u_level - 2));
    vec2 span = EMPTY_SPAN;
    for (int dy = 0; dy < 2; ++dy) {
        for (int dx = 0; dx < 2; ++dx) {
            ivec2 child = 2 * cell + ivec2(dx, dy);
            if (all(lessThan(child, below))) span = combine(span, imageLoad(u_source, origin + child).rg);
        }
    }
    return span;
}

void main() {
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(texel, imageSize(u_target)))) return;
    int pitch = u_slot_pitch >> (u_level - 1);
    ivec2 slot = texel / pitch;
    int index = slot.y * u_columns + slot.x;
    ivec2 cell = texel - slot * pitch;
    vec2 span = EMPTY_SPAN;
    if (slot.x < u_columns && index < u_tile_count) {
        ivec4 tile = u_tiles[index];
        if (all(lessThan(cell, level_size(tile.zw, u_level)))) {
            span = u_level == 1 ? first_level_span(tile, cell) : coarse_span(tile, slot, cell);
        }
    }
    imageStore(u_target, texel, vec4(span, 0.0, 0.0));
}
