#version 330 core
// The GPU ray query: the mirror pass's intersection code run on arrays of rays, one per pixel of
// the output, so that tests and tools can hold it against depthimpostor.reference.
#include "lib/common.glsl"
#include "lib/reflected_scene.glsl"

uniform sampler2D u_ray_origins;     // RGBA32F, xyz
uniform sampler2D u_ray_directions;  // RGBA32F, xyz

layout(location = 0) out vec4 out_hit;    // (hit, t, u, v)
layout(location = 1) out vec4 out_color;  // (r, g, b, object id)
layout(location = 2) out vec4 out_stats;  // (samples read, unseen_t, UNSEEN_* kind, 0)

void main() {
    ivec2 texel = ivec2(gl_FragCoord.xy);
    vec3 origin = texelFetch(u_ray_origins, texel, 0).xyz;
    vec3 direction = texelFetch(u_ray_directions, texel, 0).xyz;
    RayHit hit = nearest_depth_image_hit(origin, direction, UNBOUNDED_RAY);
    out_hit = vec4(hit.hit ? 1.0 : 0.0, hit.t, hit.image_position);
    out_color = vec4(hit.color, hit.object_id);
    out_stats = vec4(float(hit.samples), hit.unseen_t, float(hit.unseen), 0.0);
}
