"""Deforming glTF parts (skins, morph targets) on the GPU: at each time a compute pass
(shaders/deform.comp) writes a part's deformed vertices over its place in the mesh arena, from its
rest pose, influences and morph deltas uploaded once and its pose at that time (the joint
matrices and the morph weights: all a frame uploads). The maths is scene/gltf_deform.py's, the
numpy truth, function for function; a part it cannot make (gltf_deform.PartMotion.gpu_refusal)
is deformed on the CPU and uploaded as before (GpuMeshes.replace).

The world (world.py) still deforms each part on the CPU too, for what it reads of the mesh: its
bounds, the images' cameras, and the truth."""

from __future__ import annotations

import math
from dataclasses import dataclass

import moderngl
import numpy as np

from ..geometry import ObjectGeometry
from ..meshes import Mesh
from ..scene.gltf_deform import PartMotion
from ..scene.gltf_file import MIN_NORMAL_LENGTH
from .bindings import StorageBuffer, UniformBlock
from .meshes import VERTEX_ATTRIBUTES, GpuMeshes
from .shaders import ProgramCache
from .uniforms import write, write_matrix

DEFORM_PROGRAM = "deform.comp"
#: GL 4.3: compute shaders and storage buffers.
REQUIRED_GL_VERSION = 430
#: Vertices a work group (deform.comp's local_size_x).
DEFORM_GROUP = 64
#: Work groups an axis at most: GL 4.3's least GL_MAX_COMPUTE_WORK_GROUP_COUNT.
MAX_GROUPS = 65535
#: vec4 rows of the pose's uniform block: 16 KiB, GL's least GL_MAX_UNIFORM_BLOCK_SIZE (255 joints
#: and 16 morph weights, say); a larger pose goes in a storage buffer (POSE_IN_STORAGE).
DEFORM_POSE_BLOCK_ROWS = 1024


def deform_defines(pose_rows: int) -> dict[str, str]:
    """deform.comp's defines for a pose of `pose_rows` vec4 rows."""
    defines = {"DEFORM_GROUP": str(DEFORM_GROUP), "ARENA_FLOATS": str(sum(n for _, n in VERTEX_ATTRIBUTES)),
               "MIN_NORMAL_LENGTH": f"{MIN_NORMAL_LENGTH!r}", "DEFORM_POSE_BLOCK_ROWS": str(DEFORM_POSE_BLOCK_ROWS)}
    return {**defines, "POSE_IN_STORAGE": "1"} if pose_rows > DEFORM_POSE_BLOCK_ROWS else defines


def dispatch(program: moderngl.ComputeShader, items: int, group: int) -> None:
    """Run `program` over `items` invocations, `group` a work group, as lib/dispatch.glsl reads them."""
    groups = max(1, math.ceil(items / group))
    columns = min(groups, MAX_GROUPS)
    program.run(columns, math.ceil(groups / columns))


def gpu_supported(ctx: moderngl.Context) -> bool:
    return ctx.version_code >= REQUIRED_GL_VERSION


@dataclass(frozen=True, eq=False)
class PartBuffer:
    """One part's data as deform.comp reads it (its Part block), uploaded once."""

    buffer: moderngl.Buffer
    vertices: int
    influence_groups: int
    influence_base: int
    targets: int
    delta_base: int


def part_texels(motion: PartMotion) -> tuple[np.ndarray, int, int, int]:
    """(vec4 rows of deform.comp's Part block, influence groups, influence base, delta base): the
    part's vertices in local_mesh's order (every primitive's, one after another)."""
    items = motion.primitives
    count = sum(len(item.primitive.positions) for item in items)
    rest = np.zeros((count, 2, 4), np.float32)
    rest[:, 0, :3] = np.concatenate([item.primitive.positions for item in items])
    rest[:, 1, :3] = np.concatenate([item.primitive.normals for item in items if item.primitive.normals is not None])
    widths = [item.joints.shape[1] for item in items if item.joints is not None]
    groups = math.ceil(max(widths) / 4) if motion.skin is not None and widths else 0
    influences = np.zeros((count, 2, groups * 4), np.float32)  # joints (as floats: exact), then weights
    start = 0
    for item in items:
        n = len(item.primitive.positions)
        if groups and item.joints is not None and item.weights is not None:
            influences[start: start + n, 0, : item.joints.shape[1]] = item.joints
            influences[start: start + n, 1, : item.weights.shape[1]] = item.weights
        start += n
    targets = len(motion.default_weights) if motion.default_weights is not None else 0
    deltas = np.zeros((targets, count, 2, 4), np.float32)
    start = 0
    for item in items:
        n = len(item.primitive.positions)
        if item.position_deltas is not None:
            deltas[:, start: start + n, 0, :3] = item.position_deltas
        if item.normal_deltas is not None:
            deltas[:, start: start + n, 1, :3] = item.normal_deltas
        start += n
    rows = [rest.reshape(-1, 4), influences.reshape(-1, 4), deltas.reshape(-1, 4)]
    return np.concatenate(rows), groups, 2 * count, 2 * count + len(rows[1])


def part_rows(motion: PartMotion) -> int:
    """vec4 rows of the part's Part block (part_texels's), from its counts alone."""
    count = sum(len(item.primitive.positions) for item in motion.primitives)
    widths = [item.joints.shape[1] for item in motion.primitives if item.joints is not None]
    groups = math.ceil(max(widths) / 4) if motion.skin is not None and widths else 0
    targets = len(motion.default_weights) if motion.default_weights is not None else 0
    return 2 * count * (1 + groups + targets)


