"""The renderer: a thin facade over docs/architecture.md's data path, scene -> world at time t
(world.py) -> plan (plan.py) -> render graph (render_graph.py) -> frame (targets.py). Each setter
re-plans (the plan checks every limit first) and lets the graph apply the difference."""

from __future__ import annotations

import functools
import math
import numbers
from collections.abc import Callable
from typing import Any, TypeVar, cast

import moderngl
import numpy as np

from .colour import display_encode
from .constants import Algorithm, Method
from .eye import EyeCamera, reversed_z
from .gpu.context import check_usable
from .gpu.embedding import kept_state, keeps_gl_state
from .gpu.limits import allocating, check_fits
from .gpu.shaders import ProgramCache, ShaderLibrary
from .gpu.uniforms import write_scene_uniforms
from .plan import RenderPlan, plan_render
from .ppc import PPC
from .render_graph import GraphOptions, RenderGraph, RenderStats
from .scene.model import Camera, Environment, Scene
from .supersampling import SubFrame, draw_supersampled
from .targets import FrameTargets, ReflectionData
from .world import World
from .oracles.ibl import SkyLighting

Method_ = TypeVar("Method_", bound=Callable[..., Any])


def checked_time(seconds: object) -> float:
    """A scene time from the Python API: a finite number of seconds (ValueError otherwise; NaN or
    infinity would put every animated object nowhere)."""
    # numbers.Real: numpy's floats and integers too (np.float32 is no float).
    if isinstance(seconds, bool) or not isinstance(seconds, numbers.Real) or not math.isfinite(seconds):
        raise ValueError(f"time: expected a finite number of seconds, got {seconds!r}")
    return float(seconds)


def _live(method: Method_) -> Method_:
    """A public method that draws or reads: refused, with a message, on a released renderer or a
    context that is released or not current in this thread (rather than a moderngl AttributeError
    about an 'InvalidObject', or a frame silently not drawn)."""
    @functools.wraps(method)
    def checked(self: Renderer, *args: Any, **kwargs: Any) -> Any:
        if self.released:
            raise ValueError(f"Renderer.{method.__name__}: the renderer was released (Renderer.release() or the end "
                             "of its `with` block); make a new one")
        check_usable(self.ctx)
        return method(self, *args, **kwargs)
    return cast(Method_, checked)


