"""Baking depth images: every reflected object, seen from the centre of every mirror.

Each (mirror, object) pair gets a depth image whose frustum is fitted to that object alone, so
that all of the image's pixels and all of its depth precision go to it. All depth images live in
one atlas pair (RGBA8 colour; RG32F OpenGL depths of the visible surface and of the nearest back
face behind it), one tile each; each mirror gets a uniform buffer listing its own depth images,
which is all the mirror shader needs.

The back layer costs a second, depth-only draw per image. Without it the depth image knows the
surface but not what lies behind it, and a ray passing behind a silhouette must either be joined
to it by a false "rubber sheet" or fall through the object's hidden side (a hole): see the README's
"Numerical robustness".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import moderngl
import numpy as np

from ..context import bind_default_framebuffer
from ..constants import BACKGROUND_DEPTH, DEPTH_IMAGE_DTYPE, MAX_DEPTH_IMAGES_PER_MIRROR
from ..errors import SceneError
from ..geometry import ObjectGeometry
from ..ppc import PPC, FrustumFitError
from ..reference import DepthImageData
from ..scene.model import Scene
from ..shaders import ProgramCache
from .diffuse import DiffusePass
from .meshes import GpuMeshes
from .uniforms import bind_texture, bind_uniform_block, write


#: Texture units and the uniform-block binding the reflected-scene chunk reads.
COLOR_ATLAS_UNIT = 0
DEPTH_ATLAS_UNIT = 1
DEPTH_IMAGES_BINDING = 0


def bind_impostors(program: moderngl.Program, atlas: ImpostorAtlas) -> None:
    """Point a program that includes lib/reflected_scene.glsl at the depth-image atlas."""
    bind_texture(program, "u_impostor_color", atlas.color, COLOR_ATLAS_UNIT)
    bind_texture(program, "u_impostor_depth", atlas.depth, DEPTH_ATLAS_UNIT)
    bind_uniform_block(program, "DepthImages", DEPTH_IMAGES_BINDING)


@dataclass(frozen=True, eq=False)
class DepthImage:
    """One baked depth image: which mirror and object, its camera, and where it sits in the atlas."""

    mirror: ObjectGeometry
    target: ObjectGeometry
    camera: PPC
    tile_origin: tuple[int, int]

    @property
    def tile(self) -> tuple[int, int, int, int]:
        return (*self.tile_origin, self.camera.width, self.camera.height)

    def record(self) -> np.void:
        return self.camera.depth_image_record(self.target.index, self.tile_origin)


#: The face GL culls to keep the back faces. A depth image's projection puts image row 0 (the top)
#: at window y = 0, a mirror image of GL's usual y-up window: counter-clockwise outward faces
#: arrive clockwise, so GL's "front" faces are the back ones and culling GL's "back" keeps them.
BAKE_CULLS_FRONT_FACES = "back"


def mirror_centre(mirror: ObjectGeometry) -> np.ndarray:
    """The eye of a mirror's depth images: the centre of its bounding sphere."""
    return mirror.bounding_sphere[0]


def fit_depth_image_camera(scene: Scene, mirror: ObjectGeometry, target: ObjectGeometry, resolution: int) -> PPC:
    """The depth image's camera: from the mirror's centre, the tightest frustum around the object."""
    centre, _ = target.bounding_sphere
    try:
        return PPC.fitted(mirror_centre(mirror), target.world_mesh.positions, centre, resolution, resolution)
    except FrustumFitError:
        index = target.index
        raise SceneError(
            scene.source,
            f"objects[{index}]",
            f'object "{target.object.name}" surrounds or touches the centre of mirror "{mirror.object.name}": '
            "no depth-image frustum can be fitted to it; move it away from the mirror's centre",
        ) from None


def atlas_grid(count: int) -> tuple[int, int]:
    """Columns and rows of a near-square grid holding `count` tiles."""
    columns = max(1, math.ceil(math.sqrt(count)))
    return columns, max(1, math.ceil(count / columns))


