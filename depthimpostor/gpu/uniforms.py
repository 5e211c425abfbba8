"""Writing uniforms: materials and texture tables, and where each program finds the textures and
uniform blocks bound for every frame (the lights and analytic planes are blocks: gpu/scene_blocks.py).

A uniform the compiler removed (unused in that variant) is simply absent from the program, so
each write checks membership first instead of catching errors.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from typing import Any, cast

import moderngl
import numpy as np

from .bindings import StorageBuffer, TextureUnit, UniformBlock
from ..constants import (EXTRA_ATTRIBUTES, MATERIAL, MATERIAL_ARRAYS, MATERIAL_BLOCK_RECORDS, MAX_LIGHTS, MaterialKind, Sides,
                         triangle_texel_layout)
from ..scene.model import (
    CheckerMaterial, DiffuseMaterial, GltfShape, MetallicRoughnessMaterial, Scene, SceneObject, material_sides,
)
from ..scene.fields import Vec3
from ..ibl import uses_environment_lighting
from ..texture_layout import texture_defines
from ..textures import SRGB_TABLE
from .textures import array_unit


def shading_defines(scene: Scene, drawn_material: bool = False) -> dict[str, int]:
    """The variant of every shading program that the scene's lights and materials call for: its
    number of lights (more than MAX_LIGHTS is refused when the lights are written), the point
    lights' code only in scenes with one (DIRECTIONAL_LIGHTS: none), shadow rays only in scenes
    where a light casts shadows on something, the MaterialRecords table at the scene's size (MATERIAL_COUNT),
    or (`drawn_material`: a program that draws one object a call) the drawn object's record alone
    (material_defines), texture sampling only in scenes with image textures
    (TEXTURE_COUNT of them, in TEXTURE_ARRAYS arrays, with the samplers they need:
    texture_layout.texture_defines)."""
    return {"LIGHT_COUNT": min(len(scene.lights), MAX_LIGHTS),  # a constant loop bound (lib/shading.glsl)
            **material_defines(scene, drawn_material),  # the MaterialRecords table's size, and where it lives
            **({"DIRECTIONAL_LIGHTS": 1} if scene.lights and all(light.type == "directional" for light in scene.lights)
               else {}),
            **({"SHADOWS": 1} if scene.has_shadows else {}),
            # glTF's material model, only in the scenes that have it (lib/shading.glsl), and its
            # alpha mask only where a material cuts parts away.
            **({"METALLIC_ROUGHNESS": 1} if any(isinstance(m, MetallicRoughnessMaterial) for m in scene.materials)
               else {}),
            **alpha_mask_defines(scene, drawn_material),
            **sides_defines(scene),
            **mesh_attribute_defines(scene),
            **environment_lighting_defines(scene),
            **texture_defines(scene)}


def mesh_attributes(scene: Scene) -> tuple[str, ...]:
    """The glTF vertex attributes past position, normal and TEXCOORD_0 (meshes.EXTRA_ATTRIBUTES, in
    its order) that the scene's shaded surfaces read: TEXCOORD_1 where a texture reads that set,
    COLOR_0 where a shaded object's mesh has vertex colours, tangents where a material has a normal
    map. Every mesh then carries them (meshes.EXTRA_DEFAULTS where its own lack them); a scene
    without any carries none, and its programs are those of before."""
    shaded = scene.diffuse_objects
    used = {"uvs1": any(texture.uv_set == 1 for texture in scene.textures),
            "colors": any(isinstance(o.shape, GltfShape) and o.shape.mesh.colors is not None for o in shaded),
            "tangents": any(isinstance(m, MetallicRoughnessMaterial) and m.normal_texture is not None
                            for m in scene.materials)}
    return tuple(name for name in EXTRA_ATTRIBUTES if used[name])


#: The define each extra vertex attribute compiles in (lib/mesh_point.glsl's MeshPoint fields).
ATTRIBUTE_DEFINES = {"uvs1": "TEXCOORD_1", "colors": "VERTEX_COLORS", "tangents": "NORMAL_MAP"}


def mesh_attribute_defines(scene: Scene) -> dict[str, int]:
    """The variant of every program that reads the mesh at a surface point (mesh_attributes): the
    MeshPoint fields it carries, and where the triangle texture holds them (constants.triangle_texel_layout)."""
    attributes = mesh_attributes(scene)
    return {**{ATTRIBUTE_DEFINES[name]: 1 for name in attributes}, **triangle_texel_layout(attributes)}


def environment_lighting_defines(scene: Scene) -> dict[str, int]:
    """Image-based lighting where the scene has an equirect sky and a metallic-roughness material
    (ibl.py's rule): ENVIRONMENT_LIGHTING, with the sky's image (ENVIRONMENT_MAP) it reads."""
    return {"ENVIRONMENT_LIGHTING": 1, "ENVIRONMENT_MAP": 1} if uses_environment_lighting(scene) else {}


def sides_defines(scene: Scene) -> dict[str, int]:
    """glTF's doubleSided, where the scene's shaded materials have it: DOUBLE_SIDED where one is
    double-sided (its back faces are shaded turned round: lib/mesh_point.glsl's turn_to_back),
    SINGLE_SIDED where one is not (a traced ray passes through its back faces; the passes that
    draw what is seen cull them: passes/diffuse.py)."""
    sides = {material_sides(material) for material in scene.materials}
    return {**({"DOUBLE_SIDED": 1} if Sides.DOUBLE in sides else {}),
            **({"SINGLE_SIDED": 1} if Sides.SINGLE in sides else {})}


def has_alpha_mask(scene: Scene) -> bool:
    """Does a material of the scene cut parts of its surface away (glTF's alphaMode MASK), or hold
    one where an image or a shadow map cuts it (alphaMode BLEND under BLEND_IMAGE_CUTOFF)?"""
    return any(isinstance(m, MetallicRoughnessMaterial) and m.image_cutoff is not None for m in scene.materials)


def has_alpha_blend(scene: Scene) -> bool:
    """Does a material of the scene blend over what lies behind it (glTF's alphaMode BLEND)?"""
    return any(isinstance(m, MetallicRoughnessMaterial) and m.blend for m in scene.materials)


def alpha_mask_defines(scene: Scene, drawn_material: bool = False) -> dict[str, int]:
    """What a program that draws surfaces needs to cut masked parts away: ALPHA_MASK, the material
    table (or the drawn object's record: material_defines) and the textures (none in a scene without
    a masked or blended material). The depth-only programs (window_depth.frag's shadow maps and back
    faces, beyond_run.frag) take these alone; the shading programs take them with shading_defines."""
    if not has_alpha_mask(scene):
        return {}
    return {"ALPHA_MASK": 1, **material_defines(scene, drawn_material), **mesh_attribute_defines(scene),
            **texture_defines(scene)}


def material_defines(scene: Scene, drawn_material: bool = False) -> dict[str, int]:
    """Where a program reads the materials from: the MaterialRecords table at its size
    (MATERIAL_COUNT), and past a uniform block's MATERIAL_BLOCK_RECORDS the storage buffers'
    extension that lib/shading.glsl then reads it from; or (`drawn_material`: a program that draws
    one object a call, whose pass binds that object's record before each draw: passes/diffuse.py)
    the DrawnMaterial block of one record (DRAWN_MATERIAL), whatever the table's size."""
    if drawn_material:
        return {"DRAWN_MATERIAL": 1}
    count = material_count(scene)
    return {"MATERIAL_COUNT": count, **({"NEEDS_STORAGE_BLOCKS": 1} if materials_in_storage(scene) else {})}


def materials_in_storage(scene: Scene) -> bool:
    """Is the scene's MaterialRecords table a storage buffer (GL 4.3) rather than a uniform block?"""
    return material_count(scene) > MATERIAL_BLOCK_RECORDS


def blend_defines(scene: Scene, composite: bool) -> dict[str, int]:
    """The variant of a program where a blended surface (glTF's alphaMode BLEND) is whole, not cut
    at BLEND_IMAGE_CUTOFF as the images and shadow maps cut it: BLEND_WHOLE (the hybrid's images,
    whose blended hits its traced rays then composite), or ALPHA_BLEND (`composite`: the eye's
    transparent pass, which outputs alpha, and the reflector shader, whose traced rays composite
    blended hits: lib/reflected_scene.glsl). Nothing in a scene without a blended material."""
    if not has_alpha_blend(scene):
        return {}
    return {"ALPHA_BLEND": 1} if composite else {"BLEND_WHOLE": 1}


def write_material_index(program: moderngl.Program, scene: Scene, obj: SceneObject) -> None:
    """Where a program that cuts masked parts away (alpha_mask_defines) finds the object's material:
    its index in the MaterialRecords table, or -1 for a mirror or glass (never masked)."""
    if program.get("u_material_index", None) is not None:  # (a dict look-up: `in` walks every member)
        write(program, "u_material_index", -1 if obj.is_reflector else scene.material_index(obj.material))


def environment_defines(scene: Scene) -> dict[str, int]:
    """The variant of every program that reads the environment: ENVIRONMENT_MAP for an image (and
    ENVIRONMENT_LIGHTING where its texture holds the prefiltered levels below the image)."""
    return {"ENVIRONMENT_MAP": 1, **environment_lighting_defines(scene)} if scene.environment.is_map else {}


def write(program: moderngl.Program | moderngl.ComputeShader, name: str,
          data: np.ndarray | bytes | float | Sequence[float]) -> None:
    """Set a uniform if the program has it: numpy arrays as float32/int32 bytes, scalars as values."""
    found = packed(program, name, data)
    if found is not None:
        found[0].write(found[1])


def packed(program: moderngl.Program | moderngl.ComputeShader, name: str,
           data: np.ndarray | bytes | float | Sequence[float]) -> tuple[moderngl.Uniform, bytes] | None:
    """The uniform `write` sets and the bytes it writes there (None where the program lacks it):
    what a pass that writes the same values over and over (an object's, at each image it is baked
    into) packs once and writes with Uniform.write."""
    uniform = program.get(name, None)  # a dict look-up (`name in program` walks every member)
    if uniform is None:
        return None
    if not isinstance(uniform, moderngl.Uniform):
        raise TypeError(f"{name} is a {type(uniform).__name__}, not a uniform a value can be written to")
    if isinstance(data, np.ndarray):
        dtype = np.int32 if np.issubdtype(data.dtype, np.integer) else np.float32
        values = np.ascontiguousarray(data, dtype=dtype).reshape(-1)
        # An array the compiler shortened to the elements the program reads (a loop bounded by a
        # constant, LIGHT_COUNT or PLANE_COUNT, reads the first ones): those elements alone.
        return uniform, values[:uniform.array_length * uniform.dimension].tobytes()
    if isinstance(data, bytes):
        return uniform, data
    return uniform, _value_bytes(uniform, data)


def _value_bytes(uniform: moderngl.Uniform, value: float | Sequence[float]) -> bytes:
    """The bytes moderngl's `Uniform.value = value` writes (its setter, without the write)."""
    fmt: str = uniform.fmt  # type: ignore[attr-defined]  # its struct format (moderngl's stubs omit it)
    if uniform.array_length > 1:
        rows = cast(Sequence[Any], value)
        if uniform.dimension > 1:
            return b"".join(struct.pack(fmt, *row) for row in rows)
        return b"".join(struct.pack(fmt, item) for item in rows)
    if uniform.dimension > 1:
        return struct.pack(fmt, *cast(Sequence[float], value))
    return struct.pack(fmt, value)


def bind_texture(program: moderngl.Program | moderngl.ComputeShader, name: str, texture: moderngl.Texture,
                 unit: int) -> None:
    """Put `texture` on texture unit `unit` and point the sampler `name` at it."""
    texture.use(unit)
    write(program, name, unit)


def bind_uniform_block(program: moderngl.Program, name: str, binding: int) -> None:
    """Point the uniform block `name` (if the variant kept it) at a buffer binding point."""
    block = program.get(name, None)
    if block is None:
        return
    if not isinstance(block, moderngl.UniformBlock):
        raise TypeError(f"{name} is a {type(block).__name__}, not a uniform block")
    block.binding = binding


def bind_record_block(program: moderngl.Program, name: str, uniform_binding: int, storage_binding: int) -> None:
    """Point the block `name` (if the variant kept it) at its binding point: `uniform_binding` where
    the variant declares a uniform block, `storage_binding` where a storage buffer (a record table
    the variant's size puts past a uniform block's: lib/baked_images.glsl)."""
    block = program.get(name, None)
    if block is None:
        return
    if isinstance(block, moderngl.UniformBlock):
        block.binding = uniform_binding
    elif isinstance(block, moderngl.StorageBlock):
        block.binding = storage_binding
    else:
        raise TypeError(f"{name} is a {type(block).__name__}, not a uniform block or a storage block")


def write_matrix(program: moderngl.Program | moderngl.ComputeShader, name: str, matrix: np.ndarray) -> None:
    """A matrix in GL's column-major float32 layout."""
    write(program, name, matrix_bytes(matrix))


def matrix_bytes(matrix: np.ndarray) -> bytes:
    """`matrix` as write_matrix writes it: GL's column-major float32 layout."""
    return np.ascontiguousarray(matrix.T, dtype=np.float32).tobytes()


def material_count(scene: Scene) -> int:
    """The MaterialRecords table's size (MATERIAL_COUNT): one record at least, since a GLSL array
    cannot be empty (a scene of mirrors alone has no material to shade)."""
    return max(1, len(scene.materials))


def material_records(scene: Scene) -> np.ndarray:
    """lib/shading.glsl's MaterialRecords table of `scene`: one constants.MATERIAL a material, in
    the order of Scene.materials (an object's, instance's or plane's material index)."""
    records = np.zeros(material_count(scene), MATERIAL.dtype)
    # What a diffuse or checker material leaves unused: no maps, opaque.
    records["metallic_roughness_texture"] = records["occlusion_texture"] = records["emissive_texture"] = -1
    records["normal_texture"] = -1
    records["alpha_cutoff"], records["alpha"] = -1.0, 1.0
    materials = scene.materials
    if not materials:
        return records
    # What every material has, a field of all of them at once (a record at a time took 10 ms of a
    # thousand materials' start); then what a metallic-roughness one adds, record by record.
    rows: list[tuple[int, Vec3, Vec3, float]] = []
    for material in materials:
        if isinstance(material, CheckerMaterial):
            rows.append((MaterialKind.CHECKER, material.color_a, material.color_b, material.scale))
        elif isinstance(material, DiffuseMaterial):
            rows.append((MaterialKind.DIFFUSE, material.color, material.color, 1.0))
        else:
            raise TypeError(f"{material!r} is not a material that is shaded")
    shaded = records[:len(materials)]
    shaded["kind"] = [int(kind) for kind, _, _, _ in rows]
    shaded["color_a"] = [color_a for _, color_a, _, _ in rows]
    shaded["color_b"] = [color_b for _, _, color_b, _ in rows]
    shaded["scale"] = [scale for _, _, _, scale in rows]
    shaded["texture"] = [scene.texture_slot(material) for material in materials]
    shaded["double_sided"] = [int(material_sides(material)) for material in materials]
    for record, material in zip(shaded, materials, strict=True):
        if isinstance(material, MetallicRoughnessMaterial):
            record["kind"] = MaterialKind.METALLIC_ROUGHNESS
            record["emissive"], record["metallic"], record["roughness"] = (material.emissive, material.metallic,
                                                                           material.roughness)
            (record["metallic_roughness_texture"], record["occlusion_texture"], record["emissive_texture"],
             record["normal_texture"]) = (scene.slot_of(texture) for texture in material.maps)
            record["normal_scale"] = material.normal_scale
            record["occlusion_strength"] = material.occlusion_strength
            if material.image_cutoff is not None:
                record["alpha_cutoff"], record["alpha"] = material.image_cutoff, material.alpha
            record["blend"] = int(material.blend)
    return records


def write_textures(program: moderngl.Program, scene: Scene) -> None:
    """Where the scene's texture arrays (each on a repeating and a clamping sampler), the traced
    rays' atlas and its decode table are bound (gpu/textures.py binds them there)."""
    for array in range(MATERIAL_ARRAYS):
        write(program, f"u_material_array_{array}", array_unit(array, clamped=False))
        write(program, f"u_material_array_clamped_{array}", array_unit(array, clamped=True))
    write(program, "u_material_texels", TextureUnit.MATERIAL_TEXELS)
    write(program, "u_srgb_to_linear", SRGB_TABLE)


def write_scene_uniforms(program: moderngl.Program, scene: Scene) -> None:
    """Where a program finds what the renderer binds for every frame: the scene's textures (and
    the TextureRecords block of their arrays, layers, wraps and texel rectangles), the shadow maps and the environment map on their units,
    and the Lights, AnalyticPlanes, MaterialRecords and ShadowMaps blocks on their bindings. None of it changes when
    the lights or objects move (those are in the blocks' buffers: gpu/scene_blocks.py), so the
    program cache writes it once, into each program as it is made."""
    write_textures(program, scene)
    write(program, "u_shadow_depth", TextureUnit.SHADOW_MAPS)
    write(program, "u_env_map", TextureUnit.ENVIRONMENT_MAP)
    bind_uniform_block(program, "Lights", UniformBlock.LIGHTS)
    bind_uniform_block(program, "AnalyticPlanes", UniformBlock.ANALYTIC_PLANES)
    bind_uniform_block(program, "ShadowMaps", UniformBlock.SHADOW_MAPS)
    bind_uniform_block(program, "TextureRecords", UniformBlock.TEXTURE_RECORDS)
    bind_record_block(program, "MaterialRecords", UniformBlock.MATERIALS, StorageBuffer.MATERIALS)
    bind_uniform_block(program, "DrawnMaterial", UniformBlock.DRAWN_MATERIAL)
