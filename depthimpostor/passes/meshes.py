"""GPU copies of the scene's meshes: one vertex and index buffer per object, one VAO per program."""

from __future__ import annotations

import moderngl
import numpy as np

from ..geometry import ObjectGeometry
from .uniforms import write_matrix


class GpuMeshes:
    """Owns the vertex/index buffers of the objects drawn (made on first draw) and the vertex
    arrays that bind them."""

    def __init__(self, ctx: moderngl.Context) -> None:
        self.ctx = ctx
        self._buffers: dict[int, tuple[moderngl.Buffer, moderngl.Buffer]] = {}
        self._vertex_arrays: dict[tuple[int, int], moderngl.VertexArray] = {}

    def _buffers_of(self, item: ObjectGeometry) -> tuple[moderngl.Buffer, moderngl.Buffer]:
        if item.index not in self._buffers:
            mesh = item.local_mesh
            self._buffers[item.index] = (
                self.ctx.buffer(mesh.interleaved().tobytes()),
                self.ctx.buffer(np.ascontiguousarray(mesh.indices, dtype=np.uint32).tobytes()),
            )
        return self._buffers[item.index]

    def draw(self, program: moderngl.Program, item: ObjectGeometry, view_projection: np.ndarray) -> None:
        """Draw one object with `program` (which reads mesh.vert's attributes and uniforms)."""
        key = (item.index, program.glo)
        if key not in self._vertex_arrays:
            vertices, indices = self._buffers_of(item)
            # An attribute the shader does not read is compiled away; skip its bytes instead.
            layout = [("3f", name) if name in program else ("12x", None) for name in ("in_position", "in_normal")]
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

    def release(self) -> None:
        self.forget_vertex_arrays()
        for vertices, indices in self._buffers.values():
            vertices.release()
            indices.release()
        self._buffers.clear()
