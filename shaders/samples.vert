#version 330 core
// The lecture's sample visualization: each sample of a depth image drawn as a splat at the 3-D
// point it stands for, as large as the patch of surface it covers. Gaps, stretched silhouettes
// and undersampled slopes show up as they are.
#include "lib/baked_images.glsl"

uniform int u_image_index;
uniform mat4 u_view_projection;
// The viewing camera's pixel size at w = 1: a length L at clip w spans L / (u_pixel_size w) pixels.
uniform float u_pixel_size;

out vec3 v_color;

void main() {
    DepthImage image = u_depth_images[u_image_index];
    ivec2 local = ivec2(gl_VertexID % image.tile.z, gl_VertexID / image.tile.z);
    ivec2 texel = image.tile.xy + local;
    float depth = texelFetch(u_impostor_depth, texel, 0).r;
    v_color = texelFetch(u_impostor_color, texel, 0).rgb;
    if (depth >= BACKGROUND_DEPTH) {
        // Nothing was rasterized here: a point outside the clip volume is discarded.
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
        gl_PointSize = 1.0;
        return;
    }
    float w = w_from_opengl_depth(image, depth);
    gl_Position = u_view_projection * vec4(unproject(image, vec2(local) + 0.5, w), 1.0);
    // A sample covers |a| w by |b| w of surface facing its eye (a and b are one pixel at w = 1).
    float footprint = max(length(image.a.xyz), length(image.b.xyz)) * w;
    gl_PointSize = clamp(footprint / (u_pixel_size * gl_Position.w), 1.0, 64.0);
}
