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
#ifdef GLOSSY
#include "glossy.glsl"
#endif
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
// The planes traced: a constant of the program where the pass gives one (PLANE_COUNT, from the
// scene: passes/reflectors.py's reflector_defines), for the reason LIGHT_COUNT is (lib/shading.glsl).
#ifndef PLANE_COUNT
#define PLANE_COUNT u_planes.count
#endif

#if METHOD == METHOD_DEPTH || METHOD == METHOD_HYBRID
// The sphere of image j the ray is tested against: the variants that track unseen space need all
// the image can answer; the others its hits alone, in the tighter sphere around them.
vec4 image_bound(int j) {
#ifdef TRACK_UNSEEN
    return u_depth_images[j].bound;
#else
    return u_depth_images[j].hit_bound;
#endif
}

// A hit of image `image` kept if it is the nearest so far (and within t_limit); what it relied
// on and does not hold (TRACK_UNSEEN) kept if it comes first.
void take_candidate(RayHit candidate, int image, float t_limit, inout RayHit best, inout int best_image,
                    inout int samples, inout float unseen_t, inout int unseen) {
    samples += candidate.samples;
    if (candidate.unseen != UNSEEN_NONE && candidate.unseen_t < unseen_t) {
        unseen_t = candidate.unseen_t;
        unseen = candidate.unseen;
    }
    if (candidate.hit && candidate.t <= t_limit && (!best.hit || candidate.t < best.t)) {
        best = candidate;
        best_image = image;
    }
}

// The hit's colour from the atlas and, for a glossy mirror's cone, prefiltered at its footprint
// (the back layer, seen from behind, keeps its texel: it has no mips; the hybrid method, whose
// exact triangles have none either, keeps its texels too: plan.py's _builds_colour_mips).
RayHit coloured(RayHit best, int best_image, vec3 origin, vec3 direction) {
    if (best.hit) best.color = (best.layer == 1 ? texelFetch(u_impostor_back_color, best.texel, 0)
                                                : texelFetch(u_impostor_color, best.texel, 0)).rgb;
#if defined(GLOSSY) && METHOD == METHOD_DEPTH
    if (best.hit && best.layer == 0) {
        DepthImage image = u_depth_images[best_image];
        best.color = cone_color(image, origin + direction * best.t - image.eye.xyz, best.t, best.color);
    }
#endif
    return best;
}

// The two images the ray visits after image `after`, which it entered at `after_t` (-1 before the
// first), in the order of the visits: by where the ray enters their bounds, ties by index, among
// the images it enters no later than `limit`. u_depth_image_count (entered at UNBOUNDED_RAY)
// where there are fewer. The candidates are every image, or with IMAGE_CELLS those of the ray's
// list (`list`: image_list's), which holds every image the ray can enter, in rising index: the
// same two are found. The loop's bound is a constant and the count a `break`: llvmpipe unrolls
// it and reads each record's bound from one place for all the pixels of a group, where a loop to a
// uniform reads it lane by lane at every iteration (twice the cost).
void next_two_images(ivec2 list, int after, float after_t, float limit, vec3 origin, vec3 direction,
                     float inverse_square_length, out int first, out float first_t, out int second, out float second_t) {
    first = second = u_depth_image_count;
    first_t = second_t = UNBOUNDED_RAY;
    for (int k = 0; k < DEPTH_IMAGE_CAPACITY; ++k) {
        if (k >= list.y - list.x) break;
#ifdef IMAGE_CELLS
        int j = u_image_cells[list.x + k];
#else
        int j = k;
#endif
        float t = bound_entry(image_bound(j), origin, direction, inverse_square_length);
        bool candidate = (t > after_t || (t == after_t && j > after)) && t < UNBOUNDED_RAY && t <= limit;
        // j rises: an image entered where an earlier one is comes after it.
        bool before_first = candidate && t < first_t;
        bool before_second = candidate && !before_first && t < second_t;
        second = before_first ? first : before_second ? j : second;
        second_t = before_first ? first_t : before_second ? t : second_t;
        first = before_first ? j : first;
        first_t = before_first ? t : first_t;
    }
}

