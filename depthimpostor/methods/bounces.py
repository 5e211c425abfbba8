"""Mirrors in mirrors (render.max_bounces > 1): depth images of mirrors and glass that show
reflections (and refractions).

A mirror seen in another mirror is a reflected object whose colours depend on where it is seen
from. Its depth image in mirror M's set is baked from M's centre, like every image of M, by
drawing it with the mirror shader itself, its eye at M's centre and its reflected rays traced
against its own images of one bounce fewer. So the images of bounce k show bounce k - 1 (the
lecture's teapots that reflect each other): bounce 2 images read the diffuse objects' images
(level 0), bounce 3 images read bounce 2's, and so on; the frame reads render.max_bounces'.

Glass is drawn the same way, with the GLASS variant and an interior image of it from M's
centre (passes/glass.py), made with the image's own camera right before it is drawn.

Each mirror image is drawn into a one-tile scratch atlas and copied into its atlas tile through
a pixel buffer: drawing into the atlas while its other tiles are read would be a feedback loop,
which GL leaves undefined even for disjoint regions.
"""

from __future__ import annotations

from ..gpu.gl_state import raster_state
from ..constants import BACKGROUND_DEPTH
from ..scene.model import Scene
from ..passes.glass import GlassInterior
from .atlas import DepthImage, ImpostorAtlas, color_mask, mirror_centre
from .baked_images import BakedImages
from ..passes.reflectors import REFLECTORS, bounce_defines, reflector_program, reflector_tint, write_glass
from ..gpu.uniforms import write
from ..node import Frame, GraphFacts, Node, Pass


class BounceBaker:
    """Bakes the images of mirrors (levels 2 and up) of the depth-image method's BakedImages, after
    its others."""

    def __init__(self, images: BakedImages, scene: Scene) -> None:
        self.images = images
        ctx, resolution = images.ctx, images.atlas.resolution
        defines = bounce_defines()
        # A program for mirrors and one for glass (the GLASS variant), each only if shown.
        shown = {image.target.object.is_glass for image in images.depth_images if image.level}
        self.programs = {glass: reflector_program(images.programs, scene, defines, glass)
                         for glass in shown}
        self.interior = GlassInterior(ctx, images.programs, images.meshes, resolution) if True in shown else None
        self.scratch = ImpostorAtlas(ctx, 1, resolution)
        self.transfer = ctx.buffer(reserve=resolution * resolution * 8)  # one tile of RG32F
        # Per (mirror, bounces): the records a mirror drawn into a bounce k image reads (k - 1).
        self.level_buffers = {
            (index, level): images.uniform_buffer(images.images_at(index, level))
            for index in images.images_by_reflector for level in range(1, images.final_level)
        }

    def bake(self) -> int:
        """The stale mirror images, level by level (level k reads level k - 1); returns draw calls."""
        draws = 0
        for level in range(2, self.images.final_level + 1):
            for image in self.images.depth_images:
                if image.level == level and image.slot in self.images.stale:
                    draws += self._bake(image)
        return draws

    def _bake(self, image: DepthImage) -> int:
        images, framebuffer = self.images, self.scratch.framebuffer
        shown = image.target
        program = self.programs[shown.object.is_glass]
        draws = 0
        if self.interior is not None and shown.object.is_glass:
            draws += self.interior.bake(shown, image.camera)
            self.interior.bind(program)
            write_glass(program, shown)
        tile = (0, 0, image.camera.width, image.camera.height)
        framebuffer.use()
        framebuffer.viewport = tile
        framebuffer.color_mask = color_mask(2, (True,) * 4, (True,) * 4)
        framebuffer.clear(BACKGROUND_DEPTH, BACKGROUND_DEPTH, 1.0, 0.0, depth=BACKGROUND_DEPTH, viewport=tile)
        framebuffer.color_mask = color_mask(2, (True,) * 4, (True, False, False, False))
        images.bind(program)
        below = image.level - 1
        images.bind_records(self.level_buffers[(shown.index, below)])
        write(program, "u_depth_image_count", len(images.images_at(shown.index, below)))
        write(program, "u_eye", tuple(mirror_centre(image.mirror)))
        write(program, "u_tint", reflector_tint(shown))
        write(program, "u_mirror_id", shown.index)
        with raster_state(images.ctx, REFLECTORS):  # the image's flip, for the mirror's backing
            images.meshes.draw(program, shown, image.camera.view_projection)
        draws += 1 + images.bake_back_faces(image, framebuffer, tile)
        framebuffer.color_mask = color_mask(2, (True,) * 4, (True,) * 4)
        self._copy(tile, image.tile)
        images.baked(image)
        return draws

    def _copy(self, source: tuple[int, int, int, int], destination: tuple[int, int, int, int]) -> None:
        """The scratch tile into the atlas tile, on the GPU (a pixel buffer)."""
        atlas, framebuffer = self.images.atlas, self.scratch.framebuffer
        for attachment, texture, components, dtype in ((0, atlas.color, 4, "f1"), (1, atlas.depth_layers(), 2, "f4")):
            framebuffer.read_into(self.transfer, viewport=source, components=components, attachment=attachment, dtype=dtype)
            texture.write(self.transfer, viewport=destination)

    @property
    def bytes(self) -> int:
        interior = self.interior.bytes if self.interior is not None else 0
        return self.scratch.bytes + self.transfer.size + sum(b.size for b in self.level_buffers.values()) + interior

    def release(self) -> None:
        for buffer in self.level_buffers.values():
            buffer.release()
        self.transfer.release()
        self.scratch.release()
        if self.interior is not None:
            self.interior.release()


class BouncesNode(Node):
    """The graph's bounce node: the depth method's stale images of reflectors in reflectors, after
    its other images (methods/impostors.py's `bake_bounces`)."""

    stage = Pass.BOUNCES
    when = "once; again when an image it shows is re-baked"
    bakes = True

    @staticmethod
    def reads(facts: GraphFacts) -> tuple[str, ...]:
        return ("baked images", *facts.made("shadow maps", "environment lighting"))

    @staticmethod
    def writes(facts: GraphFacts) -> tuple[str, ...]:
        return ("bounce images",)

    def stale(self) -> bool:  # follows the stand-in's images: stale when any of them is
        return self.graph.impostors is not None and self.graph.stand_in_stale()

    def run(self, frame: Frame) -> bool:
        impostors, stats = self.graph.impostors, self.graph.stats
        if impostors is None:
            return False
        bounces_before, before_counts = impostors.bounce_bakes, impostors.bake_counts.copy()
        stats.draw_calls += impostors.bake_bounces()
        self.graph.count_images(impostors.bake_counts - before_counts)
        return impostors.bounce_bakes != bounces_before
