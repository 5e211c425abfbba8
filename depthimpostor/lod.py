"""Levels of detail: each round primitive (sphere, cylinder, torus, torus knot) tessellated for its
size on screen, so that ten thousand small spheres cost what their few visible pixels cost instead
of a mirror sphere's 9,000 triangles each.

A level halves the shape's tessellation (geometry.tessellation). An object gets the coarsest level
whose chordal error (the largest distance between the true surface and the triangles: a circle of
radius r cut into n chords sags by r (1 - cos(pi / n))), projected from the scene camera at the
nearest point of the object's enclosing sphere, stays under LOD_PIXEL_ERROR pixels of the scene's
frame. The world's level (World.geometry) is chosen once, when the scene's world is made, from the
camera the scene file names and the frame size it renders at; the eye's diffuse pass draws each
object at the level for the frame's own camera (World.eye_drawn_for: a viewer, a video's path or a
dataset's cameras move it), from the levels the world loaded (every level of up to
world.EYE_LEVEL_SHAPES round shapes; past that, a camera moved close to an object of the others
sees the scene camera's level).

Kept at the full tessellation, because a coarser mesh would change what they show:
- reflectors (mirrors and glass): a mirror's normals are interpolated over its triangles, so a
  coarser mirror mesh changes every reflected pixel;
- objects a reflector can show (culling.reaches): they are traced by the triangle methods (and the
  hybrid method's re-trace, and the truth), whose rays meet them at the size of an image's sample,
  not of an eye pixel; the images baked of them choose their own levels (below). The eye's own
  diffuse pass draws them at a level for the eye (World.eye_drawn), at LOD_REFLECTED_PIXEL_ERROR:
  a thousand small spheres around a mirror are 4.5 M triangles at their full meshes, most of a
  frame on a CPU rasterizer, for a few pixels each;
- objects that move (their distance from the camera changes), and, in a scene with shadows,
  shadow casters (their shadow falls elsewhere, at another size on screen).

Baked images (depth images, billboards, cube-map faces) draw each object at the coarsest level
whose chordal error, projected into that image at the object's nearest point, stays under
LOD_TEXEL_ERROR texels of it (`image_levels`, `BakeDetail`): the image's own sampling is what a
reflected ray sees of the object, whatever the eye's frame. A sphere filling a 128^2 depth image
keeps its 96 x 48 (48 x 24 would sag by 0.14 texels), and gets 48 x 24 in a 64^2 one; a small
object in a 128^2 cube-map face is drawn with a few hundred triangles. The hybrid method's images
keep the full meshes: each of their samples names the triangle it shows, which its re-trace
intersects exactly.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass

import numpy as np

from .culling import enclosing_spheres
from .geometry import ObjectGeometry, bounding_spheres, has_levels, max_level, mesh_for_shape, mesh_key, tessellation
from .meshes import Mesh
from .ppc import PPC
from .scene.model import CylinderShape, Scene, Shape, SphereShape, TorusKnotShape, TorusShape

#: The largest screen-space error a level may make, in pixels of the scene's frame: under half a
#: pixel, a silhouette moves by less than the distance between pixel centres, and the facets'
#: shading (smooth normals, interpolated) cannot be told from the full mesh's on an object a few
#: pixels across.
LOD_PIXEL_ERROR = 0.5
#: The same for a baked image, in texels of that image. Not half, as for the eye: half a texel
#: measurably moved the depth method's silhouettes (tools/bake_levels.py on tools/scene_size.py's
#: scenes, against the truth: colour RMSE +13 % at 100 objects, +4 % at 1,000, the wrong-surface
#: share up, where its spheres were baked at 48 x 24, 0.14 texels of chordal error; presumably
#: where a mirror, turning away from the eye, magnifies a texel into several pixels). At an eighth, no figure of any
#: method moved beyond its noise (results/llvmpipe/bake_levels.md), and the cube maps' faces draw
#: an eighteenth of their triangles (1,000 objects: 3.0 M instead of 54 M).
LOD_TEXEL_ERROR = 0.125
#: The same for the eye's view of an object a reflector can show (World.eye_drawn), in pixels of the
#: scene's frame: an eighth, not half, because the mirror shows its full mesh beside it, and its
#: highlights and silhouette are then compared across the mirror's edge (the objects near mirrors
#: in scenes/ are large enough on screen to keep their full meshes at it).
LOD_REFLECTED_PIXEL_ERROR = 0.125


def _sag(radius: float, chords: int) -> float:
    """How far a circle of `radius` cut into `chords` equal chords lies from them, at most."""
    return radius * (1.0 - math.cos(math.pi / chords))


def _knot_sag(shape: TorusKnotShape, segments: int) -> float:
    """How far the torus knot's centre line lies from its `segments` chords, at most (measured at
    the chords' midpoints, where the sag of a smooth curve peaks)."""
    t = 2.0 * np.pi * (np.arange(2 * segments) / (2 * segments))
    r = shape.radius * (2.0 + np.cos(shape.q * t)) / 3.0
    curve = np.stack([r * np.cos(shape.p * t), shape.radius * np.sin(shape.q * t) / 3.0, r * np.sin(shape.p * t)], axis=-1)
    ends, middles = curve[0::2], curve[1::2]
    chords = 0.5 * (ends + np.roll(ends, -1, axis=0))
    return float(np.linalg.norm(middles - chords, axis=1).max())


