"""Which objects a reflector can ever show: the plan bakes no depth image of the others.

A mirror reflects on its front alone (its back is a matte backing), and its reflected rays are
bounded by its normals. At a front-facing point p of a triangle with geometric normal g, the eye's
ray v has v.g < 0, and the reflected ray is r = H v, H the reflection through the plane normal to
the interpolated normal n. H is an orthogonal involution, so v.g = r.(H g) and every reflected ray
of p satisfies r.m > 0 with m = 2 (n.g) n - g: the open hemisphere about m (m = g on a flat face,
whatever the eye).

Over a triangle, the normalized convex combinations of the vertex normals n_i lie in the cone
about a = normalize(n_0 + n_1 + n_2) of half-angle beta = max angle(a, n_i) (a cone narrower than a
hemisphere is convex). Reflecting g about an axis within beta of a turns m by at most 2 beta from
m_a = 2 (a.g) a - g, so every reflected ray of the triangle lies within 90 + 2 beta degrees of m_a:
from a point p, the points out of reach form the cone about -m_a of half-angle
gamma = 90 - 2 beta. For a convex cone K and p in the triangle, x - p = sum b_j (x - p_j) lies in K
when the three x - p_j do, so a point out of reach of the three vertices is out of reach of the
whole triangle. An object is culled for a mirror when a sphere enclosing it is in that cone from
every vertex of every triangle: exact for planar mirrors (beta = 0: "behind the mirror"),
conservative for curved ones.

Glass is never culled: a refracted ray may leave it in any direction. Nor is anything culled for
a mirror that moves (its planes turn); an object that moves is tested with the sphere its
enclosing sphere sweeps over a turn of its animation.

`reaches` tests all pairs at once, in numpy arrays over every mirror triangle and every object,
so that a scene of thousands of objects is culled in a fraction of a second.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import TypeAlias
from dataclasses import dataclass
from enum import Enum

import numpy as np

from .geometry import ObjectGeometry

#: Radians kept between the sphere and the cone's edge, so that rounding never culls an object
#: a ray could graze.
CULL_MARGIN = 1e-6


class Reach(Enum):
    """Why a reflector can or cannot show an object."""

    REACHABLE = "reachable"
    BEHIND = "behind the mirror"  # a flat mirror: the object lies wholly behind its plane
    OUTSIDE_DIRECTIONS = "outside every direction the mirror's surface sends a ray"


def enclosing_sphere(item: ObjectGeometry) -> tuple[np.ndarray, float]:
    """A sphere holding `item` at its time, found without moving its vertices: its local mesh's
    bounding sphere (computed once per mesh, and objects of one shape share their mesh) carried by
    the model matrix, the radius stretched by the matrix's largest singular value (exact under a
    uniform scale, looser under another). Culling tests every object against every mirror, so it
    avoids `ObjectGeometry.bounding_sphere`, which transforms every vertex of every object.

    The radius grows by 1e-6 of the sphere's reach from the origin: the world mesh's float32
    vertices are rounded by up to 2^-24 of their coordinates from the float64 images this sphere holds.
    """
    centres, radii = enclosing_spheres([item])
    return centres[0], float(radii[0])


def enclosing_spheres(items: Sequence[ObjectGeometry]) -> tuple[np.ndarray, np.ndarray]:
    """enclosing_sphere of every item, in arrays ((N, 3) centres, (N,) radii): ten thousand
    objects' in one pass of numpy."""
    models = np.stack([item.model_matrix for item in items]).reshape(-1, 4, 4)
    spheres = {id(item.local_mesh): item.local_mesh for item in items}  # each mesh's once: objects share them
    of_mesh = {key: mesh.bounding_sphere() for key, mesh in spheres.items()}
    local = [of_mesh[id(item.local_mesh)] for item in items]
    linear = models[:, :3, :3]
    centres = (linear @ np.reshape([centre for centre, _ in local], (-1, 3, 1)))[..., 0] + models[:, :3, 3]
    radii = np.array([radius for _, radius in local]) * np.linalg.norm(linear, 2, axis=(1, 2))
    return centres, radii + 1e-6 * (np.linalg.norm(centres, axis=1) + radii)


def swept_sphere(item: ObjectGeometry) -> tuple[np.ndarray, float]:
    """A sphere holding `item` at every time of its animation: a rotation about an axis carries
    the centre of its enclosing sphere around a circle about its foot on the axis."""
    return _swept(item, *enclosing_sphere(item))


