// The cube-map methods: six 90-degree images from the mirror's centre, each showing every
// reflected object, looked up by a direction.
//
// METHOD_CUBEMAP looks up the reflected ray's direction alone, as if everything it reflects were
// infinitely far away: right for a ray through the mirror's centre, off by the ray's offset from
// it otherwise (the parallax error, large for near objects). METHOD_CUBEMAP_PARALLAX is what
// engines do instead: the ray is intersected with a proxy box around the mirror and what it
// reflects, and the cube map is looked up toward that point.
#include "baked_images.glsl"

// The proxy box of this mirror (world space): its own bounds and those of what it reflects, so
// that every reflected ray starts inside it.
uniform vec3 u_proxy_lower;
uniform vec3 u_proxy_upper;

// The face looking along the direction's major axis, in the order the faces are baked:
// +x, -x, +y, -y, +z, -z (methods/cubemaps.py). Ties go to the first axis; either face holds the
// direction, on its border.
int cube_face(vec3 direction) {
    vec3 magnitude = abs(direction);
    int axis = magnitude.x >= magnitude.y && magnitude.x >= magnitude.z ? 0 : (magnitude.y >= magnitude.z ? 1 : 2);
    return 2 * axis + (direction[axis] < 0.0 ? 1 : 0);
}

// Where origin + t * direction leaves the box. The origin is inside, so the exit is the nearest
// of the three far slabs; an axis the ray is parallel to never bounds it. It is set apart, not
// left to 1/0 = +Inf: an origin on that axis's face (a mirror's extreme point bounds the box)
// gives 0 * Inf = NaN, which GLSL's min and max may pass on (llvmpipe did: the exit was 0, and the
// lookup the mirror's own surface).
float box_exit(vec3 origin, vec3 direction, vec3 lower, vec3 upper) {
    vec3 inverse_direction = 1.0 / direction;
    vec3 far_t = max((lower - origin) * inverse_direction, (upper - origin) * inverse_direction);
    far_t = mix(far_t, vec3(UNBOUNDED_RAY), isinf(inverse_direction));  // a select, no arithmetic
    return max(min(min(far_t.x, far_t.y), far_t.z), 0.0);
}

RayHit cube_map_hit(vec3 origin, vec3 direction) {
    // u_depth_images[0].eye is the cube's centre (every face shares it).
    vec3 centre = u_depth_images[0].eye.xyz;
#if METHOD == METHOD_CUBEMAP_PARALLAX
    vec3 lookup = origin + direction * box_exit(origin, direction, u_proxy_lower, u_proxy_upper) - centre;
    // A lookup point at the centre itself has no direction: fall back to the ray's.
    if (dot(lookup, lookup) == 0.0) lookup = direction;
#else
    vec3 lookup = direction;
#endif
    DepthImage face = u_depth_images[cube_face(lookup)];
    // The major axis is this face's optical axis, so w > 0: the divide is safe.
    vec3 projected = camera_coordinates(face, lookup);
    vec2 s = projected.xy / projected.z;
    ivec2 texel = texel_of(face, s);
    vec4 color = texelFetch(u_impostor_color, texel, 0);
    if (color.a == 0.0) return no_hit(1);
#ifdef GLOSSY
    // A glossy mirror's cone, as the depth method reads it, from the centre the faces were baked
    // from: the level is set by roughness alone (the footprint is an angle: 2 tan over a texel's
    // angle |a| w / |lookup| about the centre), the hit's distance is not known to a direction lookup.
    color.rgb = cone_color(face, lookup, length(lookup), color.rgb);
#endif
    // What the cube map saw in that direction, where it saw it: the hit the method reports (and
    // orders against the analytic planes by its distance from the ray's origin).
    vec2 surface = texelFetch(u_impostor_depth, texel, 0).rg;
    vec3 position = unproject(face, s, w_from_opengl_depth(face, surface.x));
    return make_hit(true, distance(origin, position), s, color.rgb, surface.y, 1);
}