def chordal_error(shape: Shape, level: int) -> float:
    """The largest distance, in the shape's local units, between `shape` and its mesh at `level`
    (0 for shapes without levels: their meshes are exact)."""
    counts = tessellation(shape, level)
    if isinstance(shape, SphereShape):
        # Meridians cut the equator into `segments` chords; rings cut meridians into 2 * rings.
        return _sag(shape.radius, min(counts[0], 2 * counts[1]))
    if isinstance(shape, CylinderShape):
        return _sag(shape.radius, counts[0])
    if isinstance(shape, TorusShape):
        return _sag(shape.major + shape.minor, counts[0]) + _sag(shape.minor, counts[1])
    if isinstance(shape, TorusKnotShape):
        # Doubled along the curve: the tube's outer side bends more than its centre line.
        return 2.0 * _knot_sag(shape, counts[0]) + _sag(shape.tube, counts[1])
    return 0.0


@dataclass(frozen=True)
class EyeView:
    """What an object's size on screen depends on: where the eye is, and its focal length in
    pixels of its frame (pixels across a unit length at unit distance on the optical axis)."""

    eye: tuple[float, float, float]
    focal: float

    @classmethod
    def of_scene(cls, scene: Scene) -> EyeView:
        """The scene file's camera at the scene's frame size."""
        eye = np.asarray(scene.camera.eye, float)
        return cls((float(eye[0]), float(eye[1]), float(eye[2])),
                   0.5 * scene.render.size[1] / math.tan(math.radians(0.5 * scene.camera.fov_y)))

    @classmethod
    def of_camera(cls, camera: PPC) -> EyeView:
        """A frame's camera (a viewer's, a video's, a dataset frame's): its pixel's size at unit
        depth is |b| (PPC's pixels are square)."""
        forward = np.cross(camera.a, camera.b)
        forward /= np.linalg.norm(forward)
        focal = float(np.dot(camera.c, forward) / np.linalg.norm(camera.b))
        return cls((float(camera.C[0]), float(camera.C[1]), float(camera.C[2])), focal)


def detail_level(errors: list[float], pixels: float, limit: float = LOD_PIXEL_ERROR) -> int:
    """The coarsest level whose error (`errors[level]`, in local units, finest first) covers at
    most `limit` pixels, where a local unit covers `pixels` pixels."""
    level = 0
    while level + 1 < len(errors) and errors[level + 1] * pixels <= limit:
        level += 1
    return level


def level_errors(shape: Shape) -> list[float]:
    """chordal_error of `shape` at each of its levels, finest first (one level, 0, without levels)."""
    if shape not in _ERRORS:
        _ERRORS[shape] = [chordal_error(shape, level) for level in range(max_level(shape) + 1)]
    return _ERRORS[shape]


_ERRORS: dict[Shape, list[float]] = {}  # level_errors of each shape met so far (shapes are frozen)


def detail_levels(view: EyeView, geometry: list[ObjectGeometry], keep: Collection[int],
                  limit: float | Callable[[ObjectGeometry], float] = LOD_PIXEL_ERROR) -> dict[int, int]:
    """The level of each object (by index) but those in `keep` (their full tessellation: see the
    module's docstring for which), from its size in the view's frame: the coarsest whose error
    covers at most `limit` pixels (or `limit(object)`)."""
    return LevelTable.of(geometry, keep, limit).levels(view)


