"""The images baked from a reflector's centre, as one pass: the part the depth-image, cube-map and
billboard methods share (methods/impostors.py, methods/cubemaps.py, methods/billboards.py): the plan
of which images a reflector gets, the atlas, the per-reflector uniform buffers and the bake loop.
Each method plans its own images and keeps its own second layer.
"""

from __future__ import annotations

import builtins
import dataclasses
import math
from collections import Counter
from collections.abc import Callable, Sequence
from enum import Enum
from typing import ClassVar, NamedTuple

import moderngl
import numpy as np
from numpy.typing import NDArray

from ..gpu.batches import is_closed
from ..gpu.gl_state import BASE, raster_state
from ..gpu.bindings import TextureUnit
from ..constants import (
    BACKGROUND_DEPTH,
    DEPTH_IMAGE_BLOCK_RECORDS,
    DEPTH_IMAGE_DTYPE,
    MIN_BUDGETED_SIDE,
    STORAGE_GL_VERSION,
    depth_image_capacity,
    lists_images,
)
from ..errors import ContextError
from ..geometry import ObjectGeometry, bounding_spheres, triangle_offsets
from ..lod import BakeDetail
from ..culling import Reach, ReachTable, reaches
from ..ppc import PPC, FrustumFit, depth_image_records, fitted_cameras, view_projections
from ..resolution import MAX_AUTO_RESOLUTION, MIN_AUTO_RESOLUTION, MirrorDensity, auto_resolution, scene_view
from ..scene.model import Scene
from ..gpu.shaders import ProgramCache
from ..passes.diffuse import DiffusePass, has_checker
from ..gpu.meshes import GpuMeshes
from ..gpu.scene_blocks import DrawnMaterials
from ..gpu.uniforms import alpha_mask_defines, bind_texture, write, write_material_index
from .colour_mips import ColourMips
from .entered_images import EnteredImages
from ..passes.reflectors import Surfaces
from .atlas import BACK_FACES, BACK_FACE_PROGRAM, BEYOND_PROGRAM, DepthImage, FRONT_FACES, ImpostorAtlas, atlas_grid, bind_image_records, bind_impostors, color_mask, fit_depth_image_camera, fit_depth_image_frusta, image_label, image_records, plural, record_table, record_table_bytes, write_table




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
    #: Are a mirror's lists of candidate images by ray (methods/image_cells.py) over the images'
    #: whole bounds rather than their hit bounds? Where its programs look at more than the hits: the
    #: hybrid method tracks unseen space anywhere in an image (TRACK_UNSEEN). (A billboard's quad
    #: reaches past its object's sphere, but its opaque part lies in that sphere's silhouette: its
    #: hit bound is around that part, billboards.quad_hit_bounds.)
    lists_over_bounds: ClassVar[bool] = False
    #: Can a ray that enters an image not baked yet be answered otherwise (the hybrid method traces
    #: it: Unseen.PENDING)? Then a frame's bake may stop at bake_budget and leave the rest to the
    #: next frames.
    traces_pending: ClassVar[bool] = False
    #: What one image is called in the CLI's and the viewer's summaries.
    image_noun: ClassVar[str]
    #: One image per reflected object (False: faces that show them all).
    per_object: ClassVar[bool] = True
    #: The prefiltered colours a glossy mirror's cone reads (only in a scene with one).
    colour_mips: ColourMips | None = None

    def __init__(
        self,
        ctx: moderngl.Context,
        programs: ProgramCache,
        scene: Scene,
        meshes: GpuMeshes,
        materials: DrawnMaterials,
        mirrors: list[ObjectGeometry],
        reflected: list[ObjectGeometry],
        image_plans: dict[int, list[ImagePlan]] | None = None,
    ) -> None:
        """`materials`: the scene's records, of which a bake's draw binds its object's (gpu/scene_blocks.py);
        `image_plans`: the plan's images (RenderPlan.image_plans), so that they are not planned
        again; planned here when not given."""
        plan = image_plans if image_plans is not None else self.plan_images(scene, mirrors, reflected)
        # The records each mirror's table holds: as the programs of this scene declare them.
        self.record_capacity = depth_image_capacity(len(scene.objects))
        if self.record_capacity > DEPTH_IMAGE_BLOCK_RECORDS and ctx.version_code < STORAGE_GL_VERSION:
            raise ContextError(
                f"a scene of {len(scene.objects)} objects keeps its mirrors' image records in storage buffers, which need "
                f"OpenGL 4.3; this context has {ctx.version_code // 100}.{ctx.version_code % 100 // 10}: use a newer "
                f"driver, or at most {DEPTH_IMAGE_BLOCK_RECORDS} objects")
        self.ctx = ctx
        self.programs = programs
        self.scene = scene
        self.meshes = meshes
        layers = self.second_layer != SecondLayer.NONE
        offsets = triangle_offsets(reflected) if self.keeps_triangle_ids else None
        checker = has_checker(item.object for item in reflected)
        self.diffuse = DiffusePass(programs, scene, meshes, materials, write_depth_image=layers, triangle_offsets=offsets,
                                   checker=checker)
        self.back_layer = (DiffusePass(programs, scene, meshes, materials, write_depth_image=True, triangle_offsets=offsets,
                                       back_layer=True, checker=checker) if self.keeps_back_colors else None)
        count = sum(len(images) for images in plan.values())
        # A frame bakes only the stale images its rays may enter (aim), where that is known exactly.
        self.lazily = self.bakes_lazily(scene, count)
        # Slots as large as the largest image ("auto" sizes each image apart). Baked lazily, the
        # images take their tiles at their first bake (place), and the atlas makes the rows they
        # fill then (a thousand objects' first frame bakes a quarter to a third of their images).
        sides = [max(camera.width, camera.height) for images in plan.values() for _, camera, _ in images]
        self.atlas = ImpostorAtlas(ctx, count, max(sides, default=1), layers, self.keeps_triangle_ids,
                                   self.keeps_back_colors, self.keeps_beyond, rows_made=1 if self.lazily else None)
        self.placed = not self.lazily  # have the images their tiles (else each its slot's, for now)?
        self.images_by_reflector: dict[int, list[DepthImage]] = {}
        slot = 0
        for mirror in mirrors:
            images: list[DepthImage] = []
            for targets, camera, level in plan[mirror.index]:
                pyramid = self.atlas.pyramid_layout.entry(slot, camera.width, camera.height)
                label = image_label(mirror, targets, level, None if self.per_object else len(images))
                images.append(DepthImage(mirror, targets, camera, self.atlas.tile_origin(slot), pyramid, level, slot, label))
                slot += 1
            self.images_by_reflector[mirror.index] = images
        self.final_level = scene.render.max_bounces
        self.uniform_buffers = {index: self.uniform_buffer(self.images_at(index, self.final_level))
                                for index in self.images_by_reflector}
        self.bakes = 0  # images rendered so far (tests and stats check that nothing re-bakes)
        self.bake_counts: Counter[str] = Counter()  # by image label
        self.bounce_bakes = 0  # of them, images of reflectors (render.max_bounces > 1)
        self.stale: set[int] = {image.slot for image in self.depth_images}  # slots the next bake renders
        # Each image's objects at the level its texels can tell (lod.py); the hybrid method's at
        # their full meshes, whose triangles its samples name.
        self.detail = None if self.keeps_triangle_ids else BakeDetail()
        # Closed solids' back faces culled in the visible-surface pass, as the frame's batch culls
        # them: seen from outside, each back face lies behind a front face of the same solid.
        self.culls_back_faces = True
        self.due: set[int] | None = None  # the stale slots the next bake renders (None: every one)
        self.entered: EnteredImages | None = None  # the pass that finds them (made at the first aim)
        # What the last aim found them for (the camera, and the moves so far): a frame that sees the
        # same from the same place needs no new pass (its images are baked, or stale and not entered).
        self._aimed_at: tuple[bytes, int] | None = None
        self._moves = 0
        self._mirrors = mirrors
        # Triangles a frame's bake may draw (all its layers' draws together; each sub-frame's of an
        # anti-aliased frame; at least one image however large) where a frame bakes only the images
        # its rays enter and this stand-in can answer the others otherwise (traces_pending): the
        # images past the budget are baked by the next frames, and until then their records say so
        # (surface.w: every stale image's, mark_pending). None: every image a frame enters is baked before
        # it (one picture whatever the frame's number: the CLI's, the benchmark's, the truth's
        # comparisons). The viewer sets it (GraphOptions.bake_budget): its first frame comes
        # before a thousand objects' images are baked, and is traced where they are not.
        self.bake_budget: int | None = None
        self.pending: set[int] = set()  # slots whose records say "not baked yet" (surface.w = 1)

    @classmethod
    def bakes_lazily(cls, scene: Scene, images: int) -> bool:
        """Does a frame bake only the stale images its reflected rays may enter (aim), leaving the
        others stale? Where a mirror's images are many (found through lists: lists_images), one
        per object, and every ray that reads them is a mirror pixel's own reflected ray, which the
        marking pass draws (methods/entered_images.py): no glossy mirror (its cone reads the colour
        mips of every image), no glass (refracted rays), no images of mirrors in mirrors
        (render.max_bounces). The frame is then the one of baking them all (but for the rasterizer's
        rounding of a tile's place: methods/entered_images.py)."""
        return (cls.per_object and images > 0 and lists_images(depth_image_capacity(len(scene.objects)))
                and not scene.has_rough_mirrors and not scene.glass and scene.render.max_bounces == 1)

    def aim(self, camera: PPC | None, surfaces: Surfaces | None, behind_frame: bool = False) -> None:
        """The next bake renders the stale images whose bounds a reflected ray of a frame through
        `camera` may enter (every stale one where this stand-in does not bake lazily, or without a
        camera: the sample view, which draws every image); the others stay stale. `behind_frame`:
        the frame's depth holds what it draws before its mirrors (EnteredImages.find)."""
        if not self.lazily or camera is None or surfaces is None or not self.stale:
            self.due = None
            self._aimed_at = None
            return
        aimed_at = (np.asarray(camera.view_projection, np.float64).tobytes() + np.asarray(camera.C, np.float64).tobytes(),
                    self._moves)
        if aimed_at == self._aimed_at and self.due is not None:
            return  # as the last frame: its images are baked (the stale ones are not entered)
        self._aimed_at = aimed_at
        if self.entered is None:
            self.entered = EnteredImages(self.ctx, self.programs, self.meshes, self.record_capacity,
                                         len(self._mirrors), self.lists_over_bounds)
        tables = [(mirror, self.uniform_buffers[mirror.index], self.images_at(mirror.index, self.final_level))
                  for mirror in self._mirrors]
        found = self.entered.find(camera, surfaces, [(mirror, buffer, len(images)) for mirror, buffer, images in tables],
                                  behind_frame)
        self.due = {images[int(i)].slot for (_, _, images), entered in zip(tables, found, strict=True) for i in entered}

    @property
    def deferred(self) -> int:
        """Images the frames' rays enter that a bake budget left to later frames (their rays are
        traced meanwhile: traces_pending)."""
        return len(self.stale & self.due) if self.due is not None and self.pending else 0

    @property
    def needs_bake(self) -> bool:
        return bool(self.stale if self.due is None else self.stale & self.due)

    def bake_again(self) -> None:
        """Render every image at the next bake, although nothing moved (the benchmark's). The bakes'
        depth buffer is made now if a frame let it go (rest): a timed bake is then the bake alone,
        as an animated scene, which keeps it, pays it every frame. (Making it costs the 8 x 9
        scene's bake at 1024^2 about a quarter more: tools/bake_cost.py.) Every image, even where
        a frame bakes only those its rays enter (lazily): the benchmark times the whole bake."""
        self.stale = {image.slot for image in self.depth_images}
        self.lazily = False
        self.due = None
        self.atlas.bake_buffer()

    def refit(self, image: DepthImage, mirror: ObjectGeometry, targets: tuple[ObjectGeometry, ...]) -> PPC:
        """The camera of `image` once its mirror or objects moved, at the image's own size."""
        return fit_depth_image_camera(self.scene, mirror, targets[0], image.camera.width)

    def move(self, geometry: dict[int, ObjectGeometry], moved: set[int], stale_targets: set[int]) -> None:
        """Objects (by index) moved to `geometry`: their images are fitted again and, with every
        image showing an object of `stale_targets` (a light that shades it moved, or a shadow
        that may fall on it), baked at the next bake. Bounce images follow what they show."""
        self._mirrors = [geometry[mirror.index] for mirror in self._mirrors]
        self._moves += 1
        # A world that moves bakes what is stale, every image, as it did: the pass that finds the
        # entered ones would run at every frame that moves it, and a moved object's images are few.
        # Not under a bake budget: there the first move would bake every image no frame entered
        # yet (a thousand objects' 4 s), where the pass costs a few milliseconds a frame.
        self.lazily = self.lazily and self.budgeted
        self.due = None
        for index, images in self.images_by_reflector.items():
            for i, image in enumerate(images):
                mirror, targets = geometry[index], tuple(geometry[t.index] for t in image.targets)
                if index in moved or any(t.index in moved for t in targets):
                    images[i] = image.moved(mirror, targets, self.refit(image, mirror, targets))
                    self.stale.add(image.slot)
                elif not image.level and any(t.index in stale_targets for t in targets):
                    self.stale.add(image.slot)
        self._spread_staleness()
        for index, buffer in self.uniform_buffers.items():
            write_table(buffer, self.record_table(self.images_at(index, self.final_level)))
        self.pending = set()  # what the tables made again say
        if self.budgeted:
            self.mark_pending()
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
        cls, scene: Scene, mirrors: list[ObjectGeometry], reflected: list[ObjectGeometry], reach: ReachTable = reaches
    ) -> dict[int, list[ImagePlan]]:
        """The images to bake for each mirror (by its index): by default one per reflected
        object it may show (depth images, billboards); cube maps bake six faces instead."""
        return per_object_plan(scene, mirrors, reflected, reach, cls.texel_bytes())

    @classmethod
    def texel_bytes(cls) -> int:
        """GPU memory a texel of this stand-in's atlas takes, with the depth buffer it is baked with."""
        return ImpostorAtlas.bytes_for(1, 1, cls.second_layer != SecondLayer.NONE, cls.keeps_triangle_ids,
                                       cls.keeps_back_colors, cls.keeps_beyond)

    @classmethod
    def table_bytes(cls, scene: Scene, mirrors: list[ObjectGeometry], plans: dict[int, list[ImagePlan]]) -> tuple[int, int]:
        """GPU bytes of the mirrors' record tables (uniform_buffers) and of those the bounce images
        are drawn with (BounceBaker.level_buffers), for the images `plans`: their records and the
        lists of candidate images by ray they hold past them (methods/image_cells.py), each counted
        as record_table builds it, before any is built (the plan's memory figure)."""
        capacity = depth_image_capacity(len(scene.objects))
        final = scene.render.max_bounces
        bounces = range(1, final) if final > 1 and len(mirrors) > 1 and cls.second_layer == SecondLayer.BACK_FACE else range(0)
        tables = [0, 0]
        for mirror in mirrors:
            mirror_plans = plans.get(mirror.index, [])
            cameras = [plan.camera for plan in mirror_plans]
            arounds = [plan.targets[0].bounding_sphere if len(plan.targets) == 1 else None for plan in mirror_plans]
            records = cls.with_hit_bounds(depth_image_records(
                cameras, [0] * len(mirror_plans), [(0, 0)] * len(mirror_plans), [(0, 0, 0)] * len(mirror_plans), arounds),
                cameras, arounds)
            spheres = np.asarray(records["bound" if cls.lists_over_bounds else "hit_bound"], np.float64)
            rays_from = mirror.bounding_sphere if mirror_plans else (np.zeros(3), 0.0)
            for level, kind in [(final, 0), *((level, 1) for level in bounces)]:
                shown = [i for i, plan in enumerate(mirror_plans) if plan.level in (0, level)]
                tables[kind] += record_table_bytes(spheres[shown], capacity, rays_from)
        return tables[0], tables[1]

    def images_at(self, mirror_index: int, bounces: int) -> list[DepthImage]:
        """The images a reflected ray of this mirror is traced against when it may make
        `bounces` bounces: the diffuse objects', and the other mirrors' that show bounces - 1."""
        return [image for image in self.images_by_reflector[mirror_index] if image.level in (0, bounces)]

    @property
    def depth_images(self) -> list[DepthImage]:
        return [image for images in self.images_by_reflector.values() for image in images]

    @property
    def bytes(self) -> int:
        mips = self.colour_mips.bytes if self.colour_mips is not None else 0
        return self.atlas.bytes + sum(buffer.size for buffer in self.uniform_buffers.values()) + mips

    def use_colour_mips(self, wanted: bool) -> None:
        """Keep the images' colour mips (a glossy mirror's cone reads them) or free them. New ones
        are built at once from the images already baked."""
        if wanted and self.colour_mips is None:
            self.colour_mips = ColourMips(self.ctx, self.programs, self.atlas.pyramid_layout, self.tiles_by_place())
            if self.bakes:
                self.colour_mips.build(self.atlas.color)
        elif not wanted and self.colour_mips is not None:
            self.colour_mips.release()
            self.colour_mips = None

    def build_colour_mips(self) -> None:
        """The colour mips of every image, from the atlas as baked (the graph's colour-mip node)."""
        if self.colour_mips is not None:
            self.colour_mips.build(self.atlas.color)

    def describe(self) -> str:
        sides = sorted({image.camera.width for image in self.depth_images}) or [self.atlas.resolution]
        sizes = " to ".join(f"{side}x{side}" for side in dict.fromkeys((sides[0], sides[-1])))
        return f"{plural(len(self.depth_images), self.image_noun)} of {sizes}"

    @classmethod
    def with_hit_bounds(cls, records: NDArray[np.void], cameras: Sequence[PPC],
                        arounds: Sequence[tuple[NDArray[np.float64], float] | None]) -> NDArray[np.void]:
        """`records` with the hit bounds this stand-in's rays are tested against (a subclass whose
        images' hits lie elsewhere than a depth image's rewrites them: billboards)."""
        return records

    def image_records(self, images: list[DepthImage]) -> NDArray[np.void]:
        """The record table of a mirror's `images` (a subclass may add what its shader reads)."""
        return image_records(images, self.record_capacity)

    def record_table(self, images: list[DepthImage]) -> builtins.bytes:  # (`bytes` is a property here)
        """A mirror's record table of `images` (all of one mirror, whose reflected rays read it), as
        its buffer holds it (atlas.record_table)."""
        rays_from = images[0].mirror.bounding_sphere if images else (np.zeros(3), 0.0)
        return record_table(self.image_records(images), len(images), self.record_capacity, rays_from,
                            self.lists_over_bounds)

    def uniform_buffer(self, images: list[DepthImage]) -> moderngl.Buffer:
        """The buffer of a mirror's record table (a uniform block's or a storage buffer's: bind_records)."""
        return self.ctx.buffer(self.record_table(images))

    def bind_records(self, buffer: moderngl.Buffer) -> None:
        """Bind one of uniform_buffer's buffers where this stand-in's programs read it."""
        bind_image_records(buffer, self.record_capacity)

    def bind(self, program: moderngl.Program) -> None:
        bind_impostors(program, self.atlas)
        if self.colour_mips is not None:
            self.colour_mips.bind(program)

    def bind_reflector(self, program: moderngl.Program, mirror: ObjectGeometry) -> None:
        self.bind_records(self.uniform_buffers[mirror.index])
        write(program, "u_depth_image_count", len(self.images_at(mirror.index, self.final_level)))

    def bake(self) -> int:
        """Render the stale images into their tiles, layer by layer (every image's visible surface,
        then every back layer, then where second runs begin: three framebuffers bound in turn, not
        three an image, since a software rasterizer flushes its work at each change); returns the
        number of draw calls. Where every slot is stale (the first bake, `bake_again`), each
        layer's attachments are cleared whole, once, instead of tile by tile (_clears). The depth
        buffer is the bakes' scratch, let go when a frame bakes nothing (rest)."""
        due = self.stale if self.due is None else self.stale & self.due
        if not any(not image.level and image.slot in due for image in self.depth_images):
            return 0
        if not self.placed:
            self.place(due if self.due is not None else None)
        stale = [image for image in self.depth_images if not image.level and image.slot in due]
        drawn = dict(zip((image.slot for image in stale), self.drawn(stale), strict=True))
        if self.budgeted and self.due is not None:  # (not the sample view's, nor bake_again's)
            stale = self.within_budget(stale, drawn)
            due = {image.slot for image in stale}
        atlas = self.atlas
        atlas.grow(1 + max(atlas.slot_of(image.tile) for image in stale))
        atlas.bake_buffer()
        # Every image of every level: those of reflectors are baked after these (the bounce node).
        whole = due >= {image.slot for image in self.depth_images}
        if whole:
            atlas.unwritten = False  # every attachment is cleared whole below
        else:
            atlas.clear_unwritten()
        draws = 0
        # Each image's matrix once, all at once (ppc.view_projections), for every layer's pass.
        matrices = dict(zip((image.slot for image in stale), view_projections([image.camera for image in stale]),
                            strict=True))
        with raster_state(self.ctx):
            draws += self._bake_surfaces(stale, whole, matrices, drawn)
            if self.back_layer is not None:
                draws += self._bake_back_layers(stale, whole, matrices, drawn)
                if atlas.beyond is not None:
                    draws += self._bake_beyond(stale, whole, matrices)
            elif self.second_layer == SecondLayer.BACK_FACE:
                try:
                    for image in stale:
                        draws += self.bake_back_faces(image, atlas.framebuffer, image.tile, drawn[image.slot])
                finally:
                    atlas.framebuffer.color_mask = atlas.masks(*[(True,) * 4] * len(atlas.textures))
        for image in stale:
            self.baked(image)
        if self.budgeted:
            self.mark_pending()
        return draws

    @property
    def budgeted(self) -> bool:
        """Does a frame's bake stop at bake_budget, its rays answered otherwise where it did?"""
        return self.bake_budget is not None and self.traces_pending

    def within_budget(self, stale: list[DepthImage], drawn: dict[int, list[ObjectGeometry]]) -> list[DepthImage]:
        """The first of `stale` (in slot order, at least one) whose bakes draw no more than
        bake_budget triangles in all: each image's drawn meshes once per layer pass."""
        assert self.bake_budget is not None
        passes = 1 + (self.back_layer is not None) + (self.atlas.beyond is not None)
        kept: list[DepthImage] = []
        spent = 0
        for image in stale:
            cost = passes * sum(len(item.local_mesh.indices) for item in drawn[image.slot])
            if kept and spent + cost > self.bake_budget:
                break
            kept.append(image)
            spent += cost
        return kept

    def mark_pending(self) -> None:
        """Write into the mirrors' records which images wait for a bake (surface.w: 1 for each
        stale image, 0 for the others) where that changed: a ray that enters one is traced
        (Unseen.PENDING) until a later frame bakes it. (A budget bakes lazily, so with one bounce:
        every stale image is in the records, none a bounce image that the bounce node bakes.)"""
        pending = set(self.stale)
        if pending == self.pending:
            return
        self.pending = pending

        def marked(records: NDArray[np.void], images: list[DepthImage]) -> None:
            records["surface"][:, 3] = [float(image.slot in pending) for image in images]

        self.rewrite_records(marked)

    def place(self, first: set[int] | None = None) -> None:
        """Give every image its tile, once: the images of the slots in `first` (the first bake's)
        the atlas's first tiles, in slot order, then the others (each its slot's tile where `first`
        is None), and write the tiles into the mirrors' records. A frame that bakes a quarter of
        the images then fills a quarter of the atlas's rows (ImpostorAtlas.grow makes more when
        later frames bake more)."""
        if self.placed:
            return
        self.placed = True
        order = sorted(self.depth_images, key=lambda image: (image.slot not in first, image.slot)) if first else []
        places = {image.slot: place for place, image in enumerate(order)}
        if all(slot == place for slot, place in places.items()):
            return  # each in its slot's tile already
        layout = self.atlas.pyramid_layout
        for images in self.images_by_reflector.values():
            images[:] = [dataclasses.replace(image, tile_origin=self.atlas.tile_origin(places[image.slot]),
                                             pyramid=layout.entry(places[image.slot], image.camera.width, image.camera.height))
                         for image in images]
        def placed(records: NDArray[np.void], images: list[DepthImage]) -> None:
            records["tile"][:, :2] = [image.tile_origin for image in images]
            records["pyramid"][:, :3] = [image.pyramid for image in images]

        self.rewrite_records(placed)

    def rewrite_records(self, change: Callable[[NDArray[np.void], list[DepthImage]], None]) -> None:
        """Change some fields of every mirror's records in place (`change(records, images)`), the
        rest of its table (the lists past them) as it is: building the table again costs its lists."""
        for index, buffer in self.uniform_buffers.items():
            images = self.images_at(index, self.final_level)
            if not images:
                continue
            size = len(images) * DEPTH_IMAGE_DTYPE.itemsize
            records = np.frombuffer(buffer.read(size=size), DEPTH_IMAGE_DTYPE).copy()
            change(records, images)
            buffer.write(records.tobytes())

    def tiles_by_place(self) -> list[tuple[int, int, int, int]]:
        """Every image's tile, in the atlas's order of tiles (the pyramids' and colour mips' table,
        whose k-th entry has the k-th place of their grid), every image placed and its rows made."""
        self.place()
        self.atlas.grow(self.atlas.count)
        tiles: list[tuple[int, int, int, int]] = [(0, 0, 0, 0)] * len(self.depth_images)
        for image in self.depth_images:
            tiles[self.atlas.slot_of(image.tile)] = image.tile
        return tiles

    def drawn(self, images: list[DepthImage]) -> list[list[ObjectGeometry]]:
        """The objects of each of `images` (of level 0) as its bake draws them: each at its level
        (lod.BakeDetail)."""
        if self.detail is None:
            return [list(image.targets) for image in images]
        return self.detail.drawn([(image.camera, image.targets) for image in images])

    def rest(self) -> None:
        """A frame with nothing to bake: the bakes' depth buffer (one float a texel of the atlas)
        is let go until the next bake makes it again. A scene where nothing moves keeps it for its
        first frame alone; one whose objects or lights move bakes every frame and keeps it."""
        self.atlas.free_bake_buffer()

    def _clears(self, stale: list[DepthImage], whole: bool) -> list[tuple[int, int, int, int] | None]:
        """The viewports a layer's clear covers: the whole atlas (None) or each stale tile. One whole
        clear costs less than one a tile where all are stale: llvmpipe folds a whole clear into the
        tiles' first writes, and draws a scissored one."""
        return [None] if whole else [image.tile for image in stale]

    def _bake_surfaces(self, stale: list[DepthImage], whole: bool, matrices: dict[int, np.ndarray],
                       drawn: dict[int, list[ObjectGeometry]]) -> int:
        """The visible surface of each stale image (`drawn`: its objects as drawn, by slot): colour,
        R (and G where G is the object id), the triangle ids' R; cleared to colour alpha 0 ("nothing
        here") and BACKGROUND_DEPTH in both layers, the value the depth buffer clears to. An image
        whose objects are all closed solids (batches.is_closed) is drawn with their back faces
        culled: each lies behind a front face of its own solid, and tools/frames.py and
        tools/bake_levels.py --against culling find no frame or error figure that changes."""
        atlas = self.atlas
        framebuffer = atlas.framebuffer
        framebuffer.use()
        everything = atlas.masks(*[(True,) * 4] * len(atlas.textures))
        surface_mask = atlas.masks((True,) * 4, (True, self.second_layer == SecondLayer.OBJECT_ID, False, False),
                                   (True, False, False, False))
        draws = 0
        try:
            framebuffer.color_mask = everything
            framebuffer.viewport = (0, 0, *atlas.size)
            for tile in self._clears(stale, whole):
                framebuffer.clear(BACKGROUND_DEPTH, BACKGROUND_DEPTH, 1.0, 0.0, depth=BACKGROUND_DEPTH, viewport=tile)
            framebuffer.color_mask = surface_mask
            for image in stale:
                framebuffer.viewport = image.tile
                closed = self.culls_back_faces and all(is_closed(item) for item in drawn[image.slot])
                with raster_state(self.ctx, FRONT_FACES if closed else BASE):
                    draws += self.diffuse.draw(drawn[image.slot], matrices[image.slot])
        finally:
            framebuffer.color_mask = everything
        return draws

    def baked(self, image: DepthImage) -> None:
        self.bakes += 1
        self.bounce_bakes += bool(image.level)
        self.bake_counts[image.label] += 1
        self.stale.discard(image.slot)

    def bake_back_faces(self, image: DepthImage, framebuffer: moderngl.Framebuffer, tile: tuple[int, int, int, int],
                        drawn: list[ObjectGeometry] | None = None) -> int:
        """The nearest back face: the G layer alone, against a fresh depth buffer (images of
        reflectors at bounce k >= 2, which have no colour of their backs to show); `drawn`: the
        image's objects as its surface pass drew them (its targets by default)."""
        back_faces = self.programs.get(*BACK_FACE_PROGRAM, alpha_mask_defines(self.scene))
        drawn = list(image.targets) if drawn is None else drawn
        attachments = len(framebuffer.color_attachments)
        framebuffer.viewport = tile
        framebuffer.color_mask = color_mask(attachments)
        framebuffer.clear(depth=BACKGROUND_DEPTH, viewport=tile)
        framebuffer.color_mask = color_mask(attachments, (False,) * 4, (False, True, False, False))
        with raster_state(self.ctx, BACK_FACES):
            for target in drawn:
                write_material_index(back_faces, self.scene, target.object)
                self.meshes.draw(back_faces, target, image.camera.view_projection)
        return len(drawn)

    def _bake_back_layers(self, stale: list[DepthImage], whole: bool, matrices: dict[int, np.ndarray],
                          drawn: dict[int, list[ObjectGeometry]]) -> int:
        """The nearest back face's colour, depth (G) and triangle (G) of each stale image (its
        objects as the surface pass drew them), against a fresh depth buffer; the colour cleared
        to alpha 0 (none drawn)."""
        assert self.back_layer is not None and self.atlas.back_framebuffer is not None
        framebuffer, atlas = self.atlas.back_framebuffer, self.atlas
        framebuffer.use()
        framebuffer.viewport = (0, 0, *atlas.size)
        try:
            framebuffer.color_mask = atlas.masks((True,) * 4)
            for tile in self._clears(stale, whole):
                framebuffer.clear(1.0, 1.0, 1.0, 0.0, depth=BACKGROUND_DEPTH, viewport=tile)
            framebuffer.color_mask = atlas.masks((True,) * 4, (False, True, False, False), (False, True, False, False))
            draws = 0
            with raster_state(self.ctx, BACK_FACES):
                for image in stale:
                    framebuffer.viewport = image.tile
                    draws += self.back_layer.draw(drawn[image.slot], matrices[image.slot])
            return draws
        finally:
            framebuffer.color_mask = atlas.masks(*[(True,) * 4] * len(atlas.textures))

    def _bake_beyond(self, stale: list[DepthImage], whole: bool, matrices: dict[int, np.ndarray]) -> int:
        """Where a second solid run begins behind the first (beyond_run.frag), for each stale
        image: the nearest front face behind the layers just baked, which it reads (they are not
        attached here)."""
        assert self.atlas.beyond_framebuffer is not None
        program = self.programs.get(*BEYOND_PROGRAM, alpha_mask_defines(self.scene))
        framebuffer = self.atlas.beyond_framebuffer
        framebuffer.use()
        framebuffer.viewport = (0, 0, *self.atlas.size)
        for tile in self._clears(stale, whole):
            framebuffer.clear(BACKGROUND_DEPTH, depth=BACKGROUND_DEPTH, viewport=tile)
        bind_texture(program, "u_impostor_depth", self.atlas.depth_layers(), TextureUnit.IMPOSTOR_DEPTH)
        with raster_state(self.ctx, FRONT_FACES):
            for image in stale:
                framebuffer.viewport = image.tile
                for target in image.targets:
                    write_material_index(program, self.scene, target.object)
                    self.meshes.draw(program, target, matrices[image.slot])
        return sum(len(image.targets) for image in stale)

    def release(self) -> None:
        self.use_colour_mips(False)
        for buffer in self.uniform_buffers.values():
            buffer.release()
        if self.entered is not None:
            self.entered.release()
        self.atlas.release()


