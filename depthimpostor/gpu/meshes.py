"""GPU copies of the scene's meshes: every mesh of the world in one vertex and one index buffer
(objects of one shape and level share theirs), one VAO per program over them, and batches of
objects drawn in one call (gpu/batches.py)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import moderngl
import numpy as np

from ..constants import EXTRA_ATTRIBUTES
from ..geometry import ObjectGeometry
from ..meshes import Mesh
from .uniforms import write_matrix

#: Per-vertex attributes of mesh.vert, and how many floats each takes.
VERTEX_ATTRIBUTES = (("in_position", 3), ("in_normal", 3), ("in_uv", 2))
#: mesh.vert's inputs for glTF's other attributes (constants.EXTRA_ATTRIBUTES), which only the
#: programs of scenes that use them read (TEXCOORD_1, VERTEX_COLORS, NORMAL_MAP): they live in a
#: second buffer of the arena, of the scene's attributes (uniforms.mesh_attributes) alone.
EXTRA_VERTEX_ATTRIBUTES = {"uvs1": "in_uv1", "colors": "in_color", "tangents": "in_tangent"}


def attribute_format(program: moderngl.Program, attributes: Sequence[tuple[str, str]],
                     suffix: str = "") -> tuple[str, list[str]]:
    """moderngl's format string and attribute names for `attributes` ((name, "3f")) in a buffer:
    an attribute the shader does not read is compiled away, so its bytes are skipped instead."""
    layout = [(kind, name) if name in program else (f"{4 * int(kind[:-1])}x", None) for name, kind in attributes]
    return " ".join(kind for kind, _ in layout) + suffix, [name for _, name in layout if name is not None]


class MeshArena:
    """Meshes packed into one vertex and one index buffer; indices are stored with the mesh's
    first vertex added, so that a mesh is drawn as the range `ranges[mesh]` of the index buffer."""

    def __init__(self, ctx: moderngl.Context, meshes: Sequence[Mesh], attributes: tuple[str, ...] = ()) -> None:
        self.meshes = list({id(mesh): mesh for mesh in meshes}.values())
        self.attributes = attributes  # the glTF attributes of the extra buffer (None without any)
        self.ranges: dict[Mesh, tuple[int, int]] = {}  # (first index, index count)
        self.first_vertex: dict[Mesh, int] = {}  # where each mesh's vertices start
        vertex_start = index_start = 0
        indices = []
        for mesh in self.meshes:
            count = 3 * len(mesh.indices)
            self.ranges[mesh] = (index_start, count)
            self.first_vertex[mesh] = vertex_start
            indices.append(mesh.indices.astype(np.uint32).ravel() + np.uint32(vertex_start))
            vertex_start += len(mesh.positions)
            index_start += count
        self.vertices = ctx.buffer(np.concatenate([mesh.interleaved() for mesh in self.meshes]).tobytes())
        self.indices = ctx.buffer(np.concatenate(indices).tobytes())
        self.extras = (ctx.buffer(np.concatenate([extra_vertices(mesh, attributes) for mesh in self.meshes]).tobytes())
                       if attributes else None)

    def write_extras(self, mesh: Mesh) -> int:
        """`mesh`'s attributes written over its place in the extra buffer (a deformed mesh's);
        returns the bytes written."""
        if self.extras is None:
            return 0
        values = extra_vertices(mesh, self.attributes)
        self.extras.write(values.tobytes(), offset=self.first_vertex[mesh] * values.strides[0])
        return values.nbytes

    def release(self) -> None:
        self.vertices.release()
        self.indices.release()
        if self.extras is not None:
            self.extras.release()


def extra_vertices(mesh: Mesh, names: tuple[str, ...]) -> np.ndarray:
    """(N, floats) float32 rows of the mesh's attributes `names` (their defaults where it lacks one)."""
    return np.ascontiguousarray(np.hstack([mesh.attribute(name) for name in names]), dtype=np.float32)


def vertex_buffers(program: moderngl.Program, arena: MeshArena) -> list[tuple[Any, ...]]:
    """moderngl's vertex array content for `program` over `arena`'s vertices: the interleaved
    position, normal and UV, and the extra buffer of the glTF attributes the program reads."""
    fmt, names = attribute_format(program, [(name, f"{n}f") for name, n in VERTEX_ATTRIBUTES])
    content: list[tuple[Any, ...]] = [(arena.vertices, fmt, *names)]
    extras = [(EXTRA_VERTEX_ATTRIBUTES[name], f"{EXTRA_ATTRIBUTES[name]}f") for name in arena.attributes]
    if arena.extras is not None and any(name in program for name, _ in extras):
        fmt, names = attribute_format(program, extras)
        content.append((arena.extras, fmt, *names))
    return content


