"""The scene at one time: where each object is, sorted into what each pass draws, and what can reach
what. The plan (plan.py) and the renderer read this one model instead of each sorting the scene
and running the culling again.

What can reach what (culling.reaches: can a ray leaving a reflector meet a target?) is worked out
once per pair of objects in a world, and carried to the world of another time for the pairs of
which neither object moves.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Hashable, Sequence
from functools import cached_property
from typing import Any, TypeVar, cast

import numpy as np

from .culling import Reach, reaches
from .eye import fitted_camera
from .geometry import (
    ObjectGeometry, bounding_spheres, has_levels, linear_transforms, max_level, mesh_key, scene_geometry, world_mesh,
)
from .meshes import Mesh
from .lod import LOD_PIXEL_ERROR, LOD_REFLECTED_PIXEL_ERROR, EyeView, LevelTable, detail_levels
from .ppc import PPC
from .scene.model import Camera, Scene, Shape

Sphere = tuple[np.ndarray, float]
#: The most distinct round shapes whose every level the eye's levels make up front (World.eye_meshes).
EYE_LEVEL_SHAPES = 256
T = TypeVar("T")


class World:
    def __init__(self, scene: Scene, geometry: list[ObjectGeometry] | None = None, time: float = 0.0) -> None:
        """`scene`'s objects at `time` seconds into its animation (`geometry`: already made at that time)."""
        self.scene = scene
        self.time = time
        lights = scene.lights_at(time)
        # The scene with its lights where they are at `time` (the one the passes shade with).
        self.lit_scene = scene if lights == tuple(scene.lights) else dataclasses.replace(scene, lights=lights)
        self._reach: dict[tuple[int, int], Reach] = {}  # (reflector index, target index)
        # What the plan worked out from these objects under some render settings (the images each
        # reflector bakes, by stand-in and settings): kept across settings changes.
        self._planned: dict[Hashable, Any] = {}
        self.reach_pairs_computed = 0  # pairs culling.reaches worked out for this world (tests count them)
        # The eye's levels (eye_drawn): the meshes of every level (eye_meshes), and by (index, level)
        # each object as the eye draws it beside the geometry it stands for. Carried to the world of
        # another time or other settings (at, with_settings): a still object at the same level
        # keeps what it had, and with it its GPU buffers and the batch; a new world makes its own,
        # as it makes its own meshes (geometry.world_mesh), so that they are loaded together.
        self._eye_meshes: dict[tuple[Shape, bool, int], Mesh] = {}
        self._eye_meshes_made = [False]  # shared with the dict: made once, even where it stays empty
        self._eye_items: dict[tuple[int, int], tuple[ObjectGeometry, ObjectGeometry]] = {}
        # The objects kept at their full meshes because a reflector can show them (_detailed): the
        # eye draws them at LOD_REFLECTED_PIXEL_ERROR, the others at LOD_PIXEL_ERROR. Carried too.
        self._reached: set[int] = set()
        self._world_levels: dict[int, int] = {}  # `geometry`'s level of each object not at its full mesh
        self._eye_drawn_for: tuple[EyeView, list[ObjectGeometry]] | None = None  # the last view's
        if geometry is None:
            self._sort([g.at(time) for g in scene_geometry(scene.objects)])
            geometry = self._detailed()
        self._sort(geometry)

    def _sort(self, geometry: list[ObjectGeometry]) -> None:
        """Sort `geometry` into what each pass draws (each object's normal matrix worked out with
        the others': the passes draw nearly all of them in the first frame)."""
        self.geometry = geometry
        linear_transforms(geometry)
        scene = self.scene
        self.mirrors = [g for g in geometry if g.object.is_mirror]
        self.glass = [g for g in geometry if g.object.is_glass]
        # Mirrors and glass: drawn by the mirror pass, each with depth images of the others.
        self.reflectors = [g for g in geometry if g.object.is_reflector]
        # The planes intersected exactly (the scene chooses them: Scene.analytic_plane_indices);
        # every other diffuse object, planes past those included, is reflected through the stand-in.
        analytic = scene.analytic_plane_indices
        self.analytic_planes = [g for g in geometry if g.index in analytic]
        self.diffuse_objects = [g for g in geometry if not g.object.is_reflector]
        # The eye draws the blended ones apart, after the opaque ones (passes/transparent.py).
        self.opaque_diffuse = [g for g in self.diffuse_objects if not g.object.is_blended]
        self.blended_objects = [g for g in self.diffuse_objects if g.object.is_blended]
        self.reflected_objects = [g for g in self.diffuse_objects if g.index not in analytic]
        self.__dict__.pop("shadow_casters", None)
        self.__dict__.pop("bounds", None)
        self._eye_drawn_for = None
        self._eye_level_table: LevelTable | None = None

    def _detailed(self) -> list[ObjectGeometry]:
        """This world's (full) geometry with each object at its level of detail (lod.py): what a
        reflector can show, reflectors, moving objects and shadow casters keep their full meshes
        (and their geometry, so that what was worked out about them stays true)."""
        keep = {g.index for g in self.reflectors} | {g.index for g in self.geometry if g.object.moves}
        if self.scene.has_shadows:
            keep |= {g.index for g in self.shadow_casters}
        # Every pair at once: culling.reaches works on all of a world's reflectors together.
        for row in self.reaches(self.reflectors, self.reflected_objects):
            self._reached |= {g.index for g, why in zip(self.reflected_objects, row, strict=True) if why is Reach.REACHABLE}
        keep |= self._reached
        levels = self._world_levels = detail_levels(EyeView.of_scene(self.scene), self.geometry, keep)
        if not levels:
            return self.geometry
        # What a reflector can reach was worked out with the full meshes: kept for unchanged objects.
        self._reach = {pair: why for pair, why in self._reach.items() if pair[1] not in levels}
        detailed = scene_geometry(self.scene.objects, levels)
        return [detailed[g.index].at(self.time) if g.index in levels else g for g in self.geometry]

    @property
    def eye_drawn(self) -> list[ObjectGeometry]:
        """eye_drawn_for the scene file's camera at the scene's frame size (the plan's estimates)."""
        return self.eye_drawn_for(EyeView.of_scene(self.scene))

    def eye_drawn_for(self, view: EyeView) -> list[ObjectGeometry]:
        """The opaque diffuse objects as the eye's diffuse pass draws them from `view` (the frame's
        camera: a viewer, a video or a dataset frame moves it): each at the coarsest level whose
        error in the view's frame stays under LOD_REFLECTED_PIXEL_ERROR where a reflector can show
        it (`geometry` keeps its full mesh: the rays that meet it, the triangle methods', the
        truth's, the images' bakes, see it at another size than the eye does), under
        LOD_PIXEL_ERROR where none can (`geometry` holds it at its level for the scene's camera: a
        view closer to it draws it finer), each at the nearest level the world has loaded that is
        no coarser (eye_meshes); moving objects and shadow casters as `geometry` has them. The last
        view's list is kept: a frame drawn again from the same place is the same list, and the
        diffuse pass keeps its batch."""
        if self._eye_drawn_for is not None and self._eye_drawn_for[0] == view:
            return self._eye_drawn_for[1]
        levels = self._eye_levels(view)
        meshes, kept = self.eye_meshes, self._eye_items
        drawn = []
        for g in self.opaque_diffuse:
            wanted = levels.get(g.index, 0)
            full, as_drawn = kept.get((g.index, wanted), (None, g))
            if full is not g:  # not drawn at this level by an earlier view or world of this one's
                as_drawn = g
                own = self._world_levels.get(g.index, 0)
                # The wanted level, else the nearest finer one loaded; `geometry`'s own where it comes
                # first (or where no finer one is loaded: past EYE_LEVEL_SHAPES shapes).
                for level in range(wanted, -1, -1):
                    if level == own:
                        break
                    mesh = meshes.get(mesh_key(g.object, level))
                    if mesh is not None:
                        as_drawn = g.drawn_with(mesh)
                        break
                kept[(g.index, wanted)] = (g, as_drawn)
            drawn.append(as_drawn)
        self._eye_drawn_for = (view, drawn)
        return drawn

    def _eye_levels(self, view: EyeView) -> dict[int, int]:
        """The eye's level of each object drawn from `view` at another level than its full mesh's
        (eye_drawn_for), by index."""
        if self._eye_level_table is None:  # the objects' spheres and limits, found once for every view
            reached = self._reached
            self._eye_level_table = LevelTable.of(
                self.opaque_diffuse, self._eye_kept, lambda g: LOD_REFLECTED_PIXEL_ERROR if g.index in reached else LOD_PIXEL_ERROR)
        return self._eye_level_table.levels(view)

    @property
    def _eye_kept(self) -> set[int]:
        """The objects the eye draws at their full meshes: those that move, and shadow casters."""
        keep = {g.index for g in self.geometry if g.object.moves}
        if self.scene.has_shadows:
            keep |= {g.index for g in self.shadow_casters}
        return keep

    @property
    def eye_meshes(self) -> dict[tuple[Shape, bool, int], Mesh]:
        """The levels of the round shapes the eye may draw at another level than `geometry`'s, by
        (shape, seam, level), made once for a world and the worlds of its other times and
        settings: loaded with the world's meshes (one arena, which a batch draws from), so that a
        moved camera's or a resized frame's levels are there already (each level is a quarter of
        the one before: together a third of the full mesh, once per shape, about 13 ms to make a
        sphere's). Every level of every such shape (the full mesh too, where `geometry` holds its
        objects coarser), where they are at most EYE_LEVEL_SHAPES; past that (a scene of a
        thousand spheres of a thousand radii), the coarser levels of those the scene's camera
        draws coarser alone: a view that wants another level of the others draws them as
        `geometry` has them (a closer view, then, sees the facets of the scene camera's level)."""
        if not self._eye_meshes_made[0]:  # filled in place, once: the worlds that share the dict see them
            self._eye_meshes_made[0] = True
            keep = self._eye_kept
            shapes = {mesh_key(g.object)[:2] for g in self.opaque_diffuse if g.index not in keep and has_levels(g.object.shape)}
            coarser = {g.object.shape for g in self.opaque_diffuse if self._world_levels.get(g.index, 0)}
            if len(shapes) > EYE_LEVEL_SHAPES:
                levels = self._eye_levels(EyeView.of_scene(self.scene))
                shapes = {mesh_key(g.object)[:2] for g in self.opaque_diffuse
                          if levels.get(g.index, 0) != self._world_levels.get(g.index, 0)}
                coarser = set()
            self._eye_meshes.update({(shape, textured, level): world_mesh(shape, textured, level)
                                     for shape, textured in shapes
                                     for level in range(0 if shape in coarser else 1, max_level(shape) + 1)})
        return self._eye_meshes

    @property
    def meshes(self) -> list[Mesh]:
        """Every mesh the world's objects are drawn with: theirs, and every level the eye may draw
        them at (eye_meshes), loaded together so that one batch draws them."""
        return [g.local_mesh for g in self.geometry] + list(self.eye_meshes.values())

    @cached_property
    def shadow_casters(self) -> list[ObjectGeometry]:
        """The objects that cast shadows, where asked (finding them hashes every object: 20 ms of a
        thousand objects' start, for scenes without shadows too)."""
        casters = set(self.scene.shadow_casters)
        return [g for g in self.geometry if g.object in casters]

    @cached_property
    def bounds(self) -> list[Sphere]:
        """Every object's bounding sphere (the eye camera's near plane is fitted to them)."""
        return bounding_spheres(self.geometry)

    def camera(self, view: Camera | None = None, size: tuple[int, int] | None = None, reversed_: bool = False) -> PPC:
        """The eye camera of `view` (the scene's by default) at `size`, its near and far planes
        fitted to this world's bounds (eye.py; `reversed_`: the reversed-Z projection)."""
        return fitted_camera(view or self.scene.camera, size or self.scene.render.size, self.bounds, reversed_)

    def reaches(self, reflectors: Sequence[ObjectGeometry], targets: Sequence[ObjectGeometry]) -> list[list[Reach]]:
        """culling.reaches of this world's objects, each pair worked out once."""
        missing_rows = [r for r in reflectors if any((r.index, t.index) not in self._reach for t in targets)]
        if missing_rows:
            missing_targets = [t for t in targets if any((r.index, t.index) not in self._reach for r in missing_rows)]
            for reflector, row in zip(missing_rows, reaches(missing_rows, missing_targets), strict=True):
                for target, why in zip(missing_targets, row, strict=True):
                    self._reach[(reflector.index, target.index)] = why
            self.reach_pairs_computed += len(missing_rows) * len(missing_targets)
        return [[self._reach[(r.index, t.index)] for t in targets] for r in reflectors]

    def planned(self, key: Hashable, plan: Callable[[], T]) -> T:
        """`plan()`, worked out once per `key` for these objects at this time (the key names what
        else it depends on: the plan's images, the stand-in and the render settings)."""
        if key not in self._planned:
            self._planned[key] = plan()
        return cast(T, self._planned[key])

    def reachable(self, reflector: ObjectGeometry, targets: Sequence[ObjectGeometry]) -> list[ObjectGeometry]:
        """The targets `reflector` may show, in order."""
        return [t for t, why in zip(targets, self.reaches([reflector], targets)[0], strict=True) if why is Reach.REACHABLE]

    def with_settings(self, scene: Scene) -> World:
        """The same objects, at the same time, under other render settings (`scene` differs from
        this world's in its render section alone): what can reach what stays, shared."""
        other = World(scene, self.geometry, self.time)
        other._reach, other._planned = self._reach, self._planned
        self._share_levels(other)
        return other

    def at(self, time: float, scene: Scene | None = None) -> World:
        """This world at another time (and, given, with other render settings: the same objects).
        Pairs of which neither object moves keep what was worked out for them."""
        scene = scene or self.scene
        later = World(scene, [g.at(time) for g in self.geometry], time)
        still = {g.index for g in self.geometry if not g.object.moves}
        later._reach = {pair: why for pair, why in self._reach.items() if pair[0] in still and pair[1] in still}
        self._share_levels(later)
        return later

    def _share_levels(self, other: World) -> None:
        """Give the world of another time or other settings (the same objects) this one's levels:
        the world's, what a reflector reaches, and the eye's meshes and objects as drawn."""
        other._eye_meshes, other._eye_items, other._eye_meshes_made = self._eye_meshes, self._eye_items, self._eye_meshes_made
        other._reached, other._world_levels = self._reached, self._world_levels

    def moved(self, earlier: World) -> set[int]:
        """The objects (by index) that are somewhere else than in `earlier`."""
        return {g.index for g, before in zip(self.geometry, earlier.geometry, strict=True)
                if g.object.moves and g.time != before.time}

    def moved_lights(self, earlier: World) -> set[int]:
        """The lights (by index) that are somewhere else than in `earlier`."""
        return {i for i, (light, before) in enumerate(zip(self.lit_scene.lights, earlier.lit_scene.lights, strict=True))
                if light != before}
