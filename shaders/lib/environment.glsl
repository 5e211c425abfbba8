// What a ray sees when it hits nothing: a vertical gradient (a constant environment is the
// gradient with three equal colours), or (ENVIRONMENT_MAP) an equirectangular HDR image.
// Mirrored by depthimpostor.truth (`environment`, `equirect_lookup`) for the ray tracer, which
// reads the same texels with the same filter. The values are the Lights block's; the map is a texture.
#include "lighting.glsl"

#ifdef ENVIRONMENT_MAP
// RGB32F (RGBA32F with its prefiltered levels below it: ENVIRONMENT_LIGHTING), row 0 at the zenith;
// read texel by texel, never filtered by GL.
uniform sampler2D u_env_map;

const float ENV_PI = 3.14159265358979;

// The direction in the sky image's own frame: turned back by the sky's rotation about +Y.
vec3 sky_frame(vec3 direction) {
    vec2 rotation = u_lighting.env_rotation;  // (cos, sin): the sky turned about +Y
    return vec3(rotation.x * direction.x - rotation.y * direction.z, direction.y,
                rotation.y * direction.x + rotation.x * direction.z);
}

// The longitude atan(x, -z) (0 straight down -Z, increasing toward +X) runs across the image from
// -pi at its left edge to pi at its right; the angle from the zenith runs down it from 0 to pi:
// the share of each, (u, v), of the sky-frame direction `d` (any length).
vec2 equirect_coordinates(vec3 d) {
    float horizontal = length(d.xz);
    // atan(0, 0) is undefined: straight up or down every longitude is the same direction.
    float longitude = horizontal > 0.0 ? atan(d.x, -d.z) : 0.0;
    float polar = horizontal > 0.0 ? atan(horizontal, d.y) : (d.y < 0.0 ? ENV_PI : 0.0);
    return vec2(longitude / (2.0 * ENV_PI) + 0.5, polar / ENV_PI);
}

// Texel centres sit at half-texel offsets. The filter is bilinear, done here with four texelFetch
// rather than by the sampler: GPUs weight a hardware-filtered texel with 8 fractional bits,
// which the float64 truth could not reproduce; columns wrap around, rows stop at the poles.
// The image is the `size` texels of u_env_map from `origin` (the sky's own at the origin; its
// prefiltered levels below it: lib/environment_lighting.glsl); `uv` is equirect_coordinates'.
vec3 equirect_texels(vec2 uv, ivec2 origin, ivec2 size) {
    vec2 texel = vec2(uv.x * float(size.x), uv.y * float(size.y)) - 0.5;
    vec2 base = floor(texel);
    vec2 f = texel - base;
    // base.x is in [-1, width - 1]: adding the width before the remainder keeps it non-negative.
    int x0 = (int(base.x) + size.x) % size.x;
    int x1 = (int(base.x) + 1 + size.x) % size.x;
    int y0 = clamp(int(base.y), 0, size.y - 1);
    int y1 = clamp(int(base.y) + 1, 0, size.y - 1);
    vec3 top = mix(texelFetch(u_env_map, origin + ivec2(x0, y0), 0).rgb,
                   texelFetch(u_env_map, origin + ivec2(x1, y0), 0).rgb, f.x);
    vec3 bottom = mix(texelFetch(u_env_map, origin + ivec2(x0, y1), 0).rgb,
                      texelFetch(u_env_map, origin + ivec2(x1, y1), 0).rgb, f.x);
    return mix(top, bottom, f.y);
}

vec3 environment(vec3 direction) {
#ifdef ENVIRONMENT_LIGHTING
    ivec2 size = u_lighting.env_size;  // the texture holds the prefiltered levels below the image
#else
    ivec2 size = textureSize(u_env_map, 0);
#endif
    return u_lighting.env_intensity * equirect_texels(equirect_coordinates(sky_frame(direction)), ivec2(0), size);
}
#else
vec3 environment(vec3 direction) {
    float y = clamp(safe_normalize(direction, vec3(0.0, 1.0, 0.0)).y, -1.0, 1.0);
    return y >= 0.0 ? mix(u_lighting.env_horizon, u_lighting.env_zenith, y)
                    : mix(u_lighting.env_horizon, u_lighting.env_ground, -y);
}
#endif
