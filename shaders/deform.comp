#version 430 core
// One deforming glTF part's vertices at a time, written over its place in the mesh arena: the
// GPU twin of scene/gltf_deform.py's PartMotion.mesh_at, function for function (morphed, skinned,
// then gltf_file.local_mesh's unit normal, and the node's placement for a part without a skin).
// gpu/deform.py lays out the buffers.

layout(local_size_x = DEFORM_GROUP) in;

// (After the work group's size, which it reads.)
#include "lib/dispatch.glsl"

// The arena's interleaved vertices (gpu/meshes.py): ARENA_FLOATS floats, position and normal first.
layout(std430, binding = STORAGE_ARENA) buffer Arena {
    float u_arena[];
};
// The part as loaded: per vertex its rest position and normal (2 vec4), then from
// u_influence_base its joints and weights (u_influence_groups vec4 of each a vertex), then from
// u_delta_base each morph target's position and normal deltas (2 vec4 a target and vertex).
layout(std430, binding = STORAGE_DEFORM_PART) readonly buffer Part {
    vec4 u_part[];
};
// The part at this time: each joint's matrix (4 columns), then from u_weight_base the morph
// weights (4 a vec4). A uniform block where it fits (llvmpipe reads one, at an index that varies
// from vertex to vertex, about 2.5 times as fast as a storage buffer), else a storage buffer.
#ifdef POSE_IN_STORAGE
layout(std430, binding = STORAGE_DEFORM_POSE) readonly buffer Pose {
    vec4 u_pose[];
};
#else
layout(std140, binding = BLOCK_DEFORM_POSE) uniform Pose {
    vec4 u_pose[DEFORM_POSE_BLOCK_ROWS];
};
#endif

uniform int u_vertex_count;
uniform int u_first_vertex;      // the part's first vertex in the arena
uniform int u_influence_groups;  // 0: no skin
uniform int u_influence_base;
uniform int u_targets;           // 0: no morph targets
uniform int u_delta_base;
uniform int u_weight_base;
uniform mat4 u_placement;        // a part without a skin: its node's world matrix at this time
uniform mat3 u_placement_normals;  // and that matrix's inverse transpose

// The morph targets added at this time's weights (DeformingPrimitive.morphed), four at a time (a
// weight past the last is 0).
void morphed(int v, inout vec3 position, inout vec3 normal) {
    for (int k = 0; k < u_targets; k += 4) {
        vec4 weights = u_pose[u_weight_base + k / 4];
        for (int c = 0; c < 4 && k + c < u_targets; ++c) {
            int delta = u_delta_base + 2 * ((k + c) * u_vertex_count + v);
            float weight = c == 0 ? weights.x : c == 1 ? weights.y : c == 2 ? weights.z : weights.w;
            position += weight * u_part[delta].xyz;
            normal += weight * u_part[delta + 1].xyz;
        }
    }
}

mat4 joint_matrix(int joint) {
    return mat4(u_pose[4 * joint], u_pose[4 * joint + 1], u_pose[4 * joint + 2], u_pose[4 * joint + 3]);
}

// The vertex placed by the weighted sum of its joints' matrices, its normal by that sum's
// cofactor matrix (gltf_deform.skinned: defined where the sum is singular).
void skinned(int v, inout vec3 position, inout vec3 normal) {
    mat4 skin = mat4(0.0);
    int influences = u_influence_base + 2 * u_influence_groups * v;
    for (int g = 0; g < u_influence_groups; ++g) {
        // Joint indices travel as floats: exact below 2^24 joints. Every influence is summed, a
        // zero weight's too (as numpy's einsum does): a branch or a vector indexed by a variable
        // costs llvmpipe several times the sum.
        vec4 joints = u_part[influences + g];
        vec4 weights = u_part[influences + u_influence_groups + g];
        skin += weights.x * joint_matrix(int(joints.x)) + weights.y * joint_matrix(int(joints.y))
              + weights.z * joint_matrix(int(joints.z)) + weights.w * joint_matrix(int(joints.w));
    }
    position = (skin * vec4(position, 1.0)).xyz;
    mat3 linear = mat3(skin);
    mat3 cofactor = mat3(cross(linear[1], linear[2]), cross(linear[2], linear[0]), cross(linear[0], linear[1]));
    normal = (determinant(linear) < 0.0 ? -1.0 : 1.0) * (cofactor * normal);
}

// local_mesh's rule: a normal too short to have a direction is +Y.
vec3 unit_normal(vec3 normal) {
    float len = length(normal);
    return len > MIN_NORMAL_LENGTH ? normal / len : vec3(0.0, 1.0, 0.0);
}

void main() {
    int v = dispatch_index();
    if (v >= u_vertex_count) return;
    vec3 position = u_part[2 * v].xyz;
    vec3 normal = u_part[2 * v + 1].xyz;
    morphed(v, position, normal);
    if (u_influence_groups > 0) {
        skinned(v, position, normal);
        normal = unit_normal(normal);
    } else {
        // Mesh.transformed after local_mesh: the unit normal through the inverse transpose.
        position = (u_placement * vec4(position, 1.0)).xyz;
        normal = normalize(u_placement_normals * unit_normal(normal));
    }
    int at = (u_first_vertex + v) * ARENA_FLOATS;
    u_arena[at] = position.x;
    u_arena[at + 1] = position.y;
    u_arena[at + 2] = position.z;
    u_arena[at + 3] = normal.x;
    u_arena[at + 4] = normal.y;
    u_arena[at + 5] = normal.z;
}
