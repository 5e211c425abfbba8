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

from functools import cached_property

import moderngl
import numpy as np

from ..constants import MAX_DEPTH_IMAGES_PER_REFLECTOR
from ..geometry import ObjectGeometry
from .baked_images import BakedImages, SecondLayer
from ..gpu.uniforms import write


class BillboardPass(BakedImages):
    second_layer = SecondLayer.NONE
    image_noun = "billboard"

    def _forget_fits(self) -> None:
        self.__dict__.pop("quad_depths", None)  # the cached property below

    @cached_property
    def quad_depths(self) -> dict[int, np.ndarray]:
        """Per mirror, each quad's plane as the camera depth w of its object's centre (w is
        constant on planes parallel to the image plane: this one faces the mirror's centre)."""
        quad_depths = {}
        for index, images in self.images_by_reflector.items():
            depths = np.zeros(MAX_DEPTH_IMAGES_PER_REFLECTOR, np.float32)
            depths[: len(images)] = [image.camera.camera_coordinates(image.target.bounding_sphere[0])[2] for image in images]
            quad_depths[index] = depths
        return quad_depths

    def bind_reflector(self, program: moderngl.Program, mirror: ObjectGeometry) -> None:
        super().bind_reflector(program, mirror)
        write(program, "u_billboard_w", self.quad_depths[mirror.index])
