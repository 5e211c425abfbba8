"""Writing scene-wide values (lights, environment, materials, planes) into any program that uses them.

A uniform the compiler removed (unused in that variant) is simply absent from the program, so
each write checks membership first instead of catching errors.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import moderngl
import numpy as np

from .bindings import TextureUnit, UniformBlock
from ..constants import MAX_ANALYTIC_PLANES, MAX_LIGHTS, MAX_TEXTURES, LightKind, MaterialKind, ShadowKind, Wrap
from ..errors import SceneError
from ..geometry import ObjectGeometry
from ..scene.model import CheckerMaterial, DiffuseMaterial, Material, PlaneShape, Scene
from ..textures import SRGB_TABLE, texel_rects


#: Where every shading program finds the shadow maps (lib/shadows.glsl; passes/shadows.py binds
#: them there once per frame). The unit is past those of every method's stand-in (0 to 4).


def shading_defines(scene: Scene) -> dict[str, int]:
    """The variant of every shading program that the scene's lights and materials call for: its
    number of lights (more than MAX_LIGHTS is refused when the lights are written), shadow
    rays only in scenes where a light casts shadows on something, texture sampling only in scenes
    with image textures (TEXTURE_COUNT of them)."""
    return {"LIGHT_COUNT": min(len(scene.lights), MAX_LIGHTS),  # a constant loop bound (lib/shading.glsl)
            **({"SHADOWS": 1} if scene.has_shadows else {}),
            **({"TEXTURE_COUNT": len(scene.textures)} if scene.textures else {})}


def environment_defines(scene: Scene) -> dict[str, int]:
    """The variant of every program that reads the environment: ENVIRONMENT_MAP for an image."""
    return {"ENVIRONMENT_MAP": 1} if scene.environment.is_map else {}


def write(program: moderngl.Program | moderngl.ComputeShader, name: str,
          data: np.ndarray | bytes | float | Sequence[float]) -> None:
    """Set a uniform if the program has it: numpy arrays as float32/int32 bytes, scalars as values."""
    if name not in program:
        return
    uniform = program[name]
    if not isinstance(uniform, moderngl.Uniform):
        raise TypeError(f"{name} is a {type(uniform).__name__}, not a uniform a value can be written to")
    if isinstance(data, np.ndarray):
        dtype = np.int32 if np.issubdtype(data.dtype, np.integer) else np.float32
        values = np.ascontiguousarray(data, dtype=dtype).reshape(-1)
        # An array the compiler shortened to the elements the program reads (a loop bounded by a
        # constant, LIGHT_COUNT or PLANE_COUNT, reads the first ones): those elements alone.
        uniform.write(values[:uniform.array_length * uniform.dimension].tobytes())
    elif isinstance(data, bytes):
        uniform.write(data)
    else:
        uniform.value = data


def bind_texture(program: moderngl.Program, name: str, texture: moderngl.Texture, unit: int) -> None:
    """Put `texture` on texture unit `unit` and point the sampler `name` at it."""
    texture.use(unit)
    write(program, name, unit)


def bind_uniform_block(program: moderngl.Program, name: str, binding: int) -> None:
    """Point the uniform block `name` (if the variant kept it) at a buffer binding point."""
    if name not in program:
        return
    block = program[name]
    if not isinstance(block, moderngl.UniformBlock):
        raise TypeError(f"{name} is a {type(block).__name__}, not a uniform block")
    block.binding = binding


def write_matrix(program: moderngl.Program, name: str, matrix: np.ndarray) -> None:
    """A matrix in GL's column-major float32 layout."""
    write(program, name, np.ascontiguousarray(matrix.T, dtype=np.float32).tobytes())


MaterialFields = tuple[MaterialKind, tuple[float, float, float], tuple[float, float, float], float]


def material_fields(material: Material) -> MaterialFields:
    """(kind, colour a, colour b, checker scale): shading.glsl's Material, from a scene material."""
    if isinstance(material, CheckerMaterial):
        return MaterialKind.CHECKER, material.color_a, material.color_b, material.scale
    if isinstance(material, DiffuseMaterial):
        return MaterialKind.DIFFUSE, material.color, material.color, 1.0
    raise TypeError(f"{material!r} is not a diffuse material")


def texture_fields(scene: Scene, material: Material) -> tuple[int, tuple[float, float]]:
    """(texture slot or -1, UV scale): shading.glsl's Material.texture and uv_scale."""
    texture = material.texture if isinstance(material, DiffuseMaterial) else None
    return scene.texture_slot(material), texture.scale if texture is not None else (1.0, 1.0)


def write_material(program: moderngl.Program, name: str, material: Material, scene: Scene) -> None:
    kind, color_a, color_b, scale = material_fields(material)
    write(program, f"{name}.kind", int(kind))
    write(program, f"{name}.color_a", tuple(color_a))
    write(program, f"{name}.color_b", tuple(color_b))
    write(program, f"{name}.scale", float(scale))
    slot, uv_scale = texture_fields(scene, material)
    write(program, f"{name}.texture", slot)
    write(program, f"{name}.uv_scale", uv_scale)


