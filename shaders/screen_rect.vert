#version 330 core
// A rectangle of the viewport (u_rect: its corners in normalized device coordinates) as a
// four-vertex triangle strip; no vertex buffer needed.
uniform vec4 u_rect;  // (x0, y0, x1, y1)

void main() {
    vec2 corner = vec2(float(gl_VertexID & 1), float((gl_VertexID >> 1) & 1));
    gl_Position = vec4(mix(u_rect.xy, u_rect.zw, corner), 0.0, 1.0);
}
