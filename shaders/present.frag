#version 330 core
// Copy a frame (row 0 at the top) to the window (row 0 at the bottom), pixel for pixel, into the
// viewport whose lower-left corner is u_origin (gl_FragCoord counts from the framebuffer's corner).
// DISPLAY_ENCODE: the frame is linear and goes through the display transform on the way
// (lib/display.glsl: exposure, tone mapping, sRGB); KEEP_ROWS: into another frame (row 0 at the
// top too), not flipped.
#ifdef DISPLAY_ENCODE
#include "lib/display.glsl"
#endif
uniform sampler2D u_frame;
uniform ivec2 u_origin;
out vec4 out_color;

void main() {
    ivec2 size = textureSize(u_frame, 0);
    ivec2 pixel = ivec2(gl_FragCoord.xy) - u_origin;
#ifndef KEEP_ROWS
    pixel.y = size.y - 1 - pixel.y;
#endif
    out_color = texelFetch(u_frame, pixel, 0);
#ifdef DISPLAY_ENCODE
    out_color = vec4(display_encode(out_color.rgb), 1.0);
#endif
}
