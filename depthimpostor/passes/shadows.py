"""Shadow maps: a depth image from each light that casts shadows, of everything that casts them.

A shadow map is a depth image like a mirror's (the same camera model, record and two float
layers: the visible surface and the nearest back face behind it), taken from the light's
position with a frustum fitted to the casters: a point outside it sees no caster between it and
the light. Shading programs intersect rays toward the light with it (lib/shadows.glsl). It
depends on the lights and the casters alone: baked once, never for a camera move.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import moderngl
import numpy as np

from ..gpu.gl_state import raster_state
from ..gpu.bindings import TextureUnit, UniformBlock
from ..constants import BACKGROUND_DEPTH, DEPTH_IMAGE_DTYPE, MAX_LIGHTS, NO_OBJECT
from ..gpu.context import bind_default_framebuffer
from ..gpu.uniforms import alpha_mask_defines, write_material_index
from ..errors import SceneError
from ..geometry import ObjectGeometry
from ..ppc import PPC, FrustumFitError
from ..scene.model import Scene
from ..gpu.shaders import ProgramCache
from ..methods.atlas import BACK_FACE_PROGRAM, BACK_FACES, atlas_grid, plural
from ..gpu.meshes import GpuMeshes
from ..node import Frame, GraphFacts, Node, Pass

if TYPE_CHECKING:
    from ..world import World


#: A shadow map's single float attachment takes the window depth at location 0.
SHADOW_MAP_PROGRAM = BACK_FACE_PROGRAM
SHADOW_MAP_DEFINES = {"OUTPUT_LOCATION": 0}


def shadow_map_defines(scene: Scene) -> dict[str, int]:
    """The shadow maps' program for `scene`: what a masked material cuts away casts no shadow."""
    return {**SHADOW_MAP_DEFINES, **alpha_mask_defines(scene)}


def fit_shadow_camera(scene: Scene, light_index: int, casters: list[ObjectGeometry], resolution: int) -> PPC:
    """The shadow map's camera: from the light, the tightest frustum around every caster."""
    light = scene.lights[light_index]
    points = np.concatenate([caster.world_mesh.positions for caster in casters])
    centre = (points.min(axis=0) + points.max(axis=0)) / 2.0
    try:
        return PPC.fitted(light.position, points, centre, resolution, resolution)
    except FrustumFitError:
        raise SceneError(
            scene.source, f"lights[{light_index}].position",
            "expected a light with every shadow caster on one side of it (one shadow map, a pinhole "
            "image, must see them all); move the light out from among the objects",
        ) from None


def shadow_map_bytes(count: int, resolution: int) -> int:
    """GPU memory of `count` shadow maps: the two float layers and the depth buffer used to bake them."""
    columns, rows = atlas_grid(count)
    return columns * rows * resolution * resolution * (8 + 4)