def pose_texels(motion: PartMotion, time: float) -> tuple[np.ndarray, int]:
    """(vec4 rows of deform.comp's Pose block at `time`, where the morph weights start)."""
    matrices = motion.joint_matrices(time)
    columns = (np.zeros((0, 4), np.float32) if matrices is None
               else np.asarray(matrices, np.float32).transpose(0, 2, 1).reshape(-1, 4))
    weights = motion.weights_at(time).astype(np.float32)
    padded = np.zeros((math.ceil(len(weights) / 4), 4), np.float32)
    padded.reshape(-1)[: len(weights)] = weights
    return np.concatenate([columns, padded]), len(columns)


class GpuDeform:
    """Owns deform.comp and each GPU-deformed part's buffer; `deform` runs it for one part."""

    def __init__(self, ctx: moderngl.Context, programs: ProgramCache) -> None:
        self.ctx = ctx
        self.programs = programs
        self.enabled = gpu_supported(ctx)  # tools and tests turn it off to measure the CPU path
        self._parts: dict[PartMotion, PartBuffer] = {}
        self._pose: moderngl.Buffer | None = None
        self.dispatches = 0  # parts deformed (tests and tools)
        self.uploaded = 0  # bytes of the last `deform`'s pose

    @staticmethod
    def deformable(item: ObjectGeometry) -> PartMotion | None:
        """`item`'s motion where deform.comp can make its mesh (None: the CPU makes it)."""
        motion = item.object.motion
        return motion if isinstance(motion, PartMotion) and motion.deforms and motion.gpu_refusal is None else None

    def follow(self, meshes: GpuMeshes, pairs: list[tuple[Mesh, ObjectGeometry]]) -> list[tuple[Mesh, Mesh]]:
        """Each (old mesh, object now) deformed on the GPU where it can be, over old's vertices
        (which `now.local_mesh` then names in the arena); returns the (old, new) pairs left for
        the CPU upload."""
        left = []
        for old, now in pairs:
            motion = self.deformable(now) if self.enabled else None
            if motion is None or not meshes.rekey(old, now.local_mesh):
                left.append((old, now.local_mesh))
                continue
            arena = meshes.arena(now.local_mesh)
            self.deform(motion, now.time, arena.vertices, arena.first_vertex[now.local_mesh])
        if len(left) < len(pairs):
            # The arena is read next as vertices (the draws) and as a storage buffer (the refit).
            self.ctx.memory_barrier()
        return left

    def part(self, motion: PartMotion) -> PartBuffer:
        if motion not in self._parts:
            rows, groups, influence_base, delta_base = part_texels(motion)
            targets = len(motion.default_weights) if motion.default_weights is not None else 0
            self._parts[motion] = PartBuffer(self.ctx.buffer(rows.tobytes()), influence_base // 2, groups,
                                             influence_base, targets, delta_base)
        return self._parts[motion]

    def deform(self, motion: PartMotion, time: float, vertices: moderngl.Buffer, first_vertex: int) -> None:
        """`motion`'s part at `time` written over the arena `vertices` from `first_vertex` on."""
        part = self.part(motion)
        pose, weight_base = pose_texels(motion, time)
        data = pose.tobytes() or bytes(16)
        # The block's whole size is bound (a uniform block must be as large as the shader's).
        size = max(len(data), 16 * DEFORM_POSE_BLOCK_ROWS)
        if self._pose is None or self._pose.size < size:
            if self._pose is not None:
                self._pose.release()
            self._pose = self.ctx.buffer(reserve=size)
        self._pose.write(data)
        self.uploaded = len(data)
        program = self.programs.compute(DEFORM_PROGRAM, deform_defines(len(pose)))
        vertices.bind_to_storage_buffer(StorageBuffer.ARENA)
        part.buffer.bind_to_storage_buffer(StorageBuffer.DEFORM_PART)
        if len(pose) > DEFORM_POSE_BLOCK_ROWS:
            self._pose.bind_to_storage_buffer(StorageBuffer.DEFORM_POSE)
        else:
            self._pose.bind_to_uniform_block(UniformBlock.DEFORM_POSE)
        for name, value in (("u_vertex_count", part.vertices), ("u_first_vertex", first_vertex),
                            ("u_influence_groups", part.influence_groups), ("u_influence_base", part.influence_base),
                            ("u_targets", part.targets), ("u_delta_base", part.delta_base),
                            ("u_weight_base", weight_base)):
            write(program, name, value)
        if motion.skin is None:
            placement = motion.placement(time)
            write_matrix(program, "u_placement", placement)
            # inv(L)^T in GL's column-major order: inv(L)'s rows.
            write(program, "u_placement_normals", np.ascontiguousarray(np.linalg.inv(placement[:3, :3]), np.float32).tobytes())
        dispatch(program, part.vertices, DEFORM_GROUP)
        self.dispatches += 1

    @property
    def bytes(self) -> int:
        return sum(part.buffer.size for part in self._parts.values()) + (self._pose.size if self._pose else 0)

    def release(self) -> None:
        for part in self._parts.values():
            part.buffer.release()
        self._parts.clear()
        if self._pose is not None:
            self._pose.release()
            self._pose = None
