// mesh.vert's interpolated outputs, read by a fragment shader as the mesh point at the fragment
// (lib/mesh_point.glsl): the UVs, and the attributes past them that the scene uses.
#include "mesh_point.glsl"

in vec2 v_uv;
#ifdef TEXCOORD_1
in vec2 v_uv1;
#endif
#ifdef VERTEX_COLORS
in vec4 v_color;
#endif
#ifdef NORMAL_MAP
in vec4 v_tangent;
#endif

MeshPoint fragment_point() {
    MeshPoint point;
    point.uv = v_uv;
#ifdef TEXCOORD_1
    point.uv1 = v_uv1;
#endif
#ifdef VERTEX_COLORS
    point.color = v_color;
#endif
#ifdef NORMAL_MAP
    point.tangent = v_tangent;
#endif
    return point;
}
