#version 330 core
// A depth-image sample's splat, in the colour the depth image stored for it.
in vec3 v_color;
layout(location = 0) out vec4 out_color;

void main() {
    out_color = vec4(v_color, 1.0);
}
