#version 330 core
// The background of the camera view: the environment in the direction of each pixel's ray.
#include "lib/common.glsl"
#include "lib/environment.glsl"

// The camera's PPC vectors: the ray through window pixel (u, v) is a u + b v + c (window y = v).
uniform vec3 u_camera_a;
uniform vec3 u_camera_b;
uniform vec3 u_camera_c;

out vec4 out_color;

void main() {
    vec3 direction = u_camera_a * gl_FragCoord.x + u_camera_b * gl_FragCoord.y + u_camera_c;
    out_color = vec4(environment(direction), 1.0);
}
