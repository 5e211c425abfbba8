"""The ray-traced method's data: every reflected object's world-space triangles in one BVH.

Nothing is baked: the mirror shader traverses the BVH per reflected ray (shaders/lib/triangles.glsl).
The hierarchy is built once on the CPU (depthimpostor/methods/bvh.py) and uploaded as two float textures
and a uniform buffer of per-object materials and transforms.
"""

from __future__ import annotations

import math

import moderngl
import numpy as np

from ..gpu.bindings import StorageBuffer, TextureUnit, UniformBlock
from .bvh import build_bvh
from ..constants import (
    BVH_TEXTURE_WIDTH,
    BVH_TRIANGLE_TEXELS,
    STORAGE_GL_VERSION,
    TRIANGLE_OBJECT_BLOCK_RECORDS,
    TRIANGLE_OBJECT_DTYPE,
    depth_image_capacity,
)
from ..errors import ContextError, SceneError
from ..geometry import ObjectGeometry
from ..meshes import Mesh
from ..scene.model import Scene
from .atlas import plural
from ..gpu.uniforms import bind_record_block, bind_texture, material_fields, texture_fields



def _texture(ctx: moderngl.Context, texels: np.ndarray, source: str) -> moderngl.Texture:
    """(n, 4) float32 texels laid out in rows of BVH_TEXTURE_WIDTH; `source` names the scene."""
    rows = max(1, math.ceil(len(texels) / BVH_TEXTURE_WIDTH))
    limit = ctx.info["GL_MAX_TEXTURE_SIZE"]
    if rows > limit:
        raise SceneError(source, "objects", f"{len(texels)} BVH texels need {rows} rows, over this GL's limit of {limit}")
    padded = np.zeros((rows * BVH_TEXTURE_WIDTH, 4), np.float32)
    padded[: len(texels)] = texels
    texture = ctx.texture((BVH_TEXTURE_WIDTH, rows), 4, padded.tobytes(), dtype="f4")
    texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
    return texture


def object_capacity(scene: Scene) -> int:
    """The traced objects' records as this scene's programs declare them (constants.depth_image_defines)."""
    return depth_image_capacity(len(scene.objects))


def object_records(scene: Scene, objects: list[ObjectGeometry]) -> np.ndarray:
    """Each traced object's TRIANGLE_OBJECT record, padded to object_capacity (a uniform block is
    declared with that many; a storage buffer is read by slot alone, padded as well)."""
    records = np.zeros(object_capacity(scene), TRIANGLE_OBJECT_DTYPE)
    for slot, item in enumerate(objects):
        kind, color_a, color_b, scale = material_fields(item.object.material)
        texture, uv_scale = texture_fields(scene, item.object.material)
        # std140 mat4 is column-major: the numpy row holds a column.
        records[slot]["world_to_local"] = np.linalg.inv(item.model_matrix).T
        records[slot]["color_a"] = (*color_a, scale)
        records[slot]["color_b"] = (*color_b, 0.0)
        records[slot]["kind_and_id"] = (int(kind), item.index, texture, 0)
        records[slot]["texture"] = (*uv_scale, 0.0, 0.0)
    return records


