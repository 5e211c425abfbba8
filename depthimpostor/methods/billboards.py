"""The billboard method: per mirror and reflected object, one textured quad with transparency
(lib/billboard.glsl); the lecture's 8 x 9 scene has 72 of them. The ground, an analytic plane,
is intersected exactly by every method and needs none.

A billboard's texture is the colour of the depth image the depth-image method would bake for the
same pair, and its quad is that image's frustum cut by the plane through the object's
bounding-sphere centre that faces the mirror's centre: the quad faces the mirror through the
object's centre and covers the object's silhouette exactly as seen from there. No float depth is
kept: the quad is all the geometry a billboard has.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..constants import BOUND_MARGIN
from ..ppc import PPC
from .atlas import DepthImage
from .baked_images import BakedImages, SecondLayer


def quad_depths(cameras: Sequence[PPC], centres: NDArray[np.float64]) -> NDArray[np.float64]:
    """The camera depth w of each object's centre ((n, 3)) in its billboard's camera: the plane of
    its quad (w is constant on planes parallel to the image plane; this one faces the mirror's
    centre). PPC.camera_coordinates for all at once, each camera's own matmul, to the bit."""
    a, b, c, eye = (np.array([getattr(camera, name) for camera in cameras], np.float64) for name in "abcC")
    inverse = np.linalg.inv(np.stack([a, b, c], axis=2))  # (a thousand column_stacks took 10 ms)
    offsets = centres - eye
    return np.asarray(np.matmul(offsets[:, None, :], inverse.transpose(0, 2, 1))[:, 0, 2], np.float64)


def quad_hit_bounds(records: NDArray[np.void], cameras: Sequence[PPC],
                    arounds: Sequence[tuple[NDArray[np.float64], float] | None]) -> None:
    """Each billboard's `hit_bound`, in place: a sphere around every point of its quad a ray can
    find opaque. The quad faces the mirror's centre C through the centre c of its object's bounding
    sphere (radius r, at distance d from C), and its opaque texels show the object, whose
    projection from C lies in the cone from C tangent to that sphere: on the quad's plane, within
    r d / sqrt(d^2 - r^2) of c, and a texel's square (opaque where the object covered its centre)
    at most a texel's width beyond. Grown by BOUND_MARGIN, as PPC.hit_bound; the frustum's bound
    where that is smaller, or where the object reaches the mirror's centre (d <= r). Tighter than
    the frustum's sphere (whose far corners a quad never reaches), it lists and bakes for each ray
    only the quads it may see."""
    shown = [(row, around) for row, around in enumerate(arounds) if around is not None]
    if not shown:
        return
    rows = [row for row, _ in shown]
    centres = np.array([around[0] for _, around in shown], np.float64)
    r = np.array([float(around[1]) for _, around in shown])
    shown_cameras = [cameras[row] for row in rows]
    eye, a, b = (np.array([getattr(camera, name) for camera in shown_cameras], np.float64) for name in "Cab")
    d = np.linalg.norm(centres - eye, axis=1)
    texel = (np.linalg.norm(a, axis=1) + np.linalg.norm(b, axis=1)) * quad_depths(shown_cameras, centres)
    with np.errstate(invalid="ignore", divide="ignore"):  # d <= r: no frustum fits such an object
        radius = (r * d / np.sqrt(d * d - r * r) + texel) * (1.0 + BOUND_MARGIN)
    frustum = records["bound"][rows]
    tighter = (d > r) & (radius < frustum[:, 3])
    # Else the frustum's own bound (which holds the quad): not the depth image's hit bound that
    # depth_image_records wrote, the object's sphere and a texel, which a thin object's quad (a
    # rod seen end-on near the mirror's centre) reaches well past.
    records["hit_bound"][rows] = np.where(tighter[:, None], np.column_stack([centres, radius]), frustum)


class BillboardPass(BakedImages):
    second_layer = SecondLayer.NONE
    image_noun = "billboard"

    @classmethod
    def with_hit_bounds(cls, records: NDArray[np.void], cameras: Sequence[PPC],
                        arounds: Sequence[tuple[NDArray[np.float64], float] | None]) -> NDArray[np.void]:
        quad_hit_bounds(records, cameras, arounds)
        return records

    def image_records(self, images: list[DepthImage]) -> NDArray[np.void]:
        """The depth images' records, each with its quad's plane in `a.w` (lib/billboard.glsl,
        quad_depths) and its quad's hit bound (quad_hit_bounds)."""
        cameras = [image.camera for image in images]
        records = self.with_hit_bounds(super().image_records(images), cameras, [image.hit_bound_around for image in images])
        if images:
            centres = np.array([image.target.bounding_sphere[0] for image in images], np.float64)
            records["a"][:len(images), 3] = quad_depths(cameras, centres)
        return records
