"""The ray-traced method's data: every reflected object's triangles through a two-level BVH.

Nothing is baked: the mirror shader walks the BVH per reflected ray (shaders/lib/triangles.glsl).
Each distinct mesh (objects of one shape share theirs: geometry.scene_geometry) gets one bottom-level
hierarchy over its triangles in its own space (methods/bvh.py), built once; each reflected object is
an instance of its mesh under its transform, with its material, under a top-level hierarchy over the
instances' world boxes (methods/instances.py), which is all an object that moves changes (`move`).
Both levels and the instance records share one float texture, the triangles another (GL 3.3 has no
storage buffers, and the mirror shader has no sampler unit to spare: gpu/bindings.py).
"""

from __future__ import annotations

import dataclasses
import math

import moderngl
import numpy as np

from ..constants import BVH_TEXTURE_WIDTH, BVH_TRIANGLE_TEXELS, triangle_texel_layout
from ..errors import SceneError
from ..geometry import ObjectGeometry
from ..gpu.bindings import TextureUnit
from ..gpu.uniforms import bind_texture, mesh_attributes, write
from ..meshes import Mesh
from ..scene.model import Scene
from .atlas import plural
from .gpu_refit import GpuRefit
from .bvh import build_triangle_forest, node_count, refit_triangle_forest
from .instances import (NODE_TEXELS, BvhLayout, front_texels, instance_records, node_texels, nothing_record,
                        with_transforms)

#: What a mirror that reflects nothing traces, so that its shader still has a BVH to walk: one
#: degenerate triangle (its corners at the origin), which no ray meets (ray_triangle's determinant
#: is exactly 0).
NOTHING = Mesh(np.zeros((3, 3)), np.zeros((3, 3)), np.array([[0, 1, 2]]))


def _rows(texels: int) -> int:
    return max(1, math.ceil(texels / BVH_TEXTURE_WIDTH))


def _texture(ctx: moderngl.Context, texels: np.ndarray, source: str) -> moderngl.Texture:
    """(n, 4) float32 texels laid out in rows of BVH_TEXTURE_WIDTH; `source` names the scene."""
    padded = _padded(ctx, len(texels), texels.shape[1], source)
    padded[: len(texels)] = texels
    return _upload(ctx, padded)


def _padded(ctx: moderngl.Context, count: int, components: int, source: str) -> np.ndarray:
    """A zeroed (whole rows of BVH_TEXTURE_WIDTH, `components`) float32 array for `count` texels,
    to be filled in place and uploaded (_upload); refused past this GL's texture size."""
    rows = _rows(count)
    limit = ctx.info["GL_MAX_TEXTURE_SIZE"]
    if rows > limit:
        raise SceneError(source, "objects", f"{count} BVH texels need {rows} rows, over this GL's limit of {limit}")
    return np.zeros((rows * BVH_TEXTURE_WIDTH, components), np.float32)