def _swept(item: ObjectGeometry, centre: np.ndarray, radius: float) -> tuple[np.ndarray, float]:
    """swept_sphere of `item` from its enclosing sphere (`centre`, `radius`). A glTF part its file
    animates (scene/gltf_deform.py) may go anywhere its keyframes and splines take it: its sphere
    is everything (it is never culled), so that what a reflector shows holds at every time."""
    if item.object.motion is not None:
        return centre, math.inf
    animation = item.object.animation
    if animation is None:
        return centre, radius
    pivot = np.asarray(animation.pivot_of(item.object.position), np.float64)
    axis = np.asarray(animation.axis, np.float64)
    foot = pivot + axis * float((centre - pivot) @ axis)
    return foot, float(np.linalg.norm(centre - foot)) + radius


def swept_spheres(items: Sequence[ObjectGeometry]) -> tuple[np.ndarray, np.ndarray]:
    """swept_sphere of every item, in arrays ((N, 3) centres, (N,) radii): the enclosing spheres
    in one pass of numpy (enclosing_spheres), then the few animated items' sweeps one by one."""
    centres, radii = enclosing_spheres(items)
    for i, item in enumerate(items):
        if item.object.moves:
            centre, radius = _swept(item, centres[i].copy(), float(radii[i]))
            centres[i], radii[i] = centre, radius
    return centres, radii


