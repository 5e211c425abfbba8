"""The lecture's sample visualization: every depth image drawn as the cloud of its samples.

Each sample is unprojected in the vertex shader from the atlas (no CPU readback) and drawn as a
point sprite the size of the surface it covers, so that what the mirror shader intersects can be
looked at from any side.
"""

from __future__ import annotations

import moderngl
import numpy as np

from ..gpu.gl_state import RasterState, raster_state
from ..constants import DEPTH_IMAGE_BLOCK_RECORDS, depth_image_defines
from ..ppc import PPC
from ..gpu.shaders import ProgramCache
from ..methods.baked_images import BakedImages
from ..gpu.uniforms import write, write_matrix


class SamplesPass:
    def __init__(self, ctx: moderngl.Context, programs: ProgramCache) -> None:
        self.ctx = ctx
        self.programs = programs
        self._use_variant(DEPTH_IMAGE_BLOCK_RECORDS)

    def _use_variant(self, capacity: int) -> None:
        """The program reading record tables of `capacity` (lib/baked_images.glsl)."""
        self.capacity = capacity
        self.program = self.programs.get("samples.vert", "samples.frag", depth_image_defines(capacity))
        # Every vertex comes from gl_VertexID: the vertex array has no buffers.
        self.vertex_array = self.ctx.vertex_array(self.program, [])

    def draw(self, impostors: BakedImages, camera: PPC) -> int:
        """Draw the samples of every baked image (depth images, cube-map faces) into the bound
        framebuffer; returns the draw calls."""
        if impostors.record_capacity != self.capacity:
            self.vertex_array.release()
            self._use_variant(impostors.record_capacity)
        impostors.bind(self.program)
        write_matrix(self.program, "u_view_projection", camera.view_projection)
        write(self.program, "u_pixel_size", float(np.linalg.norm(camera.b)))
        draws = 0
        with raster_state(self.ctx, RasterState(point_size=True)):
            for mirror_index, images in impostors.images_by_reflector.items():
                impostors.bind_records(impostors.uniform_buffers[mirror_index])
                for index, image in enumerate(images):
                    write(self.program, "u_image_index", index)
                    self.vertex_array.render(moderngl.POINTS, vertices=image.camera.width * image.camera.height)
                    draws += 1
        return draws

    def release(self) -> None:
        self.vertex_array.release()