def _triangle_list(worlds: list[Mesh]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every triangle's corners, corner normals and corner UVs (zero without), and its object's
    slot. A mirror that reflects nothing still gets a BVH for its shader to walk: one degenerate
    triangle (its three corners at the origin), which no ray meets (ray_triangle's determinant is
    exactly 0)."""
    if not worlds:
        return (np.zeros((1, 3, 3), np.float32), np.zeros((1, 3, 3), np.float32), np.zeros((1, 3, 2), np.float32),
                np.zeros(1, np.int64))
    triangles = np.concatenate([mesh.positions[mesh.indices] for mesh in worlds])
    normals = np.concatenate([mesh.normals[mesh.indices] for mesh in worlds])
    uvs = np.concatenate([mesh.uvs[mesh.indices] if mesh.uvs is not None else np.zeros((len(mesh.indices), 3, 2))
                          for mesh in worlds])
    slots = np.concatenate([np.full(len(mesh.indices), slot) for slot, mesh in enumerate(worlds)])
    return triangles, normals, uvs, slots


class TrianglePass:
    """Owns the BVH textures and the per-object uniform buffer of the ray-traced method."""

    noun = "triangle"

    @classmethod
    def traced_triangles(cls, scene: Scene, reflected: list[ObjectGeometry]) -> int:
        """How many triangles the BVH of `reflected` holds (the plan's memory count)."""
        return sum(len(g.local_mesh.indices) for g in reflected)

    def __init__(
        self, ctx: moderngl.Context, scene: Scene, reflected: list[ObjectGeometry], world_meshes: list[Mesh] | None = None,
        places: bool = False,
    ) -> None:
        """`world_meshes` are the triangles to trace, one per reflected object, in world space:
        their own by default (the simplified method passes decimated ones). `places` (the hybrid
        method's) also uploads where each triangle of the list (geometry.triangle_offsets) sits in
        the BVH's order, so that a triangle a depth image names can be intersected."""
        if object_capacity(scene) > TRIANGLE_OBJECT_BLOCK_RECORDS and ctx.version_code < STORAGE_GL_VERSION:
            raise ContextError(
                f"a scene of {len(scene.objects)} objects keeps its traced objects' records in a storage buffer, which "
                f"needs OpenGL 4.3; this context has {ctx.version_code // 100}.{ctx.version_code % 100 // 10}: use a "
                f"newer driver, or at most {TRIANGLE_OBJECT_BLOCK_RECORDS} objects")
        self.ctx = ctx
        self.in_storage = object_capacity(scene) > TRIANGLE_OBJECT_BLOCK_RECORDS
        worlds = world_meshes if world_meshes is not None else [item.world_mesh for item in reflected]
        triangles, normals, uvs, slots = _triangle_list(worlds)
        bvh = build_bvh(triangles)
        self.triangle_count = sum(len(mesh.indices) for mesh in worlds)
        nodes = np.zeros((bvh.node_count, 3, 4), np.float32)
        nodes[:, 0, :3], nodes[:, 0, 3] = bvh.lower, bvh.first
        nodes[:, 1, :3], nodes[:, 1, 3] = bvh.upper, bvh.count
        nodes[:, 2, 0] = bvh.skip
        ordered = np.zeros((len(triangles), BVH_TRIANGLE_TEXELS, 4), np.float32)
        ordered[:, :3, :3] = triangles[bvh.order]
        ordered[:, 0, 3] = slots[bvh.order]
        ordered[:, 3:6, :3] = normals[bvh.order]
        ordered[:, 6, :] = uvs[bvh.order, :2].reshape(-1, 4)
        ordered[:, 7, :2] = uvs[bvh.order, 2]
        self.nodes = _texture(ctx, nodes.reshape(-1, 4), scene.source)
        self.triangles = _texture(ctx, ordered.reshape(-1, 4), scene.source)
        self.objects = ctx.buffer(object_records(scene, reflected).tobytes())
        self.places: moderngl.Texture | None = None
        if places:  # at most MAX_NAMED_TRIANGLES of them (scene/limits.py, checked in the plan)
            place = np.zeros((len(triangles), 4), np.float32)
            place[bvh.order, 0] = np.arange(len(triangles))
            self.places = _texture(ctx, place, scene.source)

    @property
    def textures(self) -> list[moderngl.Texture]:
        return [self.nodes, self.triangles] + ([self.places] if self.places is not None else [])

    @property
    def bytes(self) -> int:
        return sum(texture.width * texture.height * 16 for texture in self.textures) + self.objects.size

    def describe(self) -> str:
        return f"{plural(self.triangle_count, self.noun)} in a BVH"

    def bake(self) -> int:
        """Nothing to bake: the BVH was built and uploaded with the pass."""
        return 0

    def bind(self, program: moderngl.Program) -> None:
        bind_texture(program, "u_bvh_nodes", self.nodes, TextureUnit.BVH_NODES)
        bind_texture(program, "u_bvh_triangles", self.triangles, TextureUnit.BVH_TRIANGLES)
        bind_record_block(program, "TriangleObjects", UniformBlock.TRIANGLE_OBJECTS, StorageBuffer.TRIANGLE_OBJECTS)
        if self.in_storage:
            self.objects.bind_to_storage_buffer(StorageBuffer.TRIANGLE_OBJECTS)
        else:
            self.objects.bind_to_uniform_block(UniformBlock.TRIANGLE_OBJECTS)
        if self.places is not None:
            bind_texture(program, "u_bvh_places", self.places, TextureUnit.BVH_PLACES)

    def bind_reflector(self, program: moderngl.Program, mirror: ObjectGeometry) -> None:
        """Every mirror traces the same triangles: nothing per mirror."""

    def release(self) -> None:
        for texture in self.textures:
            texture.release()
        self.objects.release()
