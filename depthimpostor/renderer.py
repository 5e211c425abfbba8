"""The renderer: a scene in, a frame out, through the passes the scene calls for.

A scene without mirrors builds no impostor atlas and compiles no reflection shader; depth images
are baked once and again only when something they depend on changes (never for a camera move).
The renderer owns every GL object it makes and frees them in `release()`, before the context.
"""

from __future__ import annotations

import dataclasses
import time
from collections import Counter
from dataclasses import dataclass, field

import moderngl
import numpy as np

from .colour import display_encode
from .constants import NO_OBJECT, SAMPLE_OFFSETS, Algorithm, Method
from .gpu.context import bind_default_framebuffer
from .culling import may_shadow
from .gpu.embedding import FramePresenter, kept_state, keeps_gl_state
from .eye import EyeCamera, Sphere, clear_depth, eye_depth, fitted_camera, make_depth_buffer, reversed_z
from .geometry import ObjectGeometry, scene_geometry
from .world import World
from .gpu.limits import allocating, check_fits
from .passes.diffuse import DiffusePass
from .passes.environment import EnvironmentPass
from .passes.glass import GlassInterior
from .methods.baked_images import BakedImages
from .methods.impostors import ImpostorPass
from .gpu.batches import batches_supported
from .gpu.meshes import GpuMeshes
from .gpu.textures import GpuTextures
from .passes.mirrors import REFLECTION_OUTPUTS, MirrorPass, ReflectedObjects
from .passes.samples import SamplesPass
from .passes.shadows import ShadowMaps
from .methods.triangles import TrianglePass
from .gpu.uniforms import write_scene_uniforms
from .graph import BAKES, Pass
from .plan import STAND_INS, RenderPlan, check_stand_in, plan_render
from .ppc import PPC
from .scene.model import Camera, Scene
from .gpu.shaders import ProgramCache, ShaderLibrary


@dataclass
class RenderStats:
    """Counters of the work done (tests read them; `render --stats` prints them)."""

    frames: int = 0
    depth_images_baked: int = 0  # every baked image: depth images, cube-map faces, billboards
    shadow_maps_baked: int = 0
    interiors_made: int = 0  # glass interior images
    draw_calls: int = 0
    passes: Counter[str] = field(default_factory=Counter)  # frames each pass ran in, by Pass value
    images_baked: Counter[str] = field(default_factory=Counter)  # bakes of each image, by its label
    bake_seconds: list[float] = field(default_factory=list)  # one entry per bake (shadow maps and stand-in)
    draw_seconds: list[float] = field(default_factory=list)  # one entry per frame
    # The mirror pass's share of each frame, when the renderer was asked to time it.
    mirror_seconds: list[float] = field(default_factory=list)
    # Frames drawn at a sub-pixel position (render.samples per frame; 1 per frame without
    # anti-aliasing). A frame's draw time is the sum of its sub-frames'.
    sub_frames: int = 0


def camera_of(scene: Scene, geometry: list[ObjectGeometry] | None = None) -> PPC:
    """The scene's own camera (its rays: the near and far planes are OpenGL's, fitted to the
    scene's bounds). `geometry` is the scene's, when the caller has already built it."""
    spheres = [g.bounding_sphere for g in (geometry if geometry is not None else scene_geometry(scene.objects))]
    return fitted_camera(scene.camera, scene.render.size, spheres, reversed_=False)


def jittered(camera: PPC, dx: float, dy: float) -> PPC:
    """`camera` with its image shifted by (dx, dy) pixels: pixel (i, j)'s centre ray is the
    original camera's ray through (i + 0.5 + dx, j + 0.5 + dy). The eye and the pixel's size stay."""
    return dataclasses.replace(camera, c=camera.c + camera.a * dx + camera.b * dy)


@dataclass(frozen=True, eq=False)
class SubFrame:
    """One sub-pixel position of a supersampled frame: its camera, linear colour (top row first),
    and the reflection data of its rays where the renderer keeps them."""

    camera: PPC | None  # None: the renderer's own camera (a frame without anti-aliasing)
    color: np.ndarray  # (h, w, 3) float32
    reflection: ReflectionData | None


