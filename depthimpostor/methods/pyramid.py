"""The min/max depth pyramid of the hierarchical traversal, built on the GPU after each bake.

Level 0 is the depth image itself. Texel c of level L >= 1 holds (the nearest visible surface,
the farthest back of a solid run) over the image's texels [c 2^L - 1, (c + 1) 2^L] on each axis,
clipped to the image: its own 2^L x 2^L block grown by one texel on every side; background texels
add nothing (an empty span is (EMPTY_SPAN_MIN, EMPTY_SPAN_MAX)). The traversal
(lib/depth_image.glsl) skips a span of the march's samples when all their texels lie in one such
footprint and the ray's depth over the span cannot meet [min, max].

Why grown by a texel: consecutive samples of the march are at most one texel apart, so the
samples from one inside a block to the first one beyond it (the step that leaves the block
included) all fall in the grown footprint, and one texel read decides the whole span. The grown
footprints of a level are exactly the unions of their 2 x 2 children's, so every level above the
first is a plain 2 x 2 reduction of the one below; level 1 reads the 4 x 4 image texels under its
footprint. One compute dispatch per level, over every image at once.

Layout: one RG32F texture with mip levels, mip m holding level m + 1 of every image. Each image
owns a slot of 2^(M-1) x 2^(M-1) mip-0 texels (M: the coarse levels of the atlas's largest
image) on the atlas's grid, so that at mip m its texels start at (slot origin >> m) and no two
images share a texel at any level, whatever their sizes (odd ones included). The padding costs
at most a factor of 4 over the images' own coarse texels (none for powers of two); all levels
together are a third of the float atlas for powers of two.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import moderngl
import numpy as np

from ..gpu.bindings import ImageUnit, StorageBuffer, TextureUnit
from ..errors import ContextError
from ..node import Frame, GraphFacts, Node, Pass
from ..gpu.shaders import ProgramCache
from ..gpu.uniforms import bind_texture, write

PYRAMID_PROGRAM = "depth_pyramid.comp"
#: Compute shaders and image load/store arrived with GL 4.3.
REQUIRED_GL_VERSION = 430
#: Texture unit of the pyramid in the mirror shader (after the atlas's colour and depth).
#: Tile table binding of the build shader.
#: The build shader's work-group edge (local_size_x and _y in depth_pyramid.comp).
_GROUP = 8
#: GL_RG32F, the image format of the atlas's depth layers and of the pyramid.
_RG32F = 0x8230


def coarse_levels(width: int, height: int) -> int:
    """The levels above an image's own texels, up to the one whose single texel covers it."""
    return max(0, math.ceil(math.log2(max(width, height, 1))))