def _upload(ctx: moderngl.Context, padded: np.ndarray) -> moderngl.Texture:
    """The texture of `padded` (from _padded), read texel by texel (texelFetch)."""
    texture = ctx.texture((BVH_TEXTURE_WIDTH, len(padded) // BVH_TEXTURE_WIDTH), padded.shape[1], padded, dtype="f4")
    texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
    return texture


def distinct_meshes(meshes: list[Mesh]) -> dict[Mesh, int]:
    """Each distinct mesh (by identity) and its place among them, in first-use order."""
    distinct: dict[Mesh, int] = {}
    for mesh in meshes:
        distinct.setdefault(mesh, len(distinct))
    return distinct


def triangle_texels(meshes: list[Mesh], order: np.ndarray, attributes: tuple[str, ...] = ()) -> np.ndarray:
    """(triangles * texels a triangle, 4) texels of every triangle of `meshes`, mesh after mesh, in
    the `order` of their hierarchies' leaves: BVH_TRIANGLE_TEXELS, then the glTF `attributes` the
    scene uses where constants.triangle_texel_layout puts them (EXTRA_DEFAULTS for a mesh without)."""
    indices = np.concatenate([mesh.indices for mesh in meshes])[order]
    starts = np.cumsum([0] + [len(mesh.positions) for mesh in meshes[:-1]])
    indices = indices + np.repeat(starts, [len(mesh.indices) for mesh in meshes])[order, None]
    positions = np.concatenate([mesh.positions for mesh in meshes])
    normals = np.concatenate([mesh.normals for mesh in meshes])
    uvs = np.concatenate([mesh.uvs if mesh.uvs is not None else np.zeros((len(mesh.positions), 2), np.float32)
                          for mesh in meshes])
    layout = triangle_texel_layout(attributes)
    ordered = np.zeros((len(indices), layout.get("TRIANGLE_TEXELS", BVH_TRIANGLE_TEXELS), 4), np.float32)
    ordered[:, :3, :3] = positions[indices]
    ordered[:, 3:6, :3] = normals[indices]
    ordered[:, 6, :] = uvs[indices[:, :2]].reshape(-1, 4)
    ordered[:, 7, :2] = uvs[indices[:, 2]]
    for name in attributes:
        values = np.concatenate([mesh.attribute(name) for mesh in meshes])[indices]  # (triangles, 3, width)
        texel = layout[f"TRIANGLE_{name.upper()}_TEXEL"]
        if name == "uvs1":
            ordered[:, texel, :] = values[:, :2].reshape(-1, 4)
            ordered[:, 7, 2:] = values[:, 2]
        else:
            ordered[:, texel:texel + 3, :] = values
    return ordered.reshape(-1, 4)


def triangle_stride(scene: Scene) -> int:
    """Texels a triangle takes in the scene's triangle texture (its glTF attributes' included)."""
    return triangle_texel_layout(mesh_attributes(scene)).get("TRIANGLE_TEXELS", BVH_TRIANGLE_TEXELS)


class TrianglePass:
    """Owns the BVH's node and triangle textures (and the hybrid method's place texture)."""

    noun = "triangle"

    @classmethod
    def traced_meshes(cls, scene: Scene, reflected: list[ObjectGeometry]) -> list[Mesh]:
        """The mesh each of `reflected` is traced as, in its own space (objects sharing a mesh share it)."""
        return [item.local_mesh for item in reflected]

    @classmethod
    def bytes_for(cls, scene: Scene, reflected: list[ObjectGeometry], named: bool) -> int:
        """GPU memory of the pass for `reflected` (the plan's figure; `named`: the hybrid method's
        place texture too), without building it: the hierarchies' sizes depend on counts alone."""
        meshes = cls.traced_meshes(scene, reflected) or [NOTHING]
        distinct = list(distinct_meshes(meshes))
        layout = BvhLayout(len(meshes), sum(node_count(len(m.indices)) for m in distinct),
                           tuple(len(m.indices) for m in distinct))
        return cls._bytes(layout, sum(len(m.indices) for m in meshes) if named else None, triangle_stride(scene))

    @staticmethod
    def _bytes(layout: BvhLayout, named: int | None, stride: int) -> int:
        rows = _rows(layout.node_texels) + _rows(stride * sum(layout.mesh_triangles))
        return (rows * 16 + (_rows(named) * 8 if named is not None else 0)) * BVH_TEXTURE_WIDTH  # RGBA32F, RG32F

    def __init__(self, ctx: moderngl.Context, scene: Scene, reflected: list[ObjectGeometry], places: bool = False) -> None:
        """`places` (the hybrid method's) also uploads, for each triangle of the list its depth images
        name (geometry.triangle_offsets: every object's own triangles, in order), where it sits in its
        mesh's hierarchy and which instance it belongs to."""
        self.ctx = ctx
        self.scene = scene
        self.reflected = list(reflected)
        meshes = self.traced_meshes(scene, self.reflected) or [NOTHING]
        self.distinct = distinct_meshes(meshes)
        self.mesh_of = [self.distinct[mesh] for mesh in meshes]  # per instance
        # Every distinct mesh's hierarchy, built at once: a forest whose root j is mesh j's.
        self.bottom = build_triangle_forest(np.concatenate([mesh.positions[mesh.indices] for mesh in self.distinct]),
                                            [len(mesh.indices) for mesh in self.distinct])
        self.layout = BvhLayout(len(meshes), self.bottom.node_count, tuple(len(mesh.indices) for mesh in self.distinct))
        self.triangle_count = sum(len(mesh.indices) for mesh in meshes) if self.reflected else 0
        self.refits = 0  # bottom levels refitted for deformed meshes (`_refit`), and the bytes the last uploaded
        self.refit_bytes = 0
        layout = self.layout
        roots = [layout.mesh_base + mesh for mesh in self.mesh_of]
        # Materials, ids and meshes: what a move keeps.
        self._records = instance_records(scene, self.reflected, roots) if self.reflected else nothing_record(roots[0])
        nodes = np.zeros((layout.node_texels, 4), np.float32)
        nodes[: layout.front_texels] = self._front()
        nodes[NODE_TEXELS * layout.mesh_base:] = node_texels(self.bottom, 0, layout.mesh_base)
        self.nodes = _texture(ctx, nodes, scene.source)
        # Deformed meshes' trees refitted on the GPU (render_graph.py attaches it where it can).
        self.gpu: GpuRefit | None = None
        made = [self.nodes]
        try:
            self.triangles = _texture(ctx, triangle_texels(list(self.distinct), self.bottom.order,
                                                           mesh_attributes(scene)), scene.source)
            made.append(self.triangles)
            self.places = self._places_texture(meshes) if places else None
        except BaseException:
            for texture in made:
                texture.release()
            raise

    def _front(self) -> np.ndarray:
        """The top level and the instance records, from where the objects are now."""
        # (A mirror that reflects nothing: its one degenerate instance, untransformed.)
        models = np.stack([item.model_matrix for item in self.reflected]) if self.reflected else np.eye(4)[None]
        lower = self.bottom.lower[self.mesh_of].astype(np.float64)
        upper = self.bottom.upper[self.mesh_of].astype(np.float64)
        return front_texels(self.layout, with_transforms(self._records, models), models, lower, upper)

    def _places_texture(self, meshes: list[Mesh]) -> moderngl.Texture:
        """Per listed triangle (at most MAX_NAMED_TRIANGLES: scene/limits.py, checked in the plan):
        (its place in the triangle texture, its instance's slot), two floats (RG32F: a thousand
        spheres list 4.5 million triangles). Built for every instance at once: instance k's
        triangles are its mesh's, whose places start at its mesh's first triangle."""
        where = np.empty(len(self.bottom.order), np.int64)  # by a triangle's place among the distinct meshes'
        where[self.bottom.order] = np.arange(len(self.bottom.order))
        counts = np.array([len(mesh.indices) for mesh in meshes], np.int64)
        starts = np.cumsum(counts) - counts  # each instance's first listed triangle
        firsts = np.asarray(self.layout.mesh_first_triangles, np.int64)[self.mesh_of]
        listed = int(counts.sum())
        place = _padded(self.ctx, listed, 2, self.scene.source)
        # A listed triangle i of instance k is triangle i - starts[k] of its mesh.
        place[:listed, 0] = where[np.arange(listed) + np.repeat(firsts - starts, counts)]
        place[:listed, 1] = np.repeat(np.arange(len(meshes), dtype=np.float32), counts)
        return _upload(self.ctx, place)

    def move(self, geometry: dict[int, ObjectGeometry]) -> None:
        """The objects are now `geometry` (by object index): their records and the top level are
        made again and written over the node texture's front; the meshes' hierarchies stay, but
        for those of a mesh that deforms (a glTF skin, morph targets: another mesh of the same
        triangles), which are refitted (`_refit`)."""
        moved = [geometry[item.index] for item in self.reflected]
        if all(new is old for new, old in zip(moved, self.reflected, strict=True)):
            return
        before = self.traced_meshes(self.scene, self.reflected)
        self.reflected = moved
        after = self.traced_meshes(self.scene, moved)
        if any(new is not old for new, old in zip(after, before, strict=True)):
            self._refit(before, after)
            return
        self._write_front()

    def _write_front(self) -> None:
        """The top level and the records made again and written over the node texture's front:
        its whole rows, then the texels of its last row, whose rest holds mesh nodes (which a refit
        on the GPU may have changed)."""
        front = self._front()
        whole = len(front) // BVH_TEXTURE_WIDTH
        if whole:
            self.nodes.write(front[: whole * BVH_TEXTURE_WIDTH].tobytes(), viewport=(0, 0, BVH_TEXTURE_WIDTH, whole))
        if len(front) % BVH_TEXTURE_WIDTH:
            self.nodes.write(front[whole * BVH_TEXTURE_WIDTH:].tobytes(),
                             viewport=(0, whole, len(front) % BVH_TEXTURE_WIDTH, 1))

    def _refit(self, before: list[Mesh], after: list[Mesh]) -> None:
        """Deformed meshes take their predecessors' places: the bottom levels are refitted (the same
        trees and triangle order, every box made again), on the GPU where it can (methods/gpu_refit.py:
        only the roots' boxes come back, for the top level), else on the CPU
        (bvh.refit_triangle_forest), the node and triangle textures then uploaded whole."""
        distinct, trees = list(self.distinct), set()
        for old, new in zip(before, after, strict=True):
            if new is not old:
                if len(new.indices) != len(old.indices):
                    raise ValueError(f"TrianglePass: a deformed mesh must keep its {len(old.indices)} triangles, "
                                     f"got {len(new.indices)}")
                distinct[self.distinct[old]] = new
                trees.add(self.distinct[old])
        self.distinct = {mesh: j for j, mesh in enumerate(distinct)}
        self.refits += 1
        if self.gpu is not None and self.gpu.usable([distinct[j] for j in trees]):
            self._refit_on_gpu(self.gpu, sorted(trees), distinct)
            return
        self.bottom = refit_triangle_forest(self.bottom, np.concatenate([m.positions[m.indices] for m in distinct]))
        layout = self.layout
        nodes = np.zeros((_rows(layout.node_texels) * BVH_TEXTURE_WIDTH, 4), np.float32)
        nodes[: layout.front_texels] = self._front()
        nodes[NODE_TEXELS * layout.mesh_base: layout.node_texels] = node_texels(self.bottom, 0, layout.mesh_base)
        triangles = np.zeros((self.triangles.width * self.triangles.height, 4), np.float32)
        texels = triangle_texels(distinct, self.bottom.order, mesh_attributes(self.scene))
        triangles[: len(texels)] = texels
        self.nodes.write(nodes.tobytes())
        self.triangles.write(triangles.tobytes())
        self.refit_bytes = nodes.nbytes + triangles.nbytes

    def _refit_on_gpu(self, gpu: GpuRefit, trees: list[int], distinct: list[Mesh]) -> None:
        """`trees` refitted in the textures by compute passes; their roots' boxes read back into
        `bottom` (its other boxes are left as they were: only the roots are read on the CPU), and
        the front made again over them (what `refit_bytes` counts, with the roots read back)."""
        roots = gpu.refit(self.bottom, trees, distinct, self.layout.mesh_first_triangles, self.nodes, self.triangles,
                          triangle_stride(self.scene), self.layout.mesh_base)
        lower, upper = self.bottom.lower.copy(), self.bottom.upper.copy()
        lower[trees], upper[trees] = roots[:, 0], roots[:, 1]
        self.bottom = dataclasses.replace(self.bottom, lower=lower, upper=upper)
        self._write_front()
        self.refit_bytes = self.layout.front_texels * 16 + roots.nbytes

    @property
    def textures(self) -> list[moderngl.Texture]:
        return [self.nodes, self.triangles] + ([self.places] if self.places is not None else [])

    @property
    def bytes(self) -> int:
        return sum(texture.width * texture.height * 4 * texture.components for texture in self.textures)

    def describe(self) -> str:
        meshes = len(self.distinct) if self.reflected else 0
        return (f"{plural(self.triangle_count, self.noun)} in a two-level BVH "
                f"({plural(len(self.reflected), 'instance')} of {meshes} mesh{'' if meshes == 1 else 'es'})")

    def bake(self) -> int:
        """Nothing to bake: the BVH was built and uploaded with the pass."""
        return 0

    def bind(self, program: moderngl.Program) -> None:
        bind_texture(program, "u_bvh_nodes", self.nodes, TextureUnit.BVH_NODES)
        bind_texture(program, "u_bvh_triangles", self.triangles, TextureUnit.BVH_TRIANGLES)
        write(program, "u_instance_records", self.layout.records_start)
        if self.places is not None:
            bind_texture(program, "u_bvh_places", self.places, TextureUnit.BVH_PLACES)

    def bind_reflector(self, program: moderngl.Program, mirror: ObjectGeometry) -> None:
        """Every mirror traces the same triangles: nothing per mirror."""

    def release(self) -> None:
        for texture in self.textures:
            texture.release()
        if self.gpu is not None:
            self.gpu.release()
