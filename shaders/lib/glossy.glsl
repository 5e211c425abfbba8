// Glossy mirrors (GLOSSY, a scene with a mirror of roughness > 0): each pixel's reflected ray is
// the axis of a cone, and what it finds is read prefiltered at the cone's footprint where it is
// found (Uludag's cone tracing, GPU Pro 5), instead of averaging many rays as the truth does
// (oracles/ggx.py). The hit itself is the exact traversal's along the axis.
//
// The cone's half-angle is the GGX lobe's median deviation from the mirror direction: half of the
// reflected rays of a microfacet normal drawn from GGX (alpha = roughness^2) deviate less than
// 2 atan(alpha) at normal incidence, so tan(half-angle) = tan(2 atan(alpha)) = 2 alpha / (1 - alpha^2).
// Its footprint at distance t is a disk of diameter 2 t tan(half-angle), which every stand-in
// reads as a box of that width: a mip level whose texel is that wide (the baked images, the cube
// map's faces), an exactly box-filtered checker (the analytic planes), a few directions averaged
// (the environment).

#include "cone.glsl"

// The environment averaged over the cone: its axis and a ring of 8 directions at the cone's
// half-angle (half of GGX's rays fall inside it), weighted 1/5 and 1/10 each. Coarse for very
// rough mirrors, but the sky is smooth; the truth averages 64 rays.
vec3 prefiltered_environment(vec3 direction) {
    vec3 axis = safe_normalize(direction, vec3(0.0, 1.0, 0.0));
    if (g_cone_tan <= 0.0) return environment(direction);
    vec3 helper = abs(axis.y) < 0.9 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0);
    vec3 u = normalize(cross(helper, axis));
    vec3 v = cross(axis, u);
    vec3 sum = 2.0 * environment(axis);
    for (int k = 0; k < 8; ++k) {
        float angle = float(k) * 0.785398163;  // pi / 4
        sum += environment(axis + g_cone_tan * (cos(angle) * u + sin(angle) * v));
    }
    return sum / 10.0;
}

// The share of a checker's colour_b over a box of `width` (in cells, per local axis) centred at
// `cell_position`: the box average of the square wave +1 on even cells, -1 on odd ones, is
// 2 (|fract((p - w/2)/2) - 1/2| - |fract((p + w/2)/2) - 1/2|) / w per axis (Quilez's filtered
// checkerboard), and a cell is colour_a where the product of the two waves is +1.
float checker_b_share(vec2 cell_position, vec2 width) {
    vec2 w = max(width, vec2(1e-6));  // a zero width is the unfiltered checker's limit: kept off 0/0
    vec2 wave = 2.0 * (abs(fract((cell_position - 0.5 * w) * 0.5) - 0.5)
                       - abs(fract((cell_position + 0.5 * w) * 0.5) - 0.5)) / w;
    return 0.5 - 0.5 * wave.x * wave.y;
}

// The width along the plane's local x and z of the cone's footprint where a ray of local
// direction d (the world unit direction through world_to_local) meets the plane y = 0 at t: a
// disk of diameter 2 t tan across the ray, seen along it, stretches by sqrt(1 + (d.x / d.y)^2) on x
// (and likewise z); the local disk is the world one times |d| (the transform's scale).
vec2 plane_footprint(vec3 d, float t) {
    float diameter = 2.0 * t * g_cone_tan * length(d);
    vec2 slope = d.xz / d.y;
    return diameter * sqrt(1.0 + slope * slope);
}
