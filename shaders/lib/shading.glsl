// Two shading models. Diffuse and checker materials: color = albedo * (ambient + sum of lights'
// radiance * max(0, N.L)), which does not depend on the viewer, so a depth image baked from a
// mirror's centre holds exactly the colours a reflected ray should see. Shadows (the SHADOWS
// variant, for scenes with a light that casts them) do not depend on the viewer either. glTF's
// metallic-roughness materials (lib/brdf.glsl) do: a depth image holds them as seen from its
// camera (the mirror's centre), traced rays and the truth shade them for the ray itself.
#include "lighting.glsl"
#include "mesh_point.glsl"
#include "../generated/material.glsl"

// Every shaded material of the scene, one record each (gpu/scene_blocks.py writes them once):
// an object, a batch's instance, a traced triangle's instance and an analytic plane carry its index.
// MATERIAL_COUNT comes from the scene (gpu/uniforms.py's shading_defines); a program made without
// it (the GPU ray query, the tests' probes: they shade nothing) declares one record.
#ifndef MATERIAL_COUNT
#define MATERIAL_COUNT 1
#endif
#ifdef DRAWN_MATERIAL
// A program that draws one object a call (passes/diffuse.py's, the bakes' above all) reads that
// object's record alone: the pass binds it as this one-record block before each draw (a range of
// gpu/scene_blocks.DrawnMaterials' padded copy of the table). A uniform block costs llvmpipe a
// constant load; indexing a storage buffer per fragment cost a 1,000-material scene's bakes
// two fifths of their time (results/llvmpipe/startup_time.md, fourth pass).
layout(std140) uniform DrawnMaterial {
    Material u_materials[1];
};
// Past MATERIAL_BLOCK_RECORDS (GL 3.3's guaranteed 16 KiB) the table is a storage buffer (GL 4.3;
// the prefix enables it for NEEDS_STORAGE_BLOCKS), whose std430 layout of Material is std140's.
#elif MATERIAL_COUNT > MATERIAL_BLOCK_RECORDS
layout(std430) readonly buffer MaterialRecords {
    Material u_materials[MATERIAL_COUNT];
};
#else
layout(std140) uniform MaterialRecords {
    Material u_materials[MATERIAL_COUNT];
};
#endif

#ifdef SHADOWS
#include "shadows.glsl"
#endif

#ifdef TEXTURE_COUNT
#include "material_texture.glsl"
#endif

// The checker is laid out in the object's local XZ plane (the plane shape's own plane): a 3-D
// checker would flicker on a plane at y = 0, where floor(y / scale) jumps between -1 and 0. A
// textured diffuse material's colour is color_a times the texel: trilinear in rasterized
// fragments, level 0 bilinear for traced rays (material_texture.glsl); times the vertex colour
// where the scene's meshes have them (VERTEX_COLORS: glTF's COLOR_0 multiplies the base colour).
//
// NO_CHECKER: a program that draws no checker material (diffuse.frag's, for objects without one:
// passes/diffuse.py) leaves the checker out, and with it the local position it reads. llvmpipe runs
// the body of an `if` whatever the condition: the test alone would not spare it. (With
// DIRECTIONAL_LIGHTS, a fifth of the 8 x 9 scene's bake: tools/bake_cost.py.)
vec3 material_albedo(Material material, vec3 local_position, MeshPoint point) {
#ifndef NO_CHECKER
    if (material.kind == MATERIAL_CHECKER) {
        ivec2 cell = ivec2(floor(local_position.xz / material.scale));
        return ((cell.x + cell.y) & 1) == 0 ? material.color_a : material.color_b;
    }
#endif
    vec3 color = material.color_a;
#ifdef TEXTURE_COUNT
    if (material.texture >= 0) {
        color *= material_texel(material.texture, point);
    }
#endif
#ifdef VERTEX_COLORS
    color *= point.color.rgb;
#endif
    return color;
}

