"""Where a soft shadow's rays go: points of the light's disk, the same in GLSL and in the truth.

A spherical light of radius r seen from a point P is a disk of radius r facing P. Soft shadows
send SOFT_SHADOW_RAYS rays from P to fixed points of that disk (a Vogel spiral: even coverage
with no clumps for any count) in a frame built from the direction to the light alone, so that
the renderer (lib/shadows.glsl) and the ray-traced truth (oracles/truth.py) test the very same rays and
differ only in what they test them against: a depth image, or the real triangles.
"""

from __future__ import annotations

import math

import numpy as np

from .constants import SOFT_SHADOW_RAYS
from .scene.model import Light

def toward_light(light: Light, positions: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """lib/shading.glsl's toward_light in numpy: the unit direction from each of `positions` toward
    `light` (a point light at the position itself: the normal), for every shading function."""
    if light.type == "directional":
        return np.broadcast_to(-np.asarray(light.direction, float) / np.linalg.norm(light.direction), positions.shape)
    offset = np.asarray(light.position, float) - positions
    length = np.linalg.norm(offset, axis=1, keepdims=True)
    return np.where(length > 1e-20, offset / np.maximum(length, 1e-300), normals)


#: The golden angle: successive spiral points turn by it, so no two line up.
GOLDEN_ANGLE = math.pi * (3.0 - math.sqrt(5.0))


def soft_shadow_disk(count: int = SOFT_SHADOW_RAYS) -> np.ndarray:
    """(count, 2) points of the unit disk: point k at radius sqrt((k + 0.5) / count), angle k times
    the golden angle, so each covers an equal share of the disk's area."""
    k = np.arange(count, dtype=float)
    radius = np.sqrt((k + 0.5) / count)
    return np.stack([radius * np.cos(k * GOLDEN_ANGLE), radius * np.sin(k * GOLDEN_ANGLE)], axis=1)


def soft_shadow_disk_glsl() -> str:
    """The disk as a GLSL constant array (shaders/generated/soft_shadow_disk.glsl)."""
    points = ", ".join(f"vec2({x!r}, {y!r})" for x, y in soft_shadow_disk().astype(np.float32).tolist())
    return f"const vec2 SOFT_SHADOW_DISK[{SOFT_SHADOW_RAYS}] = vec2[]({points});\n"


def orthonormal_basis(normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors completing each unit normal (n, 3) to a right-handed frame, with no branch
    but a sign: Duff et al., "Building an Orthonormal Basis, Revisited" (JCGT 2017). It is
    continuous except across n.z = 0 and exact to rounding for every n, which a cross product
    with a fixed axis is not near that axis."""
    x, y, z = normals[:, 0], normals[:, 1], normals[:, 2]
    sign = np.where(z >= 0.0, 1.0, -1.0)
    a = -1.0 / (sign + z)
    b = x * y * a
    first = np.stack([1.0 + sign * x * x * a, sign * b, -sign * x], axis=1)
    second = np.stack([b, sign + y * y * a, -y], axis=1)
    return first, second


def light_sample_points(centre: np.ndarray, radius: float, points: np.ndarray) -> np.ndarray:
    """(n, SOFT_SHADOW_RAYS, 3): the points of the light's disk, as seen from each of `points`
    (n, 3), that soft-shadow rays aim at."""
    toward = np.asarray(centre, float) - points
    length = np.linalg.norm(toward, axis=1, keepdims=True)
    toward = np.where(length > 1e-20, toward / np.maximum(length, 1e-300), [0.0, 1.0, 0.0])
    first, second = orthonormal_basis(toward)
    disk = soft_shadow_disk() * radius
    return centre + disk[None, :, 0, None] * first[:, None, :] + disk[None, :, 1, None] * second[:, None, :]
