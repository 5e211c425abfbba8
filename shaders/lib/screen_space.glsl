// `--method ssr` (methods/screen_space.py): screen-space reflections. The reflected ray is
// marched through the eye's own view of the frame (its colour, world position and object id
// after the diffuse pass, copied before the reflectors are drawn), perspective-correct in screen
// space (McGuire and Mara, "Efficient GPU Screen-Space Ray Tracing", JCGT 3(4), 2014): the ray's
// ends are projected once, and 1/w and t * (1/w) are interpolated linearly along the projected
// segment, which makes them exact everywhere on it. The march walks the cells of a min-depth
// pyramid (ssr_pyramid.comp; Uludag, "Hi-Z Screen-Space Cone-Traced Reflections", GPU Pro 5): a
// cell the ray crosses wholly in front of the least w the eye saw in it is skipped, and the next
// step takes a cell one level coarser; any other cell is entered a level finer, down to pixels.
// At most SSR_MAX_STEPS cells a ray.
//
// A pixel hits where the ray's w across it overlaps [w_s, w_s (1 + SSR_THICKNESS)], w_s being
// the depth of the surface the eye sees there: the eye's depth holds front surfaces alone, each
// taken SSR_THICKNESS of its distance thick. What it cannot show is SSR's own failure, shown, not
// hidden: a ray that leaves the screen, or passes behind what the eye saw, falls back to the
// environment (what is off screen or hidden from the eye is missing from its reflection).
uniform sampler2D u_screen_color;    // the frame's colour after the diffuse pass
uniform sampler2D u_screen_surface;  // its world position and object id + 1 (0: nothing, the sky)
uniform vec3 u_ssr_eye;              // the frame camera's eye C
uniform mat3 u_ssr_inverse;          // [a b c]^-1: (u w, v w, w) = u_ssr_inverse (X - C)
uniform float u_ssr_w_near;          // its near plane, in w
uniform float u_ssr_w_far;           // and its far one, beyond every object
uniform sampler2D u_ssr_pyramid;     // min-depth pyramid: the least w of each cell (ssr_pyramid.comp)
uniform int u_ssr_levels;            // its levels
uniform float u_ssr_pixel;           // |a|: a pixel's width in the world at w = 1

// Homogeneous screen coordinates (u w, v w, w) of a world point.
vec3 ssr_homogeneous(vec3 point) {
    return u_ssr_inverse * (point - u_ssr_eye);
}

// The fade towards the frame's edges (SSR_EDGE_FADE of its half-size): 1 inside, 0 at the edge.
float ssr_edge_fade(vec2 position, vec2 size) {
    vec2 from_edge = min(position, size - position) / (0.5 * size);
    return clamp(min(from_edge.x, from_edge.y) / SSR_EDGE_FADE, 0.0, 1.0);
}

RayHit nearest_screen_hit(vec3 origin, vec3 direction) {
    vec2 size = vec2(textureSize(u_screen_surface, 0));
    vec3 h0 = ssr_homogeneous(origin);
    vec3 dh = u_ssr_inverse * direction;  // d(u w, v w, w)/dt
    // The ray is clipped to [w_near, w_far] (the eye's planes, the far one fitted beyond every
    // object): before the near plane it has no projection, past the far one nothing is there.
    if (h0.z < u_ssr_w_near) return no_hit(0);
    vec2 p0 = h0.xy / h0.z;
    float t1 = dh.z < 0.0 ? (u_ssr_w_near - h0.z) / dh.z : dh.z > 0.0 ? (u_ssr_w_far - h0.z) / dh.z : UNBOUNDED_RAY;
    // A ray along the image plane (w constant) ends where it is well off screen.
    t1 = min(t1, 4.0 * (size.x + size.y) * h0.z / max(length(dh.xy), 1e-30));
    if (t1 <= 0.0) return no_hit(0);
    vec3 h1 = h0 + dh * t1;
    vec2 p1 = h1.xy / h1.z;
    float k0 = 1.0 / h0.z, k1 = 1.0 / h1.z;
    vec2 delta = p1 - p0;
    float pixels = max(abs(delta.x), abs(delta.y));
    if (pixels < 1e-6) return no_hit(0);
    // Past a cell's border by this much of the segment (1 % of a pixel along its major axis), so
    // that the next step starts in the next cell.
    float nudge = 0.01 / pixels;
    vec2 inverse_delta = vec2(delta.x != 0.0 ? 1.0 / delta.x : UNBOUNDED_RAY,
                              delta.y != 0.0 ? 1.0 / delta.y : UNBOUNDED_RAY);
    int samples = 0;
    int level = 0;
    float s = 0.5 / pixels;  // half a pixel on: the mirror's own pixel left
    for (int i = 0; i < SSR_MAX_STEPS; ++i) {
        if (s > 1.0) break;
        vec2 p = mix(p0, p1, s);
        if (any(lessThan(p, vec2(0.0))) || any(greaterThanEqual(p, size))) break;  // left the screen
        // The cell of `level` the ray is in, and where along the segment it leaves it.
        float side = float(1 << level);
        vec2 cell = floor(p / side);
        vec2 border = (cell + step(0.0, delta)) * side;
        vec2 leave = (border - p0) * inverse_delta;
        float s_out = min(min(delta.x != 0.0 ? leave.x : UNBOUNDED_RAY, delta.y != 0.0 ? leave.y : UNBOUNDED_RAY), 1.0);
        // The ray's w over the cell (monotonic along it: its ends bound it).
        float w_a = 1.0 / mix(k0, k1, s);
        float w_b = 1.0 / mix(k0, k1, s_out);
        ++samples;
        float nearest = texelFetch(u_ssr_pyramid, ivec2(cell), level).r;
        if (max(w_a, w_b) < nearest) {
            // In front of everything the eye saw in the cell: past it, and up a level.
            s = s_out + nudge;
            level = min(level + 1, u_ssr_levels - 1);
            continue;
        }
        if (level > 0) {
            --level;
            continue;
        }
        vec4 surface = texelFetch(u_screen_surface, ivec2(cell), 0);
        float w_s = nearest;
        if (surface.w > 0.5 && min(w_a, w_b) <= w_s * (1.0 + SSR_THICKNESS)) {
            // t * (1/w) is linear in s too (t is affine in the point): the ray's own t where it
            // enters the pixel, or where it reaches the surface's w, whichever is later.
            float s_hit = s;
            if (w_a < w_s && w_b != w_a) s_hit = mix(s, s_out, clamp((1.0 / w_s - 1.0 / w_a) / (1.0 / w_b - 1.0 / w_a), 0.0, 1.0));
            float t = s_hit * t1 * k1 / mix(k0, k1, s_hit);
#ifdef GLOSSY
            // A glossy mirror's cone: the frame's colour prefiltered over the cone's footprint at the
            // hit (the copy's mip chain, made in a scene with a rough mirror), as engines' glossy
            // SSR reads it; a sharp mirror's cone is a pixel wide (level 0).
            float footprint = 2.0 * t * g_cone_tan * length(direction) / max(u_ssr_pixel * w_s, 1e-30);
            vec3 seen = textureLod(u_screen_color, (cell + 0.5) / size, log2(max(footprint, 1.0))).rgb;
#else
            vec3 seen = texelFetch(u_screen_color, ivec2(cell), 0).rgb;
#endif
            RayHit hit = make_hit(true, t, p, seen, surface.w - 1.0, samples);
            // The colour fades to the fallback; what was hit stays what compare counts.
            hit.color = mix(environment(direction), hit.color, ssr_edge_fade(p, size));
            return hit;
        }
        s = s_out + nudge;
    }
    return no_hit(samples);
}