def level_size(width: int, height: int, level: int) -> tuple[int, int]:
    """Texels of an image's level (every level halves, rounding up)."""
    return -(-width // 2**level), -(-height // 2**level)


@dataclass(frozen=True)
class PyramidLayout:
    """Where each atlas slot's pyramid lives: slots on the atlas's grid, each `pitch` mip-0
    texels wide (the largest image's first coarse level, rounded up to a power of two)."""

    columns: int
    rows: int
    levels: int  # mips of the texture: the coarse levels of the largest image

    @classmethod
    def of_grid(cls, columns: int, rows: int, resolution: int) -> PyramidLayout:
        return cls(columns, rows, coarse_levels(resolution, resolution))

    @property
    def pitch(self) -> int:
        return 2 ** (self.levels - 1) if self.levels else 0

    @property
    def size(self) -> tuple[int, int]:
        return max(1, self.columns * self.pitch), max(1, self.rows * self.pitch)

    def entry(self, slot: int, width: int, height: int) -> tuple[int, int, int]:
        """The record's `pyramid` of the image in `slot`: its mip-0 origin and its coarse levels."""
        return (slot % self.columns) * self.pitch, (slot // self.columns) * self.pitch, coarse_levels(width, height)


def pyramid_bytes(layout: PyramidLayout, tiles: int) -> int:
    """GPU memory of a pyramid: its RG32F texture's mips (GL halves each level, rounding down,
    to no less than 1) and the tile table of `tiles` ivec4 (16 bytes when empty)."""
    width, height = layout.size
    texels = sum(max(1, width >> m) * max(1, height >> m) for m in range(max(1, layout.levels)))
    return texels * 8 + max(1, tiles) * 16


class DepthPyramid:
    """The pyramid texture of one atlas, and the compute pass that fills it from the depth layers.
    methods/colour_mips.py's ColourMips is the same slot layout and build loop over the colours."""

    PROGRAM: str = PYRAMID_PROGRAM
    #: The texture's channels and its image format in the build shader.
    COMPONENTS = 2
    FORMAT = _RG32F
    #: The mirror shader's sampler of it, and its texture unit.
    SAMPLER = "u_impostor_pyramid"
    UNIT = TextureUnit.PYRAMID
    #: What needs it, for the message when the context cannot build it.
    PURPOSE = "the hierarchical algorithm builds its depth pyramid"
    REMEDY = "use the optimized algorithm"

    def __init__(
        self, ctx: moderngl.Context, programs: ProgramCache, layout: PyramidLayout, tiles: Sequence[tuple[int, int, int, int]]
    ) -> None:
        """`tiles` are the atlas tiles (x, y, width, height) of the images in slot order."""
        if ctx.version_code < REQUIRED_GL_VERSION:
            raise ContextError(
                f"{self.PURPOSE} with compute shaders, which need OpenGL "
                f"{REQUIRED_GL_VERSION // 100}.{REQUIRED_GL_VERSION % 100 // 10}; this context has "
                f"{ctx.version_code // 100}.{ctx.version_code % 100 // 10}: {self.REMEDY}"
            )
        self.ctx = ctx
        self.layout = layout
        self.tile_count = len(tiles)
        self.program = programs.compute(self.PROGRAM)
        self.texture = ctx.texture(layout.size, self.COMPONENTS, dtype="f4" if self.COMPONENTS == 2 else "f2")
        # Allocates mips 1.. (their contents are overwritten by `build`) and sets the texture's
        # level range, so that texelFetch may read every level.
        self.texture.build_mipmaps(0, max(0, layout.levels - 1))
        self.texture.filter = (moderngl.NEAREST_MIPMAP_NEAREST, moderngl.NEAREST)
        self.tiles = ctx.buffer(np.asarray(tiles, np.int32).reshape(-1, 4).tobytes() or bytes(16))
        self.builds = 0

    @property
    def bytes(self) -> int:
        return pyramid_bytes(self.layout, self.tile_count)

    def bind_first_source(self, source: moderngl.Texture) -> None:
        """Level 1's source (the depth layers), for the build shader."""
        source.bind_to_image(ImageUnit.PYRAMID_SOURCE, read=True, write=False, level=0, format=self.FORMAT)

    def build(self, source: moderngl.Texture) -> None:
        """Fill every level from the atlas texture `source` (the depth layers), which holds the
        images just baked."""
        program = self.program
        self.tiles.bind_to_storage_buffer(StorageBuffer.PYRAMID_TILES)
        write(program, "u_tile_count", self.tile_count)
        write(program, "u_columns", self.layout.columns)
        write(program, "u_slot_pitch", self.layout.pitch)
        width, height = self.layout.size
        for level in range(1, self.layout.levels + 1):
            if level == 1:
                self.bind_first_source(source)
            else:
                self.texture.bind_to_image(ImageUnit.PYRAMID_SOURCE, read=True, write=False, level=level - 2,
                                           format=self.FORMAT)
            self.texture.bind_to_image(ImageUnit.PYRAMID_TARGET, read=False, write=True, level=level - 1,
                                       format=self.FORMAT)
            write(program, "u_level", level)
            mip_width, mip_height = max(1, width >> (level - 1)), max(1, height >> (level - 1))
            program.run(-(-mip_width // _GROUP), -(-mip_height // _GROUP))
            # Image stores are not coherent with later reads: the next level reads this one
            # through imageLoad, and the mirror shader through texelFetch.
            self.ctx.memory_barrier()
        self.builds += 1

    def bind(self, program: moderngl.Program) -> None:
        bind_texture(program, self.SAMPLER, self.texture, self.UNIT)

    def read_level(self, level: int) -> np.ndarray:
        """Level `level` >= 1 of the whole texture as (rows, columns, channels) float32 (tests)."""
        width, height = self.layout.size
        mip = level - 1
        shape = (max(1, height >> mip), max(1, width >> mip), self.COMPONENTS)
        dtype = np.float32 if self.COMPONENTS == 2 else np.float16
        return np.frombuffer(self.texture.read(level=mip), dtype).reshape(shape).astype(np.float32)

    def release(self) -> None:
        self.tiles.release()
        self.texture.release()


class PyramidsNode(Node):
    """The graph's pyramid node: the depth images' min/max pyramids, built after each bake
    (methods/impostors.py's `build_pyramids`)."""

    stage = Pass.PYRAMIDS
    when = "after each bake"
    bakes = True

    @staticmethod
    def reads(facts: GraphFacts) -> tuple[str, ...]:
        return ("baked images", *facts.made("bounce images"))

    @staticmethod
    def writes(facts: GraphFacts) -> tuple[str, ...]:
        return ("depth pyramids",)

    def stale(self) -> bool:  # follows the stand-in's images: stale when any of them is
        return self.graph.impostors is not None and self.graph.stand_in_stale()

    def run(self, frame: Frame) -> bool:
        impostors = self.graph.impostors
        if impostors is None or impostors.pyramid is None:
            return False
        impostors.build_pyramids()
        return True