class ShadowMaps:
    """The shadow maps of a scene's shadowed lights in one RG32F atlas, and the uniform buffer
    of their records (indexed by light) that lib/shadows.glsl reads."""

    def __init__(
        self, ctx: moderngl.Context, programs: ProgramCache, scene: Scene, meshes: GpuMeshes,
        casters: list[ObjectGeometry],
    ) -> None:
        resolution = scene.render.shadow_resolution
        self.ctx = ctx
        self.meshes = meshes
        self.casters = casters
        self.scene = scene
        self.cameras = {i: fit_shadow_camera(scene, i, casters, resolution) for i in scene.shadowed_lights}
        columns, rows = atlas_grid(len(self.cameras))
        self.tiles = {
            light: ((slot % columns) * resolution, (slot // columns) * resolution, resolution, resolution)
            for slot, light in enumerate(self.cameras)
        }
        self.layers = ctx.texture((columns * resolution, rows * resolution), 2, dtype="f4")
        self.layers.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._depth_buffer = ctx.depth_renderbuffer(self.layers.size)
        self.framebuffer = ctx.framebuffer([self.layers], self._depth_buffer)
        self.program = programs.get(*SHADOW_MAP_PROGRAM, shadow_map_defines(scene))
        self.uniform_buffer = ctx.buffer(self._records())
        self.bakes = 0  # shadow maps rendered so far (tests check that nothing re-bakes)
        self.stale: set[int] = set(self.cameras)  # lights whose map the next bake renders

    def _records(self) -> bytes:
        records = np.zeros(MAX_LIGHTS, dtype=DEPTH_IMAGE_DTYPE)
        for light, camera in self.cameras.items():
            records[light] = camera.depth_image_record(NO_OBJECT, self.tiles[light][:2])
        return records.tobytes()

    def move(self, scene: Scene, casters: list[ObjectGeometry], lights: set[int]) -> None:
        """The casters or the lights (`scene`'s, by index) moved: the maps of `lights` are fitted
        again and baked at the next bake."""
        self.scene, self.casters = scene, casters
        resolution = scene.render.shadow_resolution
        for light in lights & set(self.cameras):
            self.cameras[light] = fit_shadow_camera(scene, light, casters, resolution)
            self.stale.add(light)
        self.uniform_buffer.write(self._records())

    @property
    def bytes(self) -> int:
        return shadow_map_bytes(len(self.cameras), self.layers.height if self.cameras else 0) + self.uniform_buffer.size

    def describe(self) -> str:
        resolution = self.layers.height if len(self.cameras) else 0
        return f"{plural(len(self.cameras), 'shadow map')} of {resolution}x{resolution}"

    def bake(self) -> int:
        """Render the stale shadow maps: the casters' visible surface into R, their nearest back
        face into G. Returns the number of draw calls."""
        self.framebuffer.use()
        draws = 0
        try:
            for light, camera in self.cameras.items():
                if light not in self.stale:
                    continue
                tile = self.tiles[light]
                self.framebuffer.viewport = tile
                self.framebuffer.color_mask = (True,) * 4
                self.framebuffer.clear(BACKGROUND_DEPTH, BACKGROUND_DEPTH, 0.0, 0.0, depth=BACKGROUND_DEPTH, viewport=tile)
                self.framebuffer.color_mask = (True, False, False, False)
                draws += self._draw_casters(camera)
                # A depth-only clear: moderngl's clear also clears every colour channel unmasked.
                self.framebuffer.color_mask = (False,) * 4
                self.framebuffer.clear(depth=BACKGROUND_DEPTH, viewport=tile)
                self.framebuffer.color_mask = (False, True, False, False)
                with raster_state(self.ctx, BACK_FACES):
                    draws += self._draw_casters(camera)
                self.bakes += 1
                self.stale.discard(light)
        finally:
            self.framebuffer.color_mask = (True,) * 4
        return draws

    def _draw_casters(self, camera: PPC) -> int:
        for caster in self.casters:
            write_material_index(self.program, self.scene, caster.object)
            self.meshes.draw(self.program, caster, camera.view_projection)
        return len(self.casters)

    def use(self) -> None:
        """Bind the maps where every shading program looks for them (gpu/uniforms.py)."""
        self.layers.use(TextureUnit.SHADOW_MAPS)
        self.uniform_buffer.bind_to_uniform_block(UniformBlock.SHADOW_MAPS)

    def read(self, light: int) -> np.ndarray:
        """Light `light`'s map as (height, width, 2) float32 OpenGL depths, top row first."""
        tile = self.tiles[light]
        data = self.framebuffer.read(viewport=tile, components=2, dtype="f4")
        return np.frombuffer(data, np.float32).reshape(tile[3], tile[2], 2).copy()

    def release(self) -> None:
        bind_default_framebuffer(self.ctx)
        for item in (self.framebuffer, self._depth_buffer, self.layers, self.uniform_buffer):
            item.release()


class ShadowMapsNode(Node):
    """The graph's shadow-map node: the stale maps baked before anything that shades."""

    stage = Pass.SHADOW_MAPS
    when = "once; a light's map again when it or a caster moves"
    bakes = True

    @staticmethod
    def writes(facts: GraphFacts) -> tuple[str, ...]:
        return ("shadow maps",)

    def stale(self) -> bool:
        maps = self.graph.shadow_maps
        return maps is not None and bool(maps.stale)

    def run(self, frame: Frame) -> bool:
        maps, stats = self.graph.shadow_maps, self.graph.stats
        if maps is None:
            return False
        before = maps.bakes
        stats.draw_calls += maps.bake()
        stats.shadow_maps_baked += maps.bakes - before
        return True

    def follow(self, earlier: World, world: World) -> None:
        """A light's map is stale when the light moved, or when a caster moved (any shadowed light's)."""
        maps = self.graph.shadow_maps
        if maps is None:
            return
        moved = world.moved(earlier)
        shadowed = set(world.lit_scene.shadowed_lights)
        moved_casters = any(g.index in moved for g in world.shadow_casters)
        maps.move(world.lit_scene, world.shadow_casters,
                  (world.moved_lights(earlier) | (shadowed if moved_casters else set())) & shadowed)
