"""Objects drawn in one call: the diffuse pass's static objects, whatever their meshes and materials.

The meshes are in one arena (gpu/meshes.py); each object's transform and material go in an
instance buffer (per-instance vertex attributes, mesh.vert's INSTANCED variant), the objects sorted
by mesh; and one indirect command per mesh draws its objects as instances of it
(glMultiDrawElementsIndirect: count, instance count, first index, base vertex, base instance).
Ten thousand boxes are one draw call instead of ten thousand, with the uniforms each one wrote.
Multi-draw indirect with a base instance is OpenGL 4.3: on an older context, `supported` is false
and the pass draws each object alone.
"""

from __future__ import annotations

from collections.abc import Sequence

import moderngl
import numpy as np

from ..geometry import ObjectGeometry
from ..scene.model import BoxShape, CylinderShape, Scene, SphereShape, TorusKnotShape, TorusShape, single_sided
from .meshes import GpuMeshes, MeshArena, attribute_format, vertex_buffers

#: One object's instance attributes, as mesh.vert's INSTANCED variant reads them: the model
#: matrix's three rows, the normal matrix's three columns, and the integers (material index in
#: the MaterialRecords table, object id, triangle offset, 0).
INSTANCE_ATTRIBUTES = (("in_model_0", "4f"), ("in_model_1", "4f"), ("in_model_2", "4f"),
                       ("in_normal_matrix_0", "3f"), ("in_normal_matrix_1", "3f"), ("in_normal_matrix_2", "3f"),
                       ("in_ids", "4i"))
INSTANCE_DTYPE = np.dtype([("model", "<f4", (3, 4)), ("normal_matrix", "<f4", (3, 3)), ("ids", "<i4", 4)])
COMMAND_DTYPE = np.dtype([("count", "<u4"), ("instances", "<u4"), ("first", "<u4"), ("base_vertex", "<i4"),
                          ("base_instance", "<u4")])


#: Shapes whose untextured meshes are closed and watertight (meshes.py): seen from outside, every
#: pixel a back face covers is covered by a nearer front face, so culling back faces changes no pixel.
CLOSED_SHAPES = (SphereShape, BoxShape, CylinderShape, TorusShape, TorusKnotShape)


def is_closed(item: ObjectGeometry) -> bool:
    """Is `item` a closed solid whose back faces can be culled? Not if its model matrix mirrors
    (the GPU draws its triangles wound the other way) nor with a texture (the round shapes'
    textured meshes have a seam whose two columns of vertices are rounded apart)."""
    return (isinstance(item.object.shape, CLOSED_SHAPES) and getattr(item.object.material, "texture", None) is None
            and item.determinant > 0.0)


def face_class(item: ObjectGeometry) -> int:
    """Which faces of `item` a pass drawing what is seen keeps: 0 both; 1 the outward ones alone
    (a closed solid, whose inward faces are hidden, or a single-sided material, glTF's doubleSided
    false, whose inward faces are not there); 2 the outward ones of a single-sided material under
    a mirroring model matrix, which winds them the other way on the screen."""
    if single_sided(item.object.material):
        return 2 if item.determinant < 0.0 else 1
    return int(is_closed(item))


def batches_supported(ctx: moderngl.Context) -> bool:
    """Can this context draw batches (multi-draw indirect with base instances: OpenGL 4.3)?"""
    return ctx.version_code >= 430


def batch_bytes(items: Sequence[ObjectGeometry]) -> int:
    """GPU memory of a batch of `items`: their instance records and one command per distinct mesh."""
    meshes = {id(item.local_mesh) for item in items}
    return len(items) * INSTANCE_DTYPE.itemsize + len(meshes) * COMMAND_DTYPE.itemsize


