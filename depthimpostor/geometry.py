"""Scene objects as triangle meshes, in world space, with the bounds the passes need."""

from __future__ import annotations

import copy
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np

from . import meshes, textured_meshes
from .meshes import Mesh, ritter_centres
from .scene.gltf import gltf_trimesh
from .scene.gltf_file import GLTF_SUFFIXES
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
    placement_matrices,
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
    if isinstance(shape, MeshShape):  # a glTF file read as a `gltf` shape is, then joined
        return meshes.load_mesh_file(shape.path, gltf_trimesh if shape.path.suffix.lower() in GLTF_SUFFIXES else None)
    if isinstance(shape, GltfShape):
        return shape.mesh  # read with the scene (scene/gltf.py), in the glTF file's world space
    raise TypeError(f"no mesh for shape {shape!r}")


@lru_cache(maxsize=256)
def _procedural_mesh(shape: Shape, textured: bool, level: int) -> Mesh:
    return mesh_for_shape(shape, textured, level)


def world_mesh(shape: Shape, textured: bool = False, level: int = 0) -> Mesh:
    """mesh_for_shape's mesh, for one world (scene_geometry). A procedural shape is tessellated and
    bounded once per (shape, seam, level): each world gets its own Mesh object (renderers key GPU
    buffers by it, and a rebuilt renderer loads a new world's meshes together) holding the same
    read-only arrays and bounding sphere. Each renderer, and each world of an edited scene,
    tessellated its shapes again (a torus knot 15 ms). Model files keep their own cache, which
    sees an edit on disk (meshes.load_mesh_file)."""
    if isinstance(shape, (MeshShape, GltfShape)):
        return mesh_for_shape(shape, textured, level)
    made = _procedural_mesh(shape, textured, level)
    made.bounding_sphere()  # computed once, kept in the copies
    return copy.copy(made)


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
        """The object at `time`: itself when it does not move. Its GPU buffers and bounds are
        kept where only its transform changes; a glTF part that deforms (a skin, morph targets)
        has another mesh at each time (scene/gltf_deform.py), which the passes upload again."""
        if not self.object.moves or time == self.time:
            return self
        motion = self.object.motion
        mesh = motion.mesh_at(time) if motion is not None and motion.deforms else self.local_mesh
        return ObjectGeometry(self.index, self.object, mesh, time)

    def drawn_with(self, mesh: Mesh) -> ObjectGeometry:
        """The same object at the same time drawn with another local mesh (a coarser level of its
        shape: lod.BakeDetail, World.eye_drawn), its transform's cached properties shared."""
        other = ObjectGeometry(self.index, self.object, mesh, self.time)
        other.__dict__.update({name: self.__dict__[name] for name in ("model_matrix", "normal_matrix", "determinant")
                               if name in self.__dict__})  # the cached properties' slots
        return other

    @cached_property
    def normal_matrix(self) -> np.ndarray:
        return np.linalg.inv(self.model_matrix[:3, :3]).T

    @cached_property
    def determinant(self) -> float:
        """Of the model matrix's linear part: negative where it mirrors (the GPU winds its
        triangles the other way). Asked by each pass and image that draws the object: a cube
        map's twelve faces ask it of every object."""
        return float(np.linalg.det(self.model_matrix[:3, :3]))

    @cached_property
    def world_mesh(self) -> Mesh:
        return self.local_mesh.transformed(self.model_matrix)

    @cached_property
    def bounding_sphere(self) -> tuple[np.ndarray, float]:
        return self.world_mesh.bounding_sphere()


#: Objects sharing a local mesh that bounding_spheres and world_vertex_groups place together, and
#: the points placed at once (float64: 6 MB, which keeps each pass over them in cache; 48 MB ran
#: several times slower).
BATCHED_SPHERES = 16
BATCH_POINTS = 2**18


