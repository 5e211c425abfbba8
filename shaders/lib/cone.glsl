// A glossy mirror's cone (lib/glossy.glsl explains it): its spread, and what the baked images'
// lookups tell of their coverage. Apart from glossy.glsl so that lib/baked_images.glsl can read it
// wherever it is first included (the shadow chunk includes it before the reflected scene does).

// tan of the cone's half-angle: 0 for a perfect mirror and for glass (the sharp path, exactly).
float g_cone_tan = 0.0;
// The share of the cone's footprint that the object its axis hit covers (cone_color sets it from
// the mips' coverage): the rest sees what lies behind the object (trace_reflected).
float g_cone_coverage = 1.0;

float cone_spread(float roughness) {
    float alpha = roughness * roughness;
    // alpha = 1 would be a half-angle of 90 degrees: the widest cone is held just short of it.
    return 2.0 * alpha / max(1.0 - alpha * alpha, 1e-3);
}