def instance_records(items: Sequence[ObjectGeometry], scene: Scene,
                     triangle_offsets: dict[int, int] | None = None) -> np.ndarray:
    """The instance attributes of `items`, in their order (each field of all of them at once: a
    record at a time took 7 ms of a thousand objects' first frame)."""
    records = np.zeros(len(items), INSTANCE_DTYPE)
    if not items:
        return records
    records["model"] = np.stack([item.model_matrix[:3] for item in items])
    # Columns, as mat3(c0, c1, c2) builds them (uniforms.write_matrix writes the same matrix).
    records["normal_matrix"] = np.stack([item.normal_matrix.T for item in items])
    records["ids"] = [(scene.material_index(item.object.material), item.index,
                       triangle_offsets[item.index] if triangle_offsets is not None else 0, 0) for item in items]
    return records


class ObjectBatch:
    """`items` (objects that do not move) drawn with one multi-draw call: owns its instance and
    command buffers and the vertex arrays that bind them with the meshes' arena."""

    def __init__(self, ctx: moderngl.Context, meshes: GpuMeshes, items: Sequence[ObjectGeometry], scene: Scene,
                 triangle_offsets: dict[int, int] | None = None) -> None:
        self.ctx = ctx
        self.items = list(items)
        arenas = {id(meshes.arena(item.local_mesh)) for item in self.items}
        if len(arenas) != 1:
            meshes.load([item.local_mesh for item in self.items])  # one arena for all, if not loaded so
        self.arena: MeshArena = meshes.arena(self.items[0].local_mesh)
        if any(item.local_mesh not in self.arena.ranges for item in self.items):
            raise ValueError("a batch's meshes must be loaded together (GpuMeshes.load)")
        # Objects grouped by mesh, each group in object order, groups in order of first appearance;
        # those whose inward faces are culled last (face_class: from `first_closed` on, and those
        # of a mirroring model matrix from `first_mirrored` on). Depth ties go to what is drawn
        # first: the open surfaces (floors, on which solids stand) are drawn first, as they are in
        # a scene's usual order.
        groups: dict[tuple[int, int], list[ObjectGeometry]] = {}
        for item in sorted(self.items, key=face_class):
            groups.setdefault((face_class(item), id(item.local_mesh)), []).append(item)
        self.first_closed = sum(kept == 0 for kept, _ in groups)
        self.first_mirrored = sum(kept < 2 for kept, _ in groups)
        ordered = [item for group in groups.values() for item in group]
        commands = np.zeros(len(groups), COMMAND_DTYPE)
        start = 0
        for command, group in zip(commands, groups.values(), strict=True):
            first, count = self.arena.ranges[group[0].local_mesh]
            command["count"], command["instances"], command["first"] = count, len(group), first
            command["base_instance"] = start
            start += len(group)
        self.draw_count = len(commands)
        self.instances = ctx.buffer(instance_records(ordered, scene, triangle_offsets).tobytes())
        self.commands = ctx.buffer(commands.tobytes())
        self._vertex_arrays: dict[int, moderngl.VertexArray] = {}

    def draw(self, program: moderngl.Program, first: int = 0, count: int | None = None) -> int:
        """Draw the batch's commands `first` to `first + count` (all by default) with `program`
        (mesh.vert's INSTANCED variant); returns the draw calls."""
        count = self.draw_count - first if count is None else count
        if count == 0:
            return 0
        if program.glo not in self._vertex_arrays:
            instance_format, instance_names = attribute_format(program, INSTANCE_ATTRIBUTES, "/i")
            self._vertex_arrays[program.glo] = self.ctx.vertex_array(
                program, [*vertex_buffers(program, self.arena), (self.instances, instance_format, *instance_names)],
                index_buffer=self.arena.indices, index_element_size=4)
        self._vertex_arrays[program.glo].render_indirect(self.commands, moderngl.TRIANGLES, count=count, first=first)
        return 1

    def forget_vertex_arrays(self) -> None:
        for vertex_array in self._vertex_arrays.values():
            vertex_array.release()
        self._vertex_arrays.clear()

    def release(self) -> None:
        self.forget_vertex_arrays()
        self.instances.release()
        self.commands.release()