// The nearest hit over all depth images of this mirror with t <= t_limit (or none), and the first
// place along the ray where one of them relied on what it does not hold (TRACK_UNSEEN). The
// images are visited nearest first, by where the ray enters their bounds, and the search stops
// where the next is entered beyond the nearest hit so far (or beyond t_limit): whatever it could
// answer lies at or after its entry, and an answer after the nearest hit is no hit of the frame.
// (Nor, with TRACK_UNSEEN, a reason that matters: resolve_unseen looks for unseen space before
// the answer only; an image is skipped only when entered strictly after the hit.) A mirror with
// many objects then marches the one or two a ray meets. One scan of the bounds (of the ray's list
// with IMAGE_CELLS) finds the next two (most rays visit one or none, and stop at the second's
// entry); another runs only where a ray has visited both. The march and the scan are in loops of as many iterations as are needed,
// not under tests: a software rasterizer such as llvmpipe runs a loop's body for a group of pixels
// as long as one of them needs it, but runs every statement of an `if` whatever the condition
// (tools/branch_cost.py).
RayHit nearest_depth_image_hit(vec3 origin, vec3 direction, float t_limit) {
    RayHit best = no_hit(0);
    int best_image = 0, samples = 0, unseen = UNSEEN_NONE;
    float unseen_t = UNBOUNDED_RAY;
    float inverse_square_length = 1.0 / dot(direction, direction);
    int next, after_next, last = -1;
    float next_t, after_next_t, last_t = -1.0;
#ifdef IMAGE_CELLS
    ivec2 list = image_list(origin, direction);
#else
    ivec2 list = ivec2(0, u_depth_image_count);
#endif
    next_two_images(list, last, last_t, t_limit, origin, direction, inverse_square_length, next, next_t, after_next,
                    after_next_t);
    bool exhausted = after_next >= u_depth_image_count;  // the scan found every image left
    for (int visit = 0; visit < DEPTH_IMAGE_CAPACITY; ++visit) {
        float limit = best.hit ? min(best.t, t_limit) : t_limit;
        for (int scan = next >= u_depth_image_count && !exhausted ? 1 : 0; scan > 0; --scan) {
            next_two_images(list, last, last_t, limit, origin, direction, inverse_square_length, next, next_t, after_next,
                            after_next_t);
            exhausted = after_next >= u_depth_image_count;
        }
        if (next >= u_depth_image_count || next_t > limit) break;
        // min(): a software rasterizer runs the body for a group as long as one of its pixels has
        // an image left (others have next == u_depth_image_count, up to the array's size): read a
        // real record.
        int image = min(next, DEPTH_IMAGE_CAPACITY - 1);
#if METHOD == METHOD_HYBRID
        // An image not baked yet (its bake deferred to a later frame: BakedImages.bake_budget,
        // surface.w set) holds nothing: what the ray meets from its bound's entry on is traced.
        RayHit candidate = u_depth_images[image].surface.w != 0.0
            ? with_unseen(no_hit(0), next_t, UNSEEN_PENDING)
            : intersect_depth_image(u_depth_images[image], origin, direction, limit);
#else
        RayHit candidate = intersect_depth_image(u_depth_images[image], origin, direction, limit);
#endif
        take_candidate(candidate, image, t_limit, best, best_image, samples, unseen_t, unseen);
        last = next;
        last_t = next_t;
        next = after_next;
        next_t = after_next_t;
        after_next = u_depth_image_count;
        after_next_t = UNBOUNDED_RAY;
    }
    best = coloured(best, best_image, origin, direction);
    best.image = best_image;
    best.samples = samples;
    return with_unseen(best, unseen_t, unseen);
}
#endif

