// The ray-traced method: the reflected objects' real triangles, in world space, found through a
// BVH (depthimpostor/bvh.py) and shaded as the rasterizer shades them. Nodes and triangles live
// in float textures (GL 3.3 has no storage buffers): element i is texel (i % width, i / width).
#include "../generated/triangle_object.glsl"
#include "ray_hit.glsl"
#include "shading.glsl"

uniform sampler2D u_bvh_nodes;      // 3 texels a node: (lower, first), (upper, count), (skip, 0, 0, 0)
// BVH_TRIANGLE_TEXELS a triangle: p0 (w: object slot), p1, p2, n0, n1, n2, (uv0, uv1), (uv2, 0, 0)
uniform sampler2D u_bvh_triangles;
// The objects' records (a triangle names its object's slot): a uniform block up to
// TRIANGLE_OBJECT_BLOCK_RECORDS, past it a storage buffer (as lib/baked_images.glsl's images; the
// record is vec4s and a mat4, laid out alike by std140 and std430).
#ifndef TRIANGLE_OBJECT_CAPACITY
#define TRIANGLE_OBJECT_CAPACITY TRIANGLE_OBJECT_BLOCK_RECORDS
#endif
#if TRIANGLE_OBJECT_CAPACITY > TRIANGLE_OBJECT_BLOCK_RECORDS
layout(std430) readonly buffer TriangleObjects {
    TriangleObject u_triangle_objects[];
};
#else
layout(std140) uniform TriangleObjects {
    TriangleObject u_triangle_objects[TRIANGLE_OBJECT_CAPACITY];
};
#endif

vec4 bvh_fetch(sampler2D data, int index) {
    return texelFetch(data, ivec2(index % BVH_TEXTURE_WIDTH, index / BVH_TEXTURE_WIDTH), 0);
}

// Slab test against [lower, upper]; t_near is where the ray enters. An axis the ray is parallel to
// (1/0 = +-Inf) is set apart: the ray is always inside its slab or never, by where it starts. Left
// to the Infs, a ray lying exactly in a slab's face gives 0 * Inf = NaN, which GLSL's min and max
// may pass on, and the box (with what it holds) could be missed.
bool ray_meets_box(vec3 origin, vec3 inverse_direction, vec3 lower, vec3 upper, float t_max, out float t_near) {
    vec3 t0 = (lower - origin) * inverse_direction;
    vec3 t1 = (upper - origin) * inverse_direction;
    bvec3 parallel = isinf(inverse_direction);
    vec3 near_t = mix(min(t0, t1), vec3(-UNBOUNDED_RAY), parallel);  // selects, no arithmetic
    vec3 far_t = mix(max(t0, t1), vec3(UNBOUNDED_RAY), parallel);
    vec3 beyond_slab = max(lower - origin, origin - upper);  // > 0 on an axis whose slab the origin is out of
    bool outside_a_parallel_slab = any(greaterThan(mix(vec3(-1.0), beyond_slab, parallel), vec3(0.0)));
    t_near = max(max(near_t.x, near_t.y), max(near_t.z, 0.0));
    float t_far = min(min(far_t.x, far_t.y), min(far_t.z, t_max));
    return t_near <= t_far && !outside_a_parallel_slab;
}

// Moller-Trumbore; returns t (or -1) and the barycentrics (u, v) of p1 and p2. Triangles are
// two-sided: a reflected ray may meet a back face of an open mesh, and Embree's truth does too.
float ray_triangle(vec3 origin, vec3 direction, vec3 p0, vec3 p1, vec3 p2, out vec2 uv) {
    vec3 edge1 = p1 - p0, edge2 = p2 - p0;
    vec3 p = cross(direction, edge2);
    float determinant = dot(edge1, p);
    uv = vec2(0.0);
    if (determinant == 0.0) return -1.0;  // the ray lies in the triangle's plane
    float inverse = 1.0 / determinant;
    vec3 s = origin - p0;
    uv.x = dot(s, p) * inverse;
    vec3 q = cross(s, edge1);
    uv.y = dot(direction, q) * inverse;
    if (uv.x < 0.0 || uv.y < 0.0 || uv.x + uv.y > 1.0) return -1.0;
    return dot(edge2, q) * inverse;
}

