"""Baking depth images: every reflected object, seen from the centre of every mirror.

Each (mirror, object) pair gets a depth image whose frustum is fitted to that object alone, so
that all of the image's pixels and all of its depth precision go to it. All depth images live in
one atlas pair (RGBA8 colour; RG32F OpenGL depths of the visible surface and of the nearest back
face behind it), one tile each; each mirror gets a uniform buffer listing its own depth images,
which is all the mirror shader needs.

The back layer costs a second, depth-only draw per image. Without it the depth image knows the
surface but not what lies behind it, and a ray passing behind a silhouette must either be joined
to it by a false "rubber sheet" or fall through the object's hidden side (a hole): see
docs/numerical_robustness.md.

BakedImages is the part the cube-map and billboard methods share with this one (passes/cubemaps.py,
passes/billboards.py): the atlas, the per-mirror uniform buffers and the bake loop. Each method
plans its own images and keeps its own second layer.
"""

from __future__ import annotations

import dataclasses
import math
from collections import Counter
from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING, Any, ClassVar, NamedTuple

import moderngl
import numpy as np
from numpy.typing import NDArray

from ..context import bind_default_framebuffer
from ..constants import BACKGROUND_DEPTH, DEPTH_IMAGE_DTYPE, MAX_DEPTH_IMAGES_PER_MIRROR, NO_OBJECT
from ..errors import SceneError
from ..scene.limits import objects_note
from ..geometry import ObjectGeometry, triangle_offsets
from ..culling import Reach, reachable_targets, reaches
from ..ppc import PPC, FrustumFitError
from ..reference import DepthImageData
from ..resolution import MIN_AUTO_RESOLUTION, auto_resolution, scene_view
from ..scene.model import Scene
from ..shaders import ProgramCache
from .diffuse import DiffusePass
from .meshes import GpuMeshes
from .pyramid import DepthPyramid, PyramidLayout
from .uniforms import bind_texture, bind_uniform_block, write

if TYPE_CHECKING:
    from .bounces import BounceBaker


#: Texture units and the uniform-block binding the reflected-scene chunk reads.
COLOR_ATLAS_UNIT = 0
DEPTH_ATLAS_UNIT = 1
BACK_COLOR_ATLAS_UNIT = 3  # after the pyramid's (2)
BEYOND_ATLAS_UNIT = 4
DEPTH_IMAGES_BINDING = 0


def bind_impostors(program: moderngl.Program, atlas: ImpostorAtlas) -> None:
    """Point a program that includes lib/baked_images.glsl at the atlas."""
    bind_texture(program, "u_impostor_color", atlas.color, COLOR_ATLAS_UNIT)
    if atlas.depth is not None:
        bind_texture(program, "u_impostor_depth", atlas.depth, DEPTH_ATLAS_UNIT)
    if atlas.back_color is not None:
        bind_texture(program, "u_impostor_back_color", atlas.back_color, BACK_COLOR_ATLAS_UNIT)
    if atlas.beyond is not None:
        bind_texture(program, "u_impostor_beyond", atlas.beyond, BEYOND_ATLAS_UNIT)
    bind_uniform_block(program, "DepthImages", DEPTH_IMAGES_BINDING)


@dataclass(frozen=True, eq=False)
class DepthImage:
    """One baked image: its mirror, the objects it shows (one for a depth image or a billboard,
    all reflected objects for a cube-map face), its camera, where it sits in the atlas, and where
    its depth pyramid would sit (used only by the hierarchical algorithm: (x, y, levels))."""

    mirror: ObjectGeometry
    targets: tuple[ObjectGeometry, ...]
    camera: PPC
    tile_origin: tuple[int, int]
    pyramid: tuple[int, int, int] = (0, 0, 0)
    level: int = 0  # see ImagePlan
    slot: int = 0  # its place in the atlas: what names it while its objects move
    label: str = ""  # how plans and stats name it (image_label)

    def moved(self, mirror: ObjectGeometry, targets: tuple[ObjectGeometry, ...], camera: PPC) -> DepthImage:
        return dataclasses.replace(self, mirror=mirror, targets=targets, camera=camera)

    @property
    def target(self) -> ObjectGeometry:
        """The one object of a per-object image."""
        if len(self.targets) != 1:
            raise ValueError(f"this image shows {len(self.targets)} objects, not one")
        return self.targets[0]

    @property
    def tile(self) -> tuple[int, int, int, int]:
        return (*self.tile_origin, self.camera.width, self.camera.height)

    def record(self) -> NDArray[np.void]:
        """The std140 record; `eye.w` names the object of a per-object image (NO_OBJECT for a
        cube-map face, whose texels name their own)."""
        object_id = self.targets[0].index if len(self.targets) == 1 else NO_OBJECT
        return self.camera.depth_image_record(object_id, self.tile_origin, self.pyramid)


