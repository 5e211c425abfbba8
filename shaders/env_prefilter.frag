#version 330 core
// One prefiltered level of an equirect sky (passes/environment.py's prefilter, once per sky): each
// texel the sky seen through the GGX lobe of the level's roughness about the texel's direction,
// with the view along that direction (N = V = R, the split sum's assumption), by GGX importance
// sampling as glTF-Sample-Viewer's ibl_filtering.frag and three.js's PMREM do it: IBL_SAMPLES
// Hammersley points, each weighted by N.L and read from the sky's mip level whose texels are as
// large as the sample's share of the lobe (filtered importance sampling, GPU Gems 3, 20.4), so that
// IBL_SAMPLES leave no visible noise. The level is drawn into its rectangle of the sky's texture
// (lib/environment_lighting.glsl reads it there).
#include "lib/common.glsl"
#include "lib/brdf.glsl"

uniform sampler2D u_source;  // the sky's image with its mip chain: trilinear, wrapping across, clamped at the poles
uniform int u_level;  // 1..IBL_LEVELS
uniform ivec2 u_origin;  // the level's first texel in the target

out vec4 out_color;

// Van der Corput's radical inverse in base 2: the second coordinate of the Hammersley points.
float radical_inverse(uint bits) {
    bits = (bits << 16u) | (bits >> 16u);
    bits = ((bits & 0x55555555u) << 1u) | ((bits & 0xAAAAAAAAu) >> 1u);
    bits = ((bits & 0x33333333u) << 2u) | ((bits & 0xCCCCCCCCu) >> 2u);
    bits = ((bits & 0x0F0F0F0Fu) << 4u) | ((bits & 0xF0F0F0F0u) >> 4u);
    bits = ((bits & 0x00FF00FFu) << 8u) | ((bits & 0xFF00FF00u) >> 8u);
    return float(bits) * 2.3283064365386963e-10;  // / 2^32
}

// Where direction d falls in the sky's image (u across from the longitude, v down from the zenith):
// lib/environment.glsl's mapping, in texture coordinates.
vec2 equirect_uv(vec3 d) {
    float horizontal = length(d.xz);
    float longitude = horizontal > 0.0 ? atan(d.x, -d.z) : 0.0;
    float polar = horizontal > 0.0 ? atan(horizontal, d.y) : (d.y < 0.0 ? BRDF_PI : 0.0);
    return vec2(longitude / (2.0 * BRDF_PI) + 0.5, polar / BRDF_PI);
}

void main() {
    int width = IBL_WIDTH >> (u_level - 1);
    vec2 size = vec2(width, width / 2);
    vec2 texel = gl_FragCoord.xy - vec2(u_origin);  // the texel's centre, in texels of the level
    float longitude = (texel.x / size.x - 0.5) * 2.0 * BRDF_PI;
    float polar = texel.y / size.y * BRDF_PI;
    vec3 n = vec3(sin(polar) * sin(longitude), cos(polar), -sin(polar) * cos(longitude));
    float roughness = float(u_level) / float(IBL_LEVELS);
    float alpha = roughness * roughness;
    // A tangent frame about n (texel centres never lie on the poles, where up would be parallel).
    vec3 tangent = normalize(cross(vec3(0.0, 1.0, 0.0), n));
    vec3 bitangent = cross(n, tangent);
    vec2 source = vec2(textureSize(u_source, 0));
    float texel_solid_angle = 4.0 * BRDF_PI / (source.x * source.y);  // the sky's texels on average
    vec3 sum = vec3(0.0);
    float weight = 0.0;
    for (int i = 0; i < IBL_SAMPLES; ++i) {
        float u = float(i) / float(IBL_SAMPLES);
        float phi = 2.0 * BRDF_PI * radical_inverse(uint(i));
        float cos_theta = sqrt((1.0 - u) / (1.0 + (alpha * alpha - 1.0) * u));  // GGX's half vectors
        float sin_theta = sqrt(max(0.0, 1.0 - cos_theta * cos_theta));
        vec3 h = tangent * (sin_theta * cos(phi)) + bitangent * (sin_theta * sin(phi)) + n * cos_theta;
        vec3 l = reflect(-n, h);
        float n_dot_l = dot(n, l);
        if (n_dot_l <= 0.0) continue;
        // The light direction's density: D(h) N.H / (4 V.H), and V.H = N.H with V = N.
        float pdf = ggx_distribution(alpha, cos_theta) / 4.0;
        // Half the log2 of the sample's solid angle over a texel's. No bias (GPU Gems adds one level):
        // against a numpy sum over every texel (tests/test_environment_lighting.py), at 128 samples,
        // a bias of 1 left the levels 1.7 % (median, roughness 0.2) to 9.5 % (roughness 1) off, none
        // 0.7 % to 3.5 %: an equirect sky's coarse mips average over uneven solid angles.
        float lod = 0.5 * log2(1.0 / (float(IBL_SAMPLES) * pdf * texel_solid_angle));
        sum += textureLod(u_source, equirect_uv(l), max(lod, 0.0)).rgb * n_dot_l;
        weight += n_dot_l;
    }
    out_color = vec4(sum / weight, 1.0);
}
