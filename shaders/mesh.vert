#version 330 core
// World-space position, normal and UVs of a mesh, shared by the diffuse and mirror passes.
uniform mat4 u_model;
uniform mat3 u_normal_matrix;  // inverse transpose of u_model's upper 3x3
uniform mat4 u_view_projection;

in vec3 in_position;
in vec3 in_normal;
in vec2 in_uv;  // texture coordinates (zero for a mesh without them)

out vec3 v_world_position;
out vec3 v_local_position;
out vec3 v_world_normal;
out vec2 v_uv;

void main() {
    vec4 world = u_model * vec4(in_position, 1.0);
    v_world_position = world.xyz;
    v_local_position = in_position;
    v_world_normal = u_normal_matrix * in_normal;
    v_uv = in_uv;
    gl_Position = u_view_projection * world;
}