// The ray against triangle i (of the BVH's order): t (or -1) and the barycentrics.
float intersect_triangle(vec3 origin, vec3 direction, int i, out vec2 uv) {
    int base = BVH_TRIANGLE_TEXELS * i;
    return ray_triangle(origin, direction, bvh_fetch(u_bvh_triangles, base).xyz, bvh_fetch(u_bvh_triangles, base + 1).xyz,
                        bvh_fetch(u_bvh_triangles, base + 2).xyz, uv);
}

// Triangle i's geometric normal, outward (meshes wind their triangles counter-clockwise seen from
// outside, and keep that under mirroring transforms: meshes.py), not unit length.
vec3 triangle_normal(int i) {
    int base = BVH_TRIANGLE_TEXELS * i;
    vec3 p0 = bvh_fetch(u_bvh_triangles, base).xyz;
    return cross(bvh_fetch(u_bvh_triangles, base + 1).xyz - p0, bvh_fetch(u_bvh_triangles, base + 2).xyz - p0);
}

// The hit on triangle i at t (barycentrics uv), to be shaded as the rasterizer shades the object
// (trace_reflected does, with the interpolated normal and the material's albedo at the point).
RayHit triangle_hit(vec3 origin, vec3 direction, int i, float t, vec2 uv, int samples) {
    int base = BVH_TRIANGLE_TEXELS * i;
    int slot = int(bvh_fetch(u_bvh_triangles, base).w);
    vec3 normal = safe_normalize((1.0 - uv.x - uv.y) * bvh_fetch(u_bvh_triangles, base + 3).xyz
                                 + uv.x * bvh_fetch(u_bvh_triangles, base + 4).xyz
                                 + uv.y * bvh_fetch(u_bvh_triangles, base + 5).xyz, -direction);
    TriangleObject object = u_triangle_objects[slot];
    vec3 position = origin + direction * t;
    Material material = Material(object.kind_and_id.x, object.color_a.xyz, object.color_b.xyz, object.color_a.w,
                                 object.kind_and_id.z, object.texture.xy);
    vec4 uv01 = bvh_fetch(u_bvh_triangles, base + 6);
    vec2 texture_uv = (1.0 - uv.x - uv.y) * uv01.xy + uv.x * uv01.zw + uv.y * bvh_fetch(u_bvh_triangles, base + 7).xy;
    vec3 albedo = material_albedo(material, (object.world_to_local * vec4(position, 1.0)).xyz, texture_uv);
    return unlit_hit(t, uv, albedo, normal, float(object.kind_and_id.y), samples);
}

// The nearest triangle the ray meets through the BVH (-1: none), with its t and barycentrics, and
// the nodes visited.
int nearest_triangle(vec3 origin, vec3 direction, out float best_t, out vec2 best_uv, out int visited) {
    vec3 inverse_direction = 1.0 / direction;
    best_t = 3.0e38;
    int best_triangle = -1;
    best_uv = vec2(0.0);
    visited = 0;
    // Depth-first through the skip links (bvh.py): into an inner node's left child when the ray
    // meets its box, else past its subtree. The node count bounds the walk.
    int node = 0;
    while (node >= 0) {
        vec4 lower = bvh_fetch(u_bvh_nodes, 3 * node), upper = bvh_fetch(u_bvh_nodes, 3 * node + 1);
        int skip = int(bvh_fetch(u_bvh_nodes, 3 * node + 2).x);
        float t_near;
        ++visited;
        if (!ray_meets_box(origin, inverse_direction, lower.xyz, upper.xyz, best_t, t_near)) {
            node = skip;
            continue;
        }
        int first = int(lower.w), count = int(upper.w);
        if (count == 0) {
            node = first;
            continue;
        }
        node = skip;
        for (int i = first; i < first + count; ++i) {
            vec2 uv;
            float t = intersect_triangle(origin, direction, i, uv);
            if (t > 0.0 && t < best_t) {
                best_t = t;
                best_triangle = i;
                best_uv = uv;
            }
        }
    }
    return best_triangle;
}

RayHit nearest_triangle_hit(vec3 origin, vec3 direction) {
    float t;
    vec2 uv;
    int visited;
    int triangle = nearest_triangle(origin, direction, t, uv, visited);
    return triangle < 0 ? no_hit(visited) : triangle_hit(origin, direction, triangle, t, uv, visited);
}