def write_textures(program: moderngl.Program, scene: Scene) -> None:
    """Where the scene's texture slots are bound (gpu/textures.py binds them there), and their
    wrap modes, for the bilinear sampling of traced rays."""
    wraps = np.full((MAX_TEXTURES, 2), int(Wrap.REPEAT), np.int32)
    for slot, texture in enumerate(scene.textures):
        write(program, f"u_material_texture_{slot}", TextureUnit.MATERIAL_TEXTURE_0 + slot)
        wraps[slot] = texture.wrap
    write(program, "u_material_texels", TextureUnit.MATERIAL_TEXELS)
    write(program, "u_material_texels_rect", texel_rects(scene))
    write(program, "u_material_texture_wrap", wraps)
    write(program, "u_srgb_to_linear", SRGB_TABLE)


def write_lighting(program: moderngl.Program, scene: Scene) -> None:
    """Ambient, lights and environment: everything the shading and environment chunks read."""
    if len(scene.lights) > MAX_LIGHTS:
        raise SceneError(scene.source, "lights", f"expected at most {MAX_LIGHTS} lights, got {len(scene.lights)}")
    kinds = np.zeros(MAX_LIGHTS, dtype=np.int32)
    vectors = np.zeros((MAX_LIGHTS, 3))
    radiance = np.zeros((MAX_LIGHTS, 3))
    shadows = np.zeros(MAX_LIGHTS, dtype=np.int32)
    radii = np.zeros(MAX_LIGHTS)
    for i, light in enumerate(scene.lights):
        if light.type == "directional":
            kinds[i] = LightKind.DIRECTIONAL
            vectors[i] = np.asarray(light.direction) / np.linalg.norm(light.direction)
        else:
            kinds[i] = LightKind.POINT
            vectors[i] = light.position
        radiance[i] = np.asarray(light.color) * light.intensity
        shadows[i] = ShadowKind[light.shadows.upper()]
        radii[i] = light.radius
    write(program, "u_ambient", float(scene.render.ambient))
    write(program, "u_light_count", len(scene.lights))
    write(program, "u_light_kind", kinds)
    write(program, "u_light_vector", vectors)
    write(program, "u_light_radiance", radiance)
    write(program, "u_light_shadows", shadows)
    write(program, "u_light_radius", radii)
    write(program, "u_shadow_depth", TextureUnit.SHADOW_MAPS)
    bind_uniform_block(program, "ShadowMaps", UniformBlock.SHADOW_MAPS)
    write_environment(program, scene)


def write_environment(program: moderngl.Program, scene: Scene) -> None:
    """lib/environment.glsl's uniforms: the gradient's colours, or the map's unit and settings."""
    env = scene.environment
    write(program, "u_env_zenith", tuple(env.zenith))
    write(program, "u_env_horizon", tuple(env.horizon))
    write(program, "u_env_ground", tuple(env.ground))
    write(program, "u_env_map", TextureUnit.ENVIRONMENT_MAP)
    write(program, "u_env_intensity", float(env.intensity))
    radians = math.radians(env.rotation)
    write(program, "u_env_rotation", (math.cos(radians), math.sin(radians)))


def write_scene_uniforms(program: moderngl.Program, scene: Scene, planes: Sequence[ObjectGeometry]) -> None:
    """Everything a program reads of the scene as it is now: the lights and environment, and (in
    the programs that trace them: the mirror shader's variants) the analytic planes. The renderer
    hands this to its ProgramCache, which alone calls it."""
    write_lighting(program, scene)
    write_textures(program, scene)
    # A program made with PLANE_COUNT has no u_plane_count (lib/reflected_scene.glsl); one made
    # with PLANE_COUNT 0 reads no plane at all.
    if "u_plane_count" in program or "u_plane_world_to_local" in program:
        write_analytic_planes(program, scene, planes)


def write_analytic_planes(program: moderngl.Program, scene: Scene, planes: Sequence[ObjectGeometry]) -> None:
    if len(planes) > MAX_ANALYTIC_PLANES:
        raise SceneError(
            scene.source, "objects", f"expected at most {MAX_ANALYTIC_PLANES} non-mirror planes, got {len(planes)}"
        )
    world_to_local = np.zeros((MAX_ANALYTIC_PLANES, 4, 4))
    half_sizes = np.zeros((MAX_ANALYTIC_PLANES, 2))
    normals = np.zeros((MAX_ANALYTIC_PLANES, 3))
    object_ids = np.zeros(MAX_ANALYTIC_PLANES, dtype=np.int32)
    for i, plane in enumerate(planes):
        shape = plane.object.shape
        if not isinstance(shape, PlaneShape):
            raise TypeError(f"object {plane.index} is a {type(shape).__name__}, not an analytic plane")
        width, depth = shape.size
        normal = plane.normal_matrix @ np.array([0.0, 1.0, 0.0])
        world_to_local[i] = np.linalg.inv(plane.model_matrix).T  # column-major for GL
        half_sizes[i] = (width / 2.0, depth / 2.0)
        normals[i] = normal / np.linalg.norm(normal)
        object_ids[i] = plane.index
        write_material(program, f"u_plane_material[{i}]", plane.object.material, scene)
    # Arrays of plain types are single uniforms named without an index; write them whole.
    write(program, "u_plane_count", len(planes))
    write(program, "u_plane_world_to_local", world_to_local)
    write(program, "u_plane_half_size", half_sizes)
    write(program, "u_plane_normal", normals)
    write(program, "u_plane_object_id", object_ids)
