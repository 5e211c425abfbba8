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
    gl_Position = u_view_projection * world;
}
