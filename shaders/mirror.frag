#version 330 core
// A mirror: the reflected ray of each pixel, from the interpolated normal, traced against this
// mirror's depth images, the analytic planes and the environment. The GLASS variant draws glass:
// the same reflected ray, blended with the refracted one (lib/glass.glsl).
#include "lib/common.glsl"
#include "lib/reflected_scene.glsl"
#ifdef GLASS
#include "lib/glass.glsl"
#endif

uniform vec3 u_eye;
uniform vec3 u_tint;  // a mirror's, or the light a glass transmits

in vec3 v_world_position;
in vec3 v_local_position;
in vec3 v_world_normal;

uniform int u_mirror_id;

layout(location = 0) out vec4 out_color;
#ifdef WRITE_DEPTH_IMAGE
// Baking a depth image of this mirror for another mirror's reflections of reflections
// (passes/bounces.py): the window depth and the object id, as diffuse.frag writes them.
layout(location = 1) out vec2 out_depth_and_object;
#endif
#ifdef WRITE_REFLECTION_DATA
// For comparisons against the ray-traced truth: the reflected ray and what it hit.
layout(location = 1) out vec4 out_ray_origin;     // (origin, mirror's object id + 1): 0 outside mirrors
layout(location = 2) out vec4 out_ray_direction;  // (unit direction, object id hit or NO_OBJECT)
layout(location = 3) out vec4 out_hit_position;   // (world position of the hit, 1 if hit)
layout(location = 4) out vec4 out_normal;         // (the unit normal facing the eye, 0)
#endif
#ifdef COUNT_SAMPLES
// For the benchmark alone: the samples (depth-image texels, BVH nodes) this ray read. The
// location follows the reflection outputs when they are there (passes/mirrors.py).
layout(location = COUNT_SAMPLES) out float out_samples;
#endif

void main() {
    vec3 view = safe_normalize(v_world_position - u_eye, vec3(0.0, 0.0, -1.0));
    vec3 normal = safe_normalize(v_world_normal, -view);
    // A mirror seen from behind (a planar mirror's back) reflects on that side too.
    normal = faceforward(normal, view, normal);
    vec3 direction = reflect(view, normal);
    RayHit hit = trace_reflected(v_world_position, direction);
#ifdef GLASS
    out_color = vec4(glass_color(v_world_position, view, normal, hit.color, u_tint, hit.samples), 1.0);
#else
    out_color = vec4(u_tint * hit.color, 1.0);
#endif
#ifdef WRITE_DEPTH_IMAGE
    out_depth_and_object = vec2(gl_FragCoord.z, float(u_mirror_id));
#endif
#ifdef WRITE_REFLECTION_DATA
    out_ray_origin = vec4(v_world_position, float(u_mirror_id + 1));
    out_ray_direction = vec4(direction, hit.hit ? hit.object_id : float(NO_OBJECT));
    out_hit_position = vec4(v_world_position + direction * hit.t, hit.hit ? 1.0 : 0.0);
    out_normal = vec4(normal, 0.0);
#endif
#ifdef COUNT_SAMPLES
    out_samples = float(hit.samples);
#endif
}