#if defined(ALPHA_MASK) || defined(ALPHA_BLEND)
// A material's alpha at a point: its factor times its texture's (and its vertex colour's); 1 for
// an opaque material.
float material_alpha(Material material, MeshPoint point) {
    float alpha = material.alpha;
#ifdef TEXTURE_COUNT
    if (material.texture >= 0) alpha *= material_texel_rgba(material.texture, point).a;
#endif
#ifdef VERTEX_COLORS
    alpha *= point.color.a;
#endif
    return alpha;
}
#endif

#ifdef ALPHA_MASK
// glTF's alphaMode MASK (the ALPHA_MASK variant: scenes with such a material): a point whose alpha,
// the material's factor times its texture's (and its vertex colour's), is under the material's
// cutoff is not there at all;
// rasterized fragments discard it, traced rays pass through it. alpha_cutoff < 0: opaque. A
// blended material (alphaMode BLEND) is cut so at BLEND_IMAGE_CUTOFF where one surface a texel is
// kept (the images, the shadow maps), and whole where it is blended or composited (ALPHA_BLEND:
// the eye's transparent pass, traced rays) or composited later (BLEND_WHOLE: the hybrid's images).
bool material_masked(Material material, MeshPoint point) {
    if (material.alpha_cutoff < 0.0) return false;
#if defined(ALPHA_BLEND) || defined(BLEND_WHOLE)
    if (material.blend != 0) return false;
#endif
    return material_alpha(material, point) < material.alpha_cutoff;
}
#endif

// The lights shaded: a constant of the program where the pass gives one (LIGHT_COUNT, from the
// scene: gpu/uniforms.py's shading_defines). llvmpipe runs a loop bounded by a uniform at about 5
// times the cost of the same loop with a constant bound, which it unrolls: 5 ms of the floor's
// 7.5 ms at 960x540 (tools/shading_cost.py). A program made without it (the GPU ray query, which
// shades nothing) loops over the Lights block's count.
#ifndef LIGHT_COUNT
#define LIGHT_COUNT u_lighting.light_count
#endif

// The unit direction from `position` toward a light. DIRECTIONAL_LIGHTS (a scene without point
// lights: shading_defines): the point lights' direction is left out, and with it the surface's
// position where no shadow reads it.
vec3 toward_light(Light light, vec3 position, vec3 normal) {
#ifdef DIRECTIONAL_LIGHTS
    return -light.vector;
#else
    return light.kind == LIGHT_DIRECTIONAL ? -light.vector : safe_normalize(light.vector - position, normal);
#endif
}

vec3 shade(vec3 albedo, vec3 position, vec3 normal) {
    vec3 irradiance = vec3(u_lighting.ambient);
    for (int i = 0; i < LIGHT_COUNT; ++i) {
        Light light = u_lighting.lights[i];
        float cosine = max(0.0, dot(normal, toward_light(light, position, normal)));
#ifdef SHADOWS
        // A surface facing away from the light gets none of it: no shadow ray needed.
        if (cosine > 0.0) cosine *= light_visibility(i, position, normal);
#endif
        irradiance += light.radiance * cosine;
    }
    return albedo * irradiance;
}

#ifdef METALLIC_ROUGHNESS
#include "brdf.glsl"
#ifdef ENVIRONMENT_LIGHTING
#include "environment_lighting.glsl"
#endif

// The ambient term of a surface of diffuse colour c_diff and specular F0: with ENVIRONMENT_LIGHTING
// (an equirect sky: ibl.py), the sky's irradiance through the diffuse base and its prefiltered
// radiance along the reflected view through the specular lobe (the split sum: times the DFG fit);
// otherwise a uniform environment of the constant ambient radiance. Darkened by the occlusion map
// either way (occlusion: 1 without one).
vec3 ambient_light(vec3 c_diff, vec3 f0, float roughness, vec3 normal, vec3 to_viewer, float occlusion) {
    float n_dot_v = abs(dot(normal, to_viewer));
#ifdef ENVIRONMENT_LIGHTING
    vec3 reflected = reflect(-to_viewer, normal);
    return occlusion * (c_diff * environment_irradiance(normal)
                        + environment_specular(reflected, roughness) * ambient_specular(f0, roughness, n_dot_v));
#else
    return u_lighting.ambient * occlusion * (c_diff + ambient_specular(f0, roughness, n_dot_v));
#endif
}

