// The traced methods: the reflected objects' real triangles, found through a two-level BVH
// (methods/triangles.py, methods/instances.py, methods/bvh.py) and shaded as the rasterizer shades
// them. The bottom level is one hierarchy per distinct mesh, over its triangles in its own space;
// the top level is a hierarchy over the instances, one per reflected object (its transform,
// material and mesh), in world space. A ray meets an instance's mesh in the mesh's space: it goes
// through the instance's world_to_local (an affine map), its direction not made unit again, so
// that the t found there is the world ray's t, and every t compares with every other. Everything
// lives in float textures (GL 3.3 has no storage buffers): element i is texel (i % width, i / width).
#include "ray_hit.glsl"
#include "shading.glsl"

// 3 texels a node, either level: (lower, first), (upper, count), (skip, 0, 0, 0). From node 0 the
// top level (a leaf holds one instance: `first` is its slot), from texel u_instance_records the
// instance records, then every mesh's bottom level (a leaf's `first`: its first triangle).
uniform sampler2D u_bvh_nodes;
uniform int u_instance_records;
// TRIANGLE_TEXELS a triangle, in its mesh's space: p0, p1, p2, n0, n1, n2, (uv0, uv1), (uv2, 0, 0),
// then the glTF attributes the scene uses (constants.triangle_texel_layout): TEXCOORD_1's
// (uv1_0, uv1_1) with uv1_2 in the zw of texel 7, the corners' colours, their tangents.
uniform sampler2D u_bvh_triangles;
#ifndef TRIANGLE_TEXELS
#define TRIANGLE_TEXELS BVH_TRIANGLE_TEXELS
#endif
#include "../generated/triangle_instance.glsl"

vec4 bvh_fetch(sampler2D data, int index) {
    return texelFetch(data, ivec2(index % BVH_TEXTURE_WIDTH, index / BVH_TEXTURE_WIDTH), 0);
}

TriangleInstance triangle_instance(int slot) {
    return read_triangle_instance(u_bvh_nodes, u_instance_records + TRIANGLE_INSTANCE_TEXELS * slot);
}