@dataclass(frozen=True, eq=False)
class LevelTable:
    """What detail_levels needs of its objects apart from the view (their enclosing spheres, scales,
    limits and each level's error), worked out once: a viewer's camera moves every frame, and a
    thousand objects' spheres take longer to find than their levels for a view."""

    indices: np.ndarray  # (n,) the objects' indices
    centres: np.ndarray  # (n, 3) their enclosing spheres, in the world
    radii: np.ndarray  # (n,)
    scales: np.ndarray  # (n,) local to world units, at most
    limits: np.ndarray  # (n,) pixels
    errors: np.ndarray  # (n, most levels) each level's chordal error (finest first), inf past the coarsest

    @classmethod
    def of(cls, geometry: list[ObjectGeometry], keep: Collection[int],
           limit: float | Callable[[ObjectGeometry], float] = LOD_PIXEL_ERROR) -> LevelTable:
        items = [g for g in geometry if g.index not in keep and has_levels(g.object.shape)]
        if not items:
            empty = np.zeros(0)
            return cls(np.zeros(0, np.int64), np.zeros((0, 3)), empty, empty, empty, np.zeros((0, 1)))
        centres, radii = enclosing_spheres(items)
        scales = np.linalg.norm(np.stack([g.model_matrix[:3, :3] for g in items]), 2, axis=(1, 2))
        per_item = [level_errors(g.object.shape) for g in items]
        errors = np.full((len(items), max(len(e) for e in per_item)), np.inf)
        for row, item_errors in enumerate(per_item):
            errors[row, :len(item_errors)] = item_errors
        limits = np.array([limit(g) if callable(limit) else limit for g in items], np.float64)
        return cls(np.array([g.index for g in items], np.int64), np.asarray(centres, np.float64),
                   np.asarray(radii, np.float64), scales, limits, errors)

    def levels(self, view: EyeView) -> dict[int, int]:
        """detail_level of each object from `view`, by index, where it is not 0."""
        if not len(self.indices):
            return {}
        offsets = self.centres - np.asarray(view.eye, np.float64)
        distance = np.sqrt(np.einsum("ij,ij->i", offsets, offsets)) - self.radii
        # Infinite where the eye is in the sphere; 0 x inf (an exact level there) is not within the limit.
        with np.errstate(divide="ignore", invalid="ignore"):
            pixels = self.scales * np.where(distance > 0.0, view.focal / distance, np.inf)
            within = self.errors[:, 1:] * pixels[:, None] <= self.limits[:, None]
        # detail_level's walk: the coarsest level before the first that is not within the limit.
        level = np.argmin(np.hstack([within, np.zeros((len(within), 1), bool)]), axis=1)
        return {int(index): int(value) for index, value in zip(self.indices, level, strict=True) if value}


