"""The scene's lights, analytic planes and materials, each in one std140 uniform buffer that every
program reads: written when they move (the materials when the scene is made), bound once a frame
(before the bakes: baked images are shaded too).

Before, each program held its own copy as plain uniforms, written program by program whenever a
light moved; a program made later had to be remembered and written too. A uniform block has
one copy: a program only needs its block bindings (gpu/uniforms.py), set once when it is made.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import moderngl
import numpy as np

from .bindings import StorageBuffer, UniformBlock
from .uniforms import material_count, material_records, materials_in_storage
from ..constants import (DRAWN_MATERIAL_STRIDE, LIGHTING, MATERIAL, MAX_ANALYTIC_PLANES, MAX_LIGHTS, PLANES, LightKind,
                         ShadowKind)
from ..errors import GpuLimitError, SceneError
from ..geometry import ObjectGeometry
from ..ibl import irradiance_sh9, uses_environment_lighting
from ..scene.model import PlaneShape, Scene


def lighting_record(scene: Scene) -> np.ndarray:
    """lib/lighting.glsl's Lights block of `scene` as it is (its lights where they are now), a
    0-d array of constants.LIGHTING."""
    if len(scene.lights) > MAX_LIGHTS:
        raise SceneError(scene.source, "lights", f"expected at most {MAX_LIGHTS} lights, got {len(scene.lights)}")
    record = np.zeros((), LIGHTING.dtype)
    record["ambient"] = scene.render.ambient
    record["light_count"] = len(scene.lights)
    env = scene.environment
    radians = math.radians(env.rotation)
    record["env_rotation"] = (math.cos(radians), math.sin(radians))
    record["env_zenith"], record["env_horizon"], record["env_ground"] = env.zenith, env.horizon, env.ground
    record["env_intensity"] = env.intensity
    if env.image is not None and uses_environment_lighting(scene):  # what lib/environment_lighting.glsl reads
        record["env_size"] = (env.image.shape[1], env.image.shape[0])
        record["env_irradiance"][:, :3] = irradiance_sh9(env.image)
    lights = record["lights"]
    for i, light in enumerate(scene.lights):
        if light.type == "directional":
            lights["kind"][i] = LightKind.DIRECTIONAL
            lights["vector"][i] = np.asarray(light.direction) / np.linalg.norm(light.direction)
        else:
            lights["kind"][i] = LightKind.POINT
            lights["vector"][i] = light.position
        lights["radiance"][i] = np.asarray(light.color) * light.intensity
        lights["shadows"][i] = ShadowKind[light.shadows.upper()]
        lights["radius"][i] = light.radius
    return record


def planes_record(scene: Scene, planes: Sequence[ObjectGeometry]) -> np.ndarray:
    """lib/reflected_scene.glsl's AnalyticPlanes block: the planes the scene intersects exactly
    (Scene.analytic_plane_indices: floors, walls) where they are now, a 0-d array of constants.PLANES."""
    if len(planes) > MAX_ANALYTIC_PLANES:  # the scene chooses at most that many: a bug, not a scene's error
        raise ValueError(f"{len(planes)} analytic planes for an array of {MAX_ANALYTIC_PLANES}: "
                         "Scene.analytic_plane_indices chooses at most that many")
    record = np.zeros((), PLANES.dtype)
    record["count"] = len(planes)
    entries = record["planes"]
    for i, plane in enumerate(planes):
        shape = plane.object.shape
        if not isinstance(shape, PlaneShape):
            raise TypeError(f"object {plane.index} is a {type(shape).__name__}, not an analytic plane")
        normal = plane.normal_matrix @ np.array([0.0, 1.0, 0.0])
        # std140's mat4 is column-major: a numpy row holds a column.
        entries["world_to_local"][i] = np.linalg.inv(plane.model_matrix).T
        entries["half_size"][i] = (shape.size[0] / 2.0, shape.size[1] / 2.0)
        entries["normal"][i] = normal / np.linalg.norm(normal)
        entries["object_id"][i] = plane.index
        entries["material"][i] = scene.material_index(plane.object.material)
    return record


class DrawnMaterials:
    """The MaterialRecords table again, a record every DRAWN_MATERIAL_STRIDE bytes, so that a
    program drawing one object a call (uniforms.material_defines' DRAWN_MATERIAL: the bakes, the
    eye's objects that move) is given that object's record alone as its DrawnMaterial block, one
    glBindBufferRange a draw, instead of indexing the table per fragment: the table of a scene of
    more than MATERIAL_BLOCK_RECORDS materials is a storage buffer, which llvmpipe reads per
    fragment at a cost a uniform block's constant does not have (results/llvmpipe/startup_time.md,
    fourth pass). A batch, whose instances carry their material's index, reads the table."""

    def __init__(self, ctx: moderngl.Context) -> None:
        alignment = int(ctx.info["GL_UNIFORM_BUFFER_OFFSET_ALIGNMENT"])
        if DRAWN_MATERIAL_STRIDE % alignment:  # a GL past the specification's largest (256)
            raise GpuLimitError(f"this GL's GL_UNIFORM_BUFFER_OFFSET_ALIGNMENT of {alignment} does not divide the "
                                f"material records' stride of {DRAWN_MATERIAL_STRIDE} bytes")
        self.buffer = ctx.buffer(reserve=DRAWN_MATERIAL_STRIDE)
        self.ctx = ctx

    def write(self, records: np.ndarray) -> None:
        """The table `records` (uniforms.material_records), each record at its stride."""
        size = MATERIAL.dtype.itemsize
        padded = np.zeros((len(records), DRAWN_MATERIAL_STRIDE), np.uint8)
        padded[:, :size] = np.ascontiguousarray(records).view(np.uint8).reshape(len(records), size)
        if padded.nbytes != self.buffer.size:  # an edited scene with another number of materials
            self.buffer.release()
            self.buffer = self.ctx.buffer(reserve=padded.nbytes)
        self.buffer.write(padded.tobytes())

    def bind(self, index: int) -> None:
        """Material `index`'s record as the DrawnMaterial block of the next draws."""
        self.buffer.bind_to_uniform_block(UniformBlock.DRAWN_MATERIAL, offset=index * DRAWN_MATERIAL_STRIDE,
                                          size=MATERIAL.dtype.itemsize)

    def release(self) -> None:
        self.buffer.release()