#: Draws the nearest back face's window depth into the second layer.
BACK_FACE_PROGRAM = ("mesh.vert", "window_depth.frag")
#: Draws where a second solid run begins behind the first (the hybrid method's).
BEYOND_PROGRAM = ("mesh.vert", "beyond_run.frag")


#: The face GL culls to keep the back faces. A depth image's projection puts image row 0 (the top)
#: at window y = 0, a mirror image of GL's usual y-up window: counter-clockwise outward faces
#: arrive clockwise, so GL's "front" faces are the back ones and culling GL's "back" keeps them.
BAKE_CULLS_FRONT_FACES = "back"


def image_records(images: list[DepthImage]) -> bytes:
    """A mirror's uniform block. It is declared with MAX_DEPTH_IMAGES_PER_MIRROR entries; a smaller
    buffer would leave part of it unbacked, which GL leaves undefined."""
    records = np.zeros(MAX_DEPTH_IMAGES_PER_MIRROR, dtype=DEPTH_IMAGE_DTYPE)
    for i, image in enumerate(images):
        records[i] = image.record()
    return records.tobytes()


def image_label(mirror: ObjectGeometry, targets: tuple[ObjectGeometry, ...], level: int, face: int | None) -> str:
    """How plans and stats name an image: "mirror -> object", or a cube-map face by its number."""
    shows = targets[0].object.name if face is None else f"face {face}"
    return f"{mirror.object.name} -> {shows}" + (f" (bounce {level})" if level else "")


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


#: moderngl's colour mask: a 4-tuple for one attachment, a tuple of them for several (its stub
#: knows the first form alone, hence Any).
ColorMask = Any


def color_mask(attachments: int, *per_attachment: tuple[bool, ...]) -> ColorMask:
    """A colour mask in moderngl's form for a framebuffer of `attachments` colour attachments: the
    masks given for the first ones, the rest masked off; one attachment's mask is a plain 4-tuple."""
    given = list(per_attachment) + [(False,) * 4] * (attachments - len(per_attachment))
    return given[0] if attachments == 1 else tuple(given)


def atlas_grid(count: int) -> tuple[int, int]:
    """Columns and rows of a near-square grid holding `count` tiles."""
    columns = max(1, math.ceil(math.sqrt(count)))
    return columns, max(1, math.ceil(count / columns))