def texels_per_unit(cameras: Sequence[PPC], centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """For each sphere ((n, 3) centres, (n,) radii) and the camera beside it in `cameras`, the most
    texels of that camera's image that a world length anywhere in the sphere covers (infinite
    where the sphere holds the eye).

    A pinhole of F texels at unit depth maps a length at distance d, at angle theta from the
    optical axis, to at most F / (d cos^2 theta) texels (a length across the ray: its depth is
    d cos theta, and the image plane, seen at theta, stretches it by 1 / cos theta). Within the
    sphere, d is at least the distance of its nearest point and theta at most the angle of its
    centre plus its angular radius, and no more than the image's corners' (farther off the axis
    the image holds nothing): a cube-map face's corner texels cover a third of its centre's."""
    places: dict[int, int] = {}  # each distinct camera's row (a cube map's six serve every object)
    which = np.array([places.setdefault(id(camera), len(places)) for camera in cameras], np.intp)
    distinct = list({id(camera): camera for camera in cameras}.values())
    eye, a, b, c = (np.array([getattr(camera, name) for camera in distinct]) for name in ("C", "a", "b", "c"))
    sizes = np.array([(camera.width, camera.height) for camera in distinct], np.float64)
    forward = np.cross(a, b)
    forward /= np.linalg.norm(forward, axis=1, keepdims=True)
    focal_texels = np.einsum("ij,ij->i", c, forward) / np.minimum(np.linalg.norm(a, axis=1), np.linalg.norm(b, axis=1))
    corners = np.stack([c + a * u[:, None] + b * v[:, None] for u in (0.0 * sizes[:, 0], sizes[:, 0])
                        for v in (0.0 * sizes[:, 1], sizes[:, 1])], axis=1)  # (cameras, 4, 3)
    corner_cosines = np.einsum("ikj,ij->ik", corners, forward) / np.linalg.norm(corners, axis=2)
    corner_angle = np.arccos(np.clip(corner_cosines.min(axis=1), -1.0, 1.0))[which]
    offsets = centres - eye[which]
    distances = np.linalg.norm(offsets, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        centre_angle = np.arccos(np.clip(np.einsum("ij,ij->i", offsets, forward[which]) / distances, -1.0, 1.0))
        angular_radius = np.arcsin(np.clip(radii / distances, 0.0, 1.0))
    angles = np.minimum(np.nan_to_num(centre_angle + angular_radius, nan=np.inf), corner_angle)
    nearest = distances - radii
    with np.errstate(divide="ignore"):
        texels = focal_texels[which] / (np.maximum(nearest, 0.0) * np.cos(angles) ** 2)
    return np.where(nearest > 0.0, texels, np.inf)


def image_levels(cameras: Sequence[PPC], items: Sequence[ObjectGeometry]) -> list[int]:
    """The level each of `items` is baked at into the image of the camera beside it in `cameras`:
    the coarsest whose chordal error covers at most LOD_TEXEL_ERROR texels of it (0, the full
    mesh, for reflectors, whose interpolated normals are what they reflect with, and for shapes
    without levels)."""
    levels = [0] * len(items)
    rounded = [i for i, item in enumerate(items) if has_levels(item.object.shape) and not item.object.is_reflector]
    if not rounded:
        return levels
    spheres = bounding_spheres([items[i] for i in rounded])  # the full meshes' (cached by the plan's camera fits)
    texels = texels_per_unit([cameras[i] for i in rounded], np.array([centre for centre, _ in spheres]),
                             np.array([radius for _, radius in spheres]))
    scales = np.linalg.norm(np.stack([items[i].model_matrix[:3, :3] for i in rounded]), 2, axis=(1, 2))  # local to world units, at most
    for i, per_unit in zip(rounded, texels * scales, strict=True):
        levels[i] = detail_level(level_errors(items[i].object.shape), float(per_unit), LOD_TEXEL_ERROR)
    return levels


@functools.lru_cache(maxsize=256)
def level_mesh(shape: Shape, textured: bool, level: int) -> Mesh:
    """The local mesh of `shape` at `level` that bakes draw: one per (shape, texture seam, level),
    shared by every image and renderer (meshes are read-only), so that the plan counts the very
    meshes the bakes load (plan_memory)."""
    return mesh_for_shape(shape, textured, level)


class BakeDetail:
    """The geometry a bake draws of its images' objects: each object at its image_levels level,
    made once per (object, level) and kept while the object does not move; objects of one shape
    and level share one local mesh (level_mesh), as the world's do (geometry.scene_geometry)."""

    def __init__(self) -> None:
        self._items: dict[tuple[int, int], tuple[ObjectGeometry, ObjectGeometry]] = {}  # (index, level): (full, coarse)

    def drawn(self, images: Sequence[tuple[PPC, Sequence[ObjectGeometry]]]) -> list[list[ObjectGeometry]]:
        """The objects of each image (its camera, its objects) as its bake draws them: each at its
        level, or itself where its own mesh is as coarse already (the world's level of an object
        no reflector shows). The levels of every image's objects are worked out at once."""
        cameras = [camera for camera, items in images for _ in items]
        levels = iter(image_levels(cameras, [item for _, items in images for item in items]))
        return [[self._at(item, next(levels)) for item in items] for _, items in images]

    def _at(self, item: ObjectGeometry, level: int) -> ObjectGeometry:
        if not level:
            return item
        kept = self._items.get((item.index, level))
        if kept is not None and kept[0] is item:
            return kept[1]
        mesh = level_mesh(*mesh_key(item.object, level))
        coarse = item if len(mesh.indices) >= len(item.local_mesh.indices) else item.drawn_with(mesh)
        self._items[(item.index, level)] = (item, coarse)
        return coarse


def bake_meshes(images: Sequence[tuple[PPC, Sequence[ObjectGeometry]]]) -> list[Mesh]:
    """The meshes the bakes of `images` (each its camera and objects) draw that are not their
    objects' own: the levels the renderer loads at its first bake (the plan's memory figure)."""
    drawn = BakeDetail().drawn(images)
    coarse = [item.local_mesh for (_, items), shown in zip(images, drawn, strict=True)
              for full, item in zip(items, shown, strict=True) if item is not full]
    return list({id(mesh): mesh for mesh in coarse}.values())
