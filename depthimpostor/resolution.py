"""`impostor_resolution = "auto"`: each depth image's resolution from what the camera sees of it.

A depth image's sample should cover about one reflected pixel: fewer samples blur and bend what
the mirror shows, more cost bake time, memory and march steps for nothing. How many pixels show
the object in the mirror is measured on the mirror's triangles, from the scene's camera:

- for each front-facing triangle in view, its area on screen (pixels^2) and the solid angle its
  three reflected directions span (Van Oosterom and Strackee's formula for a spherical triangle);
- the triangles whose reflected rays may reach the object (its bounding sphere, widened by the
  spread of the triangle's reflected directions and of its points) give the mirror's density there,
  rho = sqrt(sum of areas / sum of solid angles), in reflected pixels per radian;
- the depth image spans the angle `span` of its fitted frustum, so span * rho samples across it
  put one sample on each reflected pixel. A planar mirror has rho = the camera's pixels per
  radian; a convex one compresses the reflection (a sphere D pixels across gives D / 4 pixels per
  radian at its centre, fewer toward its rim), and so needs fewer samples.

The result is rounded up to a power of two (one to two samples per reflected pixel) and clamped
to [MIN_AUTO_RESOLUTION, MAX_AUTO_RESOLUTION]. It is chosen once, from the scene's camera:
moving the camera re-bakes nothing, so the images keep the resolution the scene's view asked for.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .geometry import ObjectGeometry
from .ppc import PPC
from .scene.model import Scene

#: An object the camera does not see in the mirror still gets a small image (the viewer's camera
#: may find it later); no image needs more than the largest the bench measures.
MIN_AUTO_RESOLUTION = 16
MAX_AUTO_RESOLUTION = 1024


def _unit(vectors: np.ndarray) -> np.ndarray:
    length = np.linalg.norm(vectors, axis=-1, keepdims=True)
    return vectors / np.where(length > 0.0, length, 1.0)


def frustum_span(camera: PPC) -> float:
    """The larger angle (radians) between opposite edges of a camera's image, through its centre."""
    spans = []
    for start, end in (((0.0, camera.height / 2), (camera.width, camera.height / 2)),
                       ((camera.width / 2, 0.0), (camera.width / 2, camera.height))):
        first, second = _unit(camera.ray_direction(*start)), _unit(camera.ray_direction(*end))
        spans.append(math.acos(float(np.clip(first @ second, -1.0, 1.0))))
    return max(spans)


