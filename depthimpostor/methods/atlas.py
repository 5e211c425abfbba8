"""The atlas every baked image lives in (depth images, cube-map faces, billboards), and each image's
record: its camera, depth range and tile, in the layout the shaders read (constants.DEPTH_IMAGE_DTYPE).

One atlas pair (RGBA8 colour; RG32F OpenGL depths of the visible surface and of the nearest back
face behind it), one tile an image; each reflector gets a uniform buffer listing its own images.
Also here: the faces a bake culls (a depth image's projection flips y), which the bakes of the
baked images, the shadow maps and the glass interiors share.
"""

from __future__ import annotations

import ctypes
import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import moderngl
import numpy as np
from numpy.typing import NDArray

from ..gpu.gl_state import Face, RasterState, other_face
from ..gpu.bindings import StorageBuffer, TextureUnit, UniformBlock
from ..gpu.context import bind_default_framebuffer, gl_function
from ..constants import DEPTH_IMAGE_BLOCK_RECORDS, DEPTH_IMAGE_DTYPE, NO_OBJECT, lists_images
from ..errors import SceneError
from ..geometry import ObjectGeometry, world_vertex_groups
from ..ppc import PPC, FrustumFit, FrustumFitError, depth_image_records, fit_frusta
from ..oracles.reference import DepthImageData
from ..scene.model import Scene
from .image_cells import cells_table, cells_table_bytes
from .pyramid import PyramidLayout
from ..gpu.uniforms import bind_record_block, bind_texture




def bind_impostors(program: moderngl.Program, atlas: ImpostorAtlas) -> None:
    """Point a program that includes lib/baked_images.glsl at the atlas."""
    bind_texture(program, "u_impostor_color", atlas.color, TextureUnit.IMPOSTOR_COLOR)
    if atlas.depth is not None:
        bind_texture(program, "u_impostor_depth", atlas.depth, TextureUnit.IMPOSTOR_DEPTH)
    if atlas.back_color is not None:
        bind_texture(program, "u_impostor_back_color", atlas.back_color, TextureUnit.IMPOSTOR_BACK_COLOR)
    if atlas.beyond is not None:
        bind_texture(program, "u_impostor_beyond", atlas.beyond, TextureUnit.IMPOSTOR_BEYOND)
    bind_record_block(program, "DepthImages", UniformBlock.DEPTH_IMAGES, StorageBuffer.DEPTH_IMAGES)


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
    slot: int = 0  # what names it while its objects move (its tile is its slot's, or BakedImages.place's)
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

    @property
    def object_id(self) -> int:
        """What the record's `eye.w` holds: the object of a per-object image (NO_OBJECT for a
        cube-map face, whose texels name their own)."""
        return self.targets[0].index if len(self.targets) == 1 else NO_OBJECT

    @property
    def hit_bound_around(self) -> tuple[np.ndarray, float] | None:
        """The sphere that bounds the hits of a per-object image: its object's (None for a face)."""
        return self.targets[0].bounding_sphere if len(self.targets) == 1 else None

    def record(self) -> NDArray[np.void]:
        """The std140 record (image_records makes a mirror's all at once)."""
        return self.camera.depth_image_record(self.object_id, self.tile_origin, self.pyramid, self.hit_bound_around)


#: Draws the nearest back face's window depth into the second layer.
BACK_FACE_PROGRAM = ("mesh.vert", "window_depth.frag")
#: Draws where a second solid run begins behind the first (the hybrid method's).
BEYOND_PROGRAM = ("mesh.vert", "beyond_run.frag")


