// The mesh's attributes at a surface point, whoever found the point: interpolated by the rasterizer
// (mesh.vert's outputs: mesh_varyings.glsl), by a traced hit's barycentrics (lib/triangles.glsl),
// laid out on an analytic plane (lib/reflected_scene.glsl), or by the truth at its exact hits
// (oracles/truth.py's MeshPoints, the same fields). A material reads its inputs from one: its
// textures' UVs (a texture reads TEXCOORD_0 or TEXCOORD_1: its record's uv_set), the vertex colour
// its base colour is multiplied by, and the tangent a normal map turns the normal in. Only what the
// scene uses is there (uniforms.mesh_attribute_defines): TEXCOORD_1, VERTEX_COLORS, NORMAL_MAP; a
// scene with none has the UVs alone, as before these existed.

struct MeshPoint {
    vec2 uv;  // TEXCOORD_0 (zero for a mesh without it)
#ifdef TEXCOORD_1
    vec2 uv1;
#endif
#ifdef VERTEX_COLORS
    vec4 color;  // COLOR_0, linear RGBA (white for a mesh without it)
#endif
#ifdef NORMAL_MAP
    vec4 tangent;  // world space, not unit or perpendicular to the normal; w: the bitangent's sign
#endif
};

// A point with the UVs `uv` and every other attribute at its default (constants.EXTRA_DEFAULTS).
MeshPoint mesh_point(vec2 uv) {
    MeshPoint point;
    point.uv = uv;
#ifdef TEXCOORD_1
    point.uv1 = DEFAULT_UVS1;
#endif
#ifdef VERTEX_COLORS
    point.color = DEFAULT_COLORS;
#endif
#ifdef NORMAL_MAP
    point.tangent = DEFAULT_TANGENTS;
#endif
    return point;
}

#ifdef DOUBLE_SIDED
// glTF's doubleSided: a back face of a double-sided material is shaded as the front face of the
// surface turned round: its normal turned, and the normal map's frame with it (the tangent and the
// bitangent's sign turned too, so that lib/shading.glsl's mapped_normal turns whole, as
// glTF-Sample-Viewer and three.js turn T, B and N). oracles/mesh_points.py's turned_to_back.
void turn_to_back(inout vec3 normal, inout MeshPoint point) {
    normal = -normal;
#ifdef NORMAL_MAP
    point.tangent = -point.tangent;
#endif
}
#endif
