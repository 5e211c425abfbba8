"""Levels of detail: each round primitive (sphere, cylinder, torus, torus knot) tessellated for its
size on screen, so that ten thousand small spheres cost what their few visible pixels cost instead
of a mirror sphere's 9,000 triangles each.

A level halves the shape's tessellation (geometry.tessellation). An object gets the coarsest level
whose chordal error (the largest distance between the true surface and the triangles: a circle of
radius r cut into n chords sags by r (1 - cos(pi / n))), projected from the scene camera at the
nearest point of the object's enclosing sphere, stays under LOD_PIXEL_ERROR pixels of the scene's
frame. The level is chosen once, when the scene's world is made: the camera the scene file names
and the frame size it renders at; a viewer that flies close to a small object sees its facets.

Kept at the full tessellation, because a coarser mesh would change what they show:
- reflectors (mirrors and glass): a mirror's normals are interpolated over its triangles, so a
  coarser mirror mesh changes every reflected pixel;
- objects a reflector can show (culling.reaches): they are drawn into depth images and traced by the
  triangle methods, whose rays meet them at the size of an image's sample, not of an eye pixel;
- objects that move (their distance from the camera changes), and, in a scene with shadows,
  shadow casters (their shadow falls elsewhere, at another size on screen).
"""

from __future__ import annotations

import math
from collections.abc import Collection

import numpy as np

from .culling import enclosing_spheres
from .geometry import ObjectGeometry, has_levels, max_level, tessellation
from .scene.model import CylinderShape, Scene, Shape, SphereShape, TorusKnotShape, TorusShape

#: The largest screen-space error a level may make, in pixels of the scene's frame: under half a
#: pixel, a silhouette moves by less than the distance between pixel centres, and the facets'
#: shading (smooth normals, interpolated) cannot be told from the full mesh's on an object a few
#: pixels across.
LOD_PIXEL_ERROR = 0.5


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


def pixels_per_unit(scene: Scene, centre: np.ndarray, radius: float) -> float:
    """Pixels of the scene's frame that a length at the nearest point of the sphere (centre,
    radius) covers, seen from the scene's camera; infinite where the eye is in the sphere."""
    distance = float(np.linalg.norm(centre - np.asarray(scene.camera.eye, float))) - radius
    if distance <= 0.0:
        return math.inf
    focal = 0.5 * scene.render.size[1] / math.tan(math.radians(0.5 * scene.camera.fov_y))
    return focal / distance


def detail_level(errors: list[float], pixels: float) -> int:
    """The coarsest level whose error (`errors[level]`, in local units, finest first) covers at
    most LOD_PIXEL_ERROR pixels, where a local unit covers `pixels` pixels."""
    level = 0
    while level + 1 < len(errors) and errors[level + 1] * pixels <= LOD_PIXEL_ERROR:
        level += 1
    return level


def detail_levels(scene: Scene, geometry: list[ObjectGeometry], keep: Collection[int]) -> dict[int, int]:
    """The level of each object (by index) but those in `keep` (their full tessellation: see the
    module's docstring for which), from its size in the scene camera's frame. The objects'
    enclosing spheres are found for all of them at once."""
    items = [g for g in geometry if g.index not in keep and has_levels(g.object.shape)]
    if not items:
        return {}
    centres, radii = enclosing_spheres(items)
    scales = np.linalg.norm(np.stack([g.model_matrix[:3, :3] for g in items]), 2, axis=(1, 2))  # local to world units, at most
    errors: dict[Shape, list[float]] = {}  # of each distinct shape, at each of its levels
    levels = {}
    for item, centre, radius, scale in zip(items, centres, radii, scales, strict=True):
        shape = item.object.shape
        if shape not in errors:
            errors[shape] = [chordal_error(shape, level) for level in range(max_level(shape) + 1)]
        level = detail_level(errors[shape], float(scale) * pixels_per_unit(scene, centre, float(radius)))
        if level:
            levels[item.index] = level
    return levels
