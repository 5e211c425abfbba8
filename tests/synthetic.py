"""Depth images made by hand from analytic surfaces, for the hard cases and the fuzzer.

Every sample is the exact intersection of the pixel centre's eye ray with the surface (what a
rasterizer computes, without its rounding), so the right answer for a ray is known in closed form.
"""

from __future__ import annotations

from collections.abc import Callable

import moderngl
import numpy as np

from depthimpostor.oracles import reference
from depthimpostor.constants import BACKGROUND_DEPTH, Algorithm
from depthimpostor.oracles.ray_query import query_depth_images
from depthimpostor.ppc import PPC
from depthimpostor.gpu.shaders import ProgramCache

#: The eye looks down -Z from the origin; w is the distance along the axis (the image plane is at 1).
EYE = np.zeros(3)


def camera(width: int = 64, height: int = 48, near: float = 1.0, far: float = 10.0, fov: float = 40.0) -> PPC:
    return PPC.look_at(EYE, [0.0, 0.0, -1.0], [0.0, 1.0, 0.0], fov, width, height, near, far)


def pixel_centres(cam: PPC) -> tuple[np.ndarray, np.ndarray]:
    return np.meshgrid(np.arange(cam.width) + 0.5, np.arange(cam.height) + 0.5)


def plane_w(cam: PPC, point: np.ndarray, normal: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """w of the plane through `point` with `normal` along the eye rays through (u, v)."""
    direction = cam.ray_direction(u, v)  # its w component is 1, so the ray parameter is w
    with np.errstate(divide="ignore", invalid="ignore"):
        return (np.dot(point - cam.C, normal)) / (direction @ normal)


def image_from_w(
    cam: PPC,
    front_w: np.ndarray,
    back_w: np.ndarray | None = None,
    color: tuple[float, float, float] = (0.8, 0.4, 0.2),
    object_id: int = 0,
) -> reference.DepthImageData:
    """A depth image of surfaces at depth front_w (NaN or outside [near, far]: nothing there), with
    a back face at back_w (None: as thin as it looks; NaN: no back face)."""

    def depth(w: np.ndarray) -> np.ndarray:
        valid = np.isfinite(w) & (w > cam.w_near) & (w < cam.w_far)
        return np.where(valid, cam.opengl_depth(np.where(valid, w, 1.0)), BACKGROUND_DEPTH).astype(np.float32)

    front = depth(front_w)
    back = None if back_w is None else np.where(front < BACKGROUND_DEPTH, depth(back_w), BACKGROUND_DEPTH)
    colors = np.broadcast_to(np.asarray(color, float), (*front.shape, 3)).copy()
    return reference.DepthImageData(cam, colors, front, object_id, None if back is None else back.astype(np.float32))


def plane_image(
    cam: PPC, point: tuple[float, float, float], normal: tuple[float, float, float],
    thickness: float | None = None, mask: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
    object_id: int = 0,
) -> reference.DepthImageData:
    """A plane (only where mask(u, v) holds), `thickness` deep along the eye rays (in w)."""
    u, v = pixel_centres(cam)
    w = plane_w(cam, np.asarray(point, float), np.asarray(normal, float), u, v)
    w = np.where(w > 0, w, np.nan)
    if mask is not None:
        w = np.where(mask(u, v), w, np.nan)
    back = None if thickness is None else w + thickness
    return image_from_w(cam, w, back, object_id=object_id)


def both(
    ctx: moderngl.Context, programs: ProgramCache, images: list[reference.DepthImageData],
    origins: np.ndarray, directions: np.ndarray, algorithm: Algorithm = Algorithm.OPTIMIZED,
) -> tuple[reference.RayHits, reference.RayHits]:
    """(GPU, numpy reference) answers for the same rays and depth images."""
    origins = np.atleast_2d(np.asarray(origins, float))
    directions = np.atleast_2d(np.asarray(directions, float))
    gpu = query_depth_images(ctx, programs, images, origins, directions, algorithm)
    expected = reference.nearest_depth_image_hit(images, origins, directions, algorithm)
    return gpu, expected


def assert_same_hits(hierarchical: reference.RayHits, linear: reference.RayHits) -> None:
    """The hierarchical traversal against the linear march on the same rays: the same hit or miss
    for every ray and the same hit point (the same step code ran), everything finite."""
    differ = hierarchical.hit != linear.hit
    assert not differ.any(), f"{int(differ.sum())} rays differ (first: ray {int(np.argmax(differ))})"
    hit = linear.hit
    assert np.allclose(hierarchical.t[hit], linear.t[hit], rtol=1e-6, atol=1e-7)
    assert np.allclose(hierarchical.image_position[hit], linear.image_position[hit], atol=1e-4)
    assert np.array_equal(hierarchical.object_id, linear.object_id)
    assert_finite_hits(hierarchical)


def assert_finite_hits(hits: reference.RayHits) -> None:
    for name in ("t", "image_position", "color"):
        value = getattr(hits, name)
        assert np.isfinite(value).all(), f"{name} has NaN or Inf"
