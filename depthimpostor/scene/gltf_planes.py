"""glTF rectangles as the scene's `plane` shape: a part whose triangles are coplanar and exactly
cover one rectangle is a floor, wall or flat mirror. As a mesh it would go through depth images
(and a floor surrounds every mirror standing on it, which the baking methods refuse); as a plane it
is intersected exactly, as a TOML scene's floors are (scene_format.md, "glTF rectangles").

`find_rectangle` recognises one in the file's world space; `plane_placement` composes it with a
TOML object's placement.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from depthimpostor.meshes import Mesh
from depthimpostor.scene.model import axis_rotation

#: Coplanarity, coverage and UV fit, relative to the rectangle's size (float32 positions and UVs
#: carry about 1e-7 relative error; a genuinely bent or textured-otherwise part is far beyond this).
RELATIVE_TOLERANCE = 1e-5
#: Directions (radians) that differ by rounding alone: one edge's, computed from two triangles.
ANGLE_ROUNDING = 1e-9


@dataclass(frozen=True, eq=False)
class Rectangle:
    """A plane shape's placement in the file's world space: local X along `axes[:, 0]`, the facing
    side +Y along `axes[:, 1]`, Z along `axes[:, 2]` (X x Y = Z), centred at `centre`."""

    size: tuple[float, float]  # (width along X, depth along Z)
    axes: np.ndarray  # 3x3 rotation, columns X, Y (the normal), Z
    centre: np.ndarray
    uv_scale: tuple[float, float] | None  # the part's UVs are the plane's times this; None: they are not


def find_rectangle(mesh: Mesh) -> Rectangle | None:
    """The rectangle the mesh's triangles cover, or None: all triangles facing one way in one plane,
    their areas summing to the area of a box (along an edge from the farthest vertex) whose four
    corners are vertices of the mesh."""
    p = np.asarray(mesh.positions, np.float64)
    tri = p[np.asarray(mesh.indices)]
    crosses = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    total = crosses.sum(axis=0)
    area2 = float(np.linalg.norm(total))
    extent = float(np.ptp(p, axis=0).max()) if len(p) else 0.0
    if len(tri) == 0 or extent <= 0.0 or area2 <= (RELATIVE_TOLERANCE * extent) ** 2:
        return None
    normal = total / area2
    lengths = np.linalg.norm(crosses, axis=1)
    # One facing: every triangle's area vector along the total (a folded part cancels out in the sum).
    if abs(float(lengths.sum()) - area2) > RELATIVE_TOLERANCE * area2:
        return None
    centre0 = p.mean(axis=0)
    if np.abs((p - centre0) @ normal).max() > RELATIVE_TOLERANCE * extent:
        return None
    for x in _corner_sides(p, tri, centre0, normal, RELATIVE_TOLERANCE * extent):
        found = _box(p, centre0, x, normal, np.cross(x, normal), 0.5 * area2, extent)
        if found is not None:
            return _oriented(mesh, *found, x, normal)
    return None


def _corner_sides(p: np.ndarray, tri: np.ndarray, centre: np.ndarray, normal: np.ndarray,
                  near: float) -> list[np.ndarray]:
    """The in-plane unit directions along which the vertex farthest from `centre` may have its two
    sides. Were the part a rectangle, that vertex is a corner (a convex shape's farthest point is a
    corner), every edge leaving it lies within its right angle, and the two sides are the edges at
    the angle's two ends: so only the most clockwise and the most counter-clockwise edge directions
    are worth trying (in the order the triangles list them), and a large flat mesh costs two passes,
    however many triangles share the corner (trying every edge was quadratic on a fan of them)."""
    corner = p[np.argmax(np.linalg.norm(p - centre, axis=1))]
    touching = tri[np.linalg.norm(tri - corner, axis=2).min(axis=1) <= near].reshape(-1, 3) - corner
    along = touching - np.outer(touching @ normal, normal)
    lengths = np.linalg.norm(along, axis=1)
    directions = along[lengths > near] / lengths[lengths > near, None]
    if not len(directions):
        return []
    # Angles about the normal from the direction toward the centre, which lies inside the corner's
    # angle: every edge is within a quarter turn of it either way, so no angle wraps around.
    inward = centre - corner - normal * float((centre - corner) @ normal)
    inward /= max(float(np.linalg.norm(inward)), 1e-300)
    angles = np.arctan2(directions @ np.cross(normal, inward), directions @ inward)
    # Each end's first edge in the triangles' order (one side, found by several triangles, differs
    # by rounding from one to the next), as trying every edge in that order found it.
    ends = {int(np.flatnonzero(angles <= angles.min() + ANGLE_ROUNDING)[0]),
            int(np.flatnonzero(angles >= angles.max() - ANGLE_ROUNDING)[0])}
    return [directions[k] for k in sorted(ends)]


def _box(p: np.ndarray, origin: np.ndarray, x: np.ndarray, normal: np.ndarray, z: np.ndarray, area: float,
         extent: float) -> tuple[np.ndarray, float, float] | None:
    """The centre, width and depth of the box around the points along x and z, when the triangles'
    area fills it and its corners are vertices."""
    s, t = (p - origin) @ x, (p - origin) @ z
    width, depth = float(s.max() - s.min()), float(t.max() - t.min())
    if abs(width * depth - area) > RELATIVE_TOLERANCE * max(area, width * depth):
        return None
    corners = [(a, b) for a in (s.min(), s.max()) for b in (t.min(), t.max())]
    near = RELATIVE_TOLERANCE * extent
    if not all(np.min(np.hypot(s - a, t - b)) <= near for a, b in corners):
        return None
    centre = origin + x * 0.5 * (s.max() + s.min()) + z * 0.5 * (t.max() + t.min())
    return centre, width, depth


def _oriented(mesh: Mesh, centre: np.ndarray, width: float, depth: float, x0: np.ndarray,
              normal: np.ndarray) -> Rectangle:
    """The rectangle turned about its normal so that the part's UVs are the plane's UVs
    (meshes.plane_uvs: u = x / width + 0.5, v = z / depth + 0.5) times a positive scale, where one
    of the four turns does that; else the first turn, with no UV scale."""
    turns = [(x0, (width, depth)), (np.cross(normal, x0), (depth, width)), (-x0, (width, depth)),
             (-np.cross(normal, x0), (depth, width))]
    rectangles = []
    for x, (w, d) in turns:
        axes = np.stack([x, normal, np.cross(x, normal)], axis=1)
        scale = _uv_scale(mesh, centre, axes, w, d)
        if scale is not None:
            return Rectangle((w, d), axes, centre, scale)
        rectangles.append(Rectangle((w, d), axes, centre, None))
    return rectangles[0]


def _uv_scale(mesh: Mesh, centre: np.ndarray, axes: np.ndarray, width: float,
              depth: float) -> tuple[float, float] | None:
    if mesh.uvs is None:
        return None
    local = (np.asarray(mesh.positions, np.float64) - centre) @ axes
    plane = np.stack([local[:, 0] / width + 0.5, local[:, 2] / depth + 0.5], axis=-1)
    uvs = np.asarray(mesh.uvs, np.float64)
    corner = np.argmax(plane[:, 0] + plane[:, 1])  # nearest the (1, 1) corner: the scale is read there
    su, sv = (float(c) for c in uvs[corner] / np.maximum(plane[corner], 1e-12))
    if not (su > 0.0 and sv > 0.0) or plane[corner].min() < 0.5:
        return None
    if np.abs(uvs - plane * (su, sv)).max() > RELATIVE_TOLERANCE * max(1.0, su, sv):
        return None
    # A whole number of repeats read back from float32 UVs is that number, so that an unscaled
    # texture stays the file's one texture (a scaled one is a texture slot of its own).
    return _snap(su), _snap(sv)


def _snap(value: float) -> float:
    return float(round(value)) if abs(value - round(value)) <= RELATIVE_TOLERANCE * value else value


def euler_degrees(rotation: np.ndarray) -> tuple[float, float, float]:
    """(rx, ry, rz) in degrees with Rz @ Ry @ Rx = rotation (SceneObject.rotation's order)."""
    ry = math.asin(float(np.clip(-rotation[2, 0], -1.0, 1.0)))
    if abs(math.cos(ry)) > 1e-9:
        rx = math.atan2(rotation[2, 1], rotation[2, 2])
        rz = math.atan2(rotation[1, 0], rotation[0, 0])
    else:  # gimbal lock: only rx - rz (or rx + rz) is fixed; rz = 0 takes all of it
        rx, rz = math.atan2(-rotation[1, 2], rotation[1, 1]), 0.0
    return math.degrees(rx), math.degrees(ry), math.degrees(rz)


def plane_placement(rectangle: Rectangle, position: tuple[float, float, float],
                    rotation: tuple[float, float, float],
                    scale: float) -> tuple[tuple[float, float, float], tuple[float, float, float]] | None:
    """The plane's position and rotation under a TOML placement (uniform `scale`), or None where
    the Euler angles do not rebuild the rotation (they always should: a guard, not a rule)."""
    rx, ry, rz = rotation
    outer = axis_rotation(2, rz) @ axis_rotation(1, ry) @ axis_rotation(0, rx)
    turn = outer @ rectangle.axes
    angles = euler_degrees(turn)
    rebuilt = axis_rotation(2, angles[2]) @ axis_rotation(1, angles[1]) @ axis_rotation(0, angles[0])
    if np.abs(rebuilt - turn).max() > 1e-9:
        return None
    where = np.asarray(position, np.float64) + scale * (outer @ rectangle.centre)
    return (float(where[0]), float(where[1]), float(where[2])), angles
