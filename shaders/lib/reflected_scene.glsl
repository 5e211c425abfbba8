// Everything a reflected ray can hit: the reflected objects as the method stands them in (this
// mirror's depth images, its cube map, its billboards, or triangles: simplified or the real
// ones; the hybrid method: the depth images, and the real triangles where they cannot answer;
// the planar method: the mirror's render of the scene through its plane; SSR: the frame itself),
// the analytic planes (floors and walls, intersected exactly by every method), and the
// environment.
#ifndef METHOD
#define METHOD METHOD_DEPTH
#endif
#if METHOD == METHOD_HYBRID && !defined(TRACK_UNSEEN)
// Before any chunk includes the marches (the shadow chunk does, through shading.glsl).
#define TRACK_UNSEEN 1
#endif
#include "ray_hit.glsl"
#include "shading.glsl"
#include "environment.glsl"
#if METHOD == METHOD_DEPTH
#include "depth_image.glsl"
#elif METHOD == METHOD_HYBRID
#include "depth_image.glsl"
#include "triangles.glsl"
#elif METHOD == METHOD_CUBEMAP || METHOD == METHOD_CUBEMAP_PARALLAX
#include "cube_map.glsl"
#elif METHOD == METHOD_BILLBOARD
#include "billboard.glsl"
#elif METHOD == METHOD_PLANAR
#include "planar.glsl"
#elif METHOD == METHOD_SSR
#include "screen_space.glsl"
#else  // METHOD_SIMPLIFIED, METHOD_RAYTRACE: one traversal, other triangles
#include "triangles.glsl"
#endif

#include "analytic_planes.glsl"

#if METHOD == METHOD_DEPTH || METHOD == METHOD_HYBRID
// The first of this mirror's depth images after image `i` whose frustum the ray enters
// (u_depth_image_count: none after it). A ray that misses a frustum misses the image: the march
// would clip it away and return no hit, with nothing unseen.
int next_entered_image(int i, vec3 origin, vec3 direction) {
    for (++i; i < u_depth_image_count; ++i) {
        DepthImage image = u_depth_images[i];
        float t_enter, t_exit;
        if (clip_ray(image, camera_coordinates(image, origin - image.eye.xyz), camera_coordinates(image, direction),
                     UNBOUNDED_RAY, t_enter, t_exit)) break;
    }
    return i;
}

// The nearest hit over all depth images of this mirror, and the first place along the ray where
// one of them relied on what it does not hold (TRACK_UNSEEN). Only the images whose frustum the
// ray enters are marched (most rays of a mirror with many objects enter one or two): a
// software rasterizer such as llvmpipe runs a loop's body for a group of pixels as long as one
// of them needs it, but runs every statement of an `if` whatever the condition, so the march is
// in a loop over the entered images, not under a test inside a loop over all of them.
RayHit nearest_depth_image_hit(vec3 origin, vec3 direction) {
    RayHit best = no_hit(0);
    int samples = 0;
    float unseen_t = UNBOUNDED_RAY;
    int unseen = UNSEEN_NONE;
    for (int i = next_entered_image(-1, origin, direction); i < u_depth_image_count;
         i = next_entered_image(i, origin, direction)) {
        // min(): a software rasterizer may run the body once for a group none of whose pixels
        // entered an image (i == u_depth_image_count, up to the array's size): read a real record.
        RayHit candidate = intersect_depth_image(u_depth_images[min(i, MAX_DEPTH_IMAGES_PER_MIRROR - 1)], origin,
                                                 direction);
        samples += candidate.samples;
        if (candidate.unseen != UNSEEN_NONE && candidate.unseen_t < unseen_t) {
            unseen_t = candidate.unseen_t;
            unseen = candidate.unseen;
        }
        if (candidate.hit && (!best.hit || candidate.t < best.t)) best = candidate;
    }
    if (best.hit) best.color = (best.layer == 1 ? texelFetch(u_impostor_back_color, best.texel, 0)
                                                : texelFetch(u_impostor_color, best.texel, 0)).rgb;
    best.samples = samples;
    return with_unseen(best, unseen_t, unseen);
}
#endif

RayHit nearest_object_hit(vec3 origin, vec3 direction) {
#if METHOD == METHOD_DEPTH || METHOD == METHOD_HYBRID
    return nearest_depth_image_hit(origin, direction);
#elif METHOD == METHOD_CUBEMAP || METHOD == METHOD_CUBEMAP_PARALLAX
    return cube_map_hit(origin, direction);
#elif METHOD == METHOD_BILLBOARD
    return nearest_billboard_hit(origin, direction);
#elif METHOD == METHOD_PLANAR || METHOD == METHOD_SSR
    return nearest_screen_hit(origin, direction);
#else
    return nearest_triangle_hit(origin, direction);
#endif
}

// A plane shape is the rectangle |x| <= w/2, |z| <= d/2 of its local y = 0 plane. The local ray
// keeps the world ray's parameter t because the transform is affine.
RayHit nearest_plane_hit(vec3 origin, vec3 direction) {
    RayHit best = no_hit(0);
    for (int i = 0; i < u_planes.count; ++i) {
        AnalyticPlane plane = u_planes.planes[i];
        vec3 o = (plane.world_to_local * vec4(origin, 1.0)).xyz;
        vec3 d = (plane.world_to_local * vec4(direction, 0.0)).xyz;
        // A ray parallel to the plane never meets it; dividing would give +-Inf or NaN.
        if (abs(d.y) < 1e-12) continue;
        float t = -o.y / d.y;
        vec3 p = o + d * t;
        // t > 0: the ray starts on the mirror, never behind it.
        if (t > 0.0 && all(lessThanEqual(abs(p.xz), plane.half_size)) && (!best.hit || t < best.t)) {
            // The plane's UVs as meshes.plane_uvs lays them out: the image over the whole rectangle.
            vec2 uv = p.xz / (2.0 * plane.half_size) + 0.5;
            best = unlit_hit(t, p.xz, material_albedo(plane.material, p, uv), plane.normal, float(plane.object_id), 0);
        }
    }
    return best;
}