#: The face GL culls to keep the back faces. A depth image's projection puts image row 0 (the top)
#: at window y = 0, a mirror image of GL's usual y-up window: counter-clockwise outward faces
#: arrive clockwise, so GL's "front" faces are the back ones and culling GL's "back" keeps them.
BAKE_CULLS_FRONT_FACES: Face = "back"
#: Baking the nearest back faces (the back layer, shadow maps' second layer): GL's "front" culled.
BACK_FACES = RasterState(cull=BAKE_CULLS_FRONT_FACES)
#: Baking the nearest front faces behind the layers (the hybrid method's second run): the others culled.
FRONT_FACES = RasterState(cull=other_face(BAKE_CULLS_FRONT_FACES))


def image_records(images: list[DepthImage], capacity: int = DEPTH_IMAGE_BLOCK_RECORDS) -> NDArray[np.void]:
    """A mirror's record table of `capacity` records (constants.depth_image_capacity), `images`
    first. The program declares that many (a uniform block), or reads as far (a storage buffer: the
    mirror shader's loop bound may read one past the count), so the table is padded to it: a
    smaller buffer would leave records unbacked, which GL leaves undefined."""
    if len(images) > capacity:
        raise ValueError(f"{len(images)} depth images passed a record table of {capacity}")
    records = np.zeros(capacity, dtype=DEPTH_IMAGE_DTYPE)
    records[:len(images)] = depth_image_records(
        [image.camera for image in images], [image.object_id for image in images],
        [image.tile_origin for image in images], [image.pyramid for image in images],
        [image.hit_bound_around for image in images])
    return records


def record_table(records: NDArray[np.void], count: int, capacity: int, rays_from: tuple[NDArray[np.float64], float],
                 over_bounds: bool) -> bytes:
    """A mirror's record table as its buffer holds it: the `capacity` records of which the first
    `count` are its images' and, where the shader finds them through lists (constants.lists_images),
    the lists of candidates for rays starting in the sphere `rays_from` (centre, radius: the
    mirror's bounds; methods/image_cells.py), over the spheres the shader tests (lib/reflected_scene.glsl's
    image_bound, lib/billboard.glsl): the images' `bound`s where `over_bounds`, their `hit_bound`s otherwise. Built
    only then: a moving object's mirror writes its table again every frame."""
    if not lists_images(capacity):
        return records.tobytes()
    spheres = np.asarray(records["bound" if over_bounds else "hit_bound"][:count], np.float64)
    return records.tobytes() + cells_table(spheres, *rays_from)


def record_table_bytes(spheres: NDArray[np.float64], capacity: int, rays_from: tuple[NDArray[np.float64], float]) -> int:
    """len(record_table(...)) of a mirror's table whose images' tested spheres (`bound`s or
    `hit_bound`s, as record_table picks them) are `spheres`: its records and, where it holds them,
    its lists, counted without making them (the plan's memory figure)."""
    records = capacity * DEPTH_IMAGE_DTYPE.itemsize
    return records + cells_table_bytes(spheres, *rays_from) if lists_images(capacity) else records


def write_table(buffer: moderngl.Buffer, table: bytes) -> None:
    """Write a mirror's record table into its buffer, made larger where the table outgrew it (its
    lists of candidates grow and shrink as objects move)."""
    if len(table) > buffer.size:
        buffer.orphan(len(table))
    buffer.write(table)


def bind_image_records(buffer: moderngl.Buffer, capacity: int) -> None:
    """Bind a mirror's record table where programs of its `capacity` read it (lib/baked_images.glsl):
    the uniform block's binding, or past a uniform block's size the storage buffer's."""
    if capacity > DEPTH_IMAGE_BLOCK_RECORDS:
        buffer.bind_to_storage_buffer(StorageBuffer.DEPTH_IMAGES)
    else:
        buffer.bind_to_uniform_block(UniformBlock.DEPTH_IMAGES)


def image_label(mirror: ObjectGeometry, targets: tuple[ObjectGeometry, ...], level: int, face: int | None) -> str:
    """How plans and stats name an image: "mirror -> object", or a cube-map face by its number."""
    shows = targets[0].object.name if face is None else f"face {face}"
    return f"{mirror.object.name} -> {shows}" + (f" (bounce {level})" if level else "")


