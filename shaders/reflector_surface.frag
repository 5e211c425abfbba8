#version 330 core
// The deferred reflector pass's first half (passes/reflectors.py): each visible reflector pixel's
// interpolated world position and normal, and which reflector it is, into float targets. The
// second half, reflector.frag's DEFERRED variant, reads them back in a screen rectangle per
// reflector: the reflected ray is then traced once per pixel, not once per fragment of every
// small triangle a curved reflector is made of (a software rasterizer shades those in groups of
// pixels, most of them outside the triangle). Float32 holds the varyings exactly: the deferred
// frame is the forward one, bit for bit.
in vec3 v_world_position;
in vec3 v_local_position;
in vec3 v_world_normal;

uniform int u_mirror_id;
// This frame's stamp (targets.Surfaces): the targets are not cleared between frames, so a texel
// is this frame's only where it carries this frame's stamp.
uniform int u_surface_stamp;

layout(location = 0) out vec4 out_position;  // (world position, the reflector's object id + 1)
layout(location = 1) out vec4 out_normal;    // (interpolated world normal, 2 stamp + 1 on GL's front faces)

void main() {
    out_position = vec4(v_world_position, float(u_mirror_id + 1));
    out_normal = vec4(v_world_normal, float(2 * u_surface_stamp + (gl_FrontFacing ? 1 : 0)));
}
