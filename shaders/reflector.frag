#version 330 core
// A mirror: the reflected ray of each pixel, from the interpolated normal, traced against this
// mirror's depth images, the analytic planes and the environment. A mirror reflects on its front
// side alone, as a real one: its back faces are its backing, a matte grey shaded like any diffuse
// surface (truth.py's MIRROR_BACKING_ALBEDO). The GLASS variant draws glass: the same reflected
// ray, blended with the refracted one (lib/glass.glsl), on both sides (the eye may be inside).
#include "lib/common.glsl"
#include "lib/reflected_scene.glsl"
#include "lib/mirror_ray.glsl"
#ifdef GLASS
#include "lib/glass.glsl"
#endif

uniform vec3 u_eye;
uniform vec3 u_tint;  // a mirror's, or the light a glass transmits

#ifdef DEFERRED
// The reflector's surface, from the deferred pass's first half (reflector_surface.frag), drawn
// over the reflector's screen rectangle (screen_rect.vert).
uniform sampler2D u_surface_position;  // (world position, reflector's object id + 1; 0: none)
uniform sampler2D u_surface_normal;    // (interpolated world normal, 2 stamp + 1 on a front face)
uniform int u_surface_stamp;           // this frame's (reflector_surface.frag)
// Set from the textures at main's start; initialised here as well because Mesa's flow analysis,
// which does not see that main assigns them before any use, warns "used uninitialized".
vec3 v_world_position = vec3(0.0);
vec3 v_world_normal = vec3(0.0, 0.0, 1.0);
bool front_facing = false;
#else
in vec3 v_world_position;
in vec3 v_local_position;
in vec3 v_world_normal;
#define front_facing gl_FrontFacing
#endif

uniform int u_mirror_id;
#ifdef GLOSSY
uniform float u_roughness;  // the mirror's GGX roughness (0: sharp; glass: 0), lib/glossy.glsl
#endif
#if METHOD == METHOD_HYBRID
// The viewer's view of where the depth images could not answer: those rays tinted magenta.
uniform bool u_tint_retraced;
#endif
#ifndef GLASS
uniform float u_backing_albedo;  // grey, written by passes/reflectors.py from truth.py
#endif

layout(location = 0) out vec4 out_color;
#ifdef WRITE_DEPTH_IMAGE
// Baking a depth image of this mirror for another mirror's reflections of reflections
// (methods/bounces.py): the window depth and the object id, as diffuse.frag writes them.
layout(location = 1) out vec2 out_depth_and_object;
#endif
#ifdef WRITE_REFLECTION_DATA
// For comparisons against the ray-traced truth: the reflected ray and what it hit.
layout(location = 1) out vec4 out_ray_origin;     // (origin, mirror's object id + 1): 0 outside mirrors
layout(location = 2) out vec4 out_ray_direction;  // (unit direction, object id hit or NO_OBJECT)
layout(location = 3) out vec4 out_hit_position;   // (world position of the hit, 1 if hit)
layout(location = 4) out vec4 out_normal;         // (the unit normal facing the eye, 1 if re-traced)
#endif
#ifdef COUNT_SAMPLES
// For the benchmark alone: the samples (depth-image texels, BVH nodes) this ray read. The
// location follows the reflection outputs when they are there (passes/reflectors.py).
layout(location = COUNT_SAMPLES) out float out_samples;
#endif

#ifndef GLASS
// A back face of a mirror: its backing, lit as diffuse.frag lights a surface, with the normal
// facing the eye. It is no mirror pixel: its reflection outputs are those outside the mirrors
// (all zero, as cleared); in a depth image it is this object's surface like any other.
void write_backing(vec3 normal) {
    out_color = vec4(shade(vec3(u_backing_albedo), v_world_position, normal), 1.0);
#ifdef WRITE_DEPTH_IMAGE
    out_depth_and_object = vec2(gl_FragCoord.z, float(u_mirror_id));
#endif
#ifdef WRITE_REFLECTION_DATA
    out_ray_origin = vec4(0.0);
    out_ray_direction = vec4(0.0);
    out_hit_position = vec4(0.0);
    out_normal = vec4(0.0);
#endif
#ifdef COUNT_SAMPLES
    out_samples = 0.0;
#endif
}
#endif

void main() {
#ifdef DEFERRED
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec4 surface = texelFetch(u_surface_position, pixel, 0);
    // Another reflector's pixel, or none: this pass leaves it as it is.
    vec4 surface_normal = texelFetch(u_surface_normal, pixel, 0);
    int stamp_and_facing = int(surface_normal.w);
    // Another reflector's pixel, or one no reflector covers this frame: left as it is.
    if (int(surface.w) != u_mirror_id + 1 || stamp_and_facing / 2 != u_surface_stamp) discard;
    v_world_position = surface.xyz;
    v_world_normal = surface_normal.xyz;
    front_facing = (stamp_and_facing & 1) == 1;
#endif
    vec3 view = view_direction(v_world_position, u_eye);
    vec3 normal = eye_facing_normal(v_world_normal, view);
#ifndef GLASS
    // GL's front faces are the outward ones: the passes draw mirrors with front_face set for
    // their flipped projections (passes/reflectors.py, outward_faces_front).
    if (!front_facing) {
        write_backing(normal);
        return;
    }
#endif
    vec3 direction = reflect(view, normal);
#ifdef GLOSSY
    g_cone_tan = cone_spread(u_roughness);
#endif
    RayHit hit = trace_reflected(v_world_position, direction);
#ifdef GLASS
    out_color = vec4(glass_color(v_world_position, view, normal, hit.color, u_tint, hit.samples), 1.0);
#else
    out_color = vec4(u_tint * hit.color, 1.0);
#endif
#if METHOD == METHOD_HYBRID
    if (u_tint_retraced && hit.retraced) out_color.rgb = mix(out_color.rgb, vec3(1.0, 0.0, 1.0), 0.6);
#endif
#ifdef WRITE_DEPTH_IMAGE
    out_depth_and_object = vec2(gl_FragCoord.z, float(u_mirror_id));
#endif
#ifdef WRITE_REFLECTION_DATA
    out_ray_origin = vec4(v_world_position, float(u_mirror_id + 1));
    out_ray_direction = vec4(direction, hit.hit ? hit.object_id : float(NO_OBJECT));
    out_hit_position = vec4(v_world_position + direction * hit.t, hit.hit ? 1.0 : 0.0);
    out_normal = vec4(normal, hit.retraced ? 1.0 : 0.0);
#endif
#ifdef COUNT_SAMPLES
    out_samples = float(hit.samples);
#endif
}
