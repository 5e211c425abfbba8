// The billboard method: per mirror and reflected object, one textured quad with transparency. The
// quad faces the mirror's centre: it is the section, through the object's bounding-sphere centre,
// of the frustum its depth image would have, and its texture is that image's colour. A ray hits
// a quad where its texel is opaque; the nearest such hit wins. Exact for a flat object lying in
// its quad's plane, and off by the object's depth everywhere else.
#include "baked_images.glsl"


RayHit nearest_billboard_hit(vec3 origin, vec3 direction) {
    RayHit best = no_hit(0);
    int samples = 0;
    float inverse_square_length = 1.0 / dot(direction, direction);
#ifdef IMAGE_CELLS
    // The quads whose hit bounds the ray may enter, in rising index: the nearest opaque hit, ties
    // to the lower index, as over every quad.
    ivec2 list = image_list(origin, direction);
    for (int k = 0; k < list.y - list.x; ++k) {
        int i = u_image_cells[list.x + k];
#else
    for (int i = 0; i < u_depth_image_count; ++i) {
#endif
        DepthImage image = u_depth_images[i];
        // A ray that misses the sphere of the quad's opaque part (its hit bound,
        // methods/billboards.py's quad_hit_bounds) cannot see it, and the frame's bakes may have
        // left its texels unmade (the marking pass marks what rays enter: entered_images.frag).
        if (bound_entry(image.hit_bound, origin, direction, inverse_square_length) == UNBOUNDED_RAY) continue;
        vec3 p0 = camera_coordinates(image, origin - image.eye.xyz);
        vec3 dp = camera_coordinates(image, direction);
        // The camera depth w of the quad's plane (w = const is a plane parallel to the image
        // plane), kept in the record's a.w (methods/billboards.py).
        float quad_w = image.a.w;
        // A ray parallel to the quad never meets it (dividing would give +-Inf or NaN).
        if (dp.z == 0.0) continue;
        float t = (quad_w - p0.z) / dp.z;
        if (t <= 0.0 || (best.hit && t >= best.t)) continue;
        vec2 s = (p0.xy + dp.xy * t) / quad_w;
        if (any(lessThan(s, vec2(0.0))) || any(greaterThanEqual(s, image.depth_range.zw))) continue;
        vec4 color = texelFetch(u_impostor_color, image.tile.xy + ivec2(s), 0);
        ++samples;
        if (color.a == 0.0) continue;  // a transparent texel: the ray goes on to what lies behind
#ifdef GLOSSY
        // A glossy mirror's cone (lib/glossy.glsl): the billboard's colour at its footprint. Each
        // call is for a nearer hit than the last, so the coverage it leaves is the best hit's.
        color.rgb = cone_color(image, origin + direction * t - image.eye.xyz, t, color.rgb);
#endif
        best = make_hit(true, t, s, color.rgb, image.eye.w, 0);
    }
    best.samples = samples;
    return best;
}
