// Small helpers every pass uses.

// normalize() of a zero vector is NaN, and a NaN normal turns a whole reflection into NaN. An
// interpolated normal is zero where opposite vertex normals cancel (degenerate or folded
// triangles), so fall back to a given direction instead.
vec3 safe_normalize(vec3 v, vec3 fallback) {
    float len = length(v);
    return len > 1e-20 ? v / len : fallback;
}
