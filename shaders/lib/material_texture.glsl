// The scene's image textures, in any number (gpu/textures.py makes them where texture_layout.py
// puts them). Texture slot k's record is u_texture_records[k] (TEXTURE_COUNT of them, one table):
// (array, layer, wrap s, wrap t) and its level 0's rectangle in the traced rays' atlas.
// Rasterized fragments (RASTERIZED_TEXTURES: diffuse.frag, the eye's and every bake's) sample one of
// TEXTURE_ARRAYS SRGB8_ALPHA8 texture arrays with mipmaps, which the GPU decodes to linear before it
// filters. Traced rays (the mirror shader) read u_material_texels: every image's level 0 as 8-bit
// integers in one atlas (one sampler: the mirror shader already samples the 16 GL 3.3 guarantees a
// fragment shader), decoded here through the exact table u_srgb_to_linear, because a GPU's own sRGB
// decode may be approximate (llvmpipe's is off by up to 0.0012, 2.5 % of the darkest values), and
// traced rays are held to the truth's float noise. texelFetch with the wrap done here on integer
// coordinates never reads a neighbour's texels.
#include "mesh_point.glsl"
#include "../generated/texture_record.glsl"

layout(std140) uniform TextureRecords {
    TextureRecord u_texture_records[TEXTURE_COUNT];
};

// The texture's UV: the mesh's (the UV set it reads: TEXCOORD_1 where the scene has a texture that
// reads it), through the slot's UV transform (KHR_texture_transform's).
vec2 texture_uv(int slot, MeshPoint point) {
#ifdef TEXCOORD_1
    vec3 affine = vec3(u_texture_records[slot].uv_set == 1 ? point.uv1 : point.uv, 1.0);
#else
    vec3 affine = vec3(point.uv, 1.0);
#endif
    return vec2(dot(u_texture_records[slot].uv_u, affine), dot(u_texture_records[slot].uv_v, affine));
}

#ifdef RASTERIZED_TEXTURES
#include "../generated/material_arrays.glsl"

// A coordinate folded into [0, 1] by a wrap mode, for the arrays' clamping sampler, which then
// filters as GL's own wrap would: a clamped coordinate as it is; a mirrored one reflected (period 2):
// the texels across a mirror seam are the edge texel's own reflection, which is what clamping at
// the edge gives, at every mip level, so it is exact; a repeated one (a texture that repeats on one
// axis and clamps or mirrors on the other: glTF samplers alone) by fract, which clamps within half a
// texel of the seam where GL would blend with the opposite edge (docs/scene_format.md).
float fold_coordinate(float u, int mode) {
    if (mode == WRAP_MIRRORED_REPEAT) {
        float period = u - 2.0 * floor(0.5 * u);
        return period <= 1.0 ? period : 2.0 - period;
    }
    return mode == WRAP_REPEAT ? fract(u) : u;
}

// Mipmapped and trilinear, for rasterized fragments, whose derivatives choose the level (the
// camera view and every baked image). A texture that repeats on both axes goes through the array's
// repeating sampler with its UV as it is: GL's own wrap and filter. Any other through the clamping
// sampler, its UV folded here, with the derivatives of the UV before folding: a fold turns the UV
// back at a seam, where the folded UV's own derivatives would pick the finest level (a line of
// aliasing along every seam) or, across fract's jump, the coarsest.
vec4 material_texel_rgba(int slot, MeshPoint point) {
    vec2 uv = texture_uv(slot, point);
    ivec4 sampling = u_texture_records[slot].sampling;  // array, layer, wrap s, wrap t
#ifdef FOLDED_TEXTURES
#ifdef REPEATING_TEXTURES
    if (sampling.z != WRAP_REPEAT || sampling.w != WRAP_REPEAT)
#endif
    {
        vec2 folded = vec2(fold_coordinate(uv.x, sampling.z), fold_coordinate(uv.y, sampling.w));
        return material_array_clamped(sampling.x, vec3(folded, float(sampling.y)), dFdx(uv), dFdy(uv));
    }
#endif
#ifdef REPEATING_TEXTURES
    return material_array(sampling.x, vec3(uv, float(sampling.y)));
#endif
}

#else
uniform usampler2D u_material_texels;
uniform float u_srgb_to_linear[256];  // textures.srgb_to_linear(k / 255) in float32

ivec2 texture_level0_size(int slot) {
    return u_texture_records[slot].texels.zw;
}

// Texel `texel` (in [0, size)) of the slot's level 0, its colour decoded from sRGB by the exact
// table (data, srgb = 0: as stored, in [0, 1]), its alpha (linear) in [0, 1].
vec4 texel_level0(int slot, ivec2 texel) {
    uvec4 encoded = texelFetch(u_material_texels, u_texture_records[slot].texels.xy + texel, 0);
    if (u_texture_records[slot].srgb == 0) return vec4(encoded) / 255.0;
    return vec4(u_srgb_to_linear[encoded.r], u_srgb_to_linear[encoded.g], u_srgb_to_linear[encoded.b],
                float(encoded.a) / 255.0);
}

// i modulo n in [0, n) (numpy's np.mod). GLSL leaves % undefined for a negative operand, and
// llvmpipe's takes it as unsigned (-1 % 12 = 3): a repeated texture's first half texel (texel -1,
// the last one wrapped) read another row.
int floor_mod(int i, int n) {
    return i >= 0 ? i % n : n - 1 - (-1 - i) % n;
}

// An integer texel coordinate brought into [0, size) by a wrap mode (textures.py's wrap_texels).
ivec2 wrap_texels(ivec2 index, ivec2 size, ivec2 mode) {
    ivec2 result;
    for (int axis = 0; axis < 2; ++axis) {
        int i = index[axis], n = size[axis];
        int period = floor_mod(i, 2 * n);
        if (mode[axis] == WRAP_CLAMP_TO_EDGE) result[axis] = clamp(i, 0, n - 1);
        else if (mode[axis] == WRAP_MIRRORED_REPEAT) result[axis] = period < n ? period : 2 * n - 1 - period;
        else result[axis] = floor_mod(i, n);
    }
    return result;
}

// Level 0, bilinear, weights in float32: for traced rays, which have no derivatives to choose a
// level from. The truth (textures.py's texture_bilinear) is this in numpy: see the comparison
// rule there.
vec4 material_texel_rgba(int slot, MeshPoint point) {
    vec2 uv = texture_uv(slot, point);
    ivec2 size = texture_level0_size(slot);
    vec2 x = uv * vec2(size) - 0.5;  // texel centres at half-integers
    vec2 base = floor(x);
    vec2 fraction = x - base;
    ivec2 i0 = ivec2(base);
    ivec2 mode = u_texture_records[slot].sampling.zw;
    vec4 c00 = texel_level0(slot, wrap_texels(i0, size, mode));
    vec4 c10 = texel_level0(slot, wrap_texels(i0 + ivec2(1, 0), size, mode));
    vec4 c01 = texel_level0(slot, wrap_texels(i0 + ivec2(0, 1), size, mode));
    vec4 c11 = texel_level0(slot, wrap_texels(i0 + ivec2(1, 1), size, mode));
    vec4 top = c00 * (1.0 - fraction.x) + c10 * fraction.x;
    vec4 bottom = c01 * (1.0 - fraction.x) + c11 * fraction.x;
    return top * (1.0 - fraction.y) + bottom * fraction.y;
}
#endif

// The texel's linear colour at the mesh point (material_texel_rgba's alpha is glTF's coverage:
// alphaMode MASK).
vec3 material_texel(int slot, MeshPoint point) {
    return material_texel_rgba(slot, point).rgb;
}
