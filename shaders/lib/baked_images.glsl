// Images baked from a mirror's centre, in one atlas: the depth images of the depth-image method,
// and the cube-map faces and billboard textures of the lecture's other stand-ins. Each is a
// DepthImage record (a camera, its depth range and its tile in the atlas); the method decides
// what the images show and what the second atlas layer holds.
#include "../generated/depth_image.glsl"
#include "ray_hit.glsl"

// One mirror's images: DEPTH_IMAGE_CAPACITY records (constants.depth_image_capacity, from the
// scene's size; the mirror shader's loop bound), in a uniform block where they fit GL 3.3's
// guaranteed 16 KiB, else in a storage buffer (GL 4.3: ARB_shader_storage_buffer_object, which
// the program's prefix enables for NEEDS_STORAGE_BLOCKS). std430 lays a struct of vec4s out as
// std140 does: one numpy record type fills either.
#ifndef DEPTH_IMAGE_CAPACITY
#define DEPTH_IMAGE_CAPACITY DEPTH_IMAGE_BLOCK_RECORDS
#endif
#if DEPTH_IMAGE_CAPACITY > DEPTH_IMAGE_BLOCK_RECORDS
// Past the records, where IMAGE_CELLS finds them through lists of candidates by ray
// (methods/image_cells.py): how the lists are laid out, then the start of each cell's list (and one
// past the last), then the lists.
layout(std430) readonly buffer DepthImages {
    DepthImage u_depth_images[DEPTH_IMAGE_CAPACITY];
    ImageGrid u_image_grid;
    int u_image_cells[];
};
#else
layout(std140) uniform DepthImages {
    DepthImage u_depth_images[DEPTH_IMAGE_CAPACITY];
};
#endif
uniform int u_depth_image_count;

#ifdef IMAGE_CELLS
// The list of the images a ray may enter, as (its start in u_image_cells, one past its end): the
// list of the cell of lines the ray lies in (methods/image_cells.py, whose ray_cells is this in
// numpy), or, for a ray that does not start in the sphere the lists were made for, the list of
// every image.
ivec2 image_list(vec3 origin, vec3 direction) {
    vec4 sphere = u_image_grid.sphere;
    ivec4 size = u_image_grid.size;  // cells per side of a face's directions, of its offsets; cells; images
    vec3 p = origin - sphere.xyz;
    vec3 m = abs(direction);
    int axis = m.x >= m.y && m.x >= m.z ? 0 : m.y >= m.z ? 1 : 2;
    // The face's axis first, then its u and v axes (image_cells.FACE_AXES).
    vec3 d = axis == 0 ? direction : axis == 1 ? direction.yzx : direction.zxy;
    vec3 o = axis == 0 ? p : axis == 1 ? p.yzx : p.zxy;
    float s = d.x >= 0.0 ? 1.0 : -1.0;
    vec2 uv = d.yz / (s * d.x);
    vec2 q = o.yz - (s * o.x) * uv;  // where the ray's line crosses the plane of depth 0
    float extent = 2.0 * sphere.w;
    bool inside = sphere.w > 0.0 && dot(p, p) <= sphere.w * sphere.w && all(lessThanEqual(abs(q), vec2(extent)));
    ivec2 direction_cell = clamp(ivec2(floor((uv + 1.0) * (0.5 * float(size.x)))), ivec2(0), ivec2(size.x - 1));
    ivec2 offset_cell = clamp(ivec2(floor((q + extent) / (2.0 * extent) * float(size.y))), ivec2(0), ivec2(size.y - 1));
    int face = 2 * axis + (s < 0.0 ? 1 : 0);
    int cell = (((face * size.x + direction_cell.x) * size.x + direction_cell.y) * size.y + offset_cell.x) * size.y
               + offset_cell.y;
    cell = inside ? cell : size.z;
    return ivec2(u_image_cells[cell], u_image_cells[cell + 1]);
}
#endif

uniform sampler2D u_impostor_color;  // atlas of every image's colours (RGBA8; alpha 0 = nothing)
// Atlas of their OpenGL window depths (RG32F): R the visible surface, G the method's second layer
// (depth images: the nearest back face; cube maps: the visible surface's object id); 1.0 = nothing.
uniform sampler2D u_impostor_depth;
// Depth images: the colour of the back layer, where a ray may come in (RGBA8; alpha 0: none drawn).
uniform sampler2D u_impostor_back_color;

// (u w, v w, w) of a world-space vector: [a b c]^-1 applied row by row.
vec3 camera_coordinates(DepthImage image, vec3 world_vector) {
    return vec3(dot(image.inverse_row0.xyz, world_vector),
                dot(image.inverse_row1.xyz, world_vector),
                dot(image.inverse_row2.xyz, world_vector));
}