// The nearest reflected object; the depth-image method looks no farther than t_limit (the others
// do: their answer beyond it is no worse, and they have no order to stop early in).
RayHit nearest_object_hit(vec3 origin, vec3 direction, float t_limit) {
#ifdef OBJECTS_LEFT_OUT
    // A bound, not a method: the mirror pass with no reflected object at all, the least any
    // stand-in can cost (tools/interactive_frame.py; never made by the renderer).
    return no_hit(0);
#endif
#if METHOD == METHOD_DEPTH || METHOD == METHOD_HYBRID
    return nearest_depth_image_hit(origin, direction, t_limit);
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

#ifdef NORMAL_MAP
// A plane's tangent, for a normal map on it: its UVs (meshes.plane_uvs) grow along local +x (dP/du)
// and down the image along local +z, so that N x T = -z points up the image (w = 1), in the world
// by the plane's local-to-world map (w turned by a mirroring one). The truth's plane_tangent.
vec4 plane_tangent(AnalyticPlane plane) {
    mat3 local_to_world = inverse(mat3(plane.world_to_local));
    return vec4(local_to_world[0], determinant(local_to_world) < 0.0 ? -1.0 : 1.0);
}
#endif

// A plane shape is the rectangle |x| <= w/2, |z| <= d/2 of its local y = 0 plane. The local ray
// keeps the world ray's parameter t because the transform is affine.
RayHit nearest_plane_hit(vec3 origin, vec3 direction) {
    RayHit best = no_hit(0);
    for (int i = 0; i < PLANE_COUNT; ++i) {
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
            MeshPoint point = mesh_point(p.xz / (2.0 * plane.half_size) + 0.5);
#ifdef NORMAL_MAP
            point.tangent = plane_tangent(plane);
#endif
            Material material = u_materials[plane.material];
#ifdef ALPHA_MASK
            if (material_masked(material, point)) continue;  // cut away: the ray goes on
#endif
            // glTF's doubleSided: met from behind, a single-sided plane is not there, a
            // double-sided one is shaded turned round (its normal: `plane.normal` is outward).
            vec3 normal = plane.normal;
#if defined(SINGLE_SIDED) || defined(DOUBLE_SIDED)
            bool from_behind = dot(plane.normal, direction) > 0.0;
#endif
#ifdef SINGLE_SIDED
            if (from_behind && material.double_sided == SIDES_SINGLE) continue;
#endif
#ifdef DOUBLE_SIDED
            if (from_behind && material.double_sided == SIDES_DOUBLE) turn_to_back(normal, point);
#endif
            vec3 albedo = material_albedo(material, p, point);
#ifdef GLOSSY
            // A glossy mirror's cone: the checker box-filtered over its footprint on the plane.
            if (g_cone_tan > 0.0 && material.kind == MATERIAL_CHECKER) {
                float share = checker_b_share(p.xz / material.scale, plane_footprint(d, t) / material.scale);
                albedo = mix(material.color_a, material.color_b, share);
            }
#endif
            best = unlit_hit(t, p.xz, albedo, normal, plane.material, point, float(plane.object_id), 0);
        }
    }
    return best;
}

#if METHOD == METHOD_HYBRID
uniform sampler2D u_impostor_triangles;  // per atlas sample: the triangle it shows (its place in the list of every object's)
// per triangle of that list: (its place in the triangle texture, its instance's slot)
uniform sampler2D u_bvh_places;

// The triangle a window sample shows (`listed`: its place in the list), and its instance's slot.
int listed_place(float listed, out int slot) {
    vec4 place = bvh_fetch(u_bvh_places, int(listed));
    slot = int(place.y);
    return int(place.x);
}

// The ray against a triangle a sample shows (`listed`: its place in the list): its place in the
// triangle texture (and its instance's slot in `slot`), or -1 where the ray meets it no nearer than
// `best_t` or outside EXACT_SURFACE_WINDOW of the hit's t.
int listed_triangle(RayHit hit, float listed, vec3 origin, vec3 direction, inout float best_t, inout vec2 best_uv,
                    out int slot) {
    int triangle = listed_place(listed, slot);
    vec3 local_origin, local_direction;
    ray_in_instance(triangle_instance(slot), origin, direction, local_origin, local_direction);
    vec2 uv;
    float t = intersect_triangle(local_origin, local_direction, triangle, uv);
    if (!(t > 0.0 && abs(t - hit.t) <= EXACT_SURFACE_WINDOW * hit.t && t < best_t)) return -1;
    // A ray coming from outside meets a closed surface first where it enters: a triangle met from
    // behind (the box's bottom, met from inside where the ray comes down through the box) is where
    // it leaves, and the entry is elsewhere. (An open mesh met from behind is traced instead.)
    if (dot(triangle_normal(triangle), local_direction) >= 0.0) return -1;
    best_t = t;
    best_uv = uv;
    return triangle;
}

// The texel `k` (0 to 8) of the 3 x 3 window around the hit's sample.
ivec2 window_texel(RayHit hit, int k) {
    return clamp(hit.texel + ivec2(k % 3 - 1, k / 3 - 1), ivec2(0), textureSize(u_impostor_triangles, 0) - 1);
}

