#version 330 core
// A mirror: the reflected ray of each pixel, from the interpolated normal, traced against this
// mirror's depth images, the analytic planes and the environment.
#include "lib/common.glsl"
#include "lib/reflected_scene.glsl"

uniform vec3 u_eye;
uniform vec3 u_tint;

in vec3 v_world_position;
in vec3 v_local_position;
in vec3 v_world_normal;

out vec4 out_color;

void main() {
    vec3 view = safe_normalize(v_world_position - u_eye, vec3(0.0, 0.0, -1.0));
    vec3 normal = safe_normalize(v_world_normal, -view);
    // A mirror seen from behind (a planar mirror's back) reflects on that side too.
    normal = faceforward(normal, view, normal);
    RayHit hit = trace_reflected(v_world_position, reflect(view, normal));
    out_color = vec4(u_tint * hit.color, 1.0);
}
