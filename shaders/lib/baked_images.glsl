// Images baked from a mirror's centre, in one atlas: the depth images of the depth-image method,
// and the cube-map faces and billboard textures of the lecture's other stand-ins. Each is a
// DepthImage record (a camera, its depth range and its tile in the atlas); the method decides
// what the images show and what the second atlas layer holds.
#include "../generated/depth_image.glsl"
#include "ray_hit.glsl"

// One mirror's images, from its uniform buffer.
layout(std140) uniform DepthImages {
    DepthImage u_depth_images[MAX_DEPTH_IMAGES_PER_REFLECTOR];
};
uniform int u_depth_image_count;

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

// The sample under image point s. Clipped endpoints lie on the frustum's sides, where s.x can be
// exactly width (or a rounding step outside [0, width]): clamp to the image's own texels.
ivec2 texel_of(DepthImage image, vec2 s) {
    ivec2 texel = clamp(ivec2(floor(s)), ivec2(0), image.tile.zw - 1);
    return image.tile.xy + texel;
}

