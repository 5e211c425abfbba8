"""The GPU ray query: the mirror shader's own intersection code, run on arrays of rays.

Each ray is one pixel of an off-screen float framebuffer; ray_query.frag includes the same
lib/reflected_scene.glsl as reflector.frag and returns the fields of `reference.RayHits`, so that
the GLSL can be tested against the numpy reference on thousands of rays.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import moderngl
import numpy as np
from numpy.typing import NDArray

from ..gpu.gl_state import NO_DEPTH_TEST, raster_state
from ..gpu.bindings import TextureUnit
from ..constants import DEPTH_IMAGE_DTYPE, Algorithm, Method, depth_image_capacity, depth_image_defines
from ..gpu.context import bind_default_framebuffer
from ..methods.atlas import ImpostorAtlas, bind_image_records, bind_impostors, record_table
from ..passes.reflectors import reflection_defines
from ..methods.pyramid import DepthPyramid
from ..methods.registry import METHODS
from ..gpu.uniforms import write
from .reference import DepthImageData, RayHits
from ..gpu.shaders import ProgramCache

#: Rays per row of the query framebuffer.
_ROW = 1024
#: Texture units of the ray inputs (after every unit the reflected-scene chunks use).


class QueriedImage(Protocol):
    """A depth image in an atlas: where (x, y, width, height), and its std140 record."""

    @property
    def tile(self) -> tuple[int, int, int, int]: ...

    def record(self) -> NDArray[np.void]: ...


class RayQuery:
    """Intersect rays with a set of depth images (nearest hit wins), on the GPU."""

    def __init__(
        self,
        ctx: moderngl.Context,
        programs: ProgramCache,
        atlas: ImpostorAtlas,
        images: Sequence[QueriedImage],
        algorithm: Algorithm = Algorithm.OPTIMIZED,
    ) -> None:
        """`images` are the atlas's depth images to intersect. The hierarchical algorithm builds
        their depth pyramids here, from the atlas as it is now."""
        if not images:
            raise ValueError("a ray query takes at least one depth image")
        self.capacity = depth_image_capacity(len(images))
        self.ctx = ctx
        self.atlas = atlas
        self.image_count = len(images)
        # TRACK_UNSEEN: the query reports what each answer rests on that the images do not hold.
        defines = {**reflection_defines(METHODS[Method.DEPTH].defines(algorithm)), "TRACK_UNSEEN": 1,
                   **depth_image_defines(self.capacity)}
        self.defines = defines
        self.program = programs.get("fullscreen.vert", "ray_query.frag", defines)
        self.records = np.zeros(self.capacity, dtype=DEPTH_IMAGE_DTYPE)
        for i, image in enumerate(images):
            self.records[i] = image.record()
        self.vertex_array = ctx.vertex_array(self.program, [])
        self.pyramid: DepthPyramid | None = None
        if algorithm.builds_pyramids:
            tiles = [(0, 0, 0, 0)] * atlas.slot_count  # an empty tile: a slot left out has no pyramid
            for image in images:
                tiles[atlas.slot_of(image.tile)] = image.tile
            self.pyramid = DepthPyramid(ctx, programs, atlas.pyramid_layout, tiles)
            self.pyramid.build(atlas.depth_layers())

    def run(self, origins: np.ndarray, directions: np.ndarray) -> RayHits:
        count = len(origins)
        width, height = min(count, _ROW), max(1, math.ceil(count / _ROW))
        padded = width * height

        def texture(rays: np.ndarray) -> moderngl.Texture:
            data = np.zeros((padded, 4), np.float32)
            data[:count, :3] = rays
            result = self.ctx.texture((width, height), 4, data.tobytes(), dtype="f4")
            result.filter = (moderngl.NEAREST, moderngl.NEAREST)
            return result

        inputs = [texture(origins), texture(directions)]
        # The table's lists of candidates by ray (where it holds them) are for rays starting in one
        # sphere: a mirror's rays start on it; these start in the sphere around their origins.
        centre = 0.5 * (origins.min(axis=0) + origins.max(axis=0)) if count else np.zeros(3)
        radius = float(np.linalg.norm(origins - centre, axis=1).max()) if count else 0.0
        records = self.ctx.buffer(record_table(self.records, self.image_count, self.capacity, (centre, radius), True))
        outputs = [self.ctx.texture((width, height), 4, dtype="f4") for _ in range(3)]
        framebuffer = self.ctx.framebuffer(outputs)
        try:
            framebuffer.use()
            framebuffer.clear()
            bind_impostors(self.program, self.atlas)
            if self.pyramid is not None:
                self.pyramid.bind(self.program)
            inputs[0].use(TextureUnit.RAY_ORIGINS)
            inputs[1].use(TextureUnit.RAY_DIRECTIONS)
            write(self.program, "u_ray_origins", TextureUnit.RAY_ORIGINS)
            write(self.program, "u_ray_directions", TextureUnit.RAY_DIRECTIONS)
            write(self.program, "u_depth_image_count", self.image_count)
            bind_image_records(records, self.capacity)
            with raster_state(self.ctx, NO_DEPTH_TEST):
                self.vertex_array.render(moderngl.TRIANGLES, vertices=3)
            hit, color, stats = (
                np.frombuffer(framebuffer.read(components=4, attachment=i, dtype="f4"), np.float32)
                .reshape(padded, 4)[:count].astype(np.float64)
                for i in range(3)
            )
        finally:
            bind_default_framebuffer(self.ctx)
            framebuffer.release()
            records.release()
            for image in (*outputs, *inputs):
                image.release()
        return RayHits(
            hit=hit[:, 0] > 0.5,
            t=hit[:, 1],
            image_position=hit[:, 2:4],
            color=color[:, :3],
            object_id=np.rint(color[:, 3]).astype(np.int64),
            samples=np.rint(stats[:, 0]).astype(np.int64),
            # Diagnostics of the reference's float64 march; the GPU does not compute them.
            conditioning=np.full(count, np.nan),
            texel_margin=np.full(count, np.nan),
            depth_margin=np.full(count, np.nan),
            # The shader's UNBOUNDED_RAY (nothing unseen) is the reference's inf.
            unseen_t=np.where(stats[:, 1] >= 1e38, np.inf, stats[:, 1]),
            unseen=np.rint(stats[:, 2]).astype(np.int64),
        )

    def release(self) -> None:
        if self.pyramid is not None:
            self.pyramid.release()
        self.vertex_array.release()


@dataclass(frozen=True)
class _UploadedImage:
    data: DepthImageData
    tile_origin: tuple[int, int]
    pyramid: tuple[int, int, int]

    @property
    def tile(self) -> tuple[int, int, int, int]:
        return (*self.tile_origin, self.data.camera.width, self.data.camera.height)

    def record(self) -> NDArray[np.void]:
        return self.data.camera.depth_image_record(self.data.object_id, self.tile_origin, self.pyramid)


def query_depth_images(
    ctx: moderngl.Context,
    programs: ProgramCache,
    images: Sequence[DepthImageData],
    origins: np.ndarray,
    directions: np.ndarray,
    algorithm: Algorithm = Algorithm.OPTIMIZED,
) -> RayHits:
    """Intersect rays with depth images given as data (hand-made or read back) on the GPU: the
    images go into an atlas of their own, so the GLSL sees exactly the texels the reference sees."""
    resolution = max(max(image.depth.shape) for image in images)
    # Back colours always (alpha 0 for an image without): the march reads them for every depth image.
    atlas = ImpostorAtlas(ctx, len(images), resolution, back_colors=True, beyond=True)
    query = None
    try:
        uploaded = []
        for slot, image in enumerate(images):
            atlas.write(atlas.tile_origin(slot), image)
            pyramid = atlas.pyramid_layout.entry(slot, image.camera.width, image.camera.height)
            uploaded.append(_UploadedImage(image, atlas.tile_origin(slot), pyramid))
        query = RayQuery(ctx, programs, atlas, uploaded, algorithm)
        return query.run(np.asarray(origins, float), np.asarray(directions, float))
    finally:
        if query is not None:
            query.release()
        atlas.release()
