"""Which baked images a frame's reflected rays may enter, found before the bake (issue 32: a scene
of 1,000 objects started in under 2 s), so that a frame bakes those alone and leaves the others
stale until a frame's rays may enter them.

The mirror shader reads an image's texels only where the ray enters the image's bound
(lib/reflected_scene.glsl's image_bound; a billboard's quad lies in its bound too), so an image no
ray of a frame enters cannot change a pixel of it: baking only the entered ones gives the frame of
baking them all (bit for bit where each image sits in the same tile; the entered images take the
atlas's first tiles, BakedImages.place, and at another tile the rasterizer may round a texel's
colour one 8-bit level otherwise: tests/test_startup_bakes.py). This pass finds them with the mirror shader's own rays: the
reflectors' surfaces drawn into the frame's surface targets with a stamp of their own and a depth
buffer of their own, behind the depth of the eye's diffuse pass drawn as the frame draws it (the
frame's mirror pixels, no fewer: it is the same draw, and nothing else drawn before the mirrors
can uncover one), then
per mirror, over its screen rectangle, entered_images.frag sets a bit per image whose bound
(widened a little) a pixel's ray enters. At 1,000 objects and 320x180 the rays enter about a
third of the 2,000 images (results/llvmpipe/startup_time.md, fourth pass).

The renderer asks for it only where every pixel's rays are the ones drawn here
(BakedImages.bakes_lazily): no glossy cones, no glass, no bounce images; each sub-frame of an
anti-aliased frame asks with its own camera.
"""

from __future__ import annotations

import moderngl
import numpy as np

from ..constants import depth_image_defines
from ..eye import clear_depth, copy_depth, eye_depth, make_depth_buffer
from ..geometry import ObjectGeometry
from ..gpu.bindings import STORAGE_ENTERED_IMAGES, StorageBuffer, TextureUnit, UniformBlock
from ..gpu.gl_state import NO_DEPTH_TEST, raster_state
from ..gpu.shaders import ProgramCache
from ..gpu.meshes import GpuMeshes
from ..gpu.uniforms import bind_record_block, write
from ..passes.reflectors import REFLECTORS, SURFACE_PROGRAM, Surfaces, screen_rectangle
from ..ppc import PPC

ENTERED_PROGRAM = ("screen_rect.vert", "entered_images.frag")


def entered_defines(capacity: int, whole_bounds: bool) -> dict[str, int]:
    """The marking program of a table of `capacity` records; `whole_bounds` (WHOLE_BOUNDS): the
    images' whole bounds (the methods whose rays read more than the hits:
    BakedImages.lists_over_bounds), else their hit bounds (the depth method's image_bound)."""
    return {**depth_image_defines(capacity), **({"WHOLE_BOUNDS": 1} if whole_bounds else {})}