// A metallic-roughness surface of `base_color` (the material's factor times its texel: material_albedo)
// at the mesh point `point`, seen along `to_viewer` (unit, from the surface): the ambient term
// (ambient_light: the sky's, or a uniform environment), the lights through the BRDF, and the
// emitted light. A variant of the scenes that have such a material (METALLIC_ROUGHNESS:
// shading_defines); oracles/brdf.py's function of the same name.
vec3 shade_metallic_roughness(Material material, vec3 base_color, MeshPoint point, vec3 position, vec3 normal,
                              vec3 to_viewer) {
    float metallic = material.metallic, roughness = material.roughness, occlusion = 1.0;
    vec3 emissive = material.emissive;
#ifdef TEXTURE_COUNT
    if (material.metallic_roughness_texture >= 0) {  // glTF: roughness in G, metalness in B
        vec3 texel = material_texel(material.metallic_roughness_texture, point);
        roughness *= texel.g;
        metallic *= texel.b;
    }
    if (material.occlusion_texture >= 0)
        occlusion = 1.0 + material.occlusion_strength * (material_texel(material.occlusion_texture, point).r - 1.0);
    if (material.emissive_texture >= 0) emissive *= material_texel(material.emissive_texture, point);
#endif
    vec3 c_diff = mix(base_color, vec3(0.0), metallic);
    vec3 f0 = mix(vec3(DIELECTRIC_F0), base_color, metallic);
    float lobe_roughness = max(roughness, MIN_ROUGHNESS);
    float alpha = lobe_roughness * lobe_roughness;
    vec3 color = ambient_light(c_diff, f0, roughness, normal, to_viewer, occlusion);
    for (int i = 0; i < LIGHT_COUNT; ++i) {
        Light light = u_lighting.lights[i];
        vec3 to_light = toward_light(light, position, normal);
        float cosine = dot(normal, to_light);
        if (cosine <= 0.0) continue;
#ifdef SHADOWS
        cosine *= light_visibility(i, position, normal);
#endif
        color += metallic_roughness_brdf(c_diff, f0, alpha, normal, to_light, to_viewer) * light.radiance * cosine;
    }
    return color + emissive;
}

#ifdef NORMAL_MAP
// glTF's normalTexture: the shading normal turned by the map's tangent-space normal (RGB * 2 - 1,
// its x and y times the material's normal_scale) in the frame of the point's tangent T (made
// perpendicular to `normal`), bitangent B = w N x T (w: the tangent's sign; glTF 3.7.2.1) and
// `normal`. The shading alone reads it: what a surface reflects and where a ray meets it are the
// geometry's. A tangent of no length (a mesh without tangents) gives a frame about any direction
// perpendicular to the normal. oracles/brdf.py's mapped_normal.
vec3 mapped_normal(Material material, MeshPoint point, vec3 normal) {
    if (material.normal_texture < 0) return normal;
    vec3 tangent = point.tangent.xyz - normal * dot(normal, point.tangent.xyz);
    vec3 any_side = abs(normal.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0);
    tangent = safe_normalize(tangent, safe_normalize(cross(normal, any_side), any_side));
    vec3 bitangent = (point.tangent.w < 0.0 ? -1.0 : 1.0) * cross(normal, tangent);
    vec3 texel = material_texel(material.normal_texture, point) * 2.0 - 1.0;
    texel.xy *= material.normal_scale;
    return safe_normalize(tangent * texel.x + bitangent * texel.y + normal * texel.z, normal);
}
#endif
#endif

// A surface of `material` (its colour at the point: `albedo`, material_albedo's; the mesh's
// attributes there: `point`), seen along `to_viewer`: the one call every pass makes to shade a point.
vec3 shade_material(Material material, vec3 albedo, MeshPoint point, vec3 position, vec3 normal, vec3 to_viewer) {
#ifdef METALLIC_ROUGHNESS
    if (material.kind == MATERIAL_METALLIC_ROUGHNESS) {
#ifdef NORMAL_MAP
        normal = mapped_normal(material, point, normal);
#endif
        return shade_metallic_roughness(material, albedo, point, position, normal, to_viewer);
    }
#endif
    return shade(albedo, position, normal);
}
