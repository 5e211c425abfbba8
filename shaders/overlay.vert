#version 330 core
// Overlay text and panels, placed in pixels of the frame they are drawn on (row 0 at the top,
// as in every frame the renderer makes).
uniform vec2 u_target_size;

in vec2 in_position;  // pixels
in vec2 in_texel;     // glyph-atlas pixels, aligned one to one with the frame's
in vec4 in_color;

out vec2 v_texel;
out vec4 v_color;

void main() {
    v_texel = in_texel;
    v_color = in_color;
    gl_Position = vec4(2.0 * in_position / u_target_size - 1.0, 0.0, 1.0);
}