class ImpostorAtlas:
    """The textures and framebuffers that hold every baked image of the scene: colour, (unless
    `layers` is False: billboards need colour alone) the two float depth layers, (with
    `back_colors`: depth images) the colour of the back layer, and (with `triangle_ids`: the
    hybrid method's) the triangles each sample shows on both layers."""

    def __init__(self, ctx: moderngl.Context, count: int, resolution: int, layers: bool = True,
                 triangle_ids: bool = False, back_colors: bool = False, beyond: bool = False) -> None:
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
        self.count = count
        self.columns = columns
        self.resolution = resolution
        self.pyramid_layout = PyramidLayout.of_grid(columns, rows, resolution)
        self.color = ctx.texture(size, 4, dtype="f1")
        # (visible surface, second layer): see lib/baked_images.glsl.
        self.depth = ctx.texture(size, 2, dtype="f4") if layers else None
        # RG32F: the places in the BVH's list (diffuse.frag's WRITE_TRIANGLE_ID) of the triangles
        # seen on the visible surface (R) and the back layer (G).
        self.triangles = ctx.texture(size, 2, dtype="f4") if triangle_ids else None
        self.textures = [self.color] if self.depth is None else [self.color, self.depth]
        if self.triangles is not None:
            self.textures.append(self.triangles)
        # RGBA8: the back layer's colour (alpha 0: none drawn, as the colour atlas).
        self.back_color = ctx.texture(size, 4, dtype="f1") if back_colors and layers else None
        for texture in self.textures + ([self.back_color] if self.back_color is not None else []):
            texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._depth_buffer = ctx.depth_renderbuffer(size)
        self.framebuffer = ctx.framebuffer(self.textures, self._depth_buffer)
        # The back layer's pass writes its colour at location 0, and G of the layers behind it.
        self.back_framebuffer: moderngl.Framebuffer | None = None
        if self.back_color is not None:
            self.back_framebuffer = ctx.framebuffer([self.back_color, *self.textures[1:]], self._depth_buffer)
            # Images baked otherwise (reflectors at bounce k, copied in) have no back colour.
            self.back_framebuffer.color_mask = self.masks((True,) * 4)
            self.back_framebuffer.clear(1.0, 1.0, 1.0, 0.0)
            self.back_framebuffer.color_mask = self.masks(*[(True,) * 4] * len(self.textures))
        # R32F: where a second solid run begins behind the first (beyond_run.frag); 0 where not
        # known (written by hand for tests): everything behind the first run is then unseen.
        self.beyond = ctx.texture(size, 1, dtype="f4") if beyond and layers else None
        self.beyond_framebuffer: moderngl.Framebuffer | None = None
        if self.beyond is not None:
            self.beyond.filter = (moderngl.NEAREST, moderngl.NEAREST)
            self.beyond_framebuffer = ctx.framebuffer([self.beyond], self._depth_buffer)
            self.beyond_framebuffer.clear(0.0)

    @property
    def size(self) -> tuple[int, int]:
        return self.color.size

    @property
    def bytes(self) -> int:
        return self.bytes_for(self.count, self.resolution, self.depth is not None, self.triangles is not None,
                              self.back_color is not None, self.beyond is not None)

    @staticmethod
    def bytes_for(count: int, resolution: int, layers: bool, triangle_ids: bool = False, back_colors: bool = False,
                  beyond: bool = False) -> int:
        """GPU memory of an atlas of `count` slots: colour, float layers (unless not `layers`),
        triangle ids (with `triangle_ids`), back colours (with `back_colors`), where second runs
        begin (with `beyond`) and the depth buffer used to bake."""
        columns, rows = atlas_grid(count)
        texel = 4 + (8 if layers else 0) + (8 if triangle_ids else 0) + (4 if back_colors and layers else 0) + 4
        texel += 4 if beyond and layers else 0
        return columns * rows * resolution * resolution * texel

    def masks(self, *per_attachment: tuple[bool, ...]) -> ColorMask:
        """A colour mask for this atlas's framebuffer (see color_mask)."""
        return color_mask(len(self.textures), *per_attachment)

    @property
    def slot_count(self) -> int:
        return self.pyramid_layout.columns * self.pyramid_layout.rows

    def tile_origin(self, slot: int) -> tuple[int, int]:
        return (slot % self.columns) * self.resolution, (slot // self.columns) * self.resolution

    def slot_of(self, tile: tuple[int, ...]) -> int:
        """The slot of the tile at (tile[0], tile[1])."""
        return (tile[1] // self.resolution) * self.columns + tile[0] // self.resolution

    def depth_layers(self) -> moderngl.Texture:
        """The float layers (visible surface, second layer) of an atlas that keeps them."""
        if self.depth is None:
            raise ValueError("this atlas keeps colour alone (billboards): it holds no depth images")
        return self.depth

    def read(self, image: DepthImage) -> DepthImageData:
        """One depth image as the numpy reference takes it (rows top to bottom, colour in [0, 1])."""
        self.depth_layers()
        viewport = image.tile
        height, width = viewport[3], viewport[2]
        color = np.frombuffer(self.framebuffer.read(viewport=viewport, components=4, attachment=0), np.uint8)
        layers = np.frombuffer(
            self.framebuffer.read(viewport=viewport, components=2, attachment=1, dtype="f4"), np.float32
        ).reshape(height, width, 2)
        back_color = None
        if self.back_framebuffer is not None:
            rgba = np.frombuffer(self.back_framebuffer.read(viewport=viewport, components=4, attachment=0), np.uint8)
            rgba = rgba.reshape(height, width, 4)
            back_color = np.where(rgba[..., 3:] > 0, rgba[..., :3] / 255.0, np.nan)
        beyond = None
        if self.beyond_framebuffer is not None:
            beyond = np.frombuffer(self.beyond_framebuffer.read(viewport=viewport, components=1, dtype="f4"), np.float32)
            beyond = beyond.reshape(height, width).copy()
        return DepthImageData(
            image.camera, color.reshape(height, width, 4)[..., :3] / 255.0, layers[..., 0].copy(),
            image.target.index, layers[..., 1].copy(), back_color, beyond,
        )

    def write(self, tile_origin: tuple[int, int], data: DepthImageData) -> None:
        """Store a depth image made elsewhere (tests build exact ones by hand)."""
        height, width = data.depth.shape
        viewport = (*tile_origin, width, height)
        rgba = np.concatenate([np.rint(np.clip(data.color, 0, 1) * 255), np.full((height, width, 1), 255)], axis=2)
        self.color.write(np.ascontiguousarray(rgba, np.uint8).tobytes(), viewport=viewport)
        layers = np.stack([data.depth, data.back_layer], axis=2)
        self.depth_layers().write(np.ascontiguousarray(layers, np.float32).tobytes(), viewport=viewport)
        if self.back_color is not None:
            back = np.zeros((height, width, 4))
            if data.back_color is not None:
                drawn = np.isfinite(data.back_color).all(axis=2)
                back[drawn] = np.concatenate([np.rint(np.clip(data.back_color[drawn], 0, 1) * 255),
                                              np.full((int(drawn.sum()), 1), 255)], axis=1)
            self.back_color.write(np.ascontiguousarray(back, np.uint8).tobytes(), viewport=viewport)
        if self.beyond is not None:
            beyond = data.beyond_depth if data.beyond_depth is not None else np.zeros((height, width))
            self.beyond.write(np.ascontiguousarray(beyond, np.float32).tobytes(), viewport=viewport)

    def release(self) -> None:
        bind_default_framebuffer(self.ctx)
        extra: list[moderngl.Framebuffer | moderngl.Texture] = []
        if self.back_framebuffer is not None and self.back_color is not None:
            extra += [self.back_framebuffer, self.back_color]
        if self.beyond_framebuffer is not None and self.beyond is not None:
            extra += [self.beyond_framebuffer, self.beyond]
        for item in (*extra, self.framebuffer, self._depth_buffer, *self.textures):
            item.release()


def plural(count: int, noun: str) -> str:
    return f"{count} {noun}{'' if count == 1 else 's'}"


class SecondLayer(Enum):
    """What the atlas's second texture holds besides the visible surface's depth (R)."""

    BACK_FACE = "back face"  # G: the nearest back face behind it (depth images)
    OBJECT_ID = "object id"  # G: the id of the object seen (cube-map faces show several)
    NONE = "none"  # no float layers at all: colour alone (billboards)


class ImagePlan(NamedTuple):
    """One image to bake: the objects it shows and the camera that sees them. `level` 0 is an
    image of diffuse objects, the same at every bounce; level k >= 2 is an image of another
    mirror showing its own reflections of bounce k - 1 (render.max_bounces; depth images only)."""

    targets: tuple[ObjectGeometry, ...]
    camera: PPC
    level: int = 0


class BakedImages:
    """Images baked from the mirrors' centres into one atlas, with a uniform buffer of records per
    mirror: what the depth-image, cube-map and billboard methods share. They differ in the images
    they plan (per object, or six faces) and in the second layer they keep."""

    second_layer: ClassVar[SecondLayer]
    #: Does each sample also record the triangle it shows (the hybrid method's exact surfaces)?
    keeps_triangle_ids: ClassVar[bool] = False
    #: Is the back layer drawn with its colour (depth images: a ray may come in through it)?
    keeps_back_colors: ClassVar[bool] = False
    #: Is it known where a second solid run begins (the hybrid method's: space behind the first
    #: run up to there is seen empty)?
    keeps_beyond: ClassVar[bool] = False
    #: What one image is called in the CLI's and the viewer's summaries.
    image_noun: ClassVar[str]
    #: One image per reflected object (False: faces that show them all).
    per_object: ClassVar[bool] = True

    def __init__(
        self,
        ctx: moderngl.Context,
        programs: ProgramCache,
        scene: Scene,
        meshes: GpuMeshes,
        mirrors: list[ObjectGeometry],
        reflected: list[ObjectGeometry],
    ) -> None:
        plan = self.plan_images(scene, mirrors, reflected)
        self.ctx = ctx
        self.programs = programs
        self.scene = scene
        self.meshes = meshes
        layers = self.second_layer != SecondLayer.NONE
        offsets = triangle_offsets(reflected) if self.keeps_triangle_ids else None
        self.diffuse = DiffusePass(programs, scene, meshes, write_depth_image=layers, triangle_offsets=offsets)
        self.back_layer = (DiffusePass(programs, scene, meshes, write_depth_image=True, triangle_offsets=offsets,
                                       back_layer=True) if self.keeps_back_colors else None)
        count = sum(len(images) for images in plan.values())
        # Slots as large as the largest image ("auto" sizes each image apart).
        sides = [max(camera.width, camera.height) for images in plan.values() for _, camera, _ in images]
        self.atlas = ImpostorAtlas(ctx, count, max(sides, default=1), layers, self.keeps_triangle_ids,
                                   self.keeps_back_colors, self.keeps_beyond)
        self.images_by_mirror: dict[int, list[DepthImage]] = {}
        slot = 0
        for mirror in mirrors:
            images: list[DepthImage] = []
            for targets, camera, level in plan[mirror.index]:
                pyramid = self.atlas.pyramid_layout.entry(slot, camera.width, camera.height)
                label = image_label(mirror, targets, level, None if self.per_object else len(images))
                images.append(DepthImage(mirror, targets, camera, self.atlas.tile_origin(slot), pyramid, level, slot, label))
                slot += 1
            self.images_by_mirror[mirror.index] = images
        self.final_level = scene.render.max_bounces
        self.uniform_buffers = {index: self._uniform_buffer(self.images_at(index, self.final_level))
                                for index in self.images_by_mirror}
        self.bakes = 0  # images rendered so far (tests and stats check that nothing re-bakes)
        self.bake_counts: Counter[str] = Counter()  # by image label
        self.bounce_bakes = 0  # of them, images of reflectors (render.max_bounces > 1)
        self.stale: set[int] = {image.slot for image in self.depth_images}  # slots the next bake renders

    @property
    def needs_bake(self) -> bool:
        return bool(self.stale)

    def bake_again(self) -> None:
        """Render every image at the next bake, although nothing moved (the benchmark's)."""
        self.stale = {image.slot for image in self.depth_images}

    def refit(self, image: DepthImage, mirror: ObjectGeometry, targets: tuple[ObjectGeometry, ...]) -> PPC:
        """The camera of `image` once its mirror or objects moved, at the image's own size."""
        return fit_depth_image_camera(self.scene, mirror, targets[0], image.camera.width)

    def move(self, geometry: dict[int, ObjectGeometry], moved: set[int], stale_targets: set[int]) -> None:
        """Objects (by index) moved to `geometry`: their images are fitted again and, with every
        image showing an object of `stale_targets` (a light that shades it moved, or a shadow
        that may fall on it), baked at the next bake. Bounce images follow what they show."""
        for index, images in self.images_by_mirror.items():
            for i, image in enumerate(images):
                mirror, targets = geometry[index], tuple(geometry[t.index] for t in image.targets)
                if index in moved or any(t.index in moved for t in targets):
                    images[i] = image.moved(mirror, targets, self.refit(image, mirror, targets))
                    self.stale.add(image.slot)
                elif not image.level and any(t.index in stale_targets for t in targets):
                    self.stale.add(image.slot)
        self._spread_staleness()
        for index, buffer in self.uniform_buffers.items():
            buffer.write(image_records(self.images_at(index, self.final_level)))
        self._forget_fits()

    def _spread_staleness(self) -> None:
        """A bounce-k image of reflector B shows B's images of levels 0 and k - 1: stale with them."""
        for level in range(2, self.final_level + 1):
            for image in self.depth_images:
                shown = image.targets[0].index if image.level == level else None
                if shown is not None and any(other.slot in self.stale for other in self.images_at(shown, level - 1)):
                    self.stale.add(image.slot)

    def _forget_fits(self) -> None:
        """Drop what a method derived from its images' cameras (cube-map boxes, billboard planes)."""

    @classmethod
    def plan_images(
        cls, scene: Scene, mirrors: list[ObjectGeometry], reflected: list[ObjectGeometry]
    ) -> dict[int, list[ImagePlan]]:
        """The images to bake for each mirror (by its index): by default one per reflected
        object it may show (depth images, billboards); cube maps bake six faces instead."""
        return per_object_plan(scene, mirrors, reflected)

    def images_at(self, mirror_index: int, bounces: int) -> list[DepthImage]:
        """The images a reflected ray of this mirror is traced against when it may make
        `bounces` bounces: the diffuse objects', and the other mirrors' that show bounces - 1."""
        return [image for image in self.images_by_mirror[mirror_index] if image.level in (0, bounces)]

    @property
    def depth_images(self) -> list[DepthImage]:
        return [image for images in self.images_by_mirror.values() for image in images]

    @property
    def bytes(self) -> int:
        return self.atlas.bytes + sum(buffer.size for buffer in self.uniform_buffers.values())

    def describe(self) -> str:
        sides = sorted({image.camera.width for image in self.depth_images}) or [self.atlas.resolution]
        sizes = " to ".join(f"{side}x{side}" for side in dict.fromkeys((sides[0], sides[-1])))
        return f"{plural(len(self.depth_images), self.image_noun)} of {sizes}"

    def _uniform_buffer(self, images: list[DepthImage]) -> moderngl.Buffer:
        return self.ctx.buffer(image_records(images))

    def bind(self, program: moderngl.Program) -> None:
        bind_impostors(program, self.atlas)

    def bind_mirror(self, program: moderngl.Program, mirror: ObjectGeometry) -> None:
        self.uniform_buffers[mirror.index].bind_to_uniform_block(DEPTH_IMAGES_BINDING)
        write(program, "u_depth_image_count", len(self.images_at(mirror.index, self.final_level)))

    def bake(self) -> int:
        """Render the stale images into their tiles; returns the number of draw calls."""
        framebuffer = self.atlas.framebuffer
        framebuffer.use()
        self.ctx.enable(moderngl.DEPTH_TEST)
        # The visible surface writes colour, R, G when G is the object id, and the triangle ids.
        atlas = self.atlas
        everything = atlas.masks(*[(True,) * 4] * len(atlas.textures))
        surface_mask = atlas.masks((True,) * 4, (True, self.second_layer == SecondLayer.OBJECT_ID, False, False),
                                   (True, False, False, False))  # triangle ids: R, the visible surface's
        draws = 0
        try:
            for image in self.depth_images:
                if image.level or image.slot not in self.stale:  # ImpostorPass bakes images of mirrors after these
                    continue
                framebuffer.viewport = image.tile
                # Cleared colour alpha 0 marks "nothing here"; both depth layers clear to
                # BACKGROUND_DEPTH, the value the depth buffer clears to.
                framebuffer.color_mask = everything
                framebuffer.clear(BACKGROUND_DEPTH, BACKGROUND_DEPTH, 1.0, 0.0, depth=BACKGROUND_DEPTH, viewport=image.tile)
                framebuffer.color_mask = surface_mask
                draws += self.diffuse.draw(list(image.targets), image.camera.view_projection)
                if self.back_layer is not None:
                    draws += self._bake_back_layer(image)
                    if self.atlas.beyond is not None:
                        draws += self._bake_beyond(image)
                    framebuffer.use()
                elif self.second_layer == SecondLayer.BACK_FACE:
                    draws += self._bake_back_faces(image, framebuffer, image.tile)
                self.baked(image)
        finally:
            framebuffer.color_mask = everything
            self.ctx.disable(moderngl.CULL_FACE)
        return draws

    def baked(self, image: DepthImage) -> None:
        self.bakes += 1
        self.bounce_bakes += bool(image.level)
        self.bake_counts[image.label] += 1
        self.stale.discard(image.slot)

    def _bake_back_faces(self, image: DepthImage, framebuffer: moderngl.Framebuffer, tile: tuple[int, int, int, int]) -> int:
        """The nearest back face: the G layer alone, against a fresh depth buffer (images of
        reflectors at bounce k >= 2, which have no colour of their backs to show)."""
        back_faces = self.programs.get(*BACK_FACE_PROGRAM)
        attachments = len(framebuffer.color_attachments)
        framebuffer.color_mask = color_mask(attachments)
        framebuffer.clear(depth=BACKGROUND_DEPTH, viewport=tile)
        framebuffer.color_mask = color_mask(attachments, (False,) * 4, (False, True, False, False))
        self.ctx.enable(moderngl.CULL_FACE)
        self.ctx.cull_face = BAKE_CULLS_FRONT_FACES
        for target in image.targets:
            self.meshes.draw(back_faces, target, image.camera.view_projection)
        self.ctx.disable(moderngl.CULL_FACE)
        return len(image.targets)

    def _bake_back_layer(self, image: DepthImage) -> int:
        """The nearest back face's colour, depth (G) and triangle (G), against a fresh depth buffer."""
        assert self.back_layer is not None and self.atlas.back_framebuffer is not None
        framebuffer, atlas = self.atlas.back_framebuffer, self.atlas
        framebuffer.use()
        framebuffer.viewport = image.tile
        framebuffer.color_mask = atlas.masks((True,) * 4)
        framebuffer.clear(1.0, 1.0, 1.0, 0.0, depth=BACKGROUND_DEPTH, viewport=image.tile)
        framebuffer.color_mask = atlas.masks((True,) * 4, (False, True, False, False), (False, True, False, False))
        self.ctx.enable(moderngl.CULL_FACE)
        self.ctx.cull_face = BAKE_CULLS_FRONT_FACES
        try:
            return self.back_layer.draw(list(image.targets), image.camera.view_projection)
        finally:
            self.ctx.disable(moderngl.CULL_FACE)
            framebuffer.color_mask = atlas.masks(*[(True,) * 4] * len(atlas.textures))

    def _bake_beyond(self, image: DepthImage) -> int:
        """Where a second solid run begins behind the first (beyond_run.frag): the nearest front
        face behind the layers just baked, which it reads (they are not attached here)."""
        assert self.atlas.beyond_framebuffer is not None
        program = self.programs.get(*BEYOND_PROGRAM)
        framebuffer = self.atlas.beyond_framebuffer
        framebuffer.use()
        framebuffer.viewport = image.tile
        framebuffer.clear(BACKGROUND_DEPTH, depth=BACKGROUND_DEPTH, viewport=image.tile)
        bind_texture(program, "u_impostor_depth", self.atlas.depth_layers(), DEPTH_ATLAS_UNIT)
        self.ctx.enable(moderngl.CULL_FACE)
        self.ctx.cull_face = "front" if BAKE_CULLS_FRONT_FACES == "back" else "back"  # keep the front faces
        try:
            for target in image.targets:
                self.meshes.draw(program, target, image.camera.view_projection)
        finally:
            self.ctx.disable(moderngl.CULL_FACE)
        return len(image.targets)

    def release(self) -> None:
        for buffer in self.uniform_buffers.values():
            buffer.release()
        self.atlas.release()


class ImpostorPass(BakedImages):
    """The depth-image method: one depth image per mirror and reflected object, with a frustum
    fitted to that object alone, and the back-face layer; with the hierarchical algorithm, the
    min/max depth pyramid of every image too, built after each bake."""

    second_layer = SecondLayer.BACK_FACE
    keeps_back_colors = True
    image_noun = "depth image"

    pyramid: DepthPyramid | None = None
    bounces: BounceBaker | None = None

    def __init__(self, ctx: moderngl.Context, programs: ProgramCache, scene: Scene, meshes: GpuMeshes,
                 mirrors: list[ObjectGeometry], reflected: list[ObjectGeometry]) -> None:
        super().__init__(ctx, programs, scene, meshes, mirrors, reflected)
        if self.final_level > 1 and len(mirrors) > 1:
            from .bounces import BounceBaker  # bounces.py builds on this module's classes

            self.bounces = BounceBaker(self, scene)

    @classmethod
    def plan_images(
        cls, scene: Scene, mirrors: list[ObjectGeometry], reflected: list[ObjectGeometry]
    ) -> dict[int, list[ImagePlan]]:
        """Per mirror, one depth image per reflected object it may show and, for each bounce k
        from 2 to render.max_bounces, one of every other mirror it may show, showing its bounce
        k - 1 reflections."""
        plan = per_object_plan(scene, mirrors, reflected)
        if scene.render.max_bounces > 1 and len(reflected) + len(mirrors) - 1 > MAX_DEPTH_IMAGES_PER_MIRROR:
            raise SceneError(
                scene.source, "render.max_bounces",
                f"expected 1 with {len(reflected)} reflected objects and {len(mirrors)} mirrors: a mirror's images of "
                f"the others would pass the {MAX_DEPTH_IMAGES_PER_MIRROR} one mirror may hold",
            )
        view = scene_view(scene)
        for mirror in mirrors:
            others = reachable_targets(mirror, [other for other in mirrors if other is not mirror])
            cameras = [image_camera(scene, view, mirror, other) for other in others]
            plan[mirror.index] += [
                ImagePlan((other,), camera, level)
                for level in range(2, scene.render.max_bounces + 1) for other, camera in zip(others, cameras, strict=False)
            ]
        return plan

    def use_pyramid(self, wanted: bool) -> None:
        """Keep a depth pyramid (the hierarchical algorithm's) or free it. A new one is built at
        once from the images already baked (the images themselves are not baked again)."""
        if wanted and self.pyramid is None:
            tiles = [image.tile for image in self.depth_images]  # in slot order, as __init__ assigned them
            self.pyramid = DepthPyramid(self.ctx, self.programs, self.atlas.pyramid_layout, tiles)
            if self.bakes:
                self.pyramid.build(self.atlas.depth_layers())
        elif not wanted and self.pyramid is not None:
            self.pyramid.release()
            self.pyramid = None

    @property
    def bytes(self) -> int:
        return super().bytes + (self.pyramid.bytes if self.pyramid is not None else 0)

    def describe(self) -> str:
        return super().describe() + (" with depth pyramids" if self.pyramid is not None else "")

    def bake(self) -> int:
        baking = self.needs_bake
        draws = super().bake()
        if self.bounces is not None:
            draws += self.bounces.bake()
        if self.pyramid is not None and baking:
            self.pyramid.build(self.atlas.depth_layers())
        return draws

    def bind(self, program: moderngl.Program) -> None:
        super().bind(program)
        if self.pyramid is not None:
            self.pyramid.bind(program)

    def release(self) -> None:
        self.use_pyramid(False)
        if self.bounces is not None:
            self.bounces.release()
        super().release()


def image_camera(scene: Scene, view: PPC, mirror: ObjectGeometry, target: ObjectGeometry) -> PPC:
    """The camera of `target`'s image for `mirror`: fitted at render.impostor_resolution, or at
    the resolution `view` (the scene's camera) asks for when it is "auto" (resolution.py)."""
    if not scene.render.auto_resolution:
        return fit_depth_image_camera(scene, mirror, target, int(scene.render.impostor_resolution))
    probe = fit_depth_image_camera(scene, mirror, target, MIN_AUTO_RESOLUTION)
    return fit_depth_image_camera(scene, mirror, target, auto_resolution(view, mirror, target, probe))


def per_object_plan(scene: Scene, mirrors: list[ObjectGeometry], reflected: list[ObjectGeometry]) -> dict[int, list[ImagePlan]]:
    """One image per mirror and reflected object it may show (culling.py), its frustum fitted to
    the object. The images of one mirror share its uniform block, which has a fixed size."""
    view = scene_view(scene)
    plan = {}
    for mirror, row in zip(mirrors, reaches(mirrors, reflected), strict=True):
        shown = [target for target, why in zip(reflected, row, strict=True) if why is Reach.REACHABLE]
        if len(shown) > MAX_DEPTH_IMAGES_PER_MIRROR:
            raise SceneError(
                scene.source, "objects",
                f"expected at most {MAX_DEPTH_IMAGES_PER_MIRROR} objects a mirror may reflect, got {len(shown)} "
                f"for \"{mirror.object.name}\"{objects_note(scene)}",
            )
        plan[mirror.index] = [ImagePlan((target,), image_camera(scene, view, mirror, target)) for target in shown]
    return plan