// Is the exact hit `point`, on triangle `triangle` of instance `slot` (shown on `layer`), hidden
// from the image's eye by another triangle that the 2 x 2 samples around the point's image show on
// that layer? A layer holds, per sample, the surface its eye meets first (the visible surface; the
// nearest back face): a point of it that another triangle of the layer hides is not in the image,
// which then cannot vouch that the ray's way to it is empty. A triangle thinner than a texel can
// fall between the samples (a fold of a shell seen edge-on, DamagedHelmet's:
// results/llvmpipe/public_models.md): the ray meets it first, goes on behind the surface beside
// the fold, and meets a surface the window does show, within the window of t, where the eye does
// not see it. (A triangle that hides the point covers its image, so it is what the samples nearest
// that image show, unless it is thinner than a texel there too.)
bool hidden_from_eye(RayHit hit, vec3 point, int triangle, int slot, int layer) {
    DepthImage image = u_depth_images[hit.image];
    vec3 seen = camera_coordinates(image, point - image.eye.xyz);
    // The block's first sample: the texel whose centre is the nearest above and left of the point.
    ivec2 corner = ivec2(floor(seen.xy / seen.z - 0.5));
    bool hidden = false;
    int checks = triangle >= 0 ? 4 : 0;  // as exact_surface's loop, for the same reason
    for (int k = 0; k < checks; ++k) {
        ivec2 texel = image.tile.xy + clamp(corner + ivec2(k % 2, k / 2), ivec2(0), image.tile.zw - 1);
        int other_slot;
        int other = listed_place(texelFetch(u_impostor_triangles, texel, 0)[layer], other_slot);
        vec3 local_origin, local_direction;
        ray_in_instance(triangle_instance(other_slot), image.eye.xyz, point - image.eye.xyz, local_origin,
                        local_direction);
        vec2 uv;
        float s = intersect_triangle(local_origin, local_direction, other, uv);
        hidden = hidden || ((other != triangle || other_slot != slot) && s > 0.0 && s < 1.0 - HIDDEN_HIT_MARGIN);
    }
    return hidden;
}

// A certain hit made exact: the ray against the real triangles that the 3 x 3 samples around the
// hit show on both layers (a triangle smaller than a texel can fall between samples; a hit on one
// layer can be on the other's triangle, where a box's faces meet), the nearest intersection within
// EXACT_SURFACE_WINDOW of the hit's t. The nearest, not the first found: a face beyond the true one
// (the box's bottom, on the floor) also lies within the window. The hit is then shaded as the
// ray-traced method shades it (the true normal, the material at the true point). -1 when none
// is there, or when the one found is hidden from the image's eye (hidden_from_eye): the ray is
// traced instead.
int exact_surface(RayHit hit, vec3 origin, vec3 direction, out float best_t, out vec2 best_uv, out int best_slot) {
    best_t = UNBOUNDED_RAY;
    best_uv = vec2(0.0);
    best_slot = -1;
    int best = -1, best_layer = 0;
    // A loop with no iteration where no ray of a group of pixels needs it (see
    // nearest_depth_image_hit on why not a test around it).
    int candidates = hit.hit ? 9 : 0;
    for (int k = 0; k < candidates; ++k) {
        vec2 listed = texelFetch(u_impostor_triangles, window_texel(hit, k), 0).rg;
        for (int layer = 0; layer < 2; ++layer) {
            int slot;
            int triangle = listed_triangle(hit, listed[layer], origin, direction, best_t, best_uv, slot);
            if (triangle >= 0) {
                best = triangle;
                best_slot = slot;
                best_layer = layer;
            }
        }
    }
    return hidden_from_eye(hit, origin + direction * best_t, best, best_slot, best_layer) ? -1 : best;
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
    int slot = -1, visited = 0;
    int triangle = hit.unseen == UNSEEN_NONE || hit.unseen_t > answer_t ? exact_surface(hit, origin, direction, t, uv, slot)
                                                                        : -1;
    bool retraced = triangle < 0;
    if (retraced) triangle = nearest_triangle(origin, direction, t, uv, slot, visited);
    RayHit found = triangle < 0 ? no_hit(0) : triangle_hit(origin, direction, slot, triangle, t, uv, 0);
    found.samples = hit.samples + visited;
    found.unseen_t = hit.unseen_t;
    found.unseen = hit.unseen;
    found.retraced = retraced;
    return found;
}
#endif

