// glTF's alphaMode MASK in the depth-only programs (window_depth.frag: shadow maps, a depth image's
// back faces; beyond_run.frag): what a masked material cuts away casts no shadow and bounds no
// solid run. The ALPHA_MASK variant alone (uniforms.alpha_mask_defines: scenes with such a
// material) reads the object's material and texture; otherwise this is nothing.
#ifdef ALPHA_MASK
#define RASTERIZED_TEXTURES 1  // trilinear, mipmapped, as the diffuse pass draws the surface
#include "common.glsl"
#include "shading.glsl"

#include "mesh_varyings.glsl"

uniform int u_material_index;  // in the MaterialRecords table (uniforms.write_material_index); -1: a reflector

void discard_masked() {
    if (u_material_index >= 0 && material_masked(u_materials[u_material_index], fragment_point())) discard;
}
#else
void discard_masked() {}
#endif
