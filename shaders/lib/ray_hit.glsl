// What a reflected ray found, whichever method found it.
#include "mesh_point.glsl"
#ifndef UNBOUNDED_RAY
// No bound on a ray's parameter (the depth-image marches: but the frustum's, which is bounded).
#define UNBOUNDED_RAY 3.0e38
#endif

struct RayHit {
    bool hit;
    float t;              // ray parameter: hit point = origin + t * direction
    vec2 image_position;  // (u, v) in the depth image, pixels (ray-traced: the barycentrics)
    vec3 color;
    float object_id;
    int samples;          // depth-image samples (ray-traced: BVH nodes) read
    // Depth images: the atlas texel whose colour the hit shows (a sample the march read), and
    // the layer it is on (0: the visible surface; 1: the back layer, come in through from behind).
    ivec2 texel;
    int layer;
    int image;  // and the image it is in (its record in u_depth_images)
    // Depth images: the ray parameter from which the answer rests on what the image does not
    // hold (lib/depth_image.glsl, "What the image does not hold"), and why (an UNSEEN_* kind);
    // UNBOUNDED_RAY and UNSEEN_NONE where it rests on nothing unseen. Other methods: the same.
    float unseen_t;
    int unseen;
    bool retraced;        // the hybrid method traced this ray against the real triangles
    // A hit on a surface shaded where the ray meets it (a plane, a triangle): `color` holds its
    // albedo and trace_reflected shades the nearest hit once, with this normal. Depth images,
    // cube maps and billboards hold colours shaded when they were baked (false).
    bool unlit;
    vec3 normal;
    int material;  // an unlit hit's material: its index in MaterialRecords (lib/shading.glsl)
    MeshPoint point;  // and the mesh's attributes there (its texture coordinates...)
};

RayHit make_hit(bool hit, float t, vec2 image_position, vec3 color, float object_id, int samples) {
    return RayHit(hit, t, image_position, color, object_id, samples, ivec2(0), 0, 0, UNBOUNDED_RAY, UNSEEN_NONE, false,
                  false, vec3(0.0), 0, mesh_point(vec2(0.0)));
}

// A hit whose colour is left to trace_reflected's one call of shade() (a shader that holds one copy
// of the shading code instead of one per kind of surface is faster on llvmpipe, which runs every
// copy for every pixel).
RayHit unlit_hit(float t, vec2 image_position, vec3 albedo, vec3 normal, int material, MeshPoint point,
                 float object_id, int samples) {
    RayHit hit = make_hit(true, t, image_position, albedo, object_id, samples);
    hit.unlit = true;
    hit.normal = normal;
    hit.material = material;
    hit.point = point;
    return hit;
}

RayHit no_hit(int samples) {
    return make_hit(false, 0.0, vec2(0.0), vec3(0.0), float(NO_OBJECT), samples);
}
