"""The top level of the traced methods' two-level BVH: one instance per reflected object (its
transform, material and mesh), and a hierarchy over the instances' world boxes.

As pbrt-v4's and Mitsuba 3's instances do, the ray goes into the instance's space and meets the
mesh's own bottom-level hierarchy there (shaders/lib/triangles.glsl), so that objects of one mesh
(a thousand equal balls, a glTF mesh under several nodes) share one bottom level, and an object
that moves changes its record and the top level alone: both are rebuilt from scratch (a median
split over the instances' boxes, which for a thousand instances costs less than a refit's
bookkeeping), and the meshes' hierarchies stay.

The node texture (methods/triangles.py) holds, in order: the top level's nodes from node 0, the
instance records from texel `records_start`, then from node `mesh_base` the meshes' bottom levels.
The first two are the texture's front, rewritten when objects move (`front_texels`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..constants import NO_OBJECT, TRIANGLE_INSTANCE, TRIANGLE_INSTANCE_DTYPE
from ..geometry import ObjectGeometry
from ..gpu.texel_records import texel_count, to_texels
from ..scene.model import Scene
from .bvh import Bvh, build_box_bvh, node_count

#: Texels of one instance record (constants.TRIANGLE_INSTANCE_FIELDS).
INSTANCE_TEXELS = texel_count(TRIANGLE_INSTANCE)
#: Texels of one node, either level: (lower, first), (upper, count), (skip, 0, 0, 0).
NODE_TEXELS = 3
#: An instance's world box is grown by this share of its size and of its distance from the origin:
#: it is made from the mesh's box in float64 and stored in float32, whose rounding could pull a face
#: inward by an ulp, and a ray grazing the object there would miss the box but not the triangle.
BOX_MARGIN = 1e-6


@dataclass(frozen=True)
class BvhLayout:
    """Where the parts of the two-level BVH sit in the node and triangle textures: `instances`
    records (at least one: a mirror that reflects nothing still traces a degenerate triangle), and
    the distinct meshes' hierarchies, a forest of `mesh_nodes` nodes whose root j is mesh j's, over
    their triangles (`mesh_triangles` a mesh), mesh after mesh."""

    instances: int
    mesh_nodes: int
    mesh_triangles: tuple[int, ...]

    @cached_property
    def top_nodes(self) -> int:
        return node_count(self.instances, 1)

    @property
    def records_start(self) -> int:
        """The texel where the instance records start."""
        return NODE_TEXELS * self.top_nodes

    @property
    def front_texels(self) -> int:
        """Texels of the top level and the records: what a move rewrites."""
        return self.records_start + INSTANCE_TEXELS * self.instances

    @property
    def mesh_base(self) -> int:
        """The node where the meshes' hierarchies start (after the front, on a node's first texel):
        mesh j's root is node mesh_base + j."""
        return math.ceil(self.front_texels / NODE_TEXELS)

    @cached_property
    def mesh_first_triangles(self) -> tuple[int, ...]:
        """Where each mesh's triangles start in the triangle texture."""
        return tuple(int(start) for start in np.cumsum((0, *self.mesh_triangles[:-1])))

    @property
    def node_texels(self) -> int:
        return NODE_TEXELS * (self.mesh_base + self.mesh_nodes)


def node_texels(bvh: Bvh, first_offset: int, node_offset: int) -> np.ndarray:
    """(nodes * NODE_TEXELS, 4) texels of `bvh`, its nodes numbered from `node_offset` (children
    and skip links moved with them) and its leaves' items from `first_offset`."""
    nodes = np.zeros((bvh.node_count, NODE_TEXELS, 4), np.float32)
    inner = bvh.count == 0
    nodes[:, 0, :3], nodes[:, 0, 3] = bvh.lower, bvh.first + np.where(inner, node_offset, first_offset)
    nodes[:, 1, :3], nodes[:, 1, 3] = bvh.upper, bvh.count
    nodes[:, 2, 0] = np.where(bvh.skip >= 0, bvh.skip + node_offset, -1)
    return nodes.reshape(-1, 4)


def instance_records(scene: Scene, reflected: list[ObjectGeometry], roots: list[int]) -> np.ndarray:
    """The records of `reflected`, whose meshes' bottom levels start at `roots`, without their
    transforms (what a move leaves as it is: `with_transforms` fills them in)."""
    records = np.zeros(len(reflected), TRIANGLE_INSTANCE_DTYPE)
    for slot, item in enumerate(reflected):
        records[slot]["ids"] = (scene.material_index(item.object.material), item.index, 0, 0)
    records["mesh"][:, 0] = roots
    return records


def with_transforms(records: np.ndarray, models: np.ndarray) -> np.ndarray:
    """`records` with the world-to-local transforms of their (n, 4, 4) `models`."""
    placed = records.copy()
    # std140 mat4 is column-major: the numpy row holds a column.
    placed["world_to_local"] = np.linalg.inv(models).transpose(0, 2, 1)
    return placed


def nothing_record(root: int) -> np.ndarray:
    """The one instance of a mirror that reflects nothing: its degenerate triangle (untransformed:
    with_transforms of the identity)."""
    records = np.zeros(1, TRIANGLE_INSTANCE_DTYPE)
    records["ids"] = (0, NO_OBJECT, 0, 0)
    records["mesh"] = (root, 0, 0, 0)
    return records


def world_boxes(models: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The world boxes of n instances: their (n, 4, 4) models applied to their meshes' (n, 3) local
    boxes (the eight corners' box), grown by BOX_MARGIN."""
    corners = np.stack([np.where(np.array([(i >> k) & 1 for k in range(3)], bool), upper, lower) for i in range(8)], axis=1)
    world = np.einsum("nij,ncj->nci", models[:, :3, :3], corners) + models[:, None, :3, 3]
    lows, highs = world.min(axis=1), world.max(axis=1)
    margin = BOX_MARGIN * (highs - lows + np.maximum(np.abs(lows), np.abs(highs))).max(axis=1, keepdims=True)
    return lows - margin, highs + margin


def front_texels(layout: BvhLayout, records: np.ndarray, models: np.ndarray, mesh_lower: np.ndarray,
                 mesh_upper: np.ndarray) -> np.ndarray:
    """The texture's front: the top level over the instances, one a leaf (its `first` the instance's
    slot), then their records. `models` and the meshes' root boxes are per instance."""
    lows, highs = world_boxes(models, mesh_lower, mesh_upper)
    top = build_box_bvh(lows, highs, 0.5 * (lows + highs), 1)
    leaves = top.count > 0
    top_first = np.where(leaves, top.order[np.minimum(top.first, len(top.order) - 1)], top.first)
    nodes = node_texels(Bvh(top.lower, top.upper, top_first, top.count, top.order, top.depth, top.skip), 0, 0)
    front = np.zeros((layout.front_texels, 4), np.float32)
    front[: len(nodes)] = nodes
    front[layout.records_start:] = to_texels(TRIANGLE_INSTANCE, records)
    return front
