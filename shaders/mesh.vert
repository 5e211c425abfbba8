#version 330 core
// World-space position, normal and UVs of a mesh, shared by the diffuse and mirror passes.
// INSTANCED (the diffuse pass's batches, gpu/batches.py): the transform and the material are
// per-instance attributes instead of uniforms, and the ids go on to the fragment shader.
uniform mat4 u_view_projection;
#ifdef INSTANCED
in vec4 in_model_0;  // the model matrix's rows (its last row is 0 0 0 1)
in vec4 in_model_1;
in vec4 in_model_2;
in vec3 in_normal_matrix_0;  // the normal matrix's columns
in vec3 in_normal_matrix_1;
in vec3 in_normal_matrix_2;
in ivec4 in_ids;  // the material's index in MaterialRecords, the object id, its triangle offset, 0
flat out ivec4 v_ids;
#else
uniform mat4 u_model;
uniform mat3 u_normal_matrix;  // inverse transpose of u_model's upper 3x3
#endif

in vec3 in_position;
in vec3 in_normal;
in vec2 in_uv;  // texture coordinates (zero for a mesh without them)
// glTF's other attributes, where the scene's materials read them (lib/mesh_point.glsl), from the
// meshes' extra vertex buffer (gpu/meshes.py: constants.EXTRA_DEFAULTS for a mesh without one).
#ifdef TEXCOORD_1
in vec2 in_uv1;
out vec2 v_uv1;
#endif
#ifdef VERTEX_COLORS
in vec4 in_color;
out vec4 v_color;
#endif
#ifdef NORMAL_MAP
in vec4 in_tangent;
out vec4 v_tangent;
#endif

#ifdef DOUBLE_SIDED
// 1 where the model matrix mirrors: its outward faces then reach the window wound the other way
// (diffuse.frag tells a back face by gl_FrontFacing).
flat out int v_mirrored;
#endif

out vec3 v_world_position;
out vec3 v_local_position;
out vec3 v_world_normal;
out vec2 v_uv;

void main() {
#ifdef INSTANCED
    mat4 model = transpose(mat4(in_model_0, in_model_1, in_model_2, vec4(0.0, 0.0, 0.0, 1.0)));
    mat3 normal_matrix = mat3(in_normal_matrix_0, in_normal_matrix_1, in_normal_matrix_2);
    v_ids = in_ids;
#else
    mat4 model = u_model;
    mat3 normal_matrix = u_normal_matrix;
#endif
    vec4 world = model * vec4(in_position, 1.0);
    v_world_position = world.xyz;
    v_local_position = in_position;
    v_world_normal = normal_matrix * in_normal;
    v_uv = in_uv;
#ifdef TEXCOORD_1
    v_uv1 = in_uv1;
#endif
#ifdef VERTEX_COLORS
    v_color = in_color;
#endif
#ifdef NORMAL_MAP
    // A tangent lies along the surface: it goes through the model matrix itself (a normal through
    // its inverse transpose), and a mirroring matrix turns the bitangent's sign (Mesh.transformed).
    mat3 linear = mat3(model);
    v_tangent = vec4(linear * in_tangent.xyz, determinant(linear) < 0.0 ? -in_tangent.w : in_tangent.w);
#endif
#ifdef DOUBLE_SIDED
    v_mirrored = determinant(mat3(model)) < 0.0 ? 1 : 0;
#endif
    gl_Position = u_view_projection * world;
}
