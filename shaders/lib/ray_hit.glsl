// What a reflected ray found, whichever method found it.
struct RayHit {
    bool hit;
    float t;              // ray parameter: hit point = origin + t * direction
    vec2 image_position;  // (u, v) in the depth image, pixels (ray-traced: the barycentrics)
    vec3 color;
    float object_id;
    int samples;          // depth-image samples (ray-traced: BVH nodes) read
};

RayHit no_hit(int samples) {
    return RayHit(false, 0.0, vec2(0.0), vec3(0.0), float(NO_OBJECT), samples);
}