def mirror_centre(mirror: ObjectGeometry) -> np.ndarray:
    """The eye of a mirror's depth images: the centre of its bounding sphere."""
    return mirror.bounding_sphere[0]


def fit_depth_image_camera(scene: Scene, mirror: ObjectGeometry, target: ObjectGeometry, resolution: int,
                           fit: FrustumFit | None = None) -> PPC:
    """The depth image's camera: from the mirror's centre, the tightest frustum around the object
    (`fit`: that frustum, found already by fit_depth_image_frusta)."""
    if fit is not None:
        return fit.camera(resolution, resolution)
    centre, _ = target.bounding_sphere
    try:
        return PPC.fitted(mirror_centre(mirror), target.world_mesh.positions, centre, resolution, resolution)
    except FrustumFitError:
        raise _surrounds(scene, mirror, target) from None


def fit_depth_image_frusta(scene: Scene, shown: list[tuple[ObjectGeometry, list[ObjectGeometry]]]
                           ) -> dict[tuple[int, int], FrustumFit]:
    """The frusta fit_depth_image_camera fits, by (mirror index, target index), for each mirror and
    the targets it shows (`shown`): each target's world vertices placed once for every mirror, and
    the objects of one mesh fitted together (geometry.world_vertex_groups, ppc.fit_frusta), the
    same to the bit as one by one (a thousand objects' took over a second that way)."""
    targets = list({target.index: target for _, items in shown for target in items}.values())
    fits: dict[tuple[int, int], FrustumFit] = {}
    for part, vertices in world_vertex_groups(targets, spheres=True):
        centres = np.stack([target.bounding_sphere[0] for target in part])
        for mirror, items in shown:
            wanted = {target.index for target in items}
            rows = [row for row, target in enumerate(part) if target.index in wanted]
            if not rows:
                continue
            if len(rows) < len(part):
                vertices_of, centres_of = vertices[rows], centres[rows]
            else:
                vertices_of, centres_of = vertices, centres
            for row, fit in zip(rows, fit_frusta(mirror_centre(mirror), vertices_of, centres_of), strict=True):
                if fit is None:
                    raise _surrounds(scene, mirror, part[row])
                fits[(mirror.index, part[row].index)] = fit
    return fits


