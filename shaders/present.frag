#version 330 core
// Copy a frame (row 0 at the top) to the window (row 0 at the bottom), pixel for pixel.
uniform sampler2D u_frame;
out vec4 out_color;

void main() {
    ivec2 size = textureSize(u_frame, 0);
    out_color = texelFetch(u_frame, ivec2(gl_FragCoord.x, size.y - 1 - int(gl_FragCoord.y)), 0);
}