def budgeted_side(count: int, asked: int, budget: int, texel_bytes: int) -> int:
    """The largest image side, at most `asked`, at which an atlas of `count` images of
    `texel_bytes` a texel keeps within `budget` bytes (a multiple of 4; MIN_BUDGETED_SIDE at least)."""
    columns, rows = atlas_grid(count)
    fits = math.isqrt(budget // (columns * rows * texel_bytes))
    return min(asked, max(MIN_BUDGETED_SIDE, fits - fits % 4))


def largest_side(scene: Scene, mirrors: int, per_object: int, texel_bytes: int) -> int:
    """The largest side the images of `mirrors` mirrors showing `per_object` objects in all may
    have within render.image_memory, with the mirrors' images of each other (render.max_bounces)."""
    count = per_object + mirrors * (mirrors - 1) * (scene.render.max_bounces - 1)
    asked = MAX_AUTO_RESOLUTION if scene.render.auto_resolution else int(scene.render.impostor_resolution)
    return budgeted_side(max(count, 1), asked, scene.render.image_memory * 2**20, texel_bytes)


def image_camera(scene: Scene, view: PPC, mirror: ObjectGeometry, target: ObjectGeometry, largest: int | None = None,
                 fit: FrustumFit | None = None, pixels_per_radian: float | None = None) -> PPC:
    """The camera of `target`'s image for `mirror`: fitted at render.impostor_resolution, or at
    the resolution `view` (the scene's camera) asks for when it is "auto" (resolution.py); at most
    `largest` (the memory budget's side: budgeted_side). `fit`: its frustum, found already
    (fit_depth_image_frusta); `pixels_per_radian`: the mirror's reflected pixels toward `target`,
    worked out already with its other images (MirrorDensity)."""
    cap = largest if largest is not None else MAX_AUTO_RESOLUTION
    if not scene.render.auto_resolution:
        return fit_depth_image_camera(scene, mirror, target, _fixed_side(scene, largest), fit)
    probe = fit_depth_image_camera(scene, mirror, target, min(MIN_AUTO_RESOLUTION, cap), fit)
    side = auto_resolution(view, mirror, target, probe, pixels_per_radian)
    return fit_depth_image_camera(scene, mirror, target, min(side, cap), fit)


def _fixed_side(scene: Scene, largest: int | None) -> int:
    """The side of every image where render.impostor_resolution is a number: it, at most `largest`."""
    return min(int(scene.render.impostor_resolution), largest if largest is not None else MAX_AUTO_RESOLUTION)


def image_cameras(scene: Scene, view: PPC, mirror: ObjectGeometry, targets: Sequence[ObjectGeometry], largest: int | None,
                  fits: Sequence[FrustumFit], pixels_per_radian: Sequence[float | None]) -> list[PPC]:
    """image_camera of each of `targets` (`fits`: their frusta; `pixels_per_radian`: the mirror's
    reflected pixels toward each, or None each): at a fixed resolution, all at once (ppc.fitted_cameras:
    the same cameras)."""
    if not scene.render.auto_resolution:
        side = _fixed_side(scene, largest)
        return fitted_cameras(fits, side, side)
    return [image_camera(scene, view, mirror, target, largest, fit, pixels)
            for target, fit, pixels in zip(targets, fits, pixels_per_radian, strict=True)]


def per_object_plan(scene: Scene, mirrors: list[ObjectGeometry], reflected: list[ObjectGeometry],
                    reach: ReachTable = reaches, texel_bytes: int | None = None) -> dict[int, list[ImagePlan]]:
    """One image per mirror and reflected object it may show (`reach`: culling.reaches, or a
    World's, which works each pair out once), its frustum fitted to the object; with `texel_bytes`
    (the stand-in's atlas texel: BakedImages.texel_bytes), its side lowered where the images would
    pass render.image_memory (budgeted_side)."""
    view = scene_view(scene)
    shown = {mirror.index: [target for target, why in zip(reflected, row, strict=True) if why is Reach.REACHABLE]
             for mirror, row in zip(mirrors, reach(mirrors, reflected), strict=True)}
    largest = (None if texel_bytes is None
               else largest_side(scene, len(mirrors), sum(len(targets) for targets in shown.values()), texel_bytes))
    # The targets' bounding spheres are found with their fits, from the same placed vertices; the
    # others' (objects of one mesh together) after: each camera reads its mirror's.
    fits = fit_depth_image_frusta(scene, [(mirror, shown[mirror.index]) for mirror in mirrors])
    bounding_spheres([*mirrors, *reflected])
    plans = {}
    for mirror in mirrors:
        targets = shown[mirror.index]
        # The mirror's reflected pixels toward each object, all at once ("auto" alone reads them).
        rho: list[float | None] = (list(MirrorDensity(view, mirror).pixels_per_radian_of(targets))
                                   if scene.render.auto_resolution and targets else [None] * len(targets))
        cameras = image_cameras(scene, view, mirror, targets, largest, [fits[(mirror.index, target.index)] for target in targets],
                                rho)
        plans[mirror.index] = [ImagePlan((target,), camera) for target, camera in zip(targets, cameras, strict=True)]
    return plans
