// The scene's image textures (passes/textures.py binds texture slot k on texture units
// MATERIAL_TEXTURE_0 + k and MATERIAL_TEXELS_0 + k; TEXTURE_COUNT of them, at most MAX_TEXTURES).
// GLSL 3.30 indexes a sampler array only with constants, hence the if-chains over the slot.
// Rasterized fragments (RASTERIZED_TEXTURES: diffuse.frag) read u_material_texture_k:
// SRGB8_ALPHA8 with mipmaps, which the GPU decodes to linear before it filters. Traced rays (the
// mirror shader) read u_material_texels: every texture's level 0 as 8-bit integers, stacked in
// one texture (slot k's rectangle u_material_texels_rect[k]: one sampler, so that the mirror
// shader stays within the 16 GL 3.3 guarantees a fragment shader), decoded here through the exact
// table u_srgb_to_linear, because a GPU's own sRGB decode may be approximate (llvmpipe's is off by
// up to 0.0012, 2.5 % of the darkest values), and traced rays are held to the truth's float noise.
// texelFetch with the wrap done here on integer coordinates never reads a neighbour's texels.
#ifdef RASTERIZED_TEXTURES
uniform sampler2D u_material_texture_0;
#if TEXTURE_COUNT > 1
uniform sampler2D u_material_texture_1;
#endif
#if TEXTURE_COUNT > 2
uniform sampler2D u_material_texture_2;
#endif
#if TEXTURE_COUNT > 3
uniform sampler2D u_material_texture_3;
#endif
#else
uniform usampler2D u_material_texels;
uniform ivec4 u_material_texels_rect[MAX_TEXTURES];  // slot k's (x, y) origin and (width, height)
uniform ivec2 u_material_texture_wrap[MAX_TEXTURES];  // (s, t) wrap modes: WRAP_* (GL's enums)
uniform float u_srgb_to_linear[256];  // textures.srgb_to_linear(k / 255) in float32
#endif

#ifdef RASTERIZED_TEXTURES
// Mipmapped, trilinear, the sampler's wrap modes: for rasterized fragments, whose derivatives
// choose the level (the camera view and every baked image).
vec3 material_texel(int slot, vec2 uv) {
#if TEXTURE_COUNT > 1
    if (slot == 1) return texture(u_material_texture_1, uv).rgb;
#endif
#if TEXTURE_COUNT > 2
    if (slot == 2) return texture(u_material_texture_2, uv).rgb;
#endif
#if TEXTURE_COUNT > 3
    if (slot == 3) return texture(u_material_texture_3, uv).rgb;
#endif
    return texture(u_material_texture_0, uv).rgb;
}

#else
ivec2 texture_level0_size(int slot) {
    return u_material_texels_rect[slot].zw;
}

// Texel `texel` (in [0, size)) of the slot's level 0, decoded from sRGB by the exact table.
vec3 texel_level0(int slot, ivec2 texel) {
    uvec4 encoded = texelFetch(u_material_texels, u_material_texels_rect[slot].xy + texel, 0);
    return vec3(u_srgb_to_linear[encoded.r], u_srgb_to_linear[encoded.g], u_srgb_to_linear[encoded.b]);
}

// An integer texel coordinate brought into [0, size) by a wrap mode (textures.py's wrap_texels).
ivec2 wrap_texels(ivec2 index, ivec2 size, ivec2 mode) {
    ivec2 result;
    for (int axis = 0; axis < 2; ++axis) {
        int i = index[axis], n = size[axis];
        int period = ((i % (2 * n)) + 2 * n) % (2 * n);  // % keeps the sign of i: made non-negative
        if (mode[axis] == WRAP_CLAMP_TO_EDGE) result[axis] = clamp(i, 0, n - 1);
        else if (mode[axis] == WRAP_MIRRORED_REPEAT) result[axis] = period < n ? period : 2 * n - 1 - period;
        else result[axis] = ((i % n) + n) % n;
    }
    return result;
}

// Level 0, bilinear, weights in float32: for traced rays, which have no derivatives to choose a
// level from. The truth (textures.py's texture_bilinear) is this in numpy: see the comparison
// rule there.
vec3 material_texel(int slot, vec2 uv) {
    ivec2 size = texture_level0_size(slot);
    vec2 x = uv * vec2(size) - 0.5;  // texel centres at half-integers
    vec2 base = floor(x);
    vec2 fraction = x - base;
    ivec2 i0 = ivec2(base);
    ivec2 mode = u_material_texture_wrap[slot];
    vec3 c00 = texel_level0(slot, wrap_texels(i0, size, mode));
    vec3 c10 = texel_level0(slot, wrap_texels(i0 + ivec2(1, 0), size, mode));
    vec3 c01 = texel_level0(slot, wrap_texels(i0 + ivec2(0, 1), size, mode));
    vec3 c11 = texel_level0(slot, wrap_texels(i0 + ivec2(1, 1), size, mode));
    vec3 top = c00 * (1.0 - fraction.x) + c10 * fraction.x;
    vec3 bottom = c01 * (1.0 - fraction.x) + c11 * fraction.x;
    return top * (1.0 - fraction.y) + bottom * fraction.y;
}
#endif
