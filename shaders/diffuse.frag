#version 330 core
// Diffuse and checker objects, for the camera view and for baking depth images (WRITE_DEPTH_IMAGE:
// the window depth also goes to a 32-bit float attachment, the depth image's Z, with the object's
// id beside it for images that show several objects: cube-map faces).
#include "lib/common.glsl"
#define RASTERIZED_TEXTURES 1  // trilinear, mipmapped textures (lib/material_texture.glsl)
#include "lib/shading.glsl"

#ifdef INSTANCED
// The object's material index and ids, from its instance attributes (mesh.vert).
flat in ivec4 v_ids;
#define MATERIAL_INDEX v_ids.x
#define OBJECT_ID v_ids.y
#define TRIANGLE_OFFSET v_ids.z
#else
#ifdef DRAWN_MATERIAL
#define MATERIAL_INDEX 0  // the drawn object's record, bound alone (lib/shading.glsl)
#else
uniform int u_material_index;  // in the MaterialRecords table (lib/shading.glsl)
#define MATERIAL_INDEX u_material_index
#endif
#define OBJECT_ID u_object_id
#define TRIANGLE_OFFSET u_triangle_offset
#endif

#ifdef METALLIC_ROUGHNESS
// Where the camera is (w = 1), or toward it at infinity (w = 0: an orthographic image), in the world
// (passes/diffuse.py, from the view-projection): metallic-roughness shading depends on the viewer.
uniform vec4 u_eye;
#endif

#ifdef DOUBLE_SIDED
flat in int v_mirrored;
uniform int u_view_mirrored;  // 1: the view-projection reflects the scene (a planar reflection's)
#endif

in vec3 v_world_position;
in vec3 v_local_position;
in vec3 v_world_normal;
#include "lib/mesh_varyings.glsl"

layout(location = 0) out vec4 out_color;
#if WRITE_DEPTH_IMAGE
layout(location = 1) out vec2 out_depth_and_object;
#ifndef INSTANCED
uniform int u_object_id;
#endif
#endif
#ifdef WRITE_SURFACE
// What the eye-dependent methods look up at a pixel (methods/planar.py, methods/screen_space.py):
// the world position seen there and the object's id + 1 (0, as cleared: nothing, the sky).
layout(location = 1) out vec4 out_surface;
#ifndef INSTANCED
uniform int u_object_id;
#endif
#endif
#ifdef WRITE_TRIANGLE_ID
// The hybrid method's depth images: the triangle seen, as its place in the list the BVH is built
// from (methods/triangles.py: the object's offset plus its index in the object's mesh). A float
// holds every integer below 2^24 exactly; TrianglePass refuses more triangles. Both channels
// hold it: the visible surface's pass keeps R, the back layer's (BACK_LAYER) G.
layout(location = 2) out vec2 out_triangle;
#ifndef INSTANCED
uniform int u_triangle_offset;
#endif
#endif

void main() {
    vec3 normal = safe_normalize(v_world_normal, vec3(0.0, 1.0, 0.0));
    Material material = u_materials[MATERIAL_INDEX];
    MeshPoint point = fragment_point();
#ifdef ALPHA_MASK
    if (material_masked(material, point)) discard;  // glTF's alphaMode MASK: the surface is not there
#endif
    vec3 albedo = material_albedo(material, v_local_position, point);
#if defined(DOUBLE_SIDED) && !defined(BACK_LAYER)
    // glTF's doubleSided: a back face seen is shaded turned round. Every PPC projection winds the
    // outward faces the way GL does not call front (OUTWARD_IS_GL_FRONT 0: passes/reflectors.py's
    // OUTWARD_FRONT_FACE), a mirroring model matrix or view the other way. (The back layer shows
    // what a ray from behind it sees: the outward face, as it is. A single-sided material's back
    // faces are culled: passes/diffuse.py.)
    bool outward = gl_FrontFacing == ((OUTWARD_IS_GL_FRONT != 0) != (v_mirrored != 0) != (u_view_mirrored != 0));
    if (!outward && material.double_sided == SIDES_DOUBLE) turn_to_back(normal, point);
#endif
#ifdef METALLIC_ROUGHNESS
    vec3 to_viewer = safe_normalize(u_eye.xyz - v_world_position * u_eye.w, normal);
    out_color = vec4(shade_material(material, albedo, point, v_world_position, normal, to_viewer), 1.0);
#else
    out_color = vec4(shade(albedo, v_world_position, normal), 1.0);
#endif
#ifdef ALPHA_BLEND
    // The eye's transparent pass (passes/transparent.py): glTF's alphaMode BLEND, blended over what
    // is drawn (the blend function is the pass's), so it covers `alpha` of it.
    out_color.a = material_alpha(material, point);
#endif
#if WRITE_DEPTH_IMAGE
#ifdef BACK_LAYER
    // The back layer of a depth image (drawn with front faces culled): its colour, the outward
    // face lit as it is (diffuse shading does not depend on the viewer; metallic-roughness shading
    // as seen from the image's camera, through the surface), and its depth in G.
    out_depth_and_object = vec2(gl_FragCoord.z);
#else
    out_depth_and_object = vec2(gl_FragCoord.z, float(OBJECT_ID));
#endif
#endif
#ifdef WRITE_SURFACE
    out_surface = vec4(v_world_position, float(OBJECT_ID + 1));
#endif
#ifdef WRITE_TRIANGLE_ID
    out_triangle = vec2(float(TRIANGLE_OFFSET + gl_PrimitiveID));
#endif
}
