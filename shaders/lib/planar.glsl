// `--method planar` (methods/planar.py): a flat mirror's image of the scene, rendered through the
// eye reflected in its plane, behind an oblique near plane at the mirror, into a target of the
// frame's size. The reflected ray of the pixel at gl_FragCoord is the eye's ray of that pixel in
// the reflected render, so the image at this pixel is what the ray sees: the lookup is exact up to
// rasterization. Nothing but the mirror shader's own pixel is read: any other ray (a glass's
// refracted one) has no image, which is why the method refuses glass and curved reflectors.
uniform sampler2D u_screen_color;    // the render's colour
uniform sampler2D u_screen_surface;  // its world position and object id + 1 (0: nothing, the sky)

RayHit nearest_screen_hit(vec3 origin, vec3 direction) {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec4 surface = texelFetch(u_screen_surface, pixel, 0);
    if (surface.w < 0.5) return no_hit(1);
    // The point lies on the ray (the render's ray of this pixel centre, reflected): its distance
    // along the unit direction.
    float t = dot(surface.xyz - origin, direction);
    return make_hit(true, t, gl_FragCoord.xy, texelFetch(u_screen_color, pixel, 0).rgb, surface.w - 1.0, 1);
}
