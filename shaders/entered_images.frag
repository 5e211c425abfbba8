#version 430 core
// Which of a mirror's baked images this frame's reflected rays may enter (methods/entered_images.py),
// before the images are baked: a bit per image, set where a mirror pixel's ray, the mirror
// shader's own (lib/mirror_ray.glsl, from the same surface targets), enters the bound the mirror
// shader tests before it reads the image (lib/reflected_scene.glsl's image_bound: the hits' bound,
// or WHOLE_BOUNDS where the method reads more than the hits), widened a little. An image no
// ray enters is read by no pixel of the frame: its bake can wait. Drawn over the mirror's screen
// rectangle (screen_rect.vert), as the deferred mirror shader is.
#include "lib/common.glsl"
#include "lib/baked_images.glsl"
#include "lib/mirror_ray.glsl"

uniform sampler2D u_surface_position;  // (world position, reflector's object id + 1; 0: none)
uniform sampler2D u_surface_normal;    // (interpolated world normal, 2 stamp + 1 on a front face)
uniform int u_surface_stamp;
uniform vec3 u_eye;
uniform int u_mirror_id;
uniform int u_first_word;  // this mirror's first word of the bits

layout(std430, binding = STORAGE_ENTERED_IMAGES) buffer EnteredImages {
    uint u_entered[];
};

#ifdef WHOLE_BOUNDS
#define ENTERED_BOUND bound
#else
#define ENTERED_BOUND hit_bound
#endif

// The bound widened by a thousandth (and a little more): this program and the mirror shader are
// compiled apart, and may round the same ray a last bit differently; a ray grazing a bound then
// still marks it.
vec4 widened(vec4 bound) {
    return vec4(bound.xyz, bound.w * 1.001 + 1e-6);
}

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec4 surface = texelFetch(u_surface_position, pixel, 0);
    int stamp_and_facing = int(texelFetch(u_surface_normal, pixel, 0).w);
    // Another reflector's pixel, none, or a mirror's back (its backing: no ray).
    if (int(surface.w) != u_mirror_id + 1 || stamp_and_facing / 2 != u_surface_stamp || (stamp_and_facing & 1) == 0)
        discard;
    vec3 view = view_direction(surface.xyz, u_eye);
    vec3 normal = eye_facing_normal(texelFetch(u_surface_normal, pixel, 0).xyz, view);
    vec3 direction = reflect(view, normal);
    float inverse_square_length = 1.0 / dot(direction, direction);
    ivec2 list = image_list(surface.xyz, direction);
    for (int k = 0; k < DEPTH_IMAGE_CAPACITY; ++k) {
        if (k >= list.y - list.x) break;
        int j = u_image_cells[list.x + k];
        if (bound_entry(widened(u_depth_images[j].ENTERED_BOUND), surface.xyz, direction, inverse_square_length)
            < UNBOUNDED_RAY)
            atomicOr(u_entered[u_first_word + (j >> 5)], 1u << uint(j & 31));
    }
    discard;  // nothing drawn: the bits are the output
}