class ImpostorAtlas:
    """The textures and framebuffer that hold every depth image of the scene."""

    def __init__(self, ctx: moderngl.Context, count: int, resolution: int) -> None:
        columns, rows = atlas_grid(count)
        size = (columns * resolution, rows * resolution)
        limit = ctx.info["GL_MAX_TEXTURE_SIZE"]
        if max(size) > limit:
            raise SceneError(
                "render settings",
                "render.impostor_resolution",
                f"{count} depth images of {resolution}x{resolution} need a {size[0]}x{size[1]} atlas, "
                f"over this GL's limit of {limit}; lower the impostor resolution",
            )
        self.ctx = ctx
        self.columns = columns
        self.resolution = resolution
        self.color = ctx.texture(size, 4, dtype="f1")
        self.depth = ctx.texture(size, 2, dtype="f4")  # (visible surface, nearest back face)
        for texture in (self.color, self.depth):
            texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._depth_buffer = ctx.depth_renderbuffer(size)
        self.framebuffer = ctx.framebuffer([self.color, self.depth], self._depth_buffer)

    @property
    def size(self) -> tuple[int, int]:
        return self.color.size

    @property
    def bytes(self) -> int:
        """GPU memory of the depth images: colour, float depth and the depth buffer used to bake."""
        width, height = self.size
        return width * height * (4 + 8 + 4)

    def tile_origin(self, slot: int) -> tuple[int, int]:
        return (slot % self.columns) * self.resolution, (slot // self.columns) * self.resolution

    def read(self, image: DepthImage) -> DepthImageData:
        """One depth image as the numpy reference takes it (rows top to bottom, colour in [0, 1])."""
        viewport = image.tile
        height, width = viewport[3], viewport[2]
        color = np.frombuffer(self.framebuffer.read(viewport=viewport, components=4, attachment=0), np.uint8)
        layers = np.frombuffer(
            self.framebuffer.read(viewport=viewport, components=2, attachment=1, dtype="f4"), np.float32
        ).reshape(height, width, 2)
        return DepthImageData(
            image.camera, color.reshape(height, width, 4)[..., :3] / 255.0, layers[..., 0].copy(),
            image.target.index, layers[..., 1].copy(),
        )

    def write(self, tile_origin: tuple[int, int], data: DepthImageData) -> None:
        """Store a depth image made elsewhere (tests build exact ones by hand)."""
        height, width = data.depth.shape
        viewport = (*tile_origin, width, height)
        rgba = np.concatenate([np.rint(np.clip(data.color, 0, 1) * 255), np.full((height, width, 1), 255)], axis=2)
        self.color.write(np.ascontiguousarray(rgba, np.uint8).tobytes(), viewport=viewport)
        layers = np.stack([data.depth, data.back_layer], axis=2)
        self.depth.write(np.ascontiguousarray(layers, np.float32).tobytes(), viewport=viewport)

    def release(self) -> None:
        bind_default_framebuffer(self.ctx)
        for item in (self.framebuffer, self._depth_buffer, self.color, self.depth):
            item.release()


class ImpostorPass:
    """Plans, bakes and uploads the depth images of every mirror."""

    def __init__(
        self,
        ctx: moderngl.Context,
        programs: ProgramCache,
        scene: Scene,
        meshes: GpuMeshes,
        mirrors: list[ObjectGeometry],
        reflected: list[ObjectGeometry],
    ) -> None:
        self.ctx = ctx
        self.scene = scene
        self.meshes = meshes
        self.diffuse = DiffusePass(programs, scene, meshes, write_depth_image=True)
        self.back_faces = programs.get("mesh.vert", "back_depth.frag")
        resolution = scene.render.impostor_resolution
        if len(reflected) > MAX_DEPTH_IMAGES_PER_MIRROR:
            raise SceneError(
                scene.source, "objects",
                f"expected at most {MAX_DEPTH_IMAGES_PER_MIRROR} reflected objects per mirror, got {len(reflected)}",
            )
        self.atlas = ImpostorAtlas(ctx, len(mirrors) * len(reflected), resolution)
        self.images_by_mirror: dict[int, list[DepthImage]] = {}
        slot = 0
        for mirror in mirrors:
            images = []
            for target in reflected:
                camera = fit_depth_image_camera(scene, mirror, target, resolution)
                images.append(DepthImage(mirror, target, camera, self.atlas.tile_origin(slot)))
                slot += 1
            self.images_by_mirror[mirror.index] = images
        self.uniform_buffers = {index: self._uniform_buffer(images) for index, images in self.images_by_mirror.items()}
        self.bakes = 0  # depth images rendered so far (tests and stats check that nothing re-bakes)

    @property
    def depth_images(self) -> list[DepthImage]:
        return [image for images in self.images_by_mirror.values() for image in images]

    def _uniform_buffer(self, images: list[DepthImage]) -> moderngl.Buffer:
        # The block is declared with MAX_DEPTH_IMAGES_PER_MIRROR entries; a smaller buffer would
        # leave part of it unbacked, which GL leaves undefined.
        records = np.zeros(MAX_DEPTH_IMAGES_PER_MIRROR, dtype=DEPTH_IMAGE_DTYPE)
        for i, image in enumerate(images):
            records[i] = image.record()
        return self.ctx.buffer(records.tobytes())

    def bind(self, program: moderngl.Program) -> None:
        bind_impostors(program, self.atlas)

    def bind_mirror(self, program: moderngl.Program, mirror: ObjectGeometry) -> None:
        self.uniform_buffers[mirror.index].bind_to_uniform_block(DEPTH_IMAGES_BINDING)
        write(program, "u_depth_image_count", len(self.images_by_mirror[mirror.index]))

    def bake(self) -> int:
        """Render every depth image into its tile; returns the number of draw calls."""
        framebuffer = self.atlas.framebuffer
        framebuffer.use()
        self.ctx.enable(moderngl.DEPTH_TEST)
        everything = ((True,) * 4, (True,) * 4)
        draws = 0
        try:
            for image in self.depth_images:
                framebuffer.viewport = image.tile
                # Cleared colour alpha 0 marks "nothing here"; both depth layers clear to
                # BACKGROUND_DEPTH, the value the depth buffer clears to.
                framebuffer.color_mask = everything
                framebuffer.clear(BACKGROUND_DEPTH, BACKGROUND_DEPTH, 1.0, 0.0, depth=BACKGROUND_DEPTH, viewport=image.tile)
                # The visible surface: colour and the R layer.
                framebuffer.color_mask = ((True,) * 4, (True, False, False, False))
                draws += self.diffuse.draw([image.target], image.camera.view_projection)
                # The nearest back face: the G layer alone, against a fresh depth buffer.
                framebuffer.color_mask = ((False,) * 4, (False,) * 4)
                framebuffer.clear(depth=BACKGROUND_DEPTH, viewport=image.tile)
                framebuffer.color_mask = ((False,) * 4, (False, True, False, False))
                self.ctx.enable(moderngl.CULL_FACE)
                self.ctx.cull_face = BAKE_CULLS_FRONT_FACES
                self.meshes.draw(self.back_faces, image.target, image.camera.view_projection)
                self.ctx.disable(moderngl.CULL_FACE)
                draws += 1
                self.bakes += 1
        finally:
            framebuffer.color_mask = everything
            self.ctx.disable(moderngl.CULL_FACE)
        return draws

    def release(self) -> None:
        for buffer in self.uniform_buffers.values():
            buffer.release()
        self.atlas.release()