#if METHOD == METHOD_HYBRID
uniform sampler2D u_impostor_triangles;  // per atlas sample: the triangle it shows (its place in the BVH's list)
uniform sampler2D u_bvh_places;          // per triangle of that list: its place in the BVH's order

// The ray against a triangle a sample shows (`listed`: its place in the BVH's list): its place in
// the BVH's order, or -1 where the ray meets it no nearer than `best_t` or outside
// EXACT_SURFACE_WINDOW of the hit's t.
int listed_triangle(RayHit hit, float listed, vec3 origin, vec3 direction, inout float best_t, inout vec2 best_uv) {
    int triangle = int(bvh_fetch(u_bvh_places, int(listed)).x);
    vec2 uv;
    float t = intersect_triangle(origin, direction, triangle, uv);
    if (!(t > 0.0 && abs(t - hit.t) <= EXACT_SURFACE_WINDOW * hit.t && t < best_t)) return -1;
    // A ray coming from outside meets a closed surface first where it enters: a triangle met from
    // behind (the box's bottom, met from inside where the ray comes down through the box) is where
    // it leaves, and the entry is elsewhere. (An open mesh met from behind is traced instead.)
    if (dot(triangle_normal(triangle), direction) >= 0.0) return -1;
    best_t = t;
    best_uv = uv;
    return triangle;
}

// A certain hit made exact: the ray against the real triangles that the 3 x 3 samples around the
// hit show on both layers (a triangle smaller than a texel can fall between samples; a hit on one
// layer can be on the other's triangle, where a box's faces meet), the nearest intersection within
// EXACT_SURFACE_WINDOW of the hit's t. The nearest, not the first found: a face beyond the true one
// (the box's bottom, on the floor) also lies within the window. The hit is then shaded as the
// ray-traced method shades it (the true normal, the material at the true point). False when none
// is there: the ray is traced instead.
int exact_surface(RayHit hit, vec3 origin, vec3 direction, out float best_t, out vec2 best_uv) {
    best_t = UNBOUNDED_RAY;
    best_uv = vec2(0.0);
    int best = -1;
    ivec2 size = textureSize(u_impostor_triangles, 0);
    // A loop with no iteration where no ray of a group of pixels needs it (see
    // nearest_depth_image_hit on why not a test around it).
    int candidates = hit.hit ? 9 : 0;
    for (int k = 0; k < candidates; ++k) {
        ivec2 texel = clamp(hit.texel + ivec2(k % 3 - 1, k / 3 - 1), ivec2(0), size - 1);
        vec2 listed = texelFetch(u_impostor_triangles, texel, 0).rg;
        for (int layer = 0; layer < 2; ++layer) {
            int triangle = listed_triangle(hit, listed[layer], origin, direction, best_t, best_uv);
            if (triangle >= 0) best = triangle;
        }
    }
    return best;
}

// The hybrid method's answer: the depth images' where it rests on nothing they do not hold before
// the nearest thing found (an object, made exact, or a plane, which is), and otherwise the real
// triangles', traced through the BVH (in the same pass: see docs/methods_and_results.md, "`--method hybrid`").
RayHit resolve_unseen(RayHit hit, RayHit plane, vec3 origin, vec3 direction) {
    float answer_t = UNBOUNDED_RAY;
    if (hit.hit) answer_t = hit.t;
    if (plane.hit) answer_t = min(answer_t, plane.t);
    if (hit.unseen == UNSEEN_NONE || hit.unseen_t > answer_t) {
        // The images' t is as good as their sampling: a plane within the window of it (a box
        // standing on the floor) is ordered against the exact hit instead.
        if (!hit.hit || (plane.hit && plane.t < (1.0 - EXACT_SURFACE_WINDOW) * hit.t)) return hit;
    }
    // One triangle, found either way, shaded once (llvmpipe's shaders slow down with every copy
    // of the shading code they hold, run or not).
    float t;
    vec2 uv;
    int visited = 0;
    int triangle = hit.unseen == UNSEEN_NONE || hit.unseen_t > answer_t ? exact_surface(hit, origin, direction, t, uv) : -1;
    bool retraced = triangle < 0;
    if (retraced) triangle = nearest_triangle(origin, direction, t, uv, visited);
    RayHit found = triangle < 0 ? no_hit(0) : triangle_hit(origin, direction, triangle, t, uv, 0);
    found.samples = hit.samples + visited;
    found.unseen_t = hit.unseen_t;
    found.unseen = hit.unseen;
    found.retraced = retraced;
    return found;
}
#endif

// What the reflected ray origin + t * direction sees: the nearest hit, or the environment.
RayHit trace_reflected(vec3 origin, vec3 direction) {
    RayHit hit = nearest_object_hit(origin, direction);
    RayHit plane = nearest_plane_hit(origin, direction);
#if METHOD == METHOD_HYBRID
    hit = resolve_unseen(hit, plane, origin, direction);
#endif
    if (plane.hit && (!hit.hit || plane.t < hit.t)) {
        plane.samples = hit.samples;
        plane.retraced = hit.retraced;
        hit = plane;
    }
    if (!hit.hit) hit.color = environment(direction);
    if (hit.hit && hit.unlit) hit.color = shade(hit.color, origin + direction * hit.t, hit.normal);
    return hit;
}