def _batches(items: Sequence[ObjectGeometry]) -> Iterator[list[ObjectGeometry]]:
    """`items` in lists of one local mesh: where at least BATCHED_SPHERES share a placeable mesh,
    up to BATCH_POINTS vertices' worth at once (placed together: _placed); otherwise one
    item a list (each alone: its world_mesh property says what is wrong, if anything)."""
    groups: dict[int, list[ObjectGeometry]] = {}
    for item in items:
        groups.setdefault(id(item.local_mesh), []).append(item)
    for group in groups.values():
        if len(group) < BATCHED_SPHERES or len(group[0].local_mesh.positions) == 0 or not _placeable(group):
            yield from ([item] for item in group)
            continue
        chunk = max(1, BATCH_POINTS // len(group[0].local_mesh.positions))
        yield from (group[first:first + chunk] for first in range(0, len(group), chunk))


def model_matrices(items: Sequence[ObjectGeometry]) -> None:
    """Work out the model_matrix of each item whose object does not move, where not yet, all at
    once (scene.model.placement_matrices, a still object's model matrix: the same to the bit). A moving object's is its
    animation's at the item's time, worked out when asked."""
    still = [item for item in items if "model_matrix" not in item.__dict__ and not item.object.moves]
    if len(still) < 2:
        return
    for item, model in zip(still, placement_matrices([item.object for item in still]), strict=True):
        item.__dict__["model_matrix"] = model.copy()  # the cached property's slot (an array of its own, as asked alone)


def linear_transforms(items: Sequence[ObjectGeometry]) -> None:
    """Work out each item's normal_matrix and determinant where not yet, all at once: numpy's stacked
    inverse and determinant make each matrix's LAPACK calls as one matrix's do, so the same to the
    bit (a thousand objects' one by one took 0.1 s of their first frame). Where a matrix is singular
    none is stored: the properties raise for it when asked, as they did. The model matrices first,
    where not yet (model_matrices)."""
    model_matrices(items)
    missing = [item for item in items if "normal_matrix" not in item.__dict__ or "determinant" not in item.__dict__]
    if len(missing) < 2:
        return
    linear = np.stack([item.model_matrix[:3, :3] for item in missing])
    try:
        inverses = np.linalg.inv(linear)
    except np.linalg.LinAlgError:
        return
    determinants = np.linalg.det(linear).tolist()
    for item, inverse, determinant in zip(missing, inverses, determinants, strict=True):
        item.__dict__.setdefault("normal_matrix", inverse.T)  # the cached properties' slots
        item.__dict__.setdefault("determinant", determinant)


def bounding_spheres(items: Sequence[ObjectGeometry]) -> list[tuple[np.ndarray, float]]:
    """Each item's bounding_sphere. Where many share a local mesh (ten thousand equal spheres, a
    glTF scene's repeated parts) they are worked out together, by the same steps as the property
    (the world mesh's float32 vertices, Mesh.bounding_sphere's two candidates), without making
    each world mesh (results/llvmpipe/many_objects.md: a scene of 10,000 small spheres)."""
    for part in _batches([item for item in items if "bounding_sphere" not in item.__dict__]):
        if len(part) > 1:
            for item, sphere in zip(part, _placed(part, spheres=True)[1], strict=True):
                item.__dict__["bounding_sphere"] = sphere  # the cached property's slot
    return [item.bounding_sphere for item in items]


def world_vertex_groups(items: Sequence[ObjectGeometry], spheres: bool = False
                        ) -> Iterator[tuple[list[ObjectGeometry], np.ndarray]]:
    """Each item's world_mesh.positions, to the bit, a few items of one local mesh at a time:
    (items, their (n, V, 3) float32 vertices). Objects of a mesh many share are placed together,
    without making their world meshes (normals and all: a thousand small spheres' took a second);
    the others, and those whose world mesh is made already, come one by one from it. With
    `spheres`, the bounding spheres of those placed together are found from the same vertices
    where not found yet (as bounding_spheres finds them: placing them twice cost 0.1 s at a
    thousand objects)."""
    made = [item for item in items if "world_mesh" in item.__dict__]
    for part in _batches([item for item in items if "world_mesh" not in item.__dict__]):
        if len(part) > 1:
            measured = spheres and any("bounding_sphere" not in item.__dict__ for item in part)
            vertices, found = _placed(part, measured)
            for item, sphere in zip(part, found, strict=measured):  # (none found unless measured)
                item.__dict__.setdefault("bounding_sphere", sphere)  # the cached property's slot
            yield part, vertices
        else:
            made += part
    for item in made:
        yield [item], item.world_mesh.positions[None]


def _placeable(items: Sequence[ObjectGeometry]) -> bool:
    """Would Mesh.transformed take every item's model matrix (finite, affine, not singular)?"""
    models = np.stack([item.model_matrix for item in items]).astype(np.float64)
    if not np.isfinite(models).all() or not np.allclose(models[:, 3], (0.0, 0.0, 0.0, 1.0)):
        return False
    linear = models[:, :3, :3]
    scale = np.linalg.norm(linear, axis=(1, 2))
    return bool(np.all(np.abs(np.linalg.det(linear)) > 1e-12 * scale**3))


#: The vertices _placed works through at once: its float64 arrays (a few hundred kB) stay in cache
#: and are reused from one batch of items to the next (arrays of a whole part's, made anew for
#: each, spent most of their time faulting fresh pages in).
PLACE_CHUNK_POINTS = 2**15


def _placed(items: Sequence[ObjectGeometry], spheres: bool) -> tuple[np.ndarray, list[tuple[np.ndarray, float]]]:
    """The world-space vertices of items of one local mesh ((n, V, 3) float32), as Mesh.transformed
    places them (numpy's stacked matmul makes each item's BLAS call as its `@` does) and Mesh
    stores them, and with `spheres` a bounding sphere of each (none without): as
    Mesh.bounding_sphere's, the smaller of two candidate centres with the radius measured from the
    world mesh's float32 vertices (so it holds every one of them exactly), but the first candidate
    is the local mesh's Ritter centre placed by the item's transform rather than Ritter's walk over
    each world mesh (64 passes over every vertex of a thousand objects took 14 s; an affine map of
    the local sphere's centre is as central, exactly so under turns and uniform scales)."""
    models = np.stack([item.model_matrix for item in items])
    local = items[0].local_mesh.positions.astype(np.float64)
    count, size = len(items), len(local)
    turns, moves = models[:, :3, :3].transpose(0, 2, 1), models[:, None, :3, 3]
    step = max(1, PLACE_CHUNK_POINTS // max(size, 1))
    vertices = np.empty((count, size, 3), np.float32)
    placed = np.empty((min(step, count), size, 3))
    # Each coordinate apart, (items, vertices) contiguous: reductions over the vertices of
    # (items, vertices, 3) arrays ran several times slower, and the arithmetic is the same.
    columns = np.empty((5, min(step, count), size))  # x, y, z and _farthest's two arrays
    # The first candidates: the local Ritter centre placed (unused, and not found, without spheres).
    ritter = models[:, :3, :3] @ _ritter_centre(items[0].local_mesh) + models[:, :3, 3] if spheres else models[:, :3, 3]
    box, radii = np.empty((count, 3)), np.empty((2, count))
    for first in range(0, count, step):
        rows = slice(first, min(first + step, count))
        n = rows.stop - first
        chunk = np.matmul(local, turns[rows], out=placed[:n])
        for axis in range(3):  # a coordinate at a time: adding rows of three ran four times slower
            chunk[..., axis] += moves[rows, :, axis]
        vertices[rows] = chunk
        if not spheres:
            continue
        for axis in range(3):
            columns[axis, :n] = vertices[rows, :, axis]
        for axis in range(3):
            box[rows, axis] = 0.5 * (columns[axis, :n].min(axis=1) + columns[axis, :n].max(axis=1))
        for candidate, centres in enumerate((ritter, box)):
            radii[candidate, rows] = _farthest(columns[:3, :n], centres[rows], columns[3:, :n])
    if not spheres:
        return vertices, []
    ritter_wins = radii[0] <= radii[1]  # np.argmin's choice: the first of equals
    return vertices, [(ritter[i].copy(), float(radii[0][i])) if ritter_wins[i] else (box[i].copy(), float(radii[1][i]))
                      for i in range(count)]


def _ritter_centre(mesh: Mesh) -> np.ndarray:
    """The centre of Ritter's sphere around a local mesh's vertices, found once a mesh (its arrays
    are read-only; each batch of its objects asked again, 64 passes over its vertices each time)."""
    cached: np.ndarray | None = mesh.__dict__.get("_ritter_centre")
    if cached is None:
        cached = ritter_centres(mesh.positions.astype(np.float64)[None])[0]
        object.__setattr__(mesh, "_ritter_centre", cached)  # the mesh is frozen; a cache, as its _bounding_sphere
    return cached


def _farthest(columns: np.ndarray, centres: np.ndarray, work: np.ndarray) -> np.ndarray:
    """np.linalg.norm(points - centres[:, None], axis=2).max(axis=1) of the points whose x, y and
    z are `columns` ((3, items, vertices)), to the bit: the squares summed in norm's order, and
    one square root an item instead of one a point (the largest root is the root of the largest
    square: the rounded square root is monotonic), in `work`'s two (items, vertices) arrays."""
    total, square = work
    np.square(np.subtract(columns[0], centres[:, 0, None], out=total), out=total)
    for axis in (1, 2):
        total += np.square(np.subtract(columns[axis], centres[:, axis, None], out=square), out=square)
    return np.sqrt(total.max(axis=1))


def triangle_offsets(objects: list[ObjectGeometry]) -> dict[int, int]:
    """Where each object's triangles start (by object index) in the list of all their triangles,
    in this order: the hybrid method's depth images name a triangle by its place in this list, and
    its BVH's place texture maps that place to the triangle's mesh and instance (methods/triangles.py)."""
    offsets, start = {}, 0
    for item in objects:
        offsets[item.index] = start
        start += len(item.local_mesh.indices)
    return offsets


def mesh_key(obj: SceneObject, level: int = 0) -> tuple[Shape, bool, int]:
    """What an object's local mesh at `level` depends on (world_mesh's arguments): its shape, whether
    an image texture needs the seam's duplicated vertices, and the level."""
    return obj.shape, getattr(obj.material, "texture", None) is not None, level


def scene_geometry(objects: tuple[SceneObject, ...], levels: dict[int, int] | None = None) -> list[ObjectGeometry]:
    """Every object's geometry, at its level of detail in `levels` (by object index; 0, the full
    tessellation, for objects not in it: lod.py chooses them); objects of one shape and level share
    one local mesh (meshes are read-only), so that a thousand equal spheres cost one sphere's
    arrays, GPU buffer and bounding sphere, and can be drawn instanced (gpu/batches.py)."""
    local: dict[tuple[Shape, bool, int], Mesh] = {}
    geometry = []
    for index, obj in enumerate(objects):
        level = levels.get(index, 0) if levels else 0
        key = mesh_key(obj, level)
        if key not in local:
            local[key] = world_mesh(*key)
        geometry.append(ObjectGeometry(index, obj, local[key]))
    return geometry
