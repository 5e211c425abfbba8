#version 330 core
// Copy a frame (row 0 at the top) to the window (row 0 at the bottom), pixel for pixel, into the
// viewport whose lower-left corner is u_origin (gl_FragCoord counts from the framebuffer's corner).
uniform sampler2D u_frame;
uniform ivec2 u_origin;
out vec4 out_color;

void main() {
    ivec2 size = textureSize(u_frame, 0);
    ivec2 pixel = ivec2(gl_FragCoord.xy) - u_origin;
    out_color = texelFetch(u_frame, ivec2(pixel.x, size.y - 1 - pixel.y), 0);
}