def _unit(vectors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors along (..., 3) `vectors`, and their lengths (zero vectors stay zero)."""
    length = np.linalg.norm(vectors, axis=-1, keepdims=True)
    return vectors / np.where(length > 0.0, length, 1.0), length[..., 0]


@dataclass(frozen=True)
class _Cones:
    """Per front-facing triangle of a static mirror: its corners, the axis m_a its reflected rays
    lie about, and gamma, the half-angle of the cone about -m_a that no reflected ray enters."""

    corners: np.ndarray  # (T, 3, 3)
    reach_axis: np.ndarray  # (T, 3)
    out_of_reach: np.ndarray  # (T,) radians
    flat: bool  # every triangle flat (beta = 0): what is culled lies behind the mirror


def _cones(reflector: ObjectGeometry) -> _Cones | None:
    """The cones of a mirror that does not move; None for glass, a moving mirror, or one whose
    triangles are all degenerate (nothing can be culled for those)."""
    if not reflector.object.is_mirror or reflector.object.moves:
        return None
    mesh = reflector.world_mesh
    corners = mesh.positions[mesh.indices].astype(np.float64)  # (T, 3, 3)
    normals = mesh.normals[mesh.indices].astype(np.float64)
    face, area = _unit(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]))
    keep = area > 0.0  # a degenerate triangle covers no pixel and sends no ray
    corners, normals, face = corners[keep], normals[keep], face[keep]
    if not len(corners):
        return None
    axis, _ = _unit(normals.sum(axis=1))
    spread = np.arccos(np.clip(np.einsum("tj,tij->ti", axis, normals), -1.0, 1.0)).max(axis=1)
    reach_axis = 2.0 * np.einsum("tj,tj->t", axis, face)[:, None] * axis - face
    # Each run of _TRIANGLE_RUN triangles taken from all over the mesh (every k-th), not from one
    # patch of it: a run that faces every way reaches nearly every sphere at once (a sphere
    # mirror's first run, near its pole, left most of a thousand objects to the next runs). What
    # is culled does not depend on the order: a sphere out of reach of every triangle.
    spaced = np.argsort(np.arange(len(corners)) % -(-len(corners) // _TRIANGLE_RUN), kind="stable")
    return _Cones(corners[spaced], reach_axis[spaced], (np.pi / 2.0 - 2.0 * spread)[spaced],
                  bool(np.all(spread < CULL_MARGIN)))


#: Elements of the (triangle corners x spheres) arrays culling works on at once: bounds its
#: memory (a few tens of MB) whatever the number of mirror triangles and objects.
_CHUNK_ELEMENTS = 2**20


#: Triangles of one mirror tested at once: after each run, only the spheres that every triangle so
#: far left out of reach are tested further (one triangle that reaches a sphere decides it). A
#: curved mirror's first runs reach nearly everything (its triangles spaced over it: _cones): a
#: thousand objects around two mirror spheres were 5.9 M corner-sphere tests at once, and are
#: now a few runs' worth.
_TRIANGLE_RUN = 64
#: The first run's triangles, fewer (each run after it twice the one before, up to _TRIANGLE_RUN):
#: a few triangles spaced over a curved mirror face every way and reach most spheres, which a
#: first run of _TRIANGLE_RUN tested against 60 more (a thousand objects around two mirror
#: spheres: 0.4 M corner-sphere tests, 50 ms; runs of 4, 8 and 16 leave none after 0.04 M, 6 ms).
_FIRST_RUN = 4


def _culled(cones: list[_Cones], centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """(mirrors, spheres) bool: is the sphere out of reach from every corner of every triangle?

    Each mirror's triangles are taken in runs, each run against the spheres still out of reach
    of all triangles before it, in chunks of spheres that bound the arrays' memory."""
    culled = np.ones((len(cones), len(centres)), bool)
    for row, cone in enumerate(cones):
        limits = cone.out_of_reach - CULL_MARGIN
        for first, last in _runs(len(cone.corners)):
            candidates = np.flatnonzero(culled[row])
            if not len(candidates):
                break
            corners = cone.corners[first:last]
            reach_axis, limit = cone.reach_axis[first:last], limits[first:last, None, None]
            step = max(1, _CHUNK_ELEMENTS // (3 * len(corners)))
            for lo in range(0, len(candidates), step):
                chosen = candidates[lo:lo + step]
                centre, radius = centres[chosen], radii[chosen]
                offsets, distances = _unit(centre[None, None] - corners[:, :, None])  # (T, 3, n, 3), (T, 3, n)
                angle_to_axis = np.arccos(np.clip(-np.einsum("tikj,tj->tik", offsets, reach_axis), -1.0, 1.0))
                sphere_angle = np.arcsin(np.clip(radius / np.maximum(distances, 1e-300), 0.0, 1.0))
                out = (distances > radius) & (angle_to_axis + sphere_angle <= limit)
                culled[row, chosen] = out.all(axis=(0, 1))
    return culled


def _runs(triangles: int) -> list[tuple[int, int]]:
    """The (first, last + 1) triangles of each run of a mirror of `triangles` (_culled): _FIRST_RUN,
    then twice as many at each run up to _TRIANGLE_RUN."""
    runs, first, size = [], 0, _FIRST_RUN
    while first < triangles:
        runs.append((first, min(first + size, triangles)))
        first, size = first + size, min(2 * size, _TRIANGLE_RUN)
    return runs


#: What can reach what: `reaches` itself, or a World's memo of it (world.py).
ReachTable: TypeAlias = Callable[[Sequence[ObjectGeometry], Sequence[ObjectGeometry]], list[list[Reach]]]


def reaches(reflectors: Sequence[ObjectGeometry], targets: Sequence[ObjectGeometry]) -> list[list[Reach]]:
    """`reach(reflector, target)` for every reflector (rows) and target (columns), all pairs at once."""
    table = [[Reach.REACHABLE] * len(targets) for _ in reflectors]
    cones = [(row, c) for row, reflector in enumerate(reflectors) if (c := _cones(reflector)) is not None]
    if not cones or not targets:
        return table
    centres, radii = swept_spheres(targets)
    culled = _culled([c for _, c in cones], centres, radii)
    for (row, c), out in zip(cones, culled, strict=True):
        why = Reach.BEHIND if c.flat else Reach.OUTSIDE_DIRECTIONS
        for column in np.flatnonzero(out):
            table[row][column] = why
    return table


def reach(reflector: ObjectGeometry, target: ObjectGeometry) -> Reach:
    """Can a ray leaving `reflector` (a mirror or glass) ever meet `target`'s enclosing sphere?"""
    return reaches([reflector], [target])[0][0]


def reachable_targets(reflector: ObjectGeometry, targets: list[ObjectGeometry],
                      reach: ReachTable = reaches) -> list[ObjectGeometry]:
    """The targets `reflector` may show, in order."""
    return [target for target, why in zip(targets, reach([reflector], targets)[0], strict=True) if why is Reach.REACHABLE]


def may_shadow(light: np.ndarray, light_radius: float, caster: tuple[np.ndarray, float],
               receiver: tuple[np.ndarray, float]) -> bool:
    """Can a caster's bounding sphere shadow any point of a receiver's from a spherical light?

    A segment from a point y of the light (|y - light| <= light_radius) to x that meets the caster
    has a twin from the light's centre to x passing within light_radius of the same point, so the
    caster's sphere grown by light_radius, seen from the centre, bounds every shadow: x is shadowed
    only inside the cone from the light through that sphere, and beyond its near side.
    """
    (caster_centre, caster_radius), (receiver_centre, receiver_radius) = caster, receiver
    grown = caster_radius + light_radius
    to_caster, caster_distance = _unit(np.asarray(caster_centre, np.float64) - light)
    to_receiver, receiver_distance = _unit(np.asarray(receiver_centre, np.float64) - light)
    if caster_distance <= grown or receiver_distance <= receiver_radius:
        return True
    if receiver_distance + receiver_radius < caster_distance - grown:
        return False  # wholly between the light and the caster
    angle = np.arccos(np.clip(float(to_caster @ to_receiver), -1.0, 1.0))
    return bool(angle <= np.arcsin(grown / caster_distance) + np.arcsin(receiver_radius / receiver_distance) + CULL_MARGIN)
