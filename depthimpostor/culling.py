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
whole triangle. An object is culled for a mirror when its bounding sphere is in that cone from
every vertex of every triangle: exact for planar mirrors (beta = 0: "behind the mirror"),
conservative for curved ones.

Glass is never culled: a refracted ray may leave it in any direction. Nor is anything culled for
a mirror that moves (its planes turn); an object that moves is tested with the sphere its
bounding sphere sweeps over a turn of its animation.
"""

from __future__ import annotations

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


def swept_sphere(item: ObjectGeometry) -> tuple[np.ndarray, float]:
    """A sphere holding `item`'s bounding sphere at every time of its animation: a rotation about
    an axis carries the centre around a circle about its foot on the axis."""
    centre, radius = item.bounding_sphere
    animation = item.object.animation
    if animation is None:
        return centre, radius
    pivot = np.asarray(animation.pivot_of(item.object.position), np.float64)
    axis = np.asarray(animation.axis, np.float64)
    foot = pivot + axis * float((centre - pivot) @ axis)
    return foot, float(np.linalg.norm(centre - foot)) + radius


def _unit(vectors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors along (..., 3) `vectors`, and their lengths (zero vectors stay zero)."""
    length = np.linalg.norm(vectors, axis=-1, keepdims=True)
    return vectors / np.where(length > 0.0, length, 1.0), length[..., 0]


def reach(reflector: ObjectGeometry, target: ObjectGeometry) -> Reach:
    """Can a ray leaving `reflector` (a mirror or glass) ever meet `target`'s bounding sphere?"""
    if not reflector.object.is_mirror or reflector.object.moves:
        return Reach.REACHABLE
    mesh = reflector.world_mesh
    corners = mesh.positions[mesh.indices].astype(np.float64)  # (T, 3, 3)
    normals = mesh.normals[mesh.indices].astype(np.float64)
    face, area = _unit(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]))
    keep = area > 0.0  # a degenerate triangle covers no pixel and sends no ray
    corners, normals, face = corners[keep], normals[keep], face[keep]
    if not len(corners):
        return Reach.REACHABLE
    axis, _ = _unit(normals.sum(axis=1))
    spread = np.arccos(np.clip(np.einsum("tj,tij->ti", axis, normals), -1.0, 1.0)).max(axis=1)
    reach_axis = 2.0 * np.einsum("tj,tj->t", axis, face)[:, None] * axis - face
    out_of_reach = np.pi / 2.0 - 2.0 * spread  # gamma: the unreachable cone's half-angle
    centre, radius = swept_sphere(target)
    offsets, distances = _unit(np.asarray(centre, np.float64) - corners)  # (T, 3, 3), (T, 3)
    angle_to_axis = np.arccos(np.clip(-np.einsum("tij,tj->ti", offsets, reach_axis), -1.0, 1.0))
    sphere_angle = np.arcsin(np.clip(radius / np.maximum(distances, 1e-300), 0.0, 1.0))
    culled = (distances > radius) & (angle_to_axis + sphere_angle <= out_of_reach[:, None] - CULL_MARGIN)
    if not culled.all():
        return Reach.REACHABLE
    return Reach.BEHIND if np.all(spread < CULL_MARGIN) else Reach.OUTSIDE_DIRECTIONS


def reachable_targets(reflector: ObjectGeometry, targets: list[ObjectGeometry]) -> list[ObjectGeometry]:
    """The targets `reflector` may show, in order."""
    return [target for target in targets if reach(reflector, target) is Reach.REACHABLE]


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
