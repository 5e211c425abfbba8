#version 430 core
// The triangle methods' bottom-level BVH refitted over deformed meshes (methods/gpu_refit.py):
// the GPU twin of methods/bvh.py's refit_triangle_forest (_bound: each leaf around its triangles,
// then each parent around its two children, the deepest level first) and of the corners and
// normals triangles.triangle_texels writes. One pass a dispatch (u_pass):
//   0: each deformed triangle's corners and normals, from the mesh arena, over its texels;
//   1: each leaf's box, around its triangles as that texture now holds them;
//   2: each parent of one level, around its children's boxes (written by the dispatches before).
// The tree's topology (children, items, skip links: the texels' w) is kept as it is.

layout(local_size_x = REFIT_GROUP) in;

// (After the work group's size, which it reads.)
#include "lib/dispatch.glsl"

// The arena's interleaved vertices (gpu/meshes.py): ARENA_FLOATS floats, position and normal first.
layout(std430, binding = STORAGE_ARENA) readonly buffer Arena {
    float u_arena[];
};
// A triangle: its corners (vertex indices in its mesh) and its slot in the triangle texture; a
// node: its number in the forest, and (x again) where it is a root, else -1.
layout(std430, binding = STORAGE_REFIT_ITEMS) readonly buffer Items {
    ivec4 u_refit_items[];
};
// Each refitted root's box (lower, upper), by its tree: read back for the top level.
layout(std430, binding = STORAGE_REFIT_ROOTS) writeonly buffer Roots {
    vec4 u_roots[];
};
layout(rgba32f, binding = IMAGE_BVH_NODES) uniform image2D u_nodes;
layout(rgba32f, binding = IMAGE_BVH_TRIANGLES) uniform image2D u_triangles;

uniform int u_pass;
uniform int u_first_item;  // this dispatch's items in u_refit_items
uniform int u_items;
uniform int u_first_vertex;  // pass 0: the mesh's first vertex in the arena
uniform int u_stride;        // texels a triangle
uniform int u_mesh_base;     // the texture's node of the forest's node 0

// Texel `texel` of a BVH texture (rows of BVH_TEXTURE_WIDTH: triangles._texture).
ivec2 texel_at(int texel) {
    return ivec2(texel % BVH_TEXTURE_WIDTH, texel / BVH_TEXTURE_WIDTH);
}

vec3 arena_vec3(int vertex, int offset) {
    int at = (u_first_vertex + vertex) * ARENA_FLOATS + offset;
    return vec3(u_arena[at], u_arena[at + 1], u_arena[at + 2]);
}

void triangle_texels(ivec4 item) {
    for (int k = 0; k < 3; ++k) {
        imageStore(u_triangles, texel_at(item.w * u_stride + k), vec4(arena_vec3(item[k], 0), 0.0));
        imageStore(u_triangles, texel_at(item.w * u_stride + 3 + k), vec4(arena_vec3(item[k], 3), 0.0));
    }
}

// A node's box written over its texels, their w (first item or child, count) kept.
void set_box(int node, vec3 lower, vec3 upper) {
    ivec2 low = texel_at(NODE_TEXELS * node), high = texel_at(NODE_TEXELS * node + 1);
    imageStore(u_nodes, low, vec4(lower, imageLoad(u_nodes, low).w));
    imageStore(u_nodes, high, vec4(upper, imageLoad(u_nodes, high).w));
}

void bound(ivec4 item) {
    int node = u_mesh_base + item.x;
    vec4 low = imageLoad(u_nodes, texel_at(NODE_TEXELS * node));
    vec4 high = imageLoad(u_nodes, texel_at(NODE_TEXELS * node + 1));
    int first = int(low.w);  // a leaf's first triangle slot; an inner node's left child (right = left + 1)
    vec3 lower = vec3(1.0 / 0.0), upper = vec3(-1.0 / 0.0);
    if (u_pass == 1) {
        for (int slot = first; slot < first + int(high.w); ++slot) {
            for (int k = 0; k < 3; ++k) {
                vec3 corner = imageLoad(u_triangles, texel_at(slot * u_stride + k)).xyz;
                lower = min(lower, corner);
                upper = max(upper, corner);
            }
        }
    } else {
        for (int child = first; child < first + 2; ++child) {
            lower = min(lower, imageLoad(u_nodes, texel_at(NODE_TEXELS * child)).xyz);
            upper = max(upper, imageLoad(u_nodes, texel_at(NODE_TEXELS * child + 1)).xyz);
        }
    }
    set_box(node, lower, upper);
    if (item.y >= 0) {
        u_roots[2 * item.y] = vec4(lower, 0.0);
        u_roots[2 * item.y + 1] = vec4(upper, 0.0);
    }
}

void main() {
    int index = dispatch_index();
    if (index >= u_items) return;
    ivec4 item = u_refit_items[u_first_item + index];
    if (u_pass == 0) {
        triangle_texels(item);
    } else {
        bound(item);
    }
}
