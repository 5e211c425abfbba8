#version 330 core
// A glyph (or the solid cell, for panels): the colour, its alpha scaled by the glyph's coverage.
uniform sampler2D u_glyphs;

in vec2 v_texel;
in vec4 v_color;
out vec4 out_color;

void main() {
    float coverage = texelFetch(u_glyphs, ivec2(floor(v_texel)), 0).r;
    out_color = vec4(v_color.rgb, v_color.a * coverage);
}
