// Shadows from depth images taken from the lights (passes/shadows.py): a light's visibility from a
// shaded point is found by intersecting rays between them with the light's depth image, the
// same march a reflected ray makes through a mirror's depth images. Each ray runs from the light
// to the point, away from the image's eye as the image's own rays do, so that it meets a caster
// through its visible surface (or inside its solid run) and the march's rules hold unchanged.
#include "depth_image.glsl"
#include "lighting.glsl"
#include "../generated/soft_shadow_disk.glsl"

layout(std140) uniform ShadowMaps {
    DepthImage u_shadow_maps[MAX_LIGHTS];  // light i's shadow map (unused for lights without shadows)
};
uniform sampler2D u_shadow_depth;  // every shadow map's layers (RG32F), one tile each

// Does a caster lie between the light point `from` and the point `to`? t <= 1 bounds the march
// to the segment: what lies behind the point casts nothing on it.
bool segment_blocked(DepthImage map, vec3 from, vec3 to) {
    // No back colours: a ray from the light never comes from behind a caster's back face.
    return intersect_optimized(u_shadow_depth, false, map, from, to - from, 1.0, UNBOUNDED_RAY).hit;
}

// Two unit vectors completing the unit vector n to an orthonormal frame, as lights.py's
// orthonormal_basis (Duff et al. 2017): soft shadows aim at the same disk points as the truth.
void orthonormal_basis(vec3 n, out vec3 first, out vec3 second) {
    float sign = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (sign + n.z);
    float b = n.x * n.y * a;
    first = vec3(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    second = vec3(b, sign + n.y * n.y * a, -n.y);
}

// The share of light `light` that reaches `position` (surface normal `normal`, facing the light).
float light_visibility(int light, vec3 position, vec3 normal) {
    int kind = u_lighting.lights[light].shadows;
    if (kind == SHADOW_NONE) return 1.0;
    DepthImage map = u_shadow_maps[light];
    // One texel's width at the point's distance from the light (w), for the normal offset.
    float w = camera_coordinates(map, position - map.eye.xyz).z;
    float texel = max(length(map.a.xyz), length(map.b.xyz)) * max(w, 0.0);
    vec3 origin = position + normal * (SHADOW_NORMAL_OFFSET_TEXELS * texel);
    vec3 centre = map.eye.xyz;
    if (kind == SHADOW_HARD) return segment_blocked(map, centre, origin) ? 0.0 : 1.0;
    vec3 first, second;
    orthonormal_basis(safe_normalize(centre - origin, vec3(0.0, 1.0, 0.0)), first, second);
    int reaching = 0;
    for (int k = 0; k < SOFT_SHADOW_RAYS; ++k) {
        vec2 disk = SOFT_SHADOW_DISK[k] * u_lighting.lights[light].radius;
        if (!segment_blocked(map, centre + first * disk.x + second * disk.y, origin)) reaching += 1;
    }
    return float(reaching) / float(SOFT_SHADOW_RAYS);
}