class MirrorDensity:
    """What reflected_pixels_per_radian reads of a mirror's triangles seen from `view`, worked out
    once for every object it is asked about (a mirror may show a thousand): which triangles the
    view sees, their reflected directions' mean and spread, their centroids and extents, their
    areas on screen and solid angles."""

    def __init__(self, view: PPC, mirror: ObjectGeometry) -> None:
        mesh = mirror.world_mesh
        corners = mesh.positions[mesh.indices].astype(np.float64)  # (T, 3, 3)
        normals = _unit(mesh.normals[mesh.indices].astype(np.float64))
        face = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        incoming = _unit(corners - view.C)
        projected = view.project(corners)  # (T, 3, (u, v, w))
        inside = (projected[..., 0] >= 0) & (projected[..., 0] <= view.width) & \
                 (projected[..., 1] >= 0) & (projected[..., 1] <= view.height)
        seen = (np.einsum("tj,tj->t", face, corners[:, 0] - view.C) < 0.0) & np.all(projected[..., 2] > 0.0, axis=1) \
            & np.any(inside, axis=1)
        # Only the triangles the view sees can count: the rest are dropped here, once.
        corners, projected, incoming, normals = corners[seen], projected[seen], incoming[seen], normals[seen]
        reflected = incoming - 2.0 * np.einsum("tij,tij->ti", incoming, normals)[..., None] * normals
        self.mean = _unit(reflected.sum(axis=1))
        self.spread = np.arccos(np.clip(np.einsum("tij,tj->ti", reflected, self.mean), -1.0, 1.0)).max(axis=1)
        self.centroid = corners.mean(axis=1)
        self.extent = np.linalg.norm(corners - self.centroid[:, None], axis=2).max(axis=1)
        uv, r = projected[..., :2], reflected
        edge_1, edge_2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
        self.area = 0.5 * np.abs(edge_1[:, 0] * edge_2[:, 1] - edge_1[:, 1] * edge_2[:, 0])
        triple = np.abs(np.einsum("tj,tj->t", r[:, 0], np.cross(r[:, 1], r[:, 2])))
        denominator = 1.0 + np.einsum("tj,tj->t", r[:, 0], r[:, 1]) + np.einsum("tj,tj->t", r[:, 1], r[:, 2]) \
            + np.einsum("tj,tj->t", r[:, 2], r[:, 0])
        self.solid_angle = 2.0 * np.arctan2(triple, denominator)

    def pixels_per_radian(self, target: ObjectGeometry) -> float:
        """rho for `target` (reflected_pixels_per_radian)."""
        return self.pixels_per_radian_of([target])[0]

    def pixels_per_radian_of(self, targets: Sequence[ObjectGeometry]) -> list[float]:
        """rho for each of `targets`: the angles for a block of them at once, each one's sums over
        its own triangles (the figure pixels_per_radian gives it alone, to the bit)."""
        figures: list[float] = []
        for first in range(0, len(targets), _TARGETS_AT_ONCE):
            block = targets[first:first + _TARGETS_AT_ONCE]
            if not len(self.mean):
                figures += [0.0] * len(block)
                continue
            spheres = [target.bounding_sphere for target in block]
            centres = np.array([centre for centre, _ in spheres], np.float64)
            radii = np.array([radius for _, radius in spheres], np.float64)
            toward = centres[:, None, :] - self.centroid  # (targets, T, 3)
            distance = np.maximum(np.linalg.norm(toward, axis=-1), 1e-300)
            sphere_angle = np.arcsin(np.clip(radii[:, None] / distance, 0.0, 1.0))
            # A ray leaves from anywhere on the triangle, up to `extent` from its centroid: that turns the
            # direction to the sphere's centre by up to asin(extent / distance).
            apex_angle = np.arcsin(np.clip(self.extent / distance, 0.0, 1.0))
            # toward / distance is _unit(toward) to the bit (a zero vector stays zero either way).
            angle = np.arccos(np.clip(np.einsum("ntj,tj->nt", toward / distance[..., None], self.mean), -1.0, 1.0))
            for chosen in angle <= sphere_angle + self.spread + apex_angle:
                total = float(self.solid_angle[chosen].sum()) if chosen.any() else 0.0
                figures.append(math.sqrt(float(self.area[chosen].sum()) / total) if total > 0.0 else 0.0)
        return figures


#: Objects whose angles MirrorDensity works out in one block: (objects, mirror triangles) arrays of
#: about 64 x 5,000 doubles (2.5 MB each) for a mirror sphere's seen half.
_TARGETS_AT_ONCE = 64


def reflected_pixels_per_radian(view: PPC, mirror: ObjectGeometry, target: ObjectGeometry) -> float:
    """rho: screen pixels per radian of reflected direction, over the mirror's triangles that
    `view` sees and whose reflected rays may reach `target`; 0 when there are none. (For many
    objects of one mirror, make its MirrorDensity once.)"""
    return MirrorDensity(view, mirror).pixels_per_radian(target)


def auto_resolution(view: PPC, mirror: ObjectGeometry, target: ObjectGeometry, image: PPC,
                    pixels_per_radian: float | None = None) -> int:
    """The resolution at which a sample of `image` (the depth image of `target` for `mirror`)
    covers about one of `view`'s reflected pixels (see the module's note). `pixels_per_radian`:
    rho, worked out already with the mirror's other images (MirrorDensity.pixels_per_radian_of)."""
    rho = pixels_per_radian if pixels_per_radian is not None else reflected_pixels_per_radian(view, mirror, target)
    samples = frustum_span(image) * rho
    if samples <= MIN_AUTO_RESOLUTION:
        return MIN_AUTO_RESOLUTION
    return int(min(MAX_AUTO_RESOLUTION, 2 ** math.ceil(math.log2(samples))))


def scene_view(scene: Scene) -> PPC:
    """The scene's own camera, as far as projecting points to pixels goes (its near and far
    planes play no part in that)."""
    view = scene.camera
    return PPC.look_at(view.eye, view.target, view.up, view.fov_y, *scene.render.size, 1.0, 2.0)
