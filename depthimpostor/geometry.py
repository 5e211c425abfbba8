"""Scene objects as triangle meshes, in world space, with the bounds the passes need."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from . import meshes, textured_meshes
from .meshes import Mesh
from .scene.model import (
    BoxShape,
    CylinderShape,
    GltfShape,
    MeshShape,
    PlaneShape,
    SceneObject,
    Shape,
    SphereShape,
    TorusKnotShape,
    TorusShape,
)


def mesh_for_shape(shape: Shape, textured: bool = False, level: int = 0) -> Mesh:
    """The local-space mesh of a shape (procedural, or loaded through trimesh); `textured` (an
    object with an image texture) gives the round shapes a seam for their UVs (textured_meshes.py).
    `level` (lod.py) halves a round shape's tessellation that many times (a sphere's, cylinder's
    and torus's level k vertices are then a subset of level 0's)."""
    if textured and isinstance(shape, SphereShape):
        return textured_meshes.sphere(shape.radius, *tessellation(shape, level))
    if textured and isinstance(shape, CylinderShape):
        return textured_meshes.cylinder(shape.radius, shape.height, *tessellation(shape, level))
    if textured and isinstance(shape, TorusShape):
        return textured_meshes.torus(shape.major, shape.minor, *tessellation(shape, level))
    if isinstance(shape, PlaneShape):
        return meshes.plane(*shape.size)
    if isinstance(shape, BoxShape):
        return meshes.box(shape.size)
    if isinstance(shape, SphereShape):
        return meshes.sphere(shape.radius, *tessellation(shape, level))
    if isinstance(shape, CylinderShape):
        return meshes.cylinder(shape.radius, shape.height, *tessellation(shape, level))
    if isinstance(shape, TorusShape):
        return meshes.torus(shape.major, shape.minor, *tessellation(shape, level))
    if isinstance(shape, TorusKnotShape):
        return meshes.torus_knot(shape.p, shape.q, shape.radius, shape.tube, *tessellation(shape, level))
    if isinstance(shape, MeshShape):
        return meshes.load_mesh_file(shape.path)
    if isinstance(shape, GltfShape):
        return shape.mesh  # read with the scene (scene/gltf.py), in the glTF file's world space
    raise TypeError(f"no mesh for shape {shape!r}")


#: The full tessellation of each round shape (meshes.py's defaults: the mirror sphere's 96 x 48 is
#: what its interpolated normals were tuned for), and the fewest of each count a level may leave.
FULL_TESSELLATION: dict[type, tuple[int, ...]] = {
    SphereShape: (96, 48), CylinderShape: (64,), TorusShape: (96, 32), TorusKnotShape: (256, 24)}
FEWEST: dict[type, tuple[int, ...]] = {
    SphereShape: (6, 3), CylinderShape: (8,), TorusShape: (12, 4), TorusKnotShape: (32, 6)}


def tessellation(shape: Shape, level: int) -> tuple[int, ...]:
    """The counts (segments, rings / sides) of `shape` at `level`: the full ones halved `level`
    times, no count below FEWEST (a shape without levels has no counts)."""
    full = FULL_TESSELLATION.get(type(shape), ())
    return tuple(max(count >> level, fewest) for count, fewest in zip(full, FEWEST[type(shape)], strict=True)) \
        if full else ()


def has_levels(shape: Shape) -> bool:
    """Is `shape` tessellated (a round primitive), and so has coarser levels than its full one?"""
    return type(shape) in FULL_TESSELLATION


def max_level(shape: Shape) -> int:
    """The coarsest level of `shape` (0 for shapes without levels: planes, boxes, models)."""
    full = FULL_TESSELLATION.get(type(shape))
    if full is None:
        return 0
    level = 0
    while tessellation(shape, level + 1) != tessellation(shape, level):
        level += 1
    return level


@dataclass(frozen=True, eq=False)
class ObjectGeometry:
    """One scene object's mesh, transform and world-space bounds, at a time of its animation."""

    index: int  # position in scene.objects: the object id the shaders report
    object: SceneObject
    local_mesh: Mesh
    time: float = 0.0  # seconds into the scene's animation

    @cached_property
    def model_matrix(self) -> np.ndarray:
        return self.object.model_matrix(self.time)

    def at(self, time: float) -> ObjectGeometry:
        """The object at `time`: itself when it does not move (its GPU buffers and bounds are
        kept either way: the mesh is the same, only its transform changes)."""
        if not self.object.moves or time == self.time:
            return self
        return ObjectGeometry(self.index, self.object, self.local_mesh, time)

    @cached_property
    def normal_matrix(self) -> np.ndarray:
        return np.linalg.inv(self.model_matrix[:3, :3]).T

    @cached_property
    def world_mesh(self) -> Mesh:
        return self.local_mesh.transformed(self.model_matrix)

    @cached_property
    def bounding_sphere(self) -> tuple[np.ndarray, float]:
        return self.world_mesh.bounding_sphere()

    @property
    def is_analytic_plane(self) -> bool:
        """Planes that are not mirrors (floors, walls) are intersected exactly, not through impostors."""
        return self.object.is_analytic_plane


def triangle_offsets(objects: list[ObjectGeometry]) -> dict[int, int]:
    """Where each object's triangles start (by object index) in the list of all their triangles,
    in this order: the list the ray-traced method's BVH is built from (methods/triangles.py), whose
    places the hybrid method's depth images record."""
    offsets, start = {}, 0
    for item in objects:
        offsets[item.index] = start
        start += len(item.local_mesh.indices)
    return offsets


def scene_geometry(objects: tuple[SceneObject, ...], levels: dict[int, int] | None = None) -> list[ObjectGeometry]:
    """Every object's geometry, at its level of detail in `levels` (by object index; 0, the full
    tessellation, for objects not in it: lod.py chooses them); objects of one shape and level share
    one local mesh (meshes are read-only), so that a thousand equal spheres cost one sphere's
    arrays, GPU buffer and bounding sphere, and can be drawn instanced (gpu/batches.py)."""
    local: dict[tuple[Shape, bool, int], Mesh] = {}
    geometry = []
    for index, obj in enumerate(objects):
        level = levels.get(index, 0) if levels else 0
        key = (obj.shape, getattr(obj.material, "texture", None) is not None, level)
        if key not in local:
            local[key] = mesh_for_shape(*key)
        geometry.append(ObjectGeometry(index, obj, local[key]))
    return geometry