@dataclass(frozen=True)
class ReflectionData:
    """Per pixel of the last frame (top row first): what each mirror pixel's reflected ray hit."""

    mirror_mask: np.ndarray  # (h, w) bool
    mirror_id: np.ndarray  # (h, w) int: the object id of the mirror seen there, NO_OBJECT elsewhere
    origin: np.ndarray  # (h, w, 3) the reflected ray's origin on the mirror
    direction: np.ndarray  # (h, w, 3) unit reflected direction
    object_id: np.ndarray  # (h, w) int, NO_OBJECT for the environment (and outside mirrors)
    hit_position: np.ndarray  # (h, w, 3) world position of the hit (meaningless where no hit)
    normal: np.ndarray  # (h, w, 3) the reflector's unit normal, facing the eye
    retraced: np.ndarray  # (h, w) bool: the hybrid method traced this pixel's ray against the real triangles


class Renderer:
    """A scene's frames, drawn with the GL context it is given. Every public method leaves the GL
    state as it found it (gpu/embedding.py; docs/python_api.md): an application can share its context."""

    def __init__(
        self,
        ctx: moderngl.Context,
        scene: Scene,
        algorithm: Algorithm = Algorithm.OPTIMIZED,
        reflection_data: bool = False,
        shaders: ShaderLibrary | None = None,
        method: Method = Method.DEPTH,
        count_samples: bool = False,
        time_mirror_pass: bool = False,
    ) -> None:
        """`reflection_data` adds float outputs of each mirror pixel's reflected ray and hit (for
        comparisons with the truth); without it neither the attachments nor the variant exist.
        `shaders` reads the GLSL from another folder (the viewer's `--shaders`). `method` is how
        reflected objects are stood in for; only its own resources are made. `count_samples`
        (the benchmark's) adds an output of the samples each reflected ray read, and
        `time_mirror_pass` (the benchmark's too) times the mirror pass apart, at the cost of a
        `ctx.finish()` before it."""
        self.ctx = ctx
        self.scene = scene
        self.algorithm = algorithm
        self.method = method
        self.show_samples = False
        self.tint_retraced = False  # the hybrid method's re-traced rays tinted (the viewer's T)
        self.reflection_data = reflection_data
        self.count_samples = count_samples
        self.time_mirror_pass = time_mirror_pass
        self.stats = RenderStats()
        self.last_sub_frames: list[SubFrame] = []  # the last supersampled frame's (render.samples > 1)
        self._unjittered: PPC | None = None  # the frame's camera while its sub-frames are drawn
        self.programs = ProgramCache(ctx, shaders)
        # The eye's depth convention (eye.py): reversed-Z where GL has clip control.
        self.reversed_z = reversed_z(ctx) is not None
        self.time = 0.0  # seconds into the scene's animation
        # First: the plan refuses what cannot be rendered before anything is made or fitted.
        self._use_world(World(scene))
        self.plan: RenderPlan = plan_render(scene, method, algorithm, reflection_data=reflection_data,
                                            count_samples=count_samples, world=self.world)
        self._relight()
        self.view = scene.camera
        self.camera = fitted_camera(self.view, scene.render.size, self.bounds, self.reversed_z)
        check_fits(ctx, scene, self.plan)  # before any GL object is made
        self.meshes = GpuMeshes(ctx)
        self.textures = GpuTextures(ctx)  # the scene's image textures, bound for every frame
        self._presenter: FramePresenter | None = None  # made when a frame is first put in a caller's framebuffer
        with kept_state(ctx), allocating(ctx, "--size or --impostor-res"):
            self.meshes.load([g.local_mesh for g in self.geometry])
            self._make_targets(scene.render.size)
            self._build_passes()

    def _use_world(self, world: World) -> None:
        """Draw `world` (the scene's objects at the renderer's time): its lists are the passes'."""
        self.world = world
        self.geometry = world.geometry
        self.bounds: list[Sphere] = world.bounds
        self.mirrors: list[ObjectGeometry] = world.mirrors
        self.glass: list[ObjectGeometry] = world.glass
        self.reflectors: list[ObjectGeometry] = world.reflectors
        self.analytic_planes = world.analytic_planes
        self.diffuse_objects = world.diffuse_objects
        self.reflected_objects = world.reflected_objects
        self.shadow_casters = world.shadow_casters

    def _make_targets(self, size: tuple[int, int]) -> None:
        ctx = self.ctx
        # Float colour so that a NaN or Inf from a shader survives to be caught by a test,
        # instead of being clamped into a plausible-looking 8-bit pixel. A texture, not a
        # renderbuffer: a supersampled frame's average is written back into it.
        self._color = ctx.texture(size, 4, dtype="f4")
        self._depth = make_depth_buffer(ctx, size)
        self._reflection_outputs = [
            ctx.renderbuffer(size, 4, dtype="f4") for _ in range(REFLECTION_OUTPUTS if self.reflection_data else 0)
        ]
        self._sample_counts = ctx.renderbuffer(size, 1, dtype="f4") if self.count_samples else None
        extra = [*self._reflection_outputs, *([self._sample_counts] if self._sample_counts is not None else [])]
        self.framebuffer = ctx.framebuffer([self._color, *extra], self._depth)
        # Passes with one output draw through a framebuffer with the colour alone: GL leaves
        # attachments a shader does not write undefined. Diffuse objects are drawn before mirrors,
        # so a mirror fragment that passes the depth test is the visible one and its extra
        # outputs stay consistent with the colour.
        self.color_framebuffer = ctx.framebuffer([self._color], self._depth) if extra else self.framebuffer

    def _build_passes(self) -> None:
        """The passes the scene and settings call for, their programs from the cache."""
        ctx, scene = self.ctx, self.scene
        self.environment = EnvironmentPass(ctx, self.programs, scene)
        # Made (and baked) before anything that shades: depth images show the shadows too.
        self.shadow_maps = (
            ShadowMaps(ctx, self.programs, self.lit_scene, self.meshes, self.shadow_casters)
            if self.plan.runs(Pass.SHADOW_MAPS) else None
        )
        self.diffuse = (DiffusePass(self.programs, scene, self.meshes, write_depth_image=False,
                                    batched=batches_supported(ctx)) if self.plan.runs(Pass.DIFFUSE) else None)
        self.stand_in: ReflectedObjects | None = None
        self.mirror_pass: MirrorPass | None = None
        self.samples: SamplesPass | None = None
        # An interior image per glass object, as large as the frame's larger side (passes/glass.py).
        self.glass_interiors = {
            item.index: GlassInterior(ctx, self.programs, self.meshes, max(scene.render.size)) for item in self.glass
        }
        if self.reflectors:
            self._make_stand_in(self.method, self.scene, self.plan)
            self.mirror_pass = self._mirror_pass()
            if self.show_samples and self.sampled is not None:
                self.samples = SamplesPass(ctx, self.programs)
        self._baked = False

    def _make_stand_in(self, method: Method, scene: Scene, plan: RenderPlan) -> None:
        """The method's stand-in for the reflected objects; the old one (if any) is released only
        once the new one exists, so that a failure leaves the renderer as it was."""
        kind = STAND_INS[method]
        check_stand_in(scene, method, self.reflectors, self.reflected_objects)
        stand_in: ReflectedObjects
        if issubclass(kind, BakedImages):
            stand_in = kind(self.ctx, self.programs, scene, self.meshes, self.reflectors, self.reflected_objects,
                            plan.image_plans)
        else:
            stand_in = kind(self.ctx, scene, self.reflected_objects)
        if self.stand_in is not None:
            self.stand_in.release()
        self.stand_in = stand_in
        self._baked = False
        self._keep_pyramids(self.algorithm)

    def _keep_pyramids(self, algorithm: Algorithm) -> None:
        """Depth pyramids exist exactly while the hierarchical algorithm intersects depth images."""
        if self.impostors is not None:
            self.impostors.use_pyramid(algorithm == Algorithm.HIERARCHICAL)

    @property
    def impostors(self) -> ImpostorPass | None:
        """The depth images, when the method is `depth`."""
        return self.stand_in if isinstance(self.stand_in, ImpostorPass) else None

    @property
    def baked_images(self) -> BakedImages | None:
        """The atlas of images the method bakes (depth images, cube-map faces, billboards)."""
        return self.stand_in if isinstance(self.stand_in, BakedImages) else None

    @property
    def sampled(self) -> BakedImages | None:
        """Baked images with a depth per sample, which the sample view can draw."""
        baked = self.baked_images
        return baked if baked is not None and baked.atlas.depth is not None else None

    @property
    def triangles(self) -> TrianglePass | None:
        """The triangles traced, when the method is `simplified` or `raytrace`."""
        return self.stand_in if isinstance(self.stand_in, TrianglePass) else None

    def _mirror_pass(self) -> MirrorPass:
        if self.stand_in is None:
            raise RuntimeError("mirror passes are made only after the reflected objects' stand-in")
        return MirrorPass(
            self.programs, self.scene, self.meshes, self.stand_in, self.method, self.algorithm,
            self.reflection_data, self.count_samples, self.glass_interiors,
        )

    def _checked_plan(self, scene: Scene, method: Method, algorithm: Algorithm) -> RenderPlan:
        """The plan of other settings, once this context is known to hold it (GpuLimitError if not).
        The world's memo of what can reach what is kept: settings do not move objects."""
        plan = plan_render(scene, method, algorithm, reflection_data=self.reflection_data,
                           count_samples=self.count_samples, world=self.world.with_settings(scene))
        check_fits(self.ctx, scene, plan)
        return plan

    # ------------------------------------------------------------------ settings
    def look_at(self, view: Camera) -> None:
        """Move the camera; depth images do not depend on it, so nothing is re-baked."""
        self.view = view
        self.camera = fitted_camera(view, self.scene.render.size, self.bounds, self.reversed_z)

    def set_camera(self, camera: PPC) -> None:
        """Use this exact camera (tests; its eye-depth projection where the renderer draws
        reversed-Z); nothing is re-baked. A later `look_at` or `resize` replaces it with the
        fitted camera of a view."""
        self.camera = EyeCamera.of(camera) if self.reversed_z else camera

    @keeps_gl_state
    def set_time(self, seconds: float) -> None:
        """Move the scene's animated objects and lights to where they are at `seconds`. Only what
        depends on what moved is baked again at the next frame: a shadow map when its light or a
        caster moved; an image when its reflector or its object moved, when a light moved (lights
        shade every image), or when a caster moved whose shadow may fall on its object; a glass
        interior when its glass moved."""
        if seconds == self.time or not self.scene.animated:
            self.time = seconds
            return
        before = {g.index: g for g in self.geometry}
        world = self.world.at(seconds)
        geometry = world.geometry
        moved = {g.index for g in geometry if g is not before[g.index]}
        lights_before = self.lit_scene.lights
        self.time = seconds
        self._use_world(world)
        self._relight()
        lights = self.lit_scene.lights
        moved_lights = {i for i, (new, old) in enumerate(zip(lights, lights_before, strict=True)) if new != old}
        self.look_at(self.view)  # the near and far planes follow the scene's bounds
        moved_casters = [g for g in self.shadow_casters if g.index in moved]
        shadowed = set(self.lit_scene.shadowed_lights)
        if self.shadow_maps is not None:
            self.shadow_maps.move(self.lit_scene, self.shadow_casters,
                                  (moved_lights | (shadowed if moved_casters else set())) & shadowed)
        if self.stand_in is None or not (moved or moved_lights):
            return
        baked = self.baked_images
        if baked is None:  # the triangle methods' BVH: built again around the moved objects
            if any(g.index in moved for g in self.reflected_objects):
                self._make_stand_in(self.method, self.scene, self.plan)
                self.mirror_pass = self._mirror_pass()
            return
        relit = {g.index for g in self.reflected_objects} if moved_lights else set()
        shadows = {
            receiver.index for receiver in self.reflected_objects for light in shadowed
            for caster in moved_casters if receiver is not caster
            for sphere in (before[caster.index].bounding_sphere, caster.bounding_sphere)
            if may_shadow(np.asarray(lights[light].position, float), lights[light].radius, sphere,
                          receiver.bounding_sphere)
        }
        baked.move({g.index: g for g in geometry}, moved, relit | shadows)

    def _relight(self) -> None:
        """`lit_scene`: the scene with its lights where they are at `time`. It and the analytic
        planes go to the program cache, which writes them into every program it holds or makes:
        the one place lights and planes are written, so that no program made after a move (a new
        setting, a reload) can have them where they were."""
        lights = self.scene.lights_at(self.time)
        self.lit_scene = self.scene if lights == tuple(self.scene.lights) else dataclasses.replace(self.scene, lights=lights)
        lit_scene, planes = self.lit_scene, self.analytic_planes
        self.programs.set_scene_uniforms(lambda program: write_scene_uniforms(program, lit_scene, planes))

    @keeps_gl_state
    def resize(self, size: tuple[int, int]) -> None:
        """Render frames of another size; depth images do not depend on it."""
        if size == self.scene.render.size:
            return
        scene = self.scene.with_overrides(size=size)
        plan = self._checked_plan(scene, self.method, self.algorithm)
        self._release_targets()
        self.scene = scene
        self.plan = plan
        self._use_world(self.world.with_settings(scene))
        self._relight()
        with allocating(self.ctx, "the frame's size"):
            self._make_targets(size)
        self.look_at(self.view)

    @keeps_gl_state
    def set_algorithm(self, algorithm: Algorithm) -> None:
        """Intersect with another algorithm: another mirror variant, the same depth images (the
        hierarchical one builds their pyramids from them; the others free the pyramids). A GL
        without compute shaders raises ContextError for the hierarchical one and keeps the old, and
        so does a context that cannot hold the pyramids (GpuLimitError)."""
        plan = self._checked_plan(self.scene, self.method, algorithm)
        self._keep_pyramids(algorithm)
        self.algorithm = algorithm
        self.plan = plan
        if self.mirror_pass is not None:
            self.mirror_pass = self._mirror_pass()

    @keeps_gl_state
    def set_method(self, method: Method) -> None:
        """Stand in for the reflected objects another way: the old method's resources go and the
        new one's are made, unless both use the same (the two cube-map lookups); a scene without
        mirrors has none either way. A method this context cannot hold raises GpuLimitError and
        leaves the renderer as it was."""
        plan = self._checked_plan(self.scene, method, self.algorithm)
        if self.reflectors and STAND_INS[method] is not STAND_INS[self.method]:
            with allocating(self.ctx, "--impostor-res"):
                self._make_stand_in(method, self.scene, plan)
        self.method = method
        self.plan = plan
        if self.reflectors:
            self.mirror_pass = self._mirror_pass()
            if self.sampled is None:
                self.show_samples = False
            if self.samples is not None and not self.show_samples:
                self.samples.release()
                self.samples = None

    @keeps_gl_state
    def set_impostor_resolution(self, resolution: int) -> None:
        """Re-plan and re-bake the baked images (all of them share the resolution, so all change).

        The new atlas is made before the old one goes: a resolution this GL cannot hold raises
        GpuLimitError (checked before anything is made) and leaves the renderer as it was.
        """
        scene = self.scene.with_overrides(impostor_resolution=resolution)
        plan = self._checked_plan(scene, self.method, self.algorithm)
        if self.baked_images is not None:
            with allocating(self.ctx, "--impostor-res"):
                self._make_stand_in(self.method, scene, plan)
        self.scene = scene
        self.plan = plan
        self._use_world(self.world.with_settings(scene))
        self._relight()
        if self.mirror_pass is not None:
            self.mirror_pass = self._mirror_pass()

    @keeps_gl_state
    def set_show_samples(self, show: bool) -> None:
        """Show each reflected object as the samples of the baked images (the lecture's sample
        visualization) instead of its triangles; the samples' program is made on first use."""
        self.show_samples = show
        if show and self.samples is None and self.sampled is not None:
            self.samples = SamplesPass(self.ctx, self.programs)

    def bake_again(self) -> None:
        """Bake the method's images again at the next frame, although nothing changed: for
        timing bakes (the benchmark); a renderer re-bakes by itself whenever it must."""
        self._baked = False
        if self.baked_images is not None:
            self.baked_images.bake_again()

    @keeps_gl_state
    def reload_shaders(self) -> None:
        """Compile every program again from the files as they are now, and re-bake.

        All programs are built before any is replaced: a file that no longer compiles raises
        ShaderError and leaves the renderer drawing with the last good programs.
        """
        fresh = self.programs.reloaded()
        self._release_passes()
        self.meshes.forget_vertex_arrays()
        self.programs.release()
        self.programs = fresh
        self._build_passes()

    # ------------------------------------------------------------------ frames
    def render(self, target: moderngl.Framebuffer | None = None,
               viewport: tuple[int, int, int, int] | None = None) -> RenderStats:
        """Draw one frame into the renderer's framebuffer, baking impostors first if they are stale,
        and (given a `target`) put it upright into `viewport` of `target` (default: all of it; the
        viewport must be the frame's size). The GL state is left as it was found.

        Times are wall-clock around `ctx.finish()`: GPU time queries under-report on software
        rasterizers, and a finish makes the time include all the work the frame queued; putting
        the frame in `target` is not timed.
        """
        # The passes expect the depth test on and nothing else (no blending of the caller's).
        with kept_state(self.ctx, enable_only=moderngl.DEPTH_TEST):
            samples = self.scene.render.samples
            stats = self._draw_frame() if samples == 1 else self._draw_supersampled(samples)
            if target is not None:
                self._put_frame(target, viewport)
        return stats

    def _put_frame(self, target: moderngl.Framebuffer, viewport: tuple[int, int, int, int] | None) -> None:
        size = self.scene.render.size
        if self._presenter is not None and self._presenter.size != size:
            self._presenter.release()
            self._presenter = None
        if self._presenter is None:
            self._presenter = FramePresenter(self.ctx, self.programs, size)
        self._presenter.draw(self.color_framebuffer, target, viewport, self.scene.render)

    def _draw_frame(self) -> RenderStats:
        """One frame: the plan's render graph (plan.graph), node by node. The bakes run only for
        what is stale, and are timed apart from the eye's passes."""
        graph = self.plan.graph
        self.environment.use()  # an equirect sky's image: bakes see it too
        self.textures.use(self.scene)  # the image textures: baked images show them too
        if self.shadow_maps is not None:  # bound for every pass that shades, bakes included
            self.shadow_maps.use()
        bakes = [node.stage for node in graph if node.stage in BAKES and self._stale(node.stage)]
        if bakes:
            self.ctx.finish()
            start = time.perf_counter()
            for stage in bakes:
                self._run_bake(stage)
            self.ctx.finish()
            self.stats.bake_seconds.append(time.perf_counter() - start)

        self.ctx.finish()
        start = time.perf_counter()
        self.framebuffer.use()
        self.framebuffer.clear(0.0, 0.0, 0.0, 0.0, depth=clear_depth(self.ctx))
        self.color_framebuffer.use()
        mirror_start: float | None = None  # when the mirror pass began, where it is timed apart
        with eye_depth(self.ctx):
            for node in graph:
                if node.stage in BAKES:
                    continue
                if node.stage in (Pass.GLASS_INTERIORS, Pass.REFLECTORS) and self.time_mirror_pass \
                        and mirror_start is None:
                    self.ctx.finish()
                    mirror_start = time.perf_counter()
                self._run_eye_pass(node.stage)
        self.ctx.finish()
        end = time.perf_counter()
        self.stats.draw_seconds.append(end - start)
        if self.time_mirror_pass:
            self.stats.mirror_seconds.append(end - mirror_start if mirror_start is not None else 0.0)
        self.stats.frames += 1
        self.stats.sub_frames += 1
        return self.stats

    def _draw_supersampled(self, samples: int) -> RenderStats:
        """One anti-aliased frame: the graph drawn once per sub-pixel position of SAMPLE_OFFSETS
        (the eye camera's corner shifted, so that every ray the mirror shader traces moves with
        its pixel), the linear colours averaged into the colour target. Bakes do not depend on the
        eye and run once; glass interiors depend on the eye's position and pixel size, which a
        jitter keeps, so they are made once too. The sub-frames stay (`sub_frames`) for `compare`,
        which traces the truth at the same positions."""
        base, stats = self.camera, self.stats
        frames, draws, mirrors = stats.frames, len(stats.draw_seconds), len(stats.mirror_seconds)
        total: np.ndarray | None = None
        kept: list[SubFrame] = []
        self._unjittered = base
        try:
            for dx, dy in SAMPLE_OFFSETS[samples]:
                self.camera = jittered(base, dx, dy)
                self._draw_frame()
                rgba = self._read_rgba()
                total = rgba.astype(np.float64) if total is None else total + rgba
                kept.append(SubFrame(self.camera, rgba[..., :3].copy(),
                                     self.read_reflection_data() if self.reflection_data else None))
        finally:
            self.camera, self._unjittered = base, None
        assert total is not None
        self._color.write((total / samples).astype(np.float32).tobytes())
        self.last_sub_frames = kept
        # One frame, whose time is its sub-frames' (reading them back is not counted).
        stats.frames = frames + 1  # _draw_frame counted each sub-frame in sub_frames, and as a frame
        stats.draw_seconds[draws:] = [sum(stats.draw_seconds[draws:])]
        if self.time_mirror_pass:
            stats.mirror_seconds[mirrors:] = [sum(stats.mirror_seconds[mirrors:])]
        return stats

    def _read_rgba(self) -> np.ndarray:
        width, height = self.scene.render.size
        data = self.framebuffer.read(components=4, dtype="f4")
        return np.frombuffer(data, dtype=np.float32).reshape(height, width, 4)

    def sub_frames(self) -> list[SubFrame]:
        """The last frame's sub-pixel frames: one per sample (render.samples), or, without
        anti-aliasing, the frame itself at the pixel centres."""
        if self.scene.render.samples == 1:
            data = self.read_reflection_data() if self.reflection_data else None
            return [SubFrame(self.camera, self.read_color_float(), data)]
        return list(self.last_sub_frames)

    def _stale(self, stage: Pass) -> bool:
        """Does a baking node have anything to do this frame?"""
        if stage is Pass.SHADOW_MAPS:
            return self.shadow_maps is not None and bool(self.shadow_maps.stale)
        if stage is Pass.STAND_IN:
            return self.stand_in is not None and self._stand_in_stale()
        # Bounce images and pyramids follow the stand-in's images: stale when any of them is.
        return self.impostors is not None and self._stand_in_stale()

    def _run_bake(self, stage: Pass) -> None:
        impostors = self.impostors
        if stage is Pass.SHADOW_MAPS and self.shadow_maps is not None:
            self._bake_shadow_maps(self.shadow_maps)
        elif stage is Pass.STAND_IN and self.stand_in is not None:  # the images show shadows: maps first
            self._bake_stand_in(self.stand_in)
        elif stage is Pass.BOUNCES and impostors is not None:
            bounces_before, before = impostors.bounce_bakes, impostors.bake_counts.copy()
            self.stats.draw_calls += impostors.bake_bounces()
            self._count_images(impostors.bake_counts - before)
            if impostors.bounce_bakes > bounces_before:
                self.stats.passes[Pass.BOUNCES.value] += 1
        elif stage is Pass.PYRAMIDS and impostors is not None and impostors.pyramid is not None:
            impostors.build_pyramids()
            self.stats.passes[Pass.PYRAMIDS.value] += 1

    def _run_eye_pass(self, stage: Pass) -> None:
        """The environment, the diffuse objects (or the samples), glass interiors, the reflectors."""
        view_projection = self.camera.view_projection
        if stage is Pass.ENVIRONMENT:
            self.environment.draw(self.camera)
        elif stage is Pass.DIFFUSE and self.diffuse is not None:
            sampled = self.sampled
            drawn = self.diffuse_objects
            if self.show_samples and self.samples is not None and sampled is not None:
                drawn = [g for g in self.diffuse_objects if g.is_analytic_plane]
                self.stats.draw_calls += self.samples.draw(sampled, self.camera)
            self.stats.draw_calls += self.diffuse.draw(drawn, view_projection)
        elif stage is Pass.GLASS_INTERIORS and self.mirror_pass is not None:
            before = self._interiors_made()
            # A glass interior depends on the eye's position and pixel size, not on a sub-pixel
            # jitter: made from the frame's own camera, so that rounding in the jittered one's
            # corner does not make it again for every sample.
            unjittered = self._unjittered if self._unjittered is not None else self.camera
            self.stats.draw_calls += self.mirror_pass.make_interiors(self.reflectors, unjittered)
            made = self._interiors_made() - before
            if not made:
                return
            self.stats.interiors_made += made
        elif stage is Pass.REFLECTORS and self.mirror_pass is not None:
            self.stats.draw_calls += self.mirror_pass.draw(self.reflectors, self.camera, self.framebuffer,
                                                           self.tint_retraced)
        else:
            return
        self.stats.passes[stage.value] += 1

    def _interiors_made(self) -> int:
        return sum(interior.bakes for interior in self.glass_interiors.values())

    def _stand_in_stale(self) -> bool:
        baked = self.baked_images
        return baked.needs_bake if baked is not None else not self._baked

    def _bake_shadow_maps(self, shadow_maps: ShadowMaps) -> None:
        before = shadow_maps.bakes
        self.stats.draw_calls += shadow_maps.bake()
        self.stats.shadow_maps_baked += shadow_maps.bakes - before
        self.stats.passes[Pass.SHADOW_MAPS.value] += 1

    def _bake_stand_in(self, stand_in: ReflectedObjects) -> None:
        """Bake the method's stale images but those of reflectors in reflectors (the bounce node's),
        or upload its triangles."""
        baked = self.baked_images
        before = baked.bake_counts.copy() if baked is not None else Counter()
        self.stats.draw_calls += stand_in.bake()
        self.stats.passes[Pass.STAND_IN.value] += 1
        if baked is not None:
            self._count_images(baked.bake_counts - before)
        self._baked = True

    def _count_images(self, new: Counter[str]) -> None:
        self.stats.images_baked += new
        self.stats.depth_images_baked += sum(new.values())

    def read_color_float(self) -> np.ndarray:
        """The last frame as (height, width, 3) float32, top row first, unclamped."""
        width, height = self.scene.render.size
        data = self.framebuffer.read(components=3, dtype="f4")
        return np.frombuffer(data, dtype=np.float32).reshape(height, width, 3).copy()

    def read_color(self) -> np.ndarray:
        """The last frame as (height, width, 3) uint8, top row first, ready for a PNG: through the
        scene's display transform (exposure, tone mapping, sRGB; colour.py)."""
        render = self.scene.render
        return display_encode(self.read_color_float(), render.tone_mapping, render.exposure)

    def read_sample_counts(self) -> np.ndarray:
        """(height, width) samples each mirror pixel's reflected ray read (0 outside mirrors)."""
        if self._sample_counts is None:
            raise ValueError("this renderer was made without count_samples=True")
        width, height = self.scene.render.size
        index = 1 + len(self._reflection_outputs)
        data = self.framebuffer.read(components=1, attachment=index, dtype="f4")
        return np.frombuffer(data, np.float32).reshape(height, width).copy()

    def read_reflection_data(self) -> ReflectionData:
        if not self._reflection_outputs:
            raise ValueError("this renderer was made without reflection_data=True")
        width, height = self.scene.render.size

        def attachment(index: int) -> np.ndarray:
            data = self.framebuffer.read(components=4, attachment=index, dtype="f4")
            return np.frombuffer(data, np.float32).reshape(height, width, 4).astype(np.float64)

        origin, direction, hit, normal = attachment(1), attachment(2), attachment(3), attachment(4)
        mask = origin[..., 3] > 0.5
        mirror_id = np.where(mask, np.rint(origin[..., 3]) - 1, NO_OBJECT).astype(np.int64)
        object_id = np.where(mask, np.rint(direction[..., 3]), NO_OBJECT).astype(np.int64)
        return ReflectionData(mask, mirror_id, origin[..., :3], direction[..., :3], object_id, hit[..., :3],
                              normal[..., :3], mask & (normal[..., 3] > 0.5))

    # ------------------------------------------------------------------ lifetime
    def _release_targets(self) -> None:
        bind_default_framebuffer(self.ctx)
        if self.color_framebuffer is not self.framebuffer:
            self.color_framebuffer.release()
        self.framebuffer.release()
        self._color.release()
        for item in (self._depth, *self._reflection_outputs):
            item.release()
        if self._sample_counts is not None:
            self._sample_counts.release()

    def _release_passes(self) -> None:
        bind_default_framebuffer(self.ctx)
        if self._presenter is not None:  # made again, with the programs of the time, when next needed
            self._presenter.release()
            self._presenter = None
        for owner in (self.stand_in, self.environment, self.diffuse, self.samples, self.shadow_maps,
                      *self.glass_interiors.values()):
            if owner is not None:
                owner.release()

    @keeps_gl_state
    def release(self) -> None:
        self._release_passes()
        self.meshes.release()
        self.textures.release()
        self.programs.release()
        self._release_targets()

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *args: object) -> None:
        self.release()