def words_for(capacity: int) -> int:
    """32-bit words of one mirror's bits."""
    return -(-capacity // 32)


class EnteredImages:
    """The marking pass's program, its bits (a storage buffer of a word per 32 images of each
    mirror) and the depth buffer its surfaces are drawn with."""

    def __init__(self, ctx: moderngl.Context, programs: ProgramCache, meshes: GpuMeshes, capacity: int,
                 mirrors: int, whole_bounds: bool) -> None:
        self.ctx, self.meshes, self.capacity = ctx, meshes, capacity
        self.program = programs.get(*ENTERED_PROGRAM, entered_defines(capacity, whole_bounds))
        self.surface_program = programs.get(*SURFACE_PROGRAM)
        write(self.program, "u_surface_position", TextureUnit.SURFACE_POSITION)
        write(self.program, "u_surface_normal", TextureUnit.SURFACE_NORMAL)
        bind_record_block(self.program, "DepthImages", UniformBlock.DEPTH_IMAGES, StorageBuffer.DEPTH_IMAGES)
        self.words = words_for(capacity)
        self.bits = ctx.buffer(reserve=4 * self.words * max(mirrors, 1))
        self.rectangle = ctx.vertex_array(self.program, [])
        self.depth: moderngl.Renderbuffer | None = None
        self.framebuffer: moderngl.Framebuffer | None = None
        # The marking draws' target: the depth buffer alone (they read the surface targets, which
        # may not be attached where they are read, and write nothing).
        self.marking: moderngl.Framebuffer | None = None

    @staticmethod
    def bytes_for(size: tuple[int, int], capacity: int, mirrors: int) -> int:
        """GPU memory: the bits and the depth buffer (a float a pixel, as the eye's)."""
        return 4 * words_for(capacity) * max(mirrors, 1) + 4 * size[0] * size[1]

    def _target(self, surfaces: Surfaces) -> moderngl.Framebuffer:
        """The surface targets with this pass's own depth buffer (the mirrors drawn here must not
        write the frame's, which the mirror pass tests them against)."""
        size = surfaces.framebuffer.size
        if self.framebuffer is None or self.framebuffer.size != size or self.framebuffer.color_attachments[0] is not \
                surfaces.framebuffer.color_attachments[0]:
            self._release_target()
            self.depth = make_depth_buffer(self.ctx, size)  # the eye's (reversed-Z where the GL has it)
            self.framebuffer = self.ctx.framebuffer(list(surfaces.framebuffer.color_attachments), self.depth)
            self.marking = self.ctx.framebuffer(depth_attachment=self.depth)
        return self.framebuffer

    def find(self, camera: PPC, surfaces: Surfaces, mirrors: list[tuple[ObjectGeometry, moderngl.Buffer, int]],
             behind_frame: bool = False) -> list[np.ndarray]:
        """For each of `mirrors` (the mirror, the buffer of its record table, its image count): the
        indices in its table of the images a pixel's reflected ray through `camera` may enter.
        `behind_frame`: the mirrors are drawn behind the frame's depth as it is now (the eye's
        passes drawn before the mirrors: the render graph runs them before the bake), a copy of
        it, so that a mirror pixel hidden in the frame is hidden here too; without it every pixel
        a mirror covers counts."""
        framebuffer = self._target(surfaces)
        assert self.marking is not None
        stamp = surfaces.next_frame()  # the mirror pass's own draw takes the next: these texels read as cleared
        if behind_frame:  # the frame's depth: surfaces.framebuffer's depth attachment is the frame's
            copy_depth(self.ctx, surfaces.framebuffer, self.marking)
        else:
            self.marking.use()
            self.marking.clear(depth=clear_depth(self.ctx))
        framebuffer.use()
        write(self.surface_program, "u_surface_stamp", stamp)
        # Drawn as the frame's eye passes draw them (their depth convention): the same fragments.
        with eye_depth(self.ctx), raster_state(self.ctx, REFLECTORS):
            for item, _, _ in mirrors:
                write(self.surface_program, "u_mirror_id", item.index)
                self.meshes.draw(self.surface_program, item, camera.view_projection)
        self.marking.use()
        surfaces.use()
        self.bits.clear()
        self.bits.bind_to_storage_buffer(STORAGE_ENTERED_IMAGES)
        write(self.program, "u_surface_stamp", stamp)
        write(self.program, "u_eye", tuple(camera.C))
        with raster_state(self.ctx, NO_DEPTH_TEST):
            for k, (item, records, count) in enumerate(mirrors):
                records.bind_to_storage_buffer(StorageBuffer.DEPTH_IMAGES)
                write(self.program, "u_depth_image_count", count)
                write(self.program, "u_mirror_id", item.index)
                write(self.program, "u_first_word", k * self.words)
                write(self.program, "u_rect", screen_rectangle(item, camera))
                self.rectangle.render(moderngl.TRIANGLE_STRIP, vertices=4)
        self.ctx.memory_barrier(moderngl.BUFFER_UPDATE_BARRIER_BIT)
        words = np.frombuffer(self.bits.read(), np.uint32).reshape(max(len(mirrors), 1), self.words)
        bits = np.unpackbits(words.view(np.uint8), bitorder="little").reshape(len(words), -1)
        return [np.flatnonzero(bits[k, :count]) for k, (_, _, count) in enumerate(mirrors)]

    def _release_target(self) -> None:
        for item in (self.marking, self.framebuffer, self.depth):
            if item is not None:
                item.release()
        self.marking = self.framebuffer = self.depth = None

    def release(self) -> None:
        self._release_target()
        self.rectangle.release()
        self.bits.release()