#if METHOD == METHOD_HYBRID && defined(ALPHA_BLEND)
// Past a blended surface (glTF's alphaMode BLEND), the hybrid's rays follow the real triangles:
// its images hold the blended surface (BLEND_WHOLE), not what it covers, which they may not hold.
RayHit nearest_real_triangle_hit(vec3 origin, vec3 direction) {
    RayHit hit = nearest_triangle_hit(origin, direction);
    hit.retraced = true;
    return hit;
}
#endif

// What the reflected ray origin + t * direction sees: the nearest hit, or the environment.
// `past_blended`: the ray goes on past a blended surface it met (trace_reflected).
RayHit trace_nearest(vec3 origin, vec3 direction, bool past_blended) {
    RayHit plane = nearest_plane_hit(origin, direction);
#if METHOD == METHOD_HYBRID
    // The hybrid method orders a plane against the exact hit within a window (resolve_unseen):
    // it needs the images' nearest hit beyond the plane too.
    RayHit hit;
#ifdef ALPHA_BLEND
    if (past_blended) hit = nearest_real_triangle_hit(origin, direction);
    else
#endif
    hit = resolve_unseen(nearest_object_hit(origin, direction, UNBOUNDED_RAY), plane, origin, direction);
#else
    // Nothing beyond the nearest plane is seen: the images entered after it are not visited.
    RayHit hit = nearest_object_hit(origin, direction, plane.hit ? plane.t : UNBOUNDED_RAY);
#endif
    if (plane.hit && (!hit.hit || plane.t < hit.t)) {
        plane.samples = hit.samples;
        plane.retraced = hit.retraced;
        hit = plane;
    }
#ifdef GLOSSY
    // The share of the cone the object its axis hit does not cover (its silhouette's
    // neighbourhood in the footprint) sees what lies behind it: the plane beyond it, or the sky.
    if (hit.hit && !hit.unlit && g_cone_coverage < 1.0) {
        vec3 behind = plane.hit ? shade_material(u_materials[plane.material], plane.color, plane.point,
                                                 origin + direction * plane.t, plane.normal, -direction)
                                : prefiltered_environment(direction);
        hit.color = mix(behind, hit.color, g_cone_coverage);
    }
    if (!hit.hit) hit.color = prefiltered_environment(direction);
#else
    if (!hit.hit) hit.color = environment(direction);
#endif
    if (hit.hit && hit.unlit)
        hit.color = shade_material(u_materials[hit.material], hit.color, hit.point, origin + direction * hit.t, hit.normal,
                                   -direction);
    return hit;
}

// What the reflected ray sees. ALPHA_BLEND (a scene with a blended material: glTF's alphaMode
// BLEND): the shaded hits along the ray composited front to back ("over"), each blended one
// covering its alpha of what lies behind it, up to BLEND_LAYERS of them; the next surface is then
// taken whole. The ray goes on from just past each blended hit (BLEND_RESTART_OFFSET of its ray
// parameter), as the truth's does (oracles/truth.py, TruthTracer.trace). A hit that its method
// holds in baked colours (depth images, cube maps, billboards: a blended surface cut at
// BLEND_IMAGE_CUTOFF and baked opaque) is opaque here. The reflection outputs (its object, its
// point) are the first hit's.
RayHit trace_reflected(vec3 origin, vec3 direction) {
#ifndef ALPHA_BLEND
    return trace_nearest(origin, direction, false);
#else
    RayHit first = no_hit(0);
    vec3 color = vec3(0.0);
    float through = 1.0;  // the share of what lies further that is still seen
    int samples = 0;
    bool retraced = false;
    vec3 start = origin;
    for (int layer = 0; layer <= BLEND_LAYERS; ++layer) {
        RayHit hit = trace_nearest(start, direction, layer > 0);
        samples += hit.samples;
        retraced = retraced || hit.retraced;
        if (layer == 0) first = hit;
        bool blended = hit.hit && hit.unlit && layer < BLEND_LAYERS && u_materials[hit.material].blend != 0;
        float alpha = blended ? material_alpha(u_materials[hit.material], hit.point) : 1.0;
        color += through * alpha * hit.color;
        through *= 1.0 - alpha;
        if (!blended || through <= 0.0) break;
        start += direction * (hit.t * (1.0 + BLEND_RESTART_OFFSET) + BLEND_RESTART_OFFSET);
    }
    first.color = color;
    first.samples = samples;
    first.retraced = retraced;
    return first;
#endif
}
