// glTF 2.0's metallic-roughness material, as its specification's Appendix B gives it: a GGX
// distribution, Smith's height-correlated visibility and Schlick's Fresnel, mixed between a
// dielectric (F0 = DIELECTRIC_F0, a diffuse base of the base colour) and a metal (F0 = the base
// colour, no diffuse base) by `metallic`. oracles/brdf.py is the same functions, by the same
// names, in numpy: the truth shades its exact hits with them.
//
// The scene's lights are given as the radiance a white diffuse surface facing them shows
// (lib/shading.glsl: colour = albedo * (ambient + sum of radiance * N.L)): so the functions
// here return pi times the BRDF, and a dielectric's diffuse base is lit exactly as a diffuse
// material of its colour, less what its Fresnel term reflects.

const float BRDF_PI = 3.14159265358979;

// GGX (Trowbridge-Reitz) normal distribution D, for alpha = roughness^2 and N.H > 0.
float ggx_distribution(float alpha, float n_dot_h) {
    float a2 = alpha * alpha;
    float f = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0;
    return a2 / (BRDF_PI * f * f);
}

// Smith's height-correlated visibility V = G / (4 |N.L| |N.V|) (the specification's form).
float smith_visibility(float alpha, float n_dot_l, float n_dot_v) {
    float a2 = alpha * alpha;
    float l = n_dot_l + sqrt(a2 + (1.0 - a2) * n_dot_l * n_dot_l);
    float v = n_dot_v + sqrt(a2 + (1.0 - a2) * n_dot_v * n_dot_v);
    return 1.0 / (l * v);
}

// Schlick's Fresnel reflectance at the angle whose cosine is v_dot_h.
vec3 fresnel_schlick(vec3 f0, float v_dot_h) {
    float m = 1.0 - v_dot_h;
    float m2 = m * m;
    return f0 + (vec3(1.0) - f0) * (m2 * m2 * m);
}

// Pi times the BRDF, for light arriving along `to_light` (N.L > 0) and leaving along `to_viewer`,
// with the material's diffuse colour c_diff, F0 and alpha.
vec3 metallic_roughness_brdf(vec3 c_diff, vec3 f0, float alpha, vec3 normal, vec3 to_light, vec3 to_viewer) {
    vec3 half_vector = safe_normalize(to_light + to_viewer, normal);
    float n_dot_l = abs(dot(normal, to_light));
    float n_dot_v = abs(dot(normal, to_viewer));
    float n_dot_h = dot(normal, half_vector);
    vec3 fresnel = fresnel_schlick(f0, abs(dot(to_viewer, half_vector)));
    float specular = n_dot_h > 0.0
        ? BRDF_PI * ggx_distribution(alpha, n_dot_h) * smith_visibility(alpha, n_dot_l, n_dot_v) : 0.0;
    return (vec3(1.0) - fresnel) * c_diff + fresnel * specular;
}

// The specular lobe's share of a uniform environment (the ambient term: a constant radiance from
// every direction), F0 * A + B by Karis' fit of the split sum's DFG term.
vec3 ambient_specular(vec3 f0, float roughness, float n_dot_v) {
    vec4 r = roughness * DFG_FIT_C0 + DFG_FIT_C1;
    float a004 = min(r.x * r.x, exp2(DFG_FIT_EXPONENT * n_dot_v)) * r.x + r.y;
    vec2 scale_bias = vec2(-DFG_FIT_SCALE, DFG_FIT_SCALE) * a004 + r.zw;
    return f0 * scale_bias.x + scale_bias.y;
}