def _surrounds(scene: Scene, mirror: ObjectGeometry, target: ObjectGeometry) -> SceneError:
    return SceneError(
        scene.source,
        scene.object_label(target.index),
        f'object "{target.object.name}" surrounds or touches the centre of mirror "{mirror.object.name}": '
        "no depth-image frustum can be fitted to it; move it away from the mirror's centre",
    )


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
                 triangle_ids: bool = False, back_colors: bool = False, beyond: bool = False,
                 rows_made: int | None = None) -> None:
        """`rows_made`: the rows of tiles made now (every row by default); `grow` makes more, up to
        the grid's, keeping what the rows made hold (a stand-in whose frames bake only the images
        their rays enter: BakedImages.place)."""
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
        self.rows = rows  # the grid's; rows_made of them are made
        self.resolution = resolution
        self.pyramid_layout = PyramidLayout.of_grid(columns, rows, resolution)
        self._kinds = (layers, triangle_ids, back_colors and layers, beyond and layers)
        self._make_textures((columns * resolution, min(rows, max(1, rows_made or rows)) * resolution))
        # The depth buffer is the bakes' scratch alone (one float a texel of the atlas):
        # free_bake_buffer lets it go between bakes of a scene that will not bake again
        # unless something changes, and bake_buffer makes it again for the next.
        self._depth_buffer: moderngl.Renderbuffer | None = None
        self._make_framebuffers(ctx.depth_renderbuffer(self.size))
        # Nothing written yet (GL leaves a new texture undefined): the first bake clears every
        # attachment whole (BakedImages.bake), so nothing is cleared here unless tiles are
        # written otherwise first (clear_unwritten). Clearing here too was a second pass over a
        # thousand objects' atlas of 600 MB.
        self.unwritten = True

    def _make_textures(self, size: tuple[int, int]) -> None:
        """The atlas's textures at `size` (GL leaves them undefined; llvmpipe writes zeros into
        every byte, about a second for a thousand images of 128^2)."""
        layers, triangle_ids, back_colors, beyond = self._kinds
        ctx = self.ctx
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
        self.back_color = ctx.texture(size, 4, dtype="f1") if back_colors else None
        # R32F: where a second solid run begins behind the first (beyond_run.frag); 0 where not
        # known (written by hand for tests): everything behind the first run is then unseen.
        self.beyond = ctx.texture(size, 1, dtype="f4") if beyond else None
        for texture in self._all_textures():
            texture.filter = (moderngl.NEAREST, moderngl.NEAREST)

    def _all_textures(self) -> list[moderngl.Texture]:
        return self.textures + [texture for texture in (self.back_color, self.beyond) if texture is not None]

    @property
    def rows_made(self) -> int:
        return self.size[1] // self.resolution

    def grow(self, slots: int) -> None:
        """Make rows enough for the first `slots` slots, where fewer are made: at least twice the
        rows made (a camera that flies enters images a few at a time), at most the grid's. The
        rows made so far are copied into the new textures (glCopyImageSubData, GL 4.3), where the
        tiles keep their places."""
        needed = min(self.rows, -(-slots // self.columns))
        if needed <= self.rows_made:
            return
        old, old_size = self._all_textures(), self.size
        kept_buffer = self._depth_buffer is not None
        self._release_framebuffers()
        if self._depth_buffer is not None:
            self._depth_buffer.release()
        self._make_textures((self.columns * self.resolution, min(self.rows, max(needed, 2 * old_size[1] // self.resolution))
                             * self.resolution))
        for source, target in zip(old, self._all_textures(), strict=True):
            copy_texture(self.ctx, source, target, old_size)
            source.release()
        self._make_framebuffers(self.ctx.depth_renderbuffer(self.size) if kept_buffer else None)

    def clear_unwritten(self) -> None:
        """Clear what a tile written by hand (`write`) or a bake of some tiles alone leaves as it
        was, in an atlas nothing was written into yet: no back colour (images baked otherwise,
        reflectors at bounce k copied in, have none) and no second run known."""
        if not self.unwritten:
            return
        self.unwritten = False
        if self.back_framebuffer is not None:
            self.back_framebuffer.color_mask = self.masks((True,) * 4)
            self.back_framebuffer.clear(1.0, 1.0, 1.0, 0.0)
            self.back_framebuffer.color_mask = self.masks(*[(True,) * 4] * len(self.textures))
        if self.beyond_framebuffer is not None:
            self.beyond_framebuffer.clear(0.0)

    def _make_framebuffers(self, depth_buffer: moderngl.Renderbuffer | None) -> None:
        """The framebuffers over the atlas's textures, with `depth_buffer` (to bake) or without it
        (to read tiles back)."""
        self._depth_buffer = depth_buffer
        self.framebuffer = self.ctx.framebuffer(self.textures, depth_buffer)
        # The back layer's pass writes its colour at location 0, and G of the layers behind it.
        self.back_framebuffer: moderngl.Framebuffer | None = None
        if self.back_color is not None:
            self.back_framebuffer = self.ctx.framebuffer([self.back_color, *self.textures[1:]], depth_buffer)
        self.beyond_framebuffer: moderngl.Framebuffer | None = None
        if self.beyond is not None:
            self.beyond_framebuffer = self.ctx.framebuffer([self.beyond], depth_buffer)

    def _release_framebuffers(self) -> None:
        bind_default_framebuffer(self.ctx)
        for framebuffer in (self.framebuffer, self.back_framebuffer, self.beyond_framebuffer):
            if framebuffer is not None:
                framebuffer.release()

    @property
    def keeps_bake_buffer(self) -> bool:
        """Is the bakes' depth buffer made (between bakes too)?"""
        return self._depth_buffer is not None

    def bake_buffer(self) -> None:
        """Make the bakes' depth buffer again if free_bake_buffer let it go."""
        if self._depth_buffer is None:
            depth_buffer = self.ctx.depth_renderbuffer(self.size)  # first: a refusal changes nothing
            self._release_framebuffers()
            self._make_framebuffers(depth_buffer)

    def free_bake_buffer(self) -> None:
        """Let the bakes' depth buffer go (the framebuffers stay, for reading tiles back)."""
        if self._depth_buffer is not None:
            self._release_framebuffers()
            self._depth_buffer.release()
            self._make_framebuffers(None)

    @property
    def size(self) -> tuple[int, int]:
        return self.color.size

    @property
    def bytes(self) -> int:
        """GPU memory now: the textures of the rows made and, while it is kept, the bakes' depth
        buffer."""
        texel = self.bytes_for(1, 1, self.depth is not None, self.triangles is not None, self.back_color is not None,
                               self.beyond is not None)
        return self.size[0] * self.size[1] * (texel - (0 if self.keeps_bake_buffer else 4))

    @staticmethod
    def bake_buffer_bytes(count: int, resolution: int) -> int:
        """GPU memory of the bakes' depth buffer (one float a texel of the atlas)."""
        columns, rows = atlas_grid(count)
        return columns * rows * resolution * resolution * 4

    @staticmethod
    def bytes_for(count: int, resolution: int, layers: bool, triangle_ids: bool = False, back_colors: bool = False,
                  beyond: bool = False, bake_buffer: bool = True) -> int:
        """GPU memory of an atlas of `count` slots: colour, float layers (unless not `layers`),
        triangle ids (with `triangle_ids`), back colours (with `back_colors`), where second runs
        begin (with `beyond`) and (with `bake_buffer`) the depth buffer used to bake."""
        columns, rows = atlas_grid(count)
        texel = 4 + (8 if layers else 0) + (8 if triangle_ids else 0) + (4 if back_colors and layers else 0)
        texel += 4 if beyond and layers else 0
        textures = columns * rows * resolution * resolution * texel
        return textures + (ImpostorAtlas.bake_buffer_bytes(count, resolution) if bake_buffer else 0)

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
        self.clear_unwritten()
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
        self._release_framebuffers()
        if self._depth_buffer is not None:
            self._depth_buffer.release()
        for texture in self._all_textures():
            texture.release()


_GL_TEXTURE_2D = 0x0DE1
_copies: dict[moderngl.Context, Any] = {}


def copy_texture(ctx: moderngl.Context, source: moderngl.Texture, target: moderngl.Texture, size: tuple[int, int]) -> None:
    """Copy the `size` texels at the origin of `source` into `target` (of one format), on the GPU:
    glCopyImageSubData (GL 4.3), which moderngl does not wrap, through the loader."""
    if ctx not in _copies:
        address = gl_function(ctx, "glCopyImageSubData") if ctx.version_code >= 430 else 0
        if not address:
            raise RuntimeError(f"{ctx.info['GL_RENDERER']} has no glCopyImageSubData (OpenGL 4.3)")
        _copies[ctx] = ctypes.CFUNCTYPE(None, *([ctypes.c_uint, ctypes.c_uint] + [ctypes.c_int] * 4) * 2,
                                        *[ctypes.c_int] * 3)(address)
    _copies[ctx](source.glo, _GL_TEXTURE_2D, 0, 0, 0, 0, target.glo, _GL_TEXTURE_2D, 0, 0, 0, 0, size[0], size[1], 1)


def plural(count: int, noun: str) -> str:
    return f"{count} {noun}{'' if count == 1 else 's'}"


