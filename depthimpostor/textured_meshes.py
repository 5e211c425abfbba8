"""The round procedural shapes with texture coordinates, for objects that carry an image texture.

meshes.py's sphere, cylinder and torus wrap their closed directions around by index (watertight,
no seam), which leaves no place for the UV jump from 1 back to 0. These variants repeat the seam
column (and give each pole cell its own pole vertex), so they are closed by position but not by
index; only textured objects use them (geometry.mesh_for_shape), so untextured frames keep the
watertight meshes. UVs follow glTF's convention ((0, 0) the image's top-left) and show the image
upright and unmirrored from outside: u runs to the viewer's right (against the angle about +Y,
which turns to the viewer's left seen from outside), v from the top (+Y side) down.
"""

from __future__ import annotations

import numpy as np

from .meshes import Mesh, _fan_triangles, _grid_triangles, _require_at_least, _require_positive, plane_uvs


def _open_grid(positions: np.ndarray, normals: np.ndarray, uvs: np.ndarray) -> tuple[np.ndarray, ...]:
    """(count_a, count_b, ...) grids as flat arrays, with meshes.py's cell triangles, less those of
    no area (a pole row's cells have one)."""
    count_a, count_b = positions.shape[:2]
    flat = positions.reshape(-1, 3)
    indices = _grid_triangles(count_a, count_b, False, False)
    a, b, c = (flat[indices[:, k]] for k in range(3))
    keep = np.linalg.norm(np.cross(b - a, c - a), axis=1) > 1e-12 * max(float(np.abs(flat).max()), 1e-30) ** 2
    return flat, normals.reshape(-1, 3), uvs.reshape(-1, 2), indices[keep]


def _unused_dropped(positions: np.ndarray, normals: np.ndarray, uvs: np.ndarray, indices: np.ndarray) -> Mesh:
    used = np.unique(indices)
    remap = np.zeros(len(positions), np.int64)
    remap[used] = np.arange(len(used))
    return Mesh(positions[used], normals[used], remap[indices], uvs[used])


def sphere(radius: float, segments: int = 96, rings: int = 48) -> Mesh:
    """meshes.sphere's surface with latitude/longitude UVs: u = 1 - phi / 2 pi, v = theta / pi."""
    _require_positive("sphere", radius=radius)
    _require_at_least("sphere", 3, segments=segments)
    _require_at_least("sphere", 2, rings=rings)
    phi = 2.0 * np.pi * np.arange(segments + 1) / segments
    theta = np.pi * np.arange(rings + 1) / rings
    pp, tt = np.meshgrid(phi, theta, indexing="ij")
    normals = np.stack([np.sin(tt) * np.cos(pp), np.cos(tt), np.sin(tt) * np.sin(pp)], axis=-1)
    normals[:, 0], normals[:, -1] = (0.0, 1.0, 0.0), (0.0, -1.0, 0.0)  # exact poles
    uvs = np.stack([1.0 - pp / (2.0 * np.pi), tt / np.pi], axis=-1)
    positions, flat_normals, flat_uvs, indices = _open_grid(radius * normals, normals, uvs)
    return _unused_dropped(positions, flat_normals, flat_uvs, indices)


def cylinder(radius: float, height: float, segments: int = 64) -> Mesh:
    """meshes.cylinder's surface with UVs: the side's u = 1 - phi / 2 pi, v from top to bottom;
    each cap a square image over its disc (the top as a plane seen from above, the bottom seen from
    below)."""
    _require_positive("cylinder", radius=radius, height=height)
    _require_at_least("cylinder", 3, segments=segments)
    phi = 2.0 * np.pi * np.arange(segments + 1) / segments
    radial = np.stack([np.cos(phi), np.zeros_like(phi), np.sin(phi)], axis=-1)
    ends = np.array([0.5 * height, -0.5 * height])
    side = radius * radial[:, None, :] + np.stack([np.zeros(2), ends, np.zeros(2)], axis=-1)[None]
    side_uvs = np.stack(np.broadcast_arrays(1.0 - phi[:, None] / (2.0 * np.pi), np.array([[0.0, 1.0]])), axis=-1)
    parts = [_open_grid(side, np.repeat(radial[:, None, :], 2, axis=1), side_uvs)]
    for y, sign in ((0.5 * height, 1.0), (-0.5 * height, -1.0)):
        rim = radius * radial[:segments] + (0.0, y, 0.0)
        points = np.concatenate([rim, [(0.0, y, 0.0)]])
        uvs = plane_uvs(points, 2.0 * radius, 2.0 * sign * radius)
        ring = np.arange(segments)
        # Increasing phi turns clockwise seen from +Y: the top fan walks the rim backwards.
        fan = _fan_triangles(segments, ring[::-1] if sign > 0 else ring)
        parts.append((points, np.tile((0.0, sign, 0.0), (segments + 1, 1)), uvs, fan))
    offsets = np.cumsum([0] + [len(part[0]) for part in parts[:-1]])
    return Mesh(np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]),
                np.concatenate([p[3] + offset for p, offset in zip(parts, offsets, strict=True)]), np.concatenate([p[2] for p in parts]))


def torus(major: float, minor: float, segments: int = 96, sides: int = 32) -> Mesh:
    """meshes.torus's surface with UVs: u = 1 - (angle about Y) / 2 pi, v = (angle about the
    tube, from the outer equator over the top) / 2 pi."""
    _require_positive("torus", major=major, minor=minor)
    _require_at_least("torus", 3, segments=segments, sides=sides)
    around_tube = 2.0 * np.pi * np.arange(sides + 1) / sides
    around_axis = 2.0 * np.pi * np.arange(segments + 1) / segments
    vv, uu = np.meshgrid(around_tube, around_axis, indexing="ij")
    normals = np.stack([np.cos(vv) * np.cos(uu), np.sin(vv), np.cos(vv) * np.sin(uu)], axis=-1)
    positions = major * np.stack([np.cos(uu), np.zeros_like(uu), np.sin(uu)], axis=-1) + minor * normals
    uvs = np.stack([1.0 - uu / (2.0 * np.pi), vv / (2.0 * np.pi)], axis=-1)
    flat, flat_normals, flat_uvs, indices = _open_grid(positions, normals, uvs)
    return Mesh(flat, flat_normals, indices, flat_uvs)