float opengl_depth(DepthImage image, float w) {
    float w_near = image.depth_range.x, w_far = image.depth_range.y;
    return w_far * (w - w_near) / (w * (w_far - w_near));
}

float w_from_opengl_depth(DepthImage image, float depth) {
    float w_near = image.depth_range.x, w_far = image.depth_range.y;
    return 1.0 / (1.0 / w_near - depth * (1.0 / w_near - 1.0 / w_far));
}

vec3 unproject(DepthImage image, vec2 s, float w) {
    return image.eye.xyz + (image.a.xyz * s.x + image.b.xyz * s.y + image.c.xyz) * w;
}

#if defined(GLOSSY) && METHOD != METHOD_HYBRID
#include "cone.glsl"

// The images' colours prefiltered (methods/colour_mips.py): RGBA16F, premultiplied by coverage;
// mip m holds level m + 1 of every image, from `pyramid.xy >> m`.
uniform sampler2D u_impostor_color_mips;

// Premultiplied colour of `image` at level `level` around image point s, filtered bilinearly
// within the image (texels beyond its edge are clamped to it, never a neighbour's).
vec4 colour_level(DepthImage image, vec2 s, int level) {
    ivec2 size = (image.tile.zw + (1 << level) - 1) >> level;
    vec2 p = s / float(1 << level) - 0.5;
    vec2 base = floor(p);
    vec2 f = p - base;
    vec4 texels[4];
    for (int k = 0; k < 4; ++k) {
        ivec2 texel = clamp(ivec2(base) + ivec2(k & 1, k >> 1), ivec2(0), size - 1);
        if (level == 0) {
            vec4 c = texelFetch(u_impostor_color, image.tile.xy + texel, 0);
            texels[k] = vec4(c.rgb * c.a, c.a);
        } else {
            texels[k] = texelFetch(u_impostor_color_mips, (image.pyramid.xy >> (level - 1)) + texel, level - 1);
        }
    }
    return mix(mix(texels[0], texels[1], f.x), mix(texels[2], texels[3], f.x), f.y);
}

// The colour a glossy mirror's cone sees where its axis meets `image`'s surface at `offset`
// from the image's eye, t along the ray: the level whose texel is as wide as the cone's footprint
// there (2 t tan, over a texel's width |a| w at the point's depth w), trilinearly, divided by
// its coverage, which g_cone_coverage keeps. `sharp` (the hit's own texel) where the footprint is
// under a texel.
vec3 cone_color(DepthImage image, vec3 offset, float t, vec3 sharp) {
    vec3 projected = camera_coordinates(image, offset);
    float texels = 2.0 * t * g_cone_tan / (length(image.a.xyz) * max(projected.z, 1e-30));
    g_cone_coverage = 1.0;
    if (!(texels > 1.0)) return sharp;
    float level = min(log2(texels), float(image.pyramid.z));
    vec2 s = projected.xy / projected.z;
    int low = int(floor(level));
    vec4 color = mix(colour_level(image, s, low), colour_level(image, s, min(low + 1, image.pyramid.z)),
                     level - float(low));
    if (!(color.a > 0.0)) return sharp;
    g_cone_coverage = min(color.a, 1.0);
    return color.rgb / color.a;
}
#endif

// The sample under image point s. Clipped endpoints lie on the frustum's sides, where s.x can be
// exactly width (or a rounding step outside [0, width]): clamp to the image's own texels.
ivec2 texel_of(DepthImage image, vec2 s) {
    ivec2 texel = clamp(ivec2(floor(s)), ivec2(0), image.tile.zw - 1);
    return image.tile.xy + texel;
}


// Where origin + t * direction enters the image's bound (DepthImage.bound: a sphere around every
// point the image can answer a ray with), or UNBOUNDED_RAY where it misses it (and where the
// direction is zero, which is no ray); `inverse_square_length` is 1 / |direction|^2, which the
// caller computes once for all the images. The chord is found from the ray's closest approach to
// the centre, not from |origin - centre|^2 - r^2, which loses every digit for a small bound far away.
float bound_entry(vec4 bound, vec3 origin, vec3 direction, float inverse_square_length) {
    vec3 to_origin = origin - bound.xyz;
    float closest = -dot(to_origin, direction) * inverse_square_length;
    vec3 offset = to_origin + direction * closest;
    float half_chord_squared = (bound.w * bound.w - dot(offset, offset)) * inverse_square_length;
    float half_chord = sqrt(max(half_chord_squared, 0.0));
    // Written so that NaN (a zero direction: 0 * Inf) fails it.
    bool met = half_chord_squared >= 0.0 && closest + half_chord >= 0.0;
    return met ? max(closest - half_chord, 0.0) : UNBOUNDED_RAY;
}