// The world ray in the instance's mesh space (the same t on both).
void ray_in_instance(TriangleInstance instance, vec3 origin, vec3 direction, out vec3 local_origin,
                     out vec3 local_direction) {
    local_origin = (instance.world_to_local * vec4(origin, 1.0)).xyz;
    local_direction = mat3(instance.world_to_local) * direction;
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
// two-sided here: a reflected ray may meet a back face of an open mesh, and Embree's truth does
// too (a single-sided material's are passed by where the traversal meets them: nearest_in_mesh).
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

// The ray (in the triangle's mesh space) against triangle i of the triangle texture: t (or -1) and
// the barycentrics.
float intersect_triangle(vec3 origin, vec3 direction, int i, out vec2 uv) {
    int base = TRIANGLE_TEXELS * i;
    return ray_triangle(origin, direction, bvh_fetch(u_bvh_triangles, base).xyz, bvh_fetch(u_bvh_triangles, base + 1).xyz,
                        bvh_fetch(u_bvh_triangles, base + 2).xyz, uv);
}

// Triangle i's geometric normal in its mesh's space, outward (meshes wind their triangles
// counter-clockwise seen from outside), not unit length. Its sign against a ray's direction is the
// same in world space: a normal maps to the world by the inverse transpose of the instance's
// local-to-world map, so dot(world normal, world direction) = dot(normal, local direction), and a
// mirroring transform keeps it outward.
vec3 triangle_normal(int i) {
    int base = TRIANGLE_TEXELS * i;
    vec3 p0 = bvh_fetch(u_bvh_triangles, base).xyz;
    return cross(bvh_fetch(u_bvh_triangles, base + 1).xyz - p0, bvh_fetch(u_bvh_triangles, base + 2).xyz - p0);
}

// Texel `texel` of triangle i's three corners (texel, texel + 1, texel + 2) at barycentrics uv.
vec4 triangle_corners(int i, int texel, vec2 uv) {
    int base = TRIANGLE_TEXELS * i + texel;
    return (1.0 - uv.x - uv.y) * bvh_fetch(u_bvh_triangles, base) + uv.x * bvh_fetch(u_bvh_triangles, base + 1)
           + uv.y * bvh_fetch(u_bvh_triangles, base + 2);
}

// The mesh point on triangle i at barycentrics uv (those of p1 and p2): its texture coordinates,
// and the attributes the scene uses, interpolated as the rasterizer interpolates them (the
// tangent still in the mesh's space: triangle_hit takes it into the world).
MeshPoint triangle_point(int i, vec2 uv) {
    int base = TRIANGLE_TEXELS * i;
    vec4 uv01 = bvh_fetch(u_bvh_triangles, base + 6);
    vec4 uv2 = bvh_fetch(u_bvh_triangles, base + 7);
    MeshPoint point = mesh_point((1.0 - uv.x - uv.y) * uv01.xy + uv.x * uv01.zw + uv.y * uv2.xy);
#ifdef TEXCOORD_1
    vec4 uv1_01 = bvh_fetch(u_bvh_triangles, base + TRIANGLE_UVS1_TEXEL);
    point.uv1 = (1.0 - uv.x - uv.y) * uv1_01.xy + uv.x * uv1_01.zw + uv.y * uv2.zw;
#endif
#ifdef VERTEX_COLORS
    point.color = triangle_corners(i, TRIANGLE_COLORS_TEXEL, uv);
#endif
#ifdef NORMAL_MAP
    point.tangent = triangle_corners(i, TRIANGLE_TANGENTS_TEXEL, uv);
#endif
    return point;
}

// The hit on triangle i of instance `slot` at t (barycentrics uv), to be shaded as the rasterizer
// shades the object (trace_reflected does, with the interpolated normal and the material's albedo
// at the point).
RayHit triangle_hit(vec3 origin, vec3 direction, int slot, int i, float t, vec2 uv, int samples) {
    int base = TRIANGLE_TEXELS * i;
    TriangleInstance object = triangle_instance(slot);
    vec3 local_normal = (1.0 - uv.x - uv.y) * bvh_fetch(u_bvh_triangles, base + 3).xyz
                        + uv.x * bvh_fetch(u_bvh_triangles, base + 4).xyz + uv.y * bvh_fetch(u_bvh_triangles, base + 5).xyz;
    // Into the world by the inverse transpose of local-to-world, which is world_to_local transposed:
    // a row vector times the matrix.
    vec3 normal = safe_normalize(local_normal * mat3(object.world_to_local), -direction);
    vec3 position = origin + direction * t;
    Material material = u_materials[object.ids.x];
    MeshPoint point = triangle_point(i, uv);
#ifdef NORMAL_MAP
    // A tangent goes into the world by local-to-world itself (the normal by its inverse transpose),
    // a mirroring map turning the bitangent's sign (as mesh.vert does it).
    mat3 local_to_world = inverse(mat3(object.world_to_local));
    point.tangent = vec4(local_to_world * point.tangent.xyz,
                         determinant(local_to_world) < 0.0 ? -point.tangent.w : point.tangent.w);
#endif
    vec3 albedo = material_albedo(material, (object.world_to_local * vec4(position, 1.0)).xyz, point);
#ifdef DOUBLE_SIDED
    // glTF's doubleSided: a back face met is shaded turned round (a single-sided one's is never met).
    if (material.double_sided == SIDES_DOUBLE && dot(triangle_normal(i), mat3(object.world_to_local) * direction) > 0.0)
        turn_to_back(normal, point);
#endif
    return unlit_hit(t, uv, albedo, normal, object.ids.x, point, float(object.ids.y), samples);
}

// The nearest triangle of one mesh that the ray (in the mesh's space) meets nearer than best_t,
// through the mesh's hierarchy from node `root`: depth-first through the skip links (bvh.py), into
// an inner node's left child when the ray meets its box, else past its subtree; the root's skip
// link (-1) ends the walk. A triangle found updates best_* (best_slot: `slot`). ALPHA_MASK: a
// point the instance's `material` cuts away (glTF's alphaMode MASK) is passed through; SINGLE_SIDED:
// so is a back face of a single-sided material (glTF's doubleSided false: it is not there).
void nearest_in_mesh(int root, int slot, int material, vec3 origin, vec3 direction, inout float best_t,
                     inout vec2 best_uv, inout int best_triangle, inout int best_slot, inout int visited) {
    vec3 inverse_direction = 1.0 / direction;
    int node = root;
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
#ifdef SINGLE_SIDED
                if (u_materials[material].double_sided == SIDES_SINGLE && dot(triangle_normal(i), direction) >= 0.0) continue;
#endif
#ifdef ALPHA_MASK
                if (material_masked(u_materials[material], triangle_point(i, uv))) continue;
#endif
                best_t = t;
                best_triangle = i;
                best_slot = slot;
                best_uv = uv;
            }
        }
    }
}

// The nearest triangle the ray meets (-1: none), with its instance's slot, its t and barycentrics,
// and the nodes visited (both levels): the top level walked as a mesh's is, each instance whose
// box the ray meets walked in its own space.
int nearest_triangle(vec3 origin, vec3 direction, out float best_t, out vec2 best_uv, out int best_slot,
                     out int visited) {
    vec3 inverse_direction = 1.0 / direction;
    best_t = 3.0e38;
    int best_triangle = -1;
    best_slot = -1;
    best_uv = vec2(0.0);
    visited = 0;
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
        TriangleInstance instance = triangle_instance(first);
        vec3 local_origin, local_direction;
        ray_in_instance(instance, origin, direction, local_origin, local_direction);
        nearest_in_mesh(instance.mesh.x, first, instance.ids.x, local_origin, local_direction, best_t, best_uv,
                        best_triangle, best_slot, visited);
    }
    return best_triangle;
}

RayHit nearest_triangle_hit(vec3 origin, vec3 direction) {
    float t;
    vec2 uv;
    int slot, visited;
    int triangle = nearest_triangle(origin, direction, t, uv, slot, visited);
    return triangle < 0 ? no_hit(visited) : triangle_hit(origin, direction, slot, triangle, t, uv, visited);
}
