"""GPU copies of the scene's meshes: one vertex and index buffer per mesh (objects of one shape
share theirs), one VAO per mesh and program."""

from __future__ import annotations

import moderngl
import numpy as np

from ..geometry import ObjectGeometry
from ..meshes import Mesh
from .uniforms import write_matrix


class GpuMeshes:
    """Owns the vertex/index buffers of the objects drawn (made on first draw) and the vertex
    arrays that bind them."""

    def __init__(self, ctx: moderngl.Context) -> None:
        self.ctx = ctx
        # Keyed by the mesh itself (identity: Mesh has eq=False), which also keeps it alive.
        self._buffers: dict[Mesh, tuple[moderngl.Buffer, moderngl.Buffer]] = {}
        self._vertex_arrays: dict[tuple[Mesh, int], moderngl.VertexArray] = {}

    def _buffers_of(self, item: ObjectGeometry) -> tuple[moderngl.Buffer, moderngl.Buffer]:
        mesh = item.local_mesh
        if mesh not in self._buffers:
            self._buffers[mesh] = (
                self.ctx.buffer(mesh.interleaved().tobytes()),
                self.ctx.buffer(np.ascontiguousarray(mesh.indices, dtype=np.uint32).tobytes()),
            )
        return self._buffers[mesh]

    def draw(self, program: moderngl.Program, item: ObjectGeometry, view_projection: np.ndarray) -> None:
        """Draw one object with `program` (which reads mesh.vert's attributes and uniforms)."""
        key = (item.local_mesh, program.glo)
        if key not in self._vertex_arrays:
            vertices, indices = self._buffers_of(item)
            # An attribute the shader does not read is compiled away; skip its bytes instead.
            attributes = (("in_position", 3), ("in_normal", 3), ("in_uv", 2))
            layout = [(f"{n}f", name) if name in program else (f"{4 * n}x", None) for name, n in attributes]
            fmt = " ".join(kind for kind, _ in layout)
            names = [name for _, name in layout if name is not None]
            self._vertex_arrays[key] = self.ctx.vertex_array(
                program, [(vertices, fmt, *names)], index_buffer=indices, index_element_size=4
            )
        write_matrix(program, "u_model", item.model_matrix)
        write_matrix(program, "u_normal_matrix", item.normal_matrix)
        write_matrix(program, "u_view_projection", view_projection)
        self._vertex_arrays[key].render(moderngl.TRIANGLES)

    def forget_vertex_arrays(self) -> None:
        """Release the vertex arrays (before the programs they were made for go: a new program
        may be given a released one's GL name, and must not find its vertex array)."""
        for vertex_array in self._vertex_arrays.values():
            vertex_array.release()
        self._vertex_arrays.clear()

    @staticmethod
    def bytes_for(meshes: list[Mesh]) -> int:
        """GPU memory of the buffers of `meshes` (each one once): interleaved float32 positions,
        normals and UVs, and uint32 indices."""
        return sum(len(mesh.positions) * 32 + len(mesh.indices) * 12 for mesh in {id(m): m for m in meshes}.values())

    def release(self) -> None:
        self.forget_vertex_arrays()
        for vertices, indices in self._buffers.values():
            vertices.release()
            indices.release()
        self._buffers.clear()
