"""The triangle methods' bottom-level BVH refitted on the GPU for deformed meshes: the GPU twin of
bvh.refit_triangle_forest and of the triangle texels TrianglePass._refit uploads (methods/triangles.py).

The deformed vertices are in the mesh arena already (gpu/deform.py wrote them, or the CPU
uploaded them: GpuMeshes.replace). Compute passes (shaders/bvh_refit.comp) then
1. write each deformed triangle's corners and normals over its texels in the triangle texture;
2. make each leaf's box around its triangles (read back from that texture: what the shader
   intersects), then the inner nodes' from their children's, one dispatch per level, the deepest
   first: the tree's topology, its triangles' order and its skip links stay (as the CPU refit's);
3. copy each refitted root's box into a small buffer, read back for the top level, which the CPU
   builds over the instances' world boxes as it does when objects move (instances.front_texels).
The node and triangle textures are written in place as images; nothing but the roots comes back.
"""

from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

from ..gpu.bindings import ImageUnit, StorageBuffer
from ..gpu.deform import GpuDeform, dispatch
from ..gpu.meshes import VERTEX_ATTRIBUTES, GpuMeshes
from ..gpu.shaders import ProgramCache
from ..gpu.uniforms import write
from ..meshes import Mesh
from .bvh import Bvh
from .instances import NODE_TEXELS

REFIT_PROGRAM = "bvh_refit.comp"
#: Items (triangles or nodes) a work group.
REFIT_GROUP = 64
#: GL_RGBA32F: the node and triangle textures' format, as images.
_RGBA32F = 0x8814


def refit_defines() -> dict[str, str]:
    return {"REFIT_GROUP": str(REFIT_GROUP), "NODE_TEXELS": str(NODE_TEXELS),
            "ARENA_FLOATS": str(sum(n for _, n in VERTEX_ATTRIBUTES))}


def node_levels(bvh: Bvh) -> tuple[np.ndarray, np.ndarray]:
    """(root: the tree each node is in, by its root's node index; depth below that root) of every
    node of a forest (build_triangle_forest's: the root of tree j is node j)."""
    root, depth = np.full(bvh.node_count, -1, np.int64), np.zeros(bvh.node_count, np.int64)
    inner = bvh.count == 0
    is_child = np.zeros(bvh.node_count, bool)
    is_child[bvh.first[inner]] = is_child[bvh.first[inner] + 1] = True
    level = np.flatnonzero(~is_child)
    root[level] = level
    below = 0
    while len(level):
        depth[level] = below
        parents = level[bvh.count[level] == 0]
        children = np.concatenate([bvh.first[parents], bvh.first[parents] + 1])
        root[children] = np.concatenate([root[parents], root[parents]])
        level, below = children, below + 1
    return root, depth


@dataclass(frozen=True, eq=False)
class RefitItems:
    """What the passes go over for one set of deformed trees: every item an ivec4, in one buffer."""

    buffer: moderngl.Buffer
    triangles: dict[int, tuple[int, int]]  # per tree: (first item, count) of its triangles
    levels: tuple[tuple[int, int], ...]  # (first item, count) of each node dispatch: leaves, then deepest first


def refit_items(bvh: Bvh, trees: list[int], meshes: list[Mesh], first_triangles: tuple[int, ...]
                ) -> tuple[np.ndarray, dict[int, tuple[int, int]], tuple[tuple[int, int], ...]]:
    """(ivec4 items, RefitItems.triangles, RefitItems.levels) for refitting `trees` (their distinct
    meshes' indices), `meshes` the distinct meshes in order. A triangle item: its corners (vertex
    indices in its mesh) and its slot in the triangle texture; a node item: the node, and its
    tree where it is a root (-1 otherwise)."""
    where: dict[int, tuple[int, int]] = {}
    rows: list[np.ndarray] = []
    for tree in trees:
        first, count = first_triangles[tree], len(meshes[tree].indices)
        local = bvh.order[first: first + count] - first  # the mesh's triangles in leaf order
        items = np.zeros((count, 4), np.int32)
        items[:, :3] = meshes[tree].indices[local]
        items[:, 3] = np.arange(first, first + count)
        where[tree] = (sum(len(row) for row in rows), count)
        rows.append(items)
    root, depth = node_levels(bvh)
    chosen = np.isin(root, trees)
    leaves = np.flatnonzero(chosen & (bvh.count > 0))
    dispatches = [leaves] + [np.flatnonzero(chosen & (bvh.count == 0) & (depth == d))
                             for d in range(int(depth[chosen].max(initial=0)), -1, -1)]
    levels = []
    for nodes in (n for n in dispatches if len(n)):
        items = np.zeros((len(nodes), 4), np.int32)
        items[:, 0] = nodes
        items[:, 1] = np.where(root[nodes] == nodes, nodes, -1)
        levels.append((sum(len(row) for row in rows), len(nodes)))
        rows.append(items)
    return np.concatenate(rows), where, tuple(levels)


