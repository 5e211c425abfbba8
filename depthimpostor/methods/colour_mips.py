"""The baked images' prefiltered colour mips, for glossy mirrors' cone tracing (Uludag, "Hi-Z
Screen-Space Cone-Traced Reflections", GPU Pro 5): built on the GPU after each bake, and only in a
scene with a rough mirror (the plan's "colour mips" pass).

Level 0 is the atlas's colour itself. Texel c of level L >= 1 is the average of the image's
texels [c 2^L, (c + 1) 2^L) on each axis, clipped to the image, premultiplied by coverage: RGB
times the share of them the image's objects cover, and that share in A (the atlas's alpha is 1
where an object was drawn, 0 on the background). A lookup divides by A, so that the background
(cleared to black) does not darken an object's silhouette; the cube-map methods, whose faces hold
every reflected object, blend the environment into the uncovered share instead. Every level above
the first is a plain 2 x 2 average of the one below (a child beyond an odd image's edge left out).

Layout: the depth pyramid's (methods/pyramid.py: one RGBA16F texture with mip levels, mip m
holding level m + 1 of every image, each image in its slot at (slot origin >> m)), so the image
records' `pyramid` entry says where both are. RGBA16F: half floats hold an average of 8-bit
colours to better than their own step, at 8 bytes a texel like the pyramid's RG32F.
"""

from __future__ import annotations

import moderngl

from ..gpu.bindings import ImageUnit, TextureUnit
from ..node import Frame, GraphFacts, Node, Pass
from .pyramid import DepthPyramid

COLOUR_MIPS_PROGRAM = "colour_mips.comp"
#: GL_RGBA16F and GL_RGBA8, the image formats of the mips and of the atlas's colour.
_RGBA16F = 0x881A
_RGBA8 = 0x8058


class ColourMips(DepthPyramid):
    """The colour mips of one atlas, and the compute pass that fills them from its colour."""

    PROGRAM = COLOUR_MIPS_PROGRAM
    COMPONENTS = 4
    FORMAT = _RGBA16F
    SAMPLER = "u_impostor_color_mips"
    UNIT = TextureUnit.COLOUR_MIPS
    PURPOSE = "a glossy mirror (roughness > 0) prefilters the baked images' colours"
    REMEDY = "set the mirrors' roughness to 0"

    def bind_first_source(self, source: moderngl.Texture) -> None:
        """Level 1's source, the atlas's RGBA8 colour, on its own image unit: an image unit's
        format must match the shader's declaration, and the levels above read RGBA16F."""
        source.bind_to_image(ImageUnit.COLOUR_ATLAS, read=True, write=False, level=0, format=_RGBA8)


class ColourMipsNode(Node):
    """The graph's colour-mip node: the baked images' colour mips, built after each bake
    (methods/baked_images.py's `build_colour_mips`)."""

    stage = Pass.COLOUR_MIPS
    when = "after each bake"
    bakes = True

    @staticmethod
    def reads(facts: GraphFacts) -> tuple[str, ...]:
        return ("baked images", *facts.made("bounce images"))

    @staticmethod
    def writes(facts: GraphFacts) -> tuple[str, ...]:
        return ("colour mips",)

    def stale(self) -> bool:  # follows the stand-in's images: stale when any of them is
        return self.graph.baked_images is not None and self.graph.stand_in_stale()

    def run(self, frame: Frame) -> bool:
        baked = self.graph.baked_images
        if baked is None or baked.colour_mips is None:
            return False
        baked.build_colour_mips()
        return True