class GpuMeshes:
    """Owns the vertex/index buffers of the world's meshes (`load`) and of meshes drawn that are
    not in it (made on first draw), and the vertex arrays that bind them."""

    def __init__(self, ctx: moderngl.Context, attributes: tuple[str, ...] = ()) -> None:
        """`attributes`: the glTF vertex attributes the scene's programs read (uniforms.mesh_attributes),
        which every arena's extra buffer holds for every vertex."""
        self.ctx = ctx
        self.attributes = attributes
        self._arenas: list[MeshArena] = []
        self._arena_of: dict[Mesh, MeshArena] = {}  # keyed by identity (Mesh has eq=False)
        self._vertex_arrays: dict[tuple[MeshArena, int], moderngl.VertexArray] = {}

    def load(self, meshes: Sequence[Mesh]) -> None:
        """Put the meshes not yet on the GPU into one arena (the renderer loads the world's)."""
        fresh = [mesh for mesh in {id(m): m for m in meshes}.values() if mesh not in self._arena_of]
        if fresh:
            arena = MeshArena(self.ctx, fresh, self.attributes)
            self._arenas.append(arena)
            self._arena_of.update(dict.fromkeys(fresh, arena))

    def replace(self, pairs: Sequence[tuple[Mesh, Mesh]]) -> int:
        """Deformed meshes (scene/gltf_deform.py): each (old, new) of one topology takes old's place
        in its arena, its vertices written over old's (the index range stays); a new one of
        another topology gets an arena of its own. Returns the bytes uploaded."""
        uploaded, fresh = 0, []
        for old, new in pairs:
            if not self.rekey(old, new):
                fresh.append(new)
                continue
            arena = self._arena_of[new]
            vertices = new.interleaved()
            arena.vertices.write(vertices.tobytes(), offset=arena.first_vertex[new] * vertices.strides[0])
            uploaded += vertices.nbytes + arena.write_extras(new)
        self.load(fresh)
        return uploaded + self.bytes_for(fresh, self.attributes)

    def holds(self, mesh: Mesh) -> bool:
        return mesh in self._arena_of

    def rekey(self, old: Mesh, new: Mesh) -> bool:
        """`new` (a deformed `old`: the same vertex count and triangles) takes old's place in its
        arena without an upload (gpu/deform.py writes its vertices there); False where it cannot
        (old not loaded, or another topology), and nothing changed."""
        arena = self._arena_of.get(old)
        if arena is None or len(old.positions) != len(new.positions) or not np.array_equal(old.indices, new.indices):
            return False
        arena.ranges[new], arena.first_vertex[new] = arena.ranges.pop(old), arena.first_vertex.pop(old)
        arena.meshes[arena.meshes.index(old)] = new
        del self._arena_of[old]
        self._arena_of[new] = arena
        return True

    def arena(self, mesh: Mesh) -> MeshArena:
        """The arena holding `mesh` (one of its own when it was not loaded)."""
        if mesh not in self._arena_of:
            self.load([mesh])
        return self._arena_of[mesh]

    def vertex_array(self, program: moderngl.Program, arena: MeshArena) -> moderngl.VertexArray:
        key = (arena, program.glo)
        if key not in self._vertex_arrays:
            self._vertex_arrays[key] = self.ctx.vertex_array(
                program, vertex_buffers(program, arena), index_buffer=arena.indices, index_element_size=4)
        return self._vertex_arrays[key]

    def draw(self, program: moderngl.Program, item: ObjectGeometry, view_projection: np.ndarray) -> None:
        """Draw one object with `program` (which reads mesh.vert's attributes and uniforms)."""
        write_matrix(program, "u_model", item.model_matrix)
        write_matrix(program, "u_normal_matrix", item.normal_matrix)
        write_matrix(program, "u_view_projection", view_projection)
        self.render(program, item)

    def render(self, program: moderngl.Program, item: ObjectGeometry) -> None:
        """Draw one object's triangles with `program`, its uniforms written already."""
        arena = self.arena(item.local_mesh)
        first, count = arena.ranges[item.local_mesh]
        self.vertex_array(program, arena).render(moderngl.TRIANGLES, vertices=count, first=first)

    def forget_vertex_arrays(self) -> None:
        """Release the vertex arrays (before the programs they were made for go: a new program
        may be given a released one's GL name, and must not find its vertex array)."""
        for vertex_array in self._vertex_arrays.values():
            vertex_array.release()
        self._vertex_arrays.clear()

    @staticmethod
    def bytes_for(meshes: list[Mesh], attributes: tuple[str, ...] = ()) -> int:
        """GPU memory of the buffers of `meshes` (each one once): interleaved float32 positions,
        normals and UVs, uint32 indices, and the glTF `attributes` the scene's programs read
        (uniforms.mesh_attributes: every vertex carries them, a mesh without its defaults)."""
        vertex = 32 + 4 * sum(EXTRA_ATTRIBUTES[name] for name in attributes)
        return sum(len(mesh.positions) * vertex + len(mesh.indices) * 12 for mesh in {id(m): m for m in meshes}.values())

    def release(self) -> None:
        self.forget_vertex_arrays()
        for arena in self._arenas:
            arena.release()
        self._arenas.clear()
        self._arena_of.clear()