class SceneBlocks:
    """The Lights, AnalyticPlanes and MaterialRecords blocks' buffers, and the table's copy that
    one-object draws bind a record of (DrawnMaterials). `write` them when the lights or planes move
    (or the scene is edited); `bind` them once a frame."""

    #: GPU memory of the lights' and planes' buffers (the plan's figure: plan.plan_memory, which
    #: adds the materials': materials_bytes).
    BYTES = LIGHTING.dtype.itemsize + PLANES.dtype.itemsize

    def __init__(self, ctx: moderngl.Context) -> None:
        self.ctx = ctx
        self.lights = ctx.buffer(reserve=LIGHTING.dtype.itemsize)
        self.planes = ctx.buffer(reserve=PLANES.dtype.itemsize)
        self.materials = ctx.buffer(reserve=MATERIAL.dtype.itemsize)
        self.materials_in_storage = False  # past a uniform block's records (uniforms.materials_in_storage)
        self.drawn_materials = DrawnMaterials(ctx)

    def write(self, scene: Scene, planes: Sequence[ObjectGeometry]) -> None:
        """`scene`'s lights (where they are now), the analytic planes `planes` and the materials."""
        self.lights.write(lighting_record(scene).tobytes())
        self.planes.write(planes_record(scene, planes).tobytes())
        records = material_records(scene)
        materials = records.tobytes()
        self.drawn_materials.write(records)
        self.materials_in_storage = materials_in_storage(scene)
        if len(materials) != self.materials.size:  # an edited scene with another number of materials
            self.materials.release()
            self.materials = self.ctx.buffer(reserve=len(materials))
        self.materials.write(materials)

    def bind(self) -> None:
        self.lights.bind_to_uniform_block(UniformBlock.LIGHTS)
        self.planes.bind_to_uniform_block(UniformBlock.ANALYTIC_PLANES)
        if self.materials_in_storage:
            self.materials.bind_to_storage_buffer(StorageBuffer.MATERIALS)
        else:
            self.materials.bind_to_uniform_block(UniformBlock.MATERIALS)

    def release(self) -> None:
        self.lights.release()
        self.planes.release()
        self.materials.release()
        self.drawn_materials.release()


def materials_bytes(scene: Scene) -> int:
    """GPU memory of `scene`'s MaterialRecords table (a uniform block up to MATERIAL_BLOCK_RECORDS
    records, a storage buffer past them: plan.plan_limits states which)."""
    return material_count(scene) * MATERIAL.dtype.itemsize


def drawn_materials_bytes(scene: Scene) -> int:
    """GPU memory of the table's copy that one-object draws bind a record of (DrawnMaterials)."""
    return material_count(scene) * DRAWN_MATERIAL_STRIDE
