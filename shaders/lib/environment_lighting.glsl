// Image-based lighting from an equirect sky (ENVIRONMENT_LIGHTING: a scene with such a sky and a
// metallic-roughness material; ibl.py states the rule and the split): what a surface's ambient
// term takes from the sky, in place of the constant ambient. oracles/ibl.py is the same functions,
// by the same names, in numpy.
#include "environment.glsl"

// The radiance a white diffuse surface of unit normal `normal` shows under the sky (its
// irradiance over pi), from the sky's nine spherical-harmonic terms (the Lights block's
// env_irradiance: ibl.py's irradiance_sh9, each term already times its constants). Nine terms
// ring under a small bright sun (a few per cent of it below zero on the far side): clamped at 0.
vec3 environment_irradiance(vec3 normal) {
    vec3 n = sky_frame(normal);
    vec4 c[9] = u_lighting.env_irradiance;
    vec3 sum = c[0].rgb + c[1].rgb * n.y + c[2].rgb * n.z + c[3].rgb * n.x
        + c[4].rgb * (n.x * n.y) + c[5].rgb * (n.y * n.z) + c[6].rgb * (n.x * n.z)
        + c[7].rgb * (3.0 * n.z * n.z - 1.0) + c[8].rgb * (n.x * n.x - n.y * n.y);
    return u_lighting.env_intensity * max(sum, vec3(0.0));
}

// Where prefiltered level `level` (1..IBL_LEVELS: the sky through GGX lobes of roughness
// level / IBL_LEVELS, IBL_WIDTH >> (level - 1) texels wide, half as high) lies in the sky's
// texture: the levels are stacked below the sky's image, each half as high as the one above, so
// the rows above level k sum to 2 h - 2 (h >> (k - 1)) for level 1's height h. Level 0 is the
// sky's image itself, at the origin.
ivec2 level_origin(int level) {
    int first = IBL_WIDTH / 2;
    return level == 0 ? ivec2(0) : ivec2(0, u_lighting.env_size.y + 2 * first - 2 * (first >> (level - 1)));
}

ivec2 level_extent(int level) {
    int width = IBL_WIDTH >> (level - 1);
    return level == 0 ? u_lighting.env_size : ivec2(width, width / 2);
}

// Prefiltered level `level` along `d`, in the sky's frame.
vec3 prefiltered_level(int level, vec3 d) {
    return equirect_texels(equirect_coordinates(d), level_origin(level), level_extent(level));
}

// The sky's radiance through a GGX lobe of `roughness` about `direction` (the reflected view
// direction: the split sum's first factor): linear between the two levels about roughness *
// IBL_LEVELS, level 0 being the sky itself (environment()), as glTF-Sample-Viewer reads its mips.
// The direction's angles are found once for both reads (llvmpipe runs every branch: one call per
// level read, not a call per level there is).
vec3 environment_specular(vec3 direction, float roughness) {
    float lod = clamp(roughness, 0.0, 1.0) * float(IBL_LEVELS);
    int below = min(int(lod), IBL_LEVELS - 1);
    vec2 uv = equirect_coordinates(sky_frame(direction));
    vec3 low = equirect_texels(uv, level_origin(below), level_extent(below));
    vec3 high = equirect_texels(uv, level_origin(below + 1), level_extent(below + 1));
    return u_lighting.env_intensity * mix(low, high, lod - float(below));
}
