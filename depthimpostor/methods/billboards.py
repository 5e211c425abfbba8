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

import numpy as np
from numpy.typing import NDArray

from .atlas import DepthImage
from .baked_images import BakedImages, SecondLayer


class BillboardPass(BakedImages):
    second_layer = SecondLayer.NONE
    image_noun = "billboard"
    lists_over_bounds = True

    def image_records(self, images: list[DepthImage]) -> NDArray[np.void]:
        """The depth images' records, each with its quad's plane in `a.w` (lib/billboard.glsl):
        the camera depth w of its object's centre (w is constant on planes parallel to the image
        plane: this one faces the mirror's centre)."""
        records = super().image_records(images)
        if images:  # PPC.camera_coordinates of each centre, all at once (each camera's own matmul, to the bit)
            cameras = [image.camera for image in images]
            inverse = np.linalg.inv(np.stack([np.column_stack([camera.a, camera.b, camera.c]) for camera in cameras]))
            offsets = np.stack([np.asarray(image.target.bounding_sphere[0], np.float64) - image.camera.C for image in images])
            records["a"][:len(images), 3] = np.matmul(offsets[:, None, :], inverse.transpose(0, 2, 1))[:, 0, 2]
        return records