class GpuRefit:
    """A TrianglePass's refit on the GPU: its items per set of deformed trees (made once each), the
    roots' buffer, and the three passes (`refit`)."""

    def __init__(self, ctx: moderngl.Context, programs: ProgramCache, meshes: GpuMeshes, deform: GpuDeform) -> None:
        self.ctx, self.programs, self.meshes, self.deform = ctx, programs, meshes, deform
        self._items: dict[tuple[int, ...], RefitItems] = {}
        self._roots: moderngl.Buffer | None = None
        self.refits = 0

    def usable(self, meshes: list[Mesh]) -> bool:
        """Can the GPU refit the trees of these deformed meshes? GL 4.3 (and not turned off), each
        in the arena (its vertices there), none with tangents (regenerated on the CPU at each time,
        which the triangle texture also holds)."""
        return self.deform.enabled and all(mesh.tangents is None and self.meshes.holds(mesh) for mesh in meshes)

    def items(self, bvh: Bvh, trees: list[int], meshes: list[Mesh], first_triangles: tuple[int, ...]) -> RefitItems:
        key = tuple(trees)
        if key not in self._items:
            rows, triangles, levels = refit_items(bvh, trees, meshes, first_triangles)
            self._items[key] = RefitItems(self.ctx.buffer(rows.tobytes()), triangles, levels)
        return self._items[key]

    def refit(self, bvh: Bvh, trees: list[int], meshes: list[Mesh], first_triangles: tuple[int, ...],
              nodes: moderngl.Texture, triangles: moderngl.Texture, stride: int, mesh_base: int) -> np.ndarray:
        """Refit `trees` (distinct mesh indices, whose meshes `meshes` now are) in the `nodes` and
        `triangles` textures (`stride` texels a triangle; the forest's node 0 at node `mesh_base`).
        Returns the (len(trees), 2, 3) lower and upper corners of their roots."""
        items = self.items(bvh, trees, meshes, first_triangles)
        items.buffer.bind_to_storage_buffer(StorageBuffer.REFIT_ITEMS)
        nodes.bind_to_image(ImageUnit.BVH_NODES, read=True, write=True, format=_RGBA32F)
        triangles.bind_to_image(ImageUnit.BVH_TRIANGLES, read=True, write=True, format=_RGBA32F)
        size = 32 * (max(trees) + 1)
        if self._roots is None or self._roots.size < size:
            if self._roots is not None:
                self._roots.release()
            self._roots = self.ctx.buffer(reserve=max(size, 256))
        self._roots.bind_to_storage_buffer(StorageBuffer.REFIT_ROOTS)
        program = self.programs.compute(REFIT_PROGRAM, refit_defines())
        write(program, "u_stride", stride)
        write(program, "u_mesh_base", mesh_base)
        write(program, "u_pass", 0)
        for tree in trees:  # 1. the triangles, from each mesh's place in its arena
            arena = self.meshes.arena(meshes[tree])
            arena.vertices.bind_to_storage_buffer(StorageBuffer.ARENA)
            first, count = items.triangles[tree]
            write(program, "u_first_vertex", arena.first_vertex[meshes[tree]])
            write(program, "u_first_item", first)
            write(program, "u_items", count)
            dispatch(program, count, REFIT_GROUP)
        for level, (first, count) in enumerate(items.levels):  # 2. the leaves, then each level's parents
            # Image stores are not coherent with later loads: each pass reads what the last wrote.
            self.ctx.memory_barrier()
            write(program, "u_pass", 1 if level == 0 else 2)
            write(program, "u_first_item", first)
            write(program, "u_items", count)
            dispatch(program, count, REFIT_GROUP)
        self.ctx.memory_barrier()
        self.refits += 1
        roots = np.frombuffer(self._roots.read(size), np.float32).reshape(-1, 2, 4)
        return roots[trees, :, :3]

    def release(self) -> None:
        for items in self._items.values():
            items.buffer.release()
        self._items.clear()
        if self._roots is not None:
            self._roots.release()
            self._roots = None