class Renderer:
    """A scene's frames, drawn with the GL context it is given. Every public method leaves the GL
    state as it found it (gpu/embedding.py; docs/python_api.md): an application can share its context."""

    def __init__(self, ctx: moderngl.Context, scene: Scene, algorithm: Algorithm = Algorithm.OPTIMIZED,
                 reflection_data: bool = False, shaders: ShaderLibrary | None = None, method: Method = Method.DEPTH,
                 count_samples: bool = False, time_mirror_pass: bool = False, bake_budget: int | None = None) -> None:
        """`method` is how reflected objects are stood in for (only its own resources are made);
        `shaders` reads the GLSL from another folder (the viewer's `--shaders`); the other flags
        are GraphOptions' (render_graph.py)."""
        check_usable(ctx)
        self.released = False
        self._sky: tuple[tuple[object, Environment], SkyLighting | None] | None = None  # sky_lighting's, once read
        self.ctx, self.scene, self.method, self.algorithm = ctx, scene, method, algorithm
        self.options = GraphOptions(reflection_data, count_samples, time_mirror_pass, bake_budget)
        self.stats = RenderStats()
        self.last_sub_frames: list[SubFrame] = []  # the last supersampled frame's (render.samples > 1)
        # Where each program finds what every frame binds (texture units, block bindings, the
        # texture table): nothing a later `with_overrides`, which changes render settings alone, alters.
        self.programs = ProgramCache(ctx, shaders, lambda program: write_scene_uniforms(program, scene))
        self.reversed_z = reversed_z(ctx) is not None  # the eye's depth convention (eye.py)
        self.time = 0.0  # seconds into the scene's animation
        # First: the plan refuses what cannot be rendered before anything is made or fitted.
        self.world = World(scene)
        self.plan = self._checked_plan(scene, method, algorithm)
        self.look_at(scene.camera)
        with kept_state(ctx), allocating(ctx, "--size or --impostor-res"):
            self.targets = FrameTargets(ctx, scene.render.size, reflection_data, count_samples, bool(self.world.reflectors))
            self.graph = RenderGraph(ctx, self.programs, self.world, self.plan, self.options, self.stats)

    def _checked_plan(self, scene: Scene, method: Method, algorithm: Algorithm, world: World | None = None) -> RenderPlan:
        """The plan of these settings, once this context is known to hold it (GpuLimitError if not)."""
        plan = plan_render(scene, method, algorithm, reflection_data=self.options.reflection_data,
                           count_samples=self.options.count_samples, world=world or self.world.with_settings(scene))
        check_fits(self.ctx, scene, plan)
        return plan

    # ------------------------------------------------------------------ settings
    def look_at(self, view: Camera) -> None:
        """Move the camera; depth images do not depend on it, so nothing is re-baked."""
        self.view = view
        self.camera = self.world.camera(view, self.scene.render.size, self.reversed_z)

    def set_camera(self, camera: PPC) -> None:
        """Use this exact camera (tests), until the next `look_at` or `resize`; nothing is re-baked."""
        self.camera = EyeCamera.of(camera) if self.reversed_z else camera

    @_live
    @keeps_gl_state
    def set_time(self, seconds: float) -> None:
        """Move the scene's animated objects and lights to where they are at `seconds` (a finite
        number: ValueError otherwise). Only what depends on what moved is baked again at the next
        frame (RenderGraph.follow)."""
        seconds = checked_time(seconds)
        if seconds != self.time and self.scene.animated:
            earlier, self.world = self.world, self.world.at(seconds)
            self.look_at(self.view)  # the near and far planes follow the scene's bounds
            self.graph.follow(earlier, self.world)
        self.time = seconds

    @_live
    @keeps_gl_state
    def _apply(self, scene: Scene, method: Method, algorithm: Algorithm, context: str, edited: bool = False) -> None:
        """Draw with other settings (or, `edited`, another version of the scene's objects): re-plan,
        and let the graph rebuild what the new plan changes (all of it for an edited scene). A
        setting this context cannot hold raises GpuLimitError and leaves the renderer as it was."""
        world = World(scene, time=self.time) if edited else self.world.with_settings(scene)
        plan = self._checked_plan(scene, method, algorithm, world)
        with allocating(self.ctx, context):
            targets = self.targets.reshaped(scene.render.size, bool(world.reflectors))
            try:
                if edited:  # its texture table into every program, those made before too
                    self.programs.rewrite_scene_uniforms(lambda program: write_scene_uniforms(program, scene))
                (self.graph.rebuild if edited else self.graph.apply)(plan, world)
            except BaseException:
                if targets is not self.targets:
                    targets.release()
                if edited:
                    self.programs.rewrite_scene_uniforms(lambda program: write_scene_uniforms(program, self.scene))
                raise
        if targets is not self.targets:
            self.targets.release()
            self.targets = targets
        resized = scene.render.size != self.scene.render.size
        self.scene, self.world, self.method, self.algorithm, self.plan = scene, world, method, algorithm, plan
        if edited or resized:  # the near and far planes follow the objects; a set_camera stays otherwise
            self.look_at(self.view)

    def resize(self, size: tuple[int, int]) -> None:
        """Render frames of another size; depth images do not depend on it."""
        if size != self.scene.render.size:
            self._apply(self.scene.with_overrides(size=size), self.method, self.algorithm, "the frame's size")

    def set_algorithm(self, algorithm: Algorithm) -> None:
        """Another mirror variant, the same depth images (pyramids made or freed). A GL without
        compute shaders raises ContextError for the hierarchical one and keeps the old."""
        self._apply(self.scene, self.method, algorithm, "--algorithm")

    def set_method(self, method: Method) -> None:
        """Another stand-in, unless both methods share one (the two cube-map lookups)."""
        self._apply(self.scene, method, self.algorithm, "--impostor-res")

    def set_impostor_resolution(self, resolution: int | str) -> None:
        """Re-plan and re-bake the baked images at another resolution (a size, or "auto")."""
        scene = self.scene.with_overrides(impostor_resolution=resolution)
        self._apply(scene, self.method, self.algorithm, "--impostor-res")

    def set_scene(self, scene: Scene) -> None:
        """An edited scene (the viewer's panel: materials, lights, bounces), drawn anew at the
        renderer's time and camera. One this context cannot hold raises and changes nothing."""
        self._apply(scene, self.method, self.algorithm, "--impostor-res", edited=True)

    @_live
    @keeps_gl_state
    def set_show_samples(self, show: bool) -> None:
        """Reflected objects shown as their baked images' samples (the lecture's visualization)."""
        self.graph.set_show_samples(show)

    @_live
    def bake_again(self) -> None:
        """Bake again at the next frame, although nothing changed (the benchmark times bakes)."""
        self.graph.bake_again()

    @_live
    @keeps_gl_state
    def reload_shaders(self) -> None:
        """Compile every program again from the files, and re-bake; a file that no longer compiles
        raises ShaderError before any program is replaced."""
        fresh = self.programs.reloaded()
        self.targets.release_presenter()
        self.graph.release_passes()
        self.graph.meshes.forget_vertex_arrays()
        self.programs.release()
        self.programs = self.graph.programs = fresh
        self.graph.build()

    # ------------------------------------------------------------------ frames
    @_live
    def render(self, target: moderngl.Framebuffer | None = None,
               viewport: tuple[int, int, int, int] | None = None) -> RenderStats:
        """Draw one frame (baking what is stale first), and given a `target` put it upright into
        `viewport` of it (default: all of it; the frame's size). Times: render_graph.py."""
        # The passes expect the depth test on and nothing else (no blending of the caller's).
        with kept_state(self.ctx, enable_only=moderngl.DEPTH_TEST):
            samples, camera = self.scene.render.samples, self.camera
            bakes = len(self.stats.bake_seconds)
            if samples == 1:
                self.graph.draw(camera, camera, self.targets)
            else:
                self.last_sub_frames = draw_supersampled(lambda sub: self.graph.draw(sub, camera, self.targets),
                                                         camera, samples, self.targets, self.stats,
                                                         self.options.reflection_data)
            if len(self.stats.bake_seconds) == bakes:  # not a sub-frame's: the frame's, all of it
                self.graph.rest()
            if target is not None:
                self.targets.present(self.programs, target, viewport, self.scene.render)
        return self.stats

    def sub_frames(self) -> list[SubFrame]:
        """The last frame's sub-pixel frames (render.samples), or the frame itself without AA. The
        sky's lighting is read with them (sky_lighting), so that `compare` given them touches no GL
        and can run in another thread."""
        self.sky_lighting()
        if self.scene.render.samples == 1:
            data = self.read_reflection_data() if self.options.reflection_data else None
            return [SubFrame(self.camera, self.read_color_float(), data)]
        return list(self.last_sub_frames)

    @_live
    def read_color_float(self) -> np.ndarray:
        """The last frame as (height, width, 3) float32, top row first, unclamped."""
        return self.targets.read_color_float()

    def read_color(self) -> np.ndarray:
        """The last frame as uint8 through the scene's display transform (colour.py), for a PNG."""
        render = self.scene.render
        return display_encode(self.read_color_float(), render.tone_mapping, render.exposure)

    def sky_lighting(self) -> SkyLighting | None:
        """What the scene's equirect sky lights metallic-roughness surfaces with (ibl.py): its
        texture as the shaders read it (prefiltered at the first frame, or now), for the truth;
        None where the sky lights nothing (constant ambient). Read from the GL once for the
        scene's environment, then kept: another thread may ask again (compare in the viewer)."""
        # Keyed on the environment pass too: a scene edit that brings the first metallic-roughness
        # material (or reloaded shaders) makes a new pass, with a prefilter, under the same sky.
        key = (self.graph.environment, self.scene.environment)
        if self._sky is None or any(a is not b for a, b in zip(self._sky[0], key, strict=True)):
            self._sky = (key, self._read_sky_lighting())
        return self._sky[1]

    @_live
    @keeps_gl_state
    def _read_sky_lighting(self) -> SkyLighting | None:
        texture = self.graph.environment.read_back()
        return None if texture is None else SkyLighting.of(self.scene.environment, texture)

    @_live
    def read_sample_counts(self) -> np.ndarray:
        return self.targets.read_sample_counts()

    @_live
    def read_reflection_data(self) -> ReflectionData:
        return self.targets.read_reflection_data()

    # ------------------------------------------------------------------ lifetime
    def release(self) -> None:
        """Free the renderer's GL objects (once: a second call does nothing); its context must be
        current in this thread."""
        if self.released or isinstance(self.ctx.mglo, moderngl.InvalidObject):  # its context freed them all
            self.released = True
            return
        check_usable(self.ctx)
        with kept_state(self.ctx):
            self._release()
        self.released = True

    def _release(self) -> None:
        self.graph.release()
        self.programs.release()
        self.targets.release()

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *args: object) -> None:
        self.release()
