#version 430 core
// SSR's min-depth pyramid (methods/screen_space.py): level 0 holds the w (distance along the eye's
// axis) of the surface each frame pixel shows, SSR_NOTHING where it shows the sky or lies outside
// the frame (the texture is a power-of-two square covering it); level k the least of the 2 x 2
// cells below, so that a ray in front of a cell's least w meets nothing the eye saw in it.
layout(local_size_x = 8, local_size_y = 8) in;

uniform int u_level;                 // the level written
uniform sampler2D u_screen_surface;  // level 0's source: world position and object id + 1 (0: sky)
uniform vec3 u_ssr_eye;
uniform mat3 u_ssr_inverse;

layout(r32f, binding = IMAGE_PYRAMID_SOURCE) uniform readonly image2D u_source;   // level - 1
layout(r32f, binding = IMAGE_PYRAMID_TARGET) uniform writeonly image2D u_target;  // level u_level

void main() {
    ivec2 cell = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(cell, imageSize(u_target)))) return;
    float w = SSR_NOTHING;
    if (u_level == 0) {
        if (all(lessThan(cell, textureSize(u_screen_surface, 0)))) {
            vec4 surface = texelFetch(u_screen_surface, cell, 0);
            if (surface.w > 0.5) w = (u_ssr_inverse * (surface.xyz - u_ssr_eye)).z;
        }
    } else {
        ivec2 below = 2 * cell;
        w = min(min(imageLoad(u_source, below).r, imageLoad(u_source, below + ivec2(1, 0)).r),
                min(imageLoad(u_source, below + ivec2(0, 1)).r, imageLoad(u_source, below + ivec2(1, 1)).r));
    }
    imageStore(u_target, cell, vec4(w));
}
