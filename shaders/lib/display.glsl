// The display transform of depthimpostor/colour.py (docs/colour.md), for frames shown in a window:
// linear colour scaled by 2^exposure, tone mapped into [0, 1], sRGB encoded.
uniform float u_exposure_scale;  // 2^exposure
uniform int u_tone_mapping;      // a TONE_MAPPING_* code

vec3 tone_map(vec3 linear) {
    vec3 x = max(linear * u_exposure_scale, vec3(0.0));
    if (u_tone_mapping == TONE_MAPPING_ACES) {
        x = x * (ACES_A * x + ACES_B) / (x * (ACES_C * x + ACES_D) + ACES_E);
    } else if (u_tone_mapping == TONE_MAPPING_REINHARD) {
        x = x / (1.0 + x);
    }
    return clamp(x, 0.0, 1.0);
}

vec3 encode_srgb(vec3 c) {
    vec3 curve = (1.0 + SRGB_OFFSET) * pow(c, vec3(1.0 / SRGB_GAMMA)) - SRGB_OFFSET;
    return mix(curve, SRGB_LINEAR_SLOPE * c, lessThanEqual(c, vec3(SRGB_LINEAR_LIMIT)));
}

vec3 display_encode(vec3 linear) {
    return encode_srgb(tone_map(linear));
}
