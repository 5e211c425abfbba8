"""The plan's render graph, made executable: the GL objects the nodes of `plan.graph` (graph.py)
run, built from the plan and the world, and the nodes themselves (node.py: one class per pass, in
its pass's module), run in order each frame (the bakes only for what is stale) and told when the
world moves; changed, not rebuilt, when a setting changes. The GL objects belong to the graph, not
to a node: the stand-in is baked by one node and read by six.

A setting change (renderer.py's setters) makes a new plan; `apply` compares it with the one the
graph was built from and rebuilds only the nodes whose part of the plan differs: another method's
stand-in, another impostor resolution's images, the mirror variant of another algorithm. A new
stand-in is made before the old one is released, so that a failure leaves the graph as it was.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

import moderngl

from .eye import clear_depth, eye_depth
from .gpu.context import bind_default_framebuffer
from .gpu.batches import batches_supported
from .gpu.deform import GpuDeform, gpu_supported
from .gpu.meshes import GpuMeshes
from .gpu.scene_blocks import SceneBlocks
from .gpu.uniforms import mesh_attributes
from .gpu.shaders import ProgramCache
from .gpu.textures import GpuTextures
from .graph import Pass, node_class
from .methods.baked_images import BakedImages
from .methods.gpu_refit import GpuRefit
from .methods.hybrid import HybridPass
from .methods.impostors import ImpostorPass
from .methods.registry import METHODS
from .methods.seen_from_eye import SeenFromEye
from .methods.triangles import TrianglePass
from .node import Frame, Node
from .passes.diffuse import DiffusePass
from .passes.environment import EnvironmentPass
from .passes.glass import GlassInterior
from .passes.reflectors import ReflectorPass, ReflectedObjects
from .passes.samples import SamplesPass
from .passes.shadows import ShadowMaps
from .passes.transparent import TransparentPass
from .plan import RenderPlan, check_stand_in, frame_surface
from .ppc import PPC
from .targets import FrameTargets
from .world import World


@dataclass
class RenderStats:
    """Counters of the work done (tests read them; `render --stats` prints them)."""

    frames: int = 0
    depth_images_baked: int = 0  # every baked image: depth images, cube-map faces, billboards
    shadow_maps_baked: int = 0
    interiors_made: int = 0  # glass interior images
    eye_images_made: int = 0  # planar reflections' renders and SSR's frame copies (made every frame)
    draw_calls: int = 0
    passes: Counter[str] = field(default_factory=Counter)  # frames each pass ran in, by Pass value
    images_baked: Counter[str] = field(default_factory=Counter)  # bakes of each image, by its label
    bake_seconds: list[float] = field(default_factory=list)  # one entry per bake (shadow maps and stand-in)
    draw_seconds: list[float] = field(default_factory=list)  # one entry per frame
    # The mirror pass's share of each frame, when the renderer was asked to time it.
    mirror_seconds: list[float] = field(default_factory=list)
    # The same two, as GL time queries measured them (when the mirror pass is timed): a GPU's own
    # clock, without the wait for ctx.finish(); llvmpipe's under-report (bench.py).
    gl_draw_seconds: list[float] = field(default_factory=list)
    gl_mirror_seconds: list[float] = field(default_factory=list)
    # Frames drawn at a sub-pixel position (render.samples per frame; 1 per frame without
    # anti-aliasing). A frame's draw time is the sum of its sub-frames'.
    sub_frames: int = 0


@dataclass(frozen=True)
class GraphOptions:
    """What the renderer was made to output besides the colour (fixed for its lifetime)."""

    reflection_data: bool = False  # float outputs of each mirror pixel's ray and hit
    count_samples: bool = False  # an output of the samples each reflected ray read (bench)
    time_mirror_pass: bool = False  # the mirror pass timed apart, after a ctx.finish() (bench)
    # Triangles a frame's bake may draw where the method answers the rays of images not baked yet
    # otherwise (the hybrid traces them): the rest are baked by the next frames (BakedImages.bake_budget;
    # the viewer's INTERACTIVE_BAKE_BUDGET). None: a frame waits for every image it enters.
    bake_budget: int | None = None


class RenderGraph:
    def __init__(self, ctx: moderngl.Context, programs: ProgramCache, world: World, plan: RenderPlan,
                 options: GraphOptions, stats: RenderStats) -> None:
        self.ctx, self.programs, self.options, self.stats = ctx, programs, options, stats
        self.world, self.plan = world, plan
        self.meshes = GpuMeshes(ctx, mesh_attributes(world.scene))  # with the glTF attributes the scene reads
        self.meshes.load(world.meshes)  # the world's meshes in one arena
        # Deforming glTF parts skinned and morphed into that arena on the GPU (where GL 4.3 is).
        self.deform = GpuDeform(ctx, programs)
        self.textures = GpuTextures(ctx)  # the scene's image textures, bound for every frame
        self.scene_blocks = SceneBlocks(ctx)  # the lights and analytic planes, bound for every frame
        self.show_samples = False
        self.tint_retraced = False  # the hybrid method's re-traced rays tinted (the viewer's T)
        self.diffuse: DiffusePass | None = None
        self.transparent: TransparentPass | None = None
        self._diffuse_key: tuple[bool, bool] | None = None  # what the diffuse pass was made for
        self.nodes: tuple[Node, ...] = ()
        self._gl_queries: tuple[moderngl.Query, ...] = ()  # the mirror pass's GL timers (_gl_timer)
        self._stand_in_bakes: frozenset[Pass] = frozenset()  # _schedule's
        self._early_eye = 0
        self.build()

    def _compile(self) -> None:
        """The plan's programs, node by node: the passes then find them in the cache."""
        for node in self.plan.graph:
            for key in node.programs:
                # A compute shader needs GL 4.3: without it the deform node and the refit use the
                # CPU, and a pass that has no CPU path (the pyramids) refuses in its own words.
                if len(key[0]) == 2 or gpu_supported(self.ctx):
                    self.programs.compile(key)

    def build(self, environment: EnvironmentPass | None = None) -> None:
        """Every node's GL side, from the plan, with the programs of the cache (and `environment`,
        the sky and its prefiltered levels kept from before, where it serves this scene)."""
        ctx, scene, world = self.ctx, self.world.scene, self.world
        self._compile()
        self.scene_blocks.write(world.lit_scene, world.analytic_planes)
        self.environment = environment if environment is not None else EnvironmentPass(ctx, self.programs, scene)
        # Made (and baked) before anything that shades: depth images show the shadows too.
        self.shadow_maps = (ShadowMaps(ctx, self.programs, world.lit_scene, self.meshes, world.shadow_casters)
                            if self.plan.runs(Pass.SHADOW_MAPS) else None)
        self.diffuse = self._diffuse_pass()
        self.transparent = (TransparentPass(self.programs, scene, self.meshes, self.scene_blocks.drawn_materials) if self.plan.runs(Pass.TRANSPARENT)
                            else None)
        self.stand_in: ReflectedObjects | None = None
        self.reflector_pass: ReflectorPass | None = None
        self.samples: SamplesPass | None = None
        # An interior image per glass object, as large as the frame's larger side (passes/glass.py).
        self.glass_interiors = {item.index: GlassInterior(ctx, self.programs, self.meshes, max(scene.render.size))
                                for item in world.glass}
        if world.reflectors:
            self._make_stand_in(self.plan)
            self.reflector_pass = self._reflector_pass()
            if self.show_samples and self.sampled is not None:
                self.samples = SamplesPass(ctx, self.programs)
        self.stand_in_baked = False
        self._make_nodes()

    def _make_nodes(self) -> None:
        """The plan's nodes, in its order, each bound to this graph."""
        self.nodes = tuple(node_class(planned.stage)(self) for planned in self.plan.graph)
        self._schedule()

    def _diffuse_pass(self) -> DiffusePass | None:
        """The frame's diffuse objects: with the eye's surface beside the colour where SSR reads it.
        The one there is kept when it would be made the same (another algorithm, another method
        that reads no surface), and released when it is replaced."""
        key = (self.plan.runs(Pass.DIFFUSE), frame_surface(self.plan.method, bool(self.world.reflectors)))
        if self.diffuse is not None and key == self._diffuse_key:
            return self.diffuse
        made = (DiffusePass(self.programs, self.world.scene, self.meshes, self.scene_blocks.drawn_materials,
                            write_depth_image=False,
                            batched=batches_supported(self.ctx), write_surface=key[1]) if key[0] else None)
        if self.diffuse is not None:  # released once the new one exists
            self.diffuse.release()
        self._diffuse_key = key
        return made

    # ------------------------------------------------------------------ what the nodes hold
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

    @property
    def seen_from_eye(self) -> SeenFromEye | None:
        """The stand-in made in the frame from the eye (planar, SSR)."""
        return self.stand_in if isinstance(self.stand_in, SeenFromEye) else None

    def stand_in_stale(self) -> bool:
        """Has the stand-in anything to bake (the bounce images, pyramids and colour mips follow it)?"""
        baked = self.baked_images
        return baked.needs_bake if baked is not None else not self.stand_in_baked

    def count_images(self, new: Counter[str]) -> None:
        """Images baked (by label) into the stats."""
        self.stats.images_baked += new
        self.stats.depth_images_baked += sum(new.values())

    def _make_stand_in(self, plan: RenderPlan) -> None:
        """The method's stand-in for the reflected objects; the old one (if any) is released only
        once the new one exists, so that a failure leaves the graph as it was."""
        world, scene = self.world, self.world.scene
        kind = METHODS[plan.method].stand_in
        check_stand_in(scene, plan.method, world.reflectors, world.reflected_objects)
        stand_in: ReflectedObjects
        if issubclass(kind, BakedImages):
            stand_in = kind(self.ctx, self.programs, scene, self.meshes, self.scene_blocks.drawn_materials,
                            world.reflectors, world.reflected_objects, plan.image_plans)
            stand_in.bake_budget = self.options.bake_budget
        elif issubclass(kind, SeenFromEye):
            stand_in = kind(self.ctx, self.programs, scene, self.meshes, self.scene_blocks.drawn_materials,
                            world.reflectors)
        else:
            stand_in = kind(self.ctx, scene, world.reflected_objects)
        traced = (stand_in if isinstance(stand_in, TrianglePass)
                  else stand_in.triangles if isinstance(stand_in, HybridPass) else None)
        if traced is not None and any(g.object.deforms for g in world.reflected_objects):
            # Deforming meshes' trees refitted by compute passes (where GL 4.3 is: GpuRefit.usable).
            traced.gpu = GpuRefit(self.ctx, self.programs, self.meshes, self.deform)
        try:  # its pyramids and colour mips too (a GL without compute shaders refuses them) ...
            self._keep_pyramids(plan, stand_in)
        except BaseException:
            stand_in.release()
            raise
        if self.stand_in is not None:  # ... before the old one goes
            self.stand_in.release()
        self.stand_in = stand_in
        self.stand_in_baked = False

    def _keep_pyramids(self, plan: RenderPlan, stand_in: ReflectedObjects | None = None) -> None:
        """Depth pyramids and colour mips exist exactly while the plan builds them (on `stand_in`,
        the graph's own by default)."""
        stand_in = stand_in if stand_in is not None else self.stand_in
        if isinstance(stand_in, ImpostorPass):
            stand_in.use_pyramid(plan.builds_pyramids)
        if isinstance(stand_in, BakedImages):
            stand_in.use_colour_mips(plan.runs(Pass.COLOUR_MIPS))

    def _reflector_pass(self) -> ReflectorPass:
        if self.stand_in is None:
            raise RuntimeError("the reflector pass is made only after the reflected objects' stand-in")
        made = ReflectorPass(self.programs, self.world.scene, self.meshes, self.stand_in,
                             METHODS[self.plan.method].defines(self.plan.algorithm), self.options.reflection_data,
                             self.options.count_samples, self.glass_interiors)
        if self.reflector_pass is not None:
            self.reflector_pass.release()
        return made

    # ------------------------------------------------------------------ changes
    def apply(self, plan: RenderPlan, world: World) -> None:
        """Draw by `plan` (another method, algorithm or impostor resolution) in `world` (the same
        objects, perhaps other render settings): the nodes whose part of the plan changed are
        rebuilt, the others kept. What can be refused (a program, a stand-in or pyramids this GL
        cannot make) is made first: a refusal leaves the graph drawing by the plan it had."""
        before, before_world = self.plan, self.world
        same_stand_in = METHODS[plan.method].stand_in is METHODS[before.method].stand_in
        new_images = plan.image_plans is not before.image_plans and (
            plan.images != before.images or world.scene.render.impostor_resolution
            != self.world.scene.render.impostor_resolution)
        self.plan, self.world = plan, world  # what the nodes below are made from
        interiors = kept_interiors = self.glass_interiors
        try:
            self._compile()
            interiors = self._sized_interiors()  # before the stand-in, which replaces the old one
            if world.reflectors and (not same_stand_in or (new_images and self.baked_images is not None)):
                self._make_stand_in(plan)
            else:
                self._keep_pyramids(plan)
        except BaseException:
            _release_other(interiors, kept_interiors)
            self.plan, self.world = before, before_world
            raise
        self.glass_interiors = interiors
        self.diffuse = self._diffuse_pass()
        if self.reflector_pass is not None:
            self.reflector_pass = self._reflector_pass()
        self._make_nodes()
        _release_other(kept_interiors, interiors)  # once no pass reads them
        if self.sampled is None:
            self.show_samples = False
        if self.samples is not None and not self.show_samples:
            self.samples.release()
            self.samples = None

    def _sized_interiors(self) -> dict[int, GlassInterior]:
        """The glass interiors, or new ones as large as the frame's larger side where it changed."""
        side = max(self.world.scene.render.size)
        if all(interior.size == side for interior in self.glass_interiors.values()):
            return self.glass_interiors
        made: dict[int, GlassInterior] = {}
        try:
            for index in self.glass_interiors:
                made[index] = GlassInterior(self.ctx, self.programs, self.meshes, side)
        except BaseException:
            _release_other(made, self.glass_interiors)
            raise
        return made

    def follow(self, earlier: World, world: World) -> None:
        """The world moved from `earlier` to `world`: each node marks stale only what depends on
        what moved (a shadow map when its light or a caster moved; an image when its reflector or
        object moved, when a light moved, or when a caster moved whose shadow may fall on its object)."""
        self.world = world
        self.scene_blocks.write(world.lit_scene, world.analytic_planes)
        for node in self.nodes:
            node.follow(earlier, world)

    def rebuild(self, plan: RenderPlan, world: World) -> None:
        """Every node made again for another scene (the same context, meshes and textures), but the
        sky where the edit left it as it was (the same image, lighting the same way): its
        prefilter runs once per sky, not once per edit of a material or a light."""
        kept = self.environment if self.environment.serves(world.scene) else None
        if kept is not None:
            self.environment = None  # type: ignore[assignment]  # not released with the other passes
        self.release_passes()
        self.plan, self.world = plan, world
        self.meshes.load(world.meshes)
        self.build(kept)

    def set_show_samples(self, show: bool) -> None:
        self.show_samples = show
        if show and self.samples is None and self.sampled is not None:
            self.samples = SamplesPass(self.ctx, self.programs)

    def rest(self) -> None:
        """A frame (all its sub-frames) baked nothing: what only bakes use is let go until the next
        bake (the baked images' depth buffer, BakedImages.rest)."""
        if self.baked_images is not None:
            self.baked_images.rest()

    def bake_again(self) -> None:
        self.stand_in_baked = False
        if self.baked_images is not None:
            self.baked_images.bake_again()

    # ------------------------------------------------------------------ a frame
    def draw(self, camera: PPC, unjittered: PPC, targets: FrameTargets) -> None:
        """One frame through `camera`, node by node in the plan's order (`unjittered`: the frame's
        own camera, where `camera` is one of its sub-pixel positions): the bakes the eye's first
        passes read (shadow maps, the sky's prefilter), those passes (the sky, the diffuse objects:
        `_schedule`), the stand-in's bakes, which may bake only the images the frame's rays enter,
        found against the depth those passes left (BakedImages.aim), then the other eye passes.
        The bakes run only for what is stale, and are timed apart from the eye's passes. The sample
        view's diffuse pass draws the baked images' samples, so its frames bake first. Times are
        wall-clock around `ctx.finish()`: GPU time queries under-report on software rasterizers,
        and a finish makes the time include all the work the frame queued."""
        stats, frame = self.stats, Frame(camera, unjittered, targets)
        self.environment.use()  # an equirect sky's image: bakes see it too
        self.textures.use(self.world.scene)  # the image textures: baked images show them too
        self.scene_blocks.bind()  # the lights and planes: bakes shade with them too
        if self.shadow_maps is not None:  # bound for every pass that shades, bakes included
            self.shadow_maps.use()
        baked = self.baked_images
        early_count = 0 if self.show_samples else self._early_eye
        eye_nodes = [node for node in self.nodes if not node.bakes]
        early, rest = eye_nodes[:early_count], eye_nodes[early_count:]
        later_bakes = [node for node in self.nodes if node.stage in self._stand_in_bakes] if early else []
        if not later_bakes and baked is not None:  # every bake first: aimed without the frame's depth
            baked.aim(None if self.show_samples else camera, targets.surfaces)
        first_bakes = self._bakes([node for node in self.nodes if node.bakes and node not in later_bakes], frame)
        # A bake may follow the first eye passes (the finish between them times the two apart).
        pending = any(node.stale() for node in later_bakes) or (bool(later_bakes) and baked is not None
                                                                  and bool(baked.stale))
        self.ctx.finish()
        start = time.perf_counter()
        targets.framebuffer.use()
        targets.framebuffer.clear(0.0, 0.0, 0.0, 0.0, depth=clear_depth(self.ctx))
        targets.color_framebuffer.use()
        with eye_depth(self.ctx), self._gl_timer(0):
            for node in early:
                self._run(node, frame)
        draw_seconds = 0.0
        later: float | None = None
        if pending:
            self.ctx.finish()
            draw_seconds = time.perf_counter() - start
            if baked is not None:  # which stale images this frame's rays may enter (the others wait)
                # Behind the frame's depth as the first eye passes left it: the passes after them only
                # draw nearer, so no mirror pixel it hides is uncovered (the sample view, whose
                # diffuse pass draws samples, never comes here: it bakes first).
                baked.aim(camera, targets.surfaces, behind_frame=True)
            later = self._bakes(later_bakes, frame)
            self.ctx.finish()
            start = time.perf_counter()
            targets.color_framebuffer.use()
        if first_bakes is not None or later is not None:  # one entry a frame that baked
            stats.bake_seconds.append((first_bakes or 0.0) + (later or 0.0))

        timed = self.options.time_mirror_pass
        # Where the mirror pass begins (the first node of its time), where it is timed apart.
        split = next((i for i, node in enumerate(rest) if node.mirror_time), len(rest)) if timed else len(rest)
        mirror_start: float | None = None  # when the mirror pass began, where it is timed apart
        with eye_depth(self.ctx):
            with self._gl_timer(1):
                for node in rest[:split]:
                    self._run(node, frame)
            if split < len(rest):
                self.ctx.finish()
                mirror_start = time.perf_counter()
                with self._gl_timer(2):
                    for node in rest[split:]:
                        self._run(node, frame)
        self.ctx.finish()
        end = time.perf_counter()
        stats.draw_seconds.append(draw_seconds + end - start)
        if timed:
            stats.mirror_seconds.append(end - mirror_start if mirror_start is not None else 0.0)
            first, before_mirror = (query.elapsed / 1e9 for query in self._gl_queries[:2])
            # A query never begun is not read (GL_INVALID_OPERATION where a driver checks).
            mirror = self._gl_queries[2].elapsed / 1e9 if mirror_start is not None else 0.0
            stats.gl_draw_seconds.append(first + before_mirror + mirror)
            stats.gl_mirror_seconds.append(mirror)
        stats.frames += 1
        stats.sub_frames += 1

    def _bakes(self, nodes: list[Node], frame: Frame) -> float | None:
        """Run the stale ones of `nodes` (bakes; each asked before any runs: a bake may make
        another fresh); the seconds they took, None where none was stale."""
        stale = [node for node in nodes if node.stale()]
        if not stale:
            return None
        self.ctx.finish()
        start = time.perf_counter()
        for node in stale:
            self._run(node, frame)
        self.ctx.finish()
        return time.perf_counter() - start

    def _schedule(self) -> None:
        """Where the plan's order (graph.NODES) interleaves the bakes with the eye's passes: the
        eye's first passes (the sky, the diffuse objects) come before the stand-in's bake and the
        bakes that follow it, so that the stand-in may bake only what the frame's rays enter, found
        against the depth those passes drew (BakedImages.aim)."""
        order = list(self.plan.graph)
        first_eye = next((i for i, planned in enumerate(order) if not node_class(planned.stage).bakes), len(order))
        self._stand_in_bakes = frozenset(planned.stage for planned in order[first_eye:]
                                         if node_class(planned.stage).bakes)
        # No further than the mirror pass either, whose time (GraphOptions.time_mirror_pass) is its own.
        later = next((i for i in range(first_eye, len(order)) if order[i].stage in self._stand_in_bakes
                      or node_class(order[i].stage).mirror_time), len(order))
        self._early_eye = later - first_eye

    @contextmanager
    def _gl_timer(self, index: int) -> Iterator[None]:
        """A GL time query around part `index` of the eye's passes (0: those before the stand-in's
        bakes, 1: the others before the mirror pass, 2: the mirror pass), where the mirror pass is
        timed; else nothing. Queries in turn rather than one around the frame and one inside it:
        GL runs one time query at a time."""
        if not self.options.time_mirror_pass:
            yield
            return
        if not self._gl_queries:  # moderngl's queries live as long as their context: made once
            self._gl_queries = (self.ctx.query(time=True), self.ctx.query(time=True), self.ctx.query(time=True))
        with self._gl_queries[index]:
            yield

    def _run(self, node: Node, frame: Frame) -> None:
        """A node run, and counted in the stats' passes where it did anything."""
        if node.run(frame):
            self.stats.passes[node.stage.value] += 1

    def release_passes(self) -> None:
        bind_default_framebuffer(self.ctx)
        for owner in (self.stand_in, self.environment, self.diffuse, self.transparent, self.samples, self.shadow_maps,
                      self.reflector_pass, *self.glass_interiors.values()):
            if owner is not None:
                owner.release()
        self.diffuse = self.transparent = None  # made again by the next build

    def release(self) -> None:
        self.release_passes()
        self.deform.release()
        self.meshes.release()
        self.textures.release()
        self.scene_blocks.release()


def _release_other(interiors: dict[int, GlassInterior], kept: dict[int, GlassInterior]) -> None:
    """Release `interiors` unless they are the `kept` ones."""
    if interiors is not kept:
        for interior in interiors.values():
            interior.release()
