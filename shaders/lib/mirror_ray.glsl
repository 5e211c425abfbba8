// A mirror pixel's reflected ray, from the reflector's surface there (its world position and
// interpolated normal) and the eye: the mirror shader's (reflector.frag) and, before the bakes,
// the pass that finds the images such rays may enter (entered_images.frag), which must see the
// same rays.

// The unit direction from the eye to the surface point.
vec3 view_direction(vec3 position, vec3 eye) {
    return safe_normalize(position - eye, vec3(0.0, 0.0, -1.0));
}

// The unit normal turned to the eye: the interpolated normal can face away from it near a curved
// reflector's silhouette (and does on the back of a mirror, or inside glass).
vec3 eye_facing_normal(vec3 interpolated_normal, vec3 view) {
    vec3 normal = safe_normalize(interpolated_normal, -view);
    return faceforward(normal, view, normal);
}
