"""The render plan: from the scene alone, the passes, images and shader variants a frame needs,
and why each is there. The renderer builds exactly these (tests compare the two), and
`depthimpostor plan` prints them.

Nothing else is made: no reflection pass without a mirror or glass, no image of an object a
mirror can never show (culling.py), no shadow map for a light without shadows, no GLASS or
SHADOWS variant in a scene without glass or shadows, no depth pyramid unless the hierarchical
algorithm reads it, no GLOSSY variant nor colour mips without a rough mirror.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from .constants import (
    BLEND_IMAGE_CUTOFF,
    depth_image_capacity, DEPTH_IMAGE_BLOCK_RECORDS, DEPTH_IMAGE_DTYPE, DRAWN_MATERIAL_STRIDE, MATERIAL, MATERIAL_BLOCK_RECORDS, MAX_ANALYTIC_PLANES,
    MAX_BOUNCES, MAX_LIGHTS, MAX_NAMED_TRIANGLES, BVH_TEXTURE_WIDTH, BVH_TRIANGLE_TEXELS, EXTRA_ATTRIBUTES,
    HIERARCHICAL_MIN_SIDE, IBL_LEVELS, IBL_SAMPLES, Algorithm, Method, image_algorithm, lists_images, triangle_texel_layout,
)
from .culling import Reach
from .geometry import ObjectGeometry
from .passes.deform import deform_plan, deforming_parts
from .passes.diffuse import DIFFUSE_PROGRAM, diffuse_defines, has_checker
from .methods.entered_images import ENTERED_PROGRAM, EnteredImages, entered_defines
from .passes.environment import ENVIRONMENT_PROGRAM, PREFILTER_PROGRAM, environment_map_bytes
from .passes.glass import INTERIOR_PROGRAM, interior_bytes
from .methods.atlas import BACK_FACE_PROGRAM, BEYOND_PROGRAM, ImpostorAtlas, atlas_grid, image_label, plural
from .methods.baked_images import BakedImages, ImagePlan, SecondLayer
from .gpu.batches import batch_bytes
from .methods.planar import check_flat_mirrors
from .methods.seen_from_eye import SeenFromEye
from .gpu.meshes import GpuMeshes
from .gpu.scene_blocks import SceneBlocks, drawn_materials_bytes, materials_bytes
from .gpu.uniforms import materials_in_storage
from .gpu.textures import GpuTextures
from .texture_layout import texture_layout
from .passes.reflectors import (
    DEFERRED,
    DEFERRED_REFLECTOR_PROGRAM,
    REFLECTION_OUTPUTS,
    REFLECTOR_PROGRAM,
    SURFACE_PROGRAM,
    bounce_defines,
    glossy_defines,
    reflection_defines,
    reflector_defines,
)
from .targets import Surfaces
from .methods.registry import METHODS
from .methods.colour_mips import COLOUR_MIPS_PROGRAM
from .methods.pyramid import PYRAMID_PROGRAM, PyramidLayout, pyramid_bytes
from .passes.shadows import shadow_map_defines, SHADOW_MAP_PROGRAM, fit_shadow_camera, shadow_map_bytes
from .gpu.uniforms import alpha_mask_defines, environment_defines, mesh_attributes
from .scene.limits import check_method, check_model_reach, check_model_uvs, check_scene
from .scene.model import GltfShape, MeshShape, MetallicRoughnessMaterial, Scene
from .gpu.shaders import Defines, ProgramKey, program_key
from .graph import Pass, RenderNode, build_graph, format_graph, in_order, node_class
from .ibl import PREFILTER_SECONDS, level_size, prefilter_reads, uses_environment_lighting
from .lod import bake_meshes
from .world import World

@dataclass(frozen=True)
class PlannedPass:
    stage: Pass
    reason: str

    @property
    def when(self) -> str:
        """When its node runs (the bakes run again only for what moved)."""
        return node_class(self.stage).when


@dataclass(frozen=True)
class PlannedImage:
    """One baked image (named "reflector -> what it shows" as the renderer's stats name it), its
    bounce level and size."""

    label: str
    level: int
    width: int
    height: int
    reason: str


@dataclass(frozen=True)
class SkippedImage:
    reflector: str
    target: str
    reason: str


@dataclass(frozen=True)
class PlannedVariant:
    key: ProgramKey
    reason: str

    @property
    def name(self) -> str:
        stages, defines = self.key
        settings = ", ".join(f"{k}={v}" for k, v in defines)
        return " + ".join(stages) + (f" [{settings}]" if settings else "")


@dataclass(frozen=True)
class PlannedObject:
    """An object as messages name it: its name, and its label (Scene.object_label): for a part of a
    glTF file (`from_gltf`), the node, mesh and material, which its name (the node's) does not all say."""

    name: str
    label: str
    from_gltf: bool


#: The memory entry of the baked images' depth buffer, kept only while frames bake (BakedImages.rest).
BAKE_DEPTH_BUFFER = "bake depth buffer"


@dataclass(frozen=True)
class RenderPlan:
    scene: str
    method: Method
    algorithm: Algorithm
    passes: tuple[PlannedPass, ...]
    images: tuple[PlannedImage, ...]
    skipped: tuple[SkippedImage, ...]
    variants: tuple[PlannedVariant, ...]
    memory: dict[str, int] = field(default_factory=dict)  # bytes per resource
    # The baked images of each reflector (by index), with their cameras: what the stand-in bakes,
    # so that it does not plan them again.
    image_plans: dict[int, list[ImagePlan]] = field(default_factory=dict, compare=False, repr=False)
    # The passes as the render graph the renderer runs (graph.py): each with what it reads and writes.
    graph: tuple[RenderNode, ...] = ()
    # render.samples: the eye's passes run this many times per frame (at sub-pixel positions), the bakes once.
    samples: int = 1
    # Where the scene's image textures go (texture_layout.py), for `plan`'s memory lines; "" without any.
    textures: str = ""
    # The diffuse planes' names: those intersected exactly, and those drawn as meshes
    # (Scene.analytic_plane_indices chooses).
    analytic_planes: tuple[str, ...] = ()
    mesh_planes: tuple[str, ...] = ()
    # Each object's name, and how messages name it (Scene.object_label).
    objects: tuple[PlannedObject, ...] = ()
    # What the scene uses of each limit that remains, in memory and GL terms (plan_limits).
    limits: tuple[str, ...] = ()
    # Per glTF file (as the scene names it), what it uses that the loader does not implement.
    ignored: tuple[tuple[str, tuple[str, ...]], ...] = ()

    def planes_lines(self) -> list[str]:
        """Which diffuse planes are intersected exactly and which are drawn as meshes (none where
        the scene has no diffuse plane)."""
        if not self.mesh_planes:
            return [f"planes intersected exactly: {_listed(self.analytic_planes)}"] if self.analytic_planes else []
        return [f"planes intersected exactly: {_listed(self.analytic_planes)} (the {MAX_ANALYTIC_PLANES} largest)",
                f"planes drawn as meshes: {_listed(self.mesh_planes)} (reflected as any object is)"]

    def samples_line(self) -> str:
        """What anti-aliasing costs: eye passes per frame, and no GPU memory (the average is host-side)."""
        if self.samples == 1:
            return "anti-aliasing: none (render.samples = 1: one ray per pixel centre)"
        return (f"anti-aliasing: {self.samples} samples: the eye's passes (environment, diffuse, reflectors) run "
                f"{self.samples} times per frame at jittered sub-pixel positions, bakes and glass interiors once; "
                "no GPU memory beyond one sample's (the frames are averaged in host memory)")

    def parts_lines(self) -> list[str]:
        """The objects of glTF files, named as above and as the file names them (none without)."""
        parts = [o for o in self.objects if o.from_gltf]
        return [f"glTF parts ({len(parts)}):", *(f"  {o.name}: {o.label}" for o in parts)] if parts else []

    def ignored_lines(self) -> list[str]:
        """One line per glTF file that uses what the loader does not implement, naming it all."""
        return [f"ignored in {file} (not implemented, drawn as if absent): {', '.join(names)}"
                for file, names in self.ignored]

    def runs(self, stage: Pass) -> bool:
        return any(planned.stage is stage for planned in self.passes)

    @property
    def program_keys(self) -> set[ProgramKey]:
        return {variant.key for variant in self.variants}

    @property
    def builds_pyramids(self) -> bool:
        """Are depth pyramids kept (the hierarchical algorithm, or `auto` with an image it traverses
        so; none where the reflectors have no depth image to march)?"""
        return self.runs(Pass.PYRAMIDS)

    def traversal(self, image: PlannedImage) -> Algorithm:
        """How the reflectors' shader marches `image` (`auto` picks by its size)."""
        return image_algorithm(self.algorithm, image.width, image.height)

    def counts(self) -> dict[str, int]:
        return {"passes": len(self.passes), "images": len(self.images), "skipped": len(self.skipped),
                "variants": len(self.variants)}

    def to_json(self) -> dict[str, Any]:
        return {
            "scene": self.scene,
            "method": self.method.option,
            "algorithm": self.algorithm.name.lower(),
            "counts": self.counts(),
            "passes": [{"name": p.stage.value, "when": p.when, "why": p.reason} for p in self.passes],
            "images": [{"image": i.label, "level": i.level, "width": i.width, "height": i.height, "why": i.reason,
                        **({"traversal": self.traversal(i).name.lower()} if self.algorithm == Algorithm.AUTO else {})}
                       for i in self.images],
            "skipped": [{"reflector": s.reflector, "object": s.target, "why": s.reason} for s in self.skipped],
            "variants": [{"stages": list(v.key[0]), "defines": dict(v.key[1]), "why": v.reason} for v in self.variants],
            "graph": [{"pass": n.stage.value, "reads": list(n.reads), "writes": list(n.writes)} for n in self.graph],
            "memory_bytes": dict(self.memory),
            "samples": self.samples,
            "planes": {"analytic": list(self.analytic_planes), "meshes": list(self.mesh_planes)},
            "objects": [{"name": o.name, "label": o.label} for o in self.objects],
            "limits": list(self.limits),
            "ignored": {file: list(names) for file, names in self.ignored},
        }

    def format(self) -> str:
        lines = [f"plan of {self.scene} ({self.method.option}"
                 + (f", {self.algorithm.name.lower()} algorithm" if METHODS[self.method].marches_depth_images else "") + ")"]
        lines += self.planes_lines()
        lines.append(f"passes ({len(self.passes)}):")
        lines += [f"  {p.stage.value:<28} {p.when}\n  {'':<28} why: {p.reason}" for p in self.passes]
        lines.append(f"images ({len(self.images)}):")
        for image in self.images:
            picked = f", {self.traversal(image).name.lower()} (auto)" if self.algorithm == Algorithm.AUTO else ""
            lines.append(f"  {image.label}: {image.width}x{image.height}{picked} ({image.reason})")
        if self.skipped:
            lines.append(f"skipped ({len(self.skipped)}):")
            lines += [f"  {s.reflector} -> {s.target}: {s.reason}" for s in self.skipped]
        lines.append(f"shader variants ({len(self.variants)}):")
        lines += [f"  {v.name}\n      why: {v.reason}" for v in self.variants]
        lines.append(format_graph(self.graph))
        lines += self.parts_lines()
        lines += self.ignored_lines()
        lines.append(self.samples_line())
        total = sum(self.memory.values())
        parts = ", ".join(f"{name} {size / 2**20:.2f}" for name, size in self.memory.items())
        lines.append(f"memory: {total / 2**20:.2f} MiB" + (f" ({parts})" if parts else ""))
        if BAKE_DEPTH_BUFFER in self.memory:
            lines.append(f"  the {BAKE_DEPTH_BUFFER} is let go at the first frame that bakes nothing (a still scene's "
                         "second) and made again for the next bake")
        if self.textures:
            lines.append(f"  {self.textures}")
        lines.append("limits (what this scene uses of each; scene/limits.py says why each exists):")
        lines += [f"  {line}" for line in self.limits]
        return "\n".join(lines)


def _names(items: list[ObjectGeometry]) -> str:
    return ", ".join(f'"{item.object.name}"' for item in items)


#: The names a plan line lists before it says how many more there are.
LISTED_NAMES = 4


def _listed(names: Sequence[str]) -> str:
    """`count` ("a", "b", ... and k more): a line stays a line in a scene of a hundred planes."""
    shown = ", ".join(f'"{name}"' for name in names[:LISTED_NAMES])
    more = f" and {len(names) - LISTED_NAMES} more" if len(names) > LISTED_NAMES else ""
    return f"{len(names)} ({shown}{more})"


def check_stand_in(scene: Scene, method: Method, reflectors: list[ObjectGeometry],
                   reflected: list[ObjectGeometry]) -> None:
    """The limits of `method`'s stand-in for `reflected` in `reflectors` (scene/limits.py): the
    plan checks them, and the renderer again before it switches to another method."""
    check_method(scene, METHODS[method], len(reflectors), sum(len(g.local_mesh.indices) for g in reflected))
    if METHODS[method].flat_mirrors:
        check_flat_mirrors(scene, reflectors)


def _builds_pyramids(method: Method, algorithm: Algorithm, images: Sequence[PlannedImage]) -> bool:
    """Does a frame march some of `images` hierarchically (and so need their pyramids)?"""
    sizes = {(image.width, image.height) for image in images}  # (a thousand images share a few sizes)
    return METHODS[method].marches_depth_images and any(
        image_algorithm(algorithm, width, height) == Algorithm.HIERARCHICAL for width, height in sizes)


def _builds_colour_mips(scene: Scene, method: Method, images: Sequence[PlannedImage]) -> bool:
    """Does a glossy mirror read the baked images' colours prefiltered (their colour mips)? Not
    the hybrid method's: its exact triangles have no prefiltered colours, and the mirror shader
    would pass 16 samplers with the mips beside its BVH (tests/test_bindings.py)."""
    return (scene.has_rough_mirrors and issubclass(METHODS[method].stand_in, BakedImages) and bool(images)
            and not METHODS[method].names_triangles)


def plan_render(scene: Scene, method: Method = Method.DEPTH, algorithm: Algorithm = Algorithm.OPTIMIZED,
                geometry: list[ObjectGeometry] | None = None, reflection_data: bool = False,
                count_samples: bool = False, world: World | None = None) -> RenderPlan:
    """The plan of `scene` drawn with `method` (and, for depth images, `algorithm`); a renderer's
    `reflection_data` and `count_samples` add to its memory. Every limit the renderer would meet
    is checked here, before it makes any GL object: a SceneError says which. `world` (the scene's
    objects where they are, world.py) keeps what can reach what between plans."""
    check_scene(scene)  # already checked by the loader; again for scenes built in code
    world = world if world is not None else World(scene, geometry)
    geometry = world.geometry
    for item in geometry:
        if isinstance(item.object.shape, MeshShape):
            check_model_reach(scene, item.index, item.local_mesh)
            check_model_uvs(scene, item.index, item.local_mesh)
    mirrors = [g for g in geometry if g.object.is_mirror]
    glass = [g for g in geometry if g.object.is_glass]
    reflectors = [g for g in geometry if g.object.is_reflector]
    diffuse = [g for g in geometry if not g.object.is_reflector and not g.object.is_blended]
    blended = [g for g in geometry if not g.object.is_reflector and g.object.is_blended]
    reflected = world.reflected_objects  # the planes past the exact ones among them
    check_stand_in(scene, method, reflectors, reflected)
    passes: list[PlannedPass] = []
    variants: dict[ProgramKey, tuple[str, Pass]] = {}

    def variant(stage: Pass, stages: tuple[str, ...], defines: Defines | None, reason: str) -> None:
        """A program the `stage` node compiles (and `reason`, what it is for)."""
        variants.setdefault(program_key(stages, defines), (reason, stage))

    if scene.has_shadows:
        lights = [f"lights[{i}] ({scene.lights[i].shadows})" for i in scene.shadowed_lights]
        passes.append(PlannedPass(Pass.SHADOW_MAPS, f"{', '.join(lights)} cast shadows"))
        variant(Pass.SHADOW_MAPS, SHADOW_MAP_PROGRAM, shadow_map_defines(scene),
                "shadow maps: the casters' depth from each shadowed light")
        casters = set(scene.shadow_casters)
        for light in scene.shadowed_lights:  # refuses a light among its casters, as the shadow pass would
            fit_shadow_camera(scene, light, [g for g in geometry if g.object in casters], scene.render.shadow_resolution)

    if deforming_parts(scene):
        deform_reason, deform_programs = deform_plan(scene, METHODS[method].traces is not None and
                                                     any(g.object.deforms and g.object.moves for g in reflected))
        passes.append(PlannedPass(Pass.DEFORM, deform_reason))
        for compute, compute_defines, why in deform_programs:
            variant(Pass.DEFORM, compute, compute_defines, why)

    if uses_environment_lighting(scene):
        passes.append(PlannedPass(Pass.ENVIRONMENT_LIGHTING, environment_lighting_reason(scene)))
        variant(Pass.ENVIRONMENT_LIGHTING, PREFILTER_PROGRAM, None,
                f"the sky's specular through GGX lobes, one level a draw ({IBL_SAMPLES} samples a texel)")

    images: list[PlannedImage] = []
    image_plans: dict[int, list[ImagePlan]] = {}
    skipped: list[SkippedImage] = []
    shown_in_bounces: set[bool] = set()  # is_glass of the reflectors bounce images show
    stand_in = METHODS[method].stand_in
    if reflectors:
        shown = reflected + (reflectors if scene.render.max_bounces > 1 else [])
        for reflector, row in zip(reflectors, world.reaches(reflectors, shown), strict=True):
            skipped += [SkippedImage(reflector.object.name, target.object.name, why.value)
                        for target, why in zip(shown, row, strict=True) if why is not Reach.REACHABLE and target is not reflector]
        if issubclass(stand_in, BakedImages):
            # Planned once per stand-in and render settings: an algorithm or a method sharing the
            # stand-in plans the same images (World.planned).
            planned = image_plans = world.planned(
                ("images", stand_in, scene.render),
                lambda: stand_in.plan_images(scene, reflectors, reflected, world.reaches))
            by_index = {g.index: g for g in geometry}
            count = sum(len(plans) for plans in planned.values())
            asked = None if scene.render.auto_resolution else int(scene.render.impostor_resolution)
            for index, plans in planned.items():
                for face, (targets, camera, level) in enumerate(plans):
                    label = image_label(by_index[index], targets, level, None if stand_in.per_object else face)
                    reason = (f"bounce {level}: shows its reflections of bounce {level - 1}" if level
                              else "a reflected object it may show" if stand_in.per_object
                              else f"a cube-map face showing {_names(list(targets))}")
                    if asked is not None and camera.width < asked and stand_in.per_object:
                        reason += (f"; {camera.width}^2, not {asked}^2: {count} images within render.image_memory = "
                                   f"{scene.render.image_memory} MiB")
                    images.append(PlannedImage(label, level, camera.width, camera.height, reason))
                    if level:
                        shown_in_bounces.add(targets[0].object.is_glass)
        noun = f"{stand_in.image_noun}s" if issubclass(stand_in, (BakedImages, SeenFromEye)) else "a BVH of their triangles"
        also = ", and a BVH of their triangles for the rays those cannot answer" if METHODS[method].names_triangles else ""
        seen_from_eye = METHODS[method].seen_from_eye
        lazily = issubclass(stand_in, BakedImages) and bool(images) and stand_in.bakes_lazily(scene, len(images))
        when = ("; each baked when a frame's reflected rays may first enter it (a pass over the mirror pixels finds "
                "which; the frame is the one of baking them all), into the atlas's next free tile: the atlas makes "
                "its rows as they fill, up to the memory below" if lazily else "")
        passes.append(PlannedPass(Pass.STAND_IN if seen_from_eye is None else Pass.EYE_IMAGES,
                                  f"{_names(reflectors)} may reflect {plural(len(reflected), 'object')}, "
                                  f"seen through {noun}{also}{when}"))
        for stages, defines, why in seen_from_eye.variants(scene) if seen_from_eye is not None else []:
            variant(Pass.EYE_IMAGES, stages, defines, why)
        if lazily and issubclass(stand_in, BakedImages):
            variant(Pass.STAND_IN, ENTERED_PROGRAM,
                    entered_defines(depth_image_capacity(len(scene.objects)), stand_in.lists_over_bounds),
                    f"which {stand_in.image_noun}s a frame's reflected rays may enter, before the bake")
        if issubclass(stand_in, BakedImages) and images:
            ids = stand_in.keeps_triangle_ids
            with_ids = ", with the triangle each sample shows" if ids else ""
            checker = has_checker(g.object for g in reflected)
            variant(Pass.STAND_IN, DIFFUSE_PROGRAM,
                    diffuse_defines(scene, stand_in.second_layer != SecondLayer.NONE, ids, checker=checker),
                    f"{stand_in.image_noun}s: the reflected objects shaded into them{with_ids}")
            if stand_in.keeps_back_colors:
                variant(Pass.STAND_IN, DIFFUSE_PROGRAM, diffuse_defines(scene, True, ids, back_layer=True, checker=checker),
                        f"depth images: the back layer's colour and depth (a ray may come in through it){with_ids}")
            if stand_in.keeps_beyond:
                variant(Pass.STAND_IN, BEYOND_PROGRAM, alpha_mask_defines(scene), "depth images: where a second solid run begins (the space before it "
                        "is seen empty)")
        if shown_in_bounces:
            passes.append(PlannedPass(Pass.BOUNCES, f"render.max_bounces = {scene.render.max_bounces}: reflectors "
                                      "show each other's reflections"))
            variant(Pass.BOUNCES, BACK_FACE_PROGRAM, alpha_mask_defines(scene),
                    "a reflector drawn into another's depth image: its back-face layer")
            for shown_glass in sorted(shown_in_bounces):
                variant(Pass.BOUNCES, REFLECTOR_PROGRAM, reflector_defines(scene, bounce_defines(), shown_glass),
                        f"a {'glass' if shown_glass else 'mirror'} drawn into another reflector's depth image")
            if True in shown_in_bounces:
                variant(Pass.BOUNCES, INTERIOR_PROGRAM, None, "glass seen in a mirror: its interior from the mirror's centre")
        if _builds_pyramids(method, algorithm, images):
            auto = f" (auto: the images of sides >= {HIERARCHICAL_MIN_SIDE})" if algorithm == Algorithm.AUTO else ""
            passes.append(PlannedPass(Pass.PYRAMIDS, f"the hierarchical algorithm skips spans by min/max depth{auto}"))
            variant(Pass.PYRAMIDS, (PYRAMID_PROGRAM,), None, "the hierarchical algorithm's min/max pyramid")
        if _builds_colour_mips(scene, method, images):
            rough = _names([g for g in mirrors if g.object.material.is_rough])  # type: ignore[union-attr]
            passes.append(PlannedPass(Pass.COLOUR_MIPS, f"glossy mirrors ({rough}) read the images' colours "
                                      "prefiltered at their cones' footprints"))
            variant(Pass.COLOUR_MIPS, (COLOUR_MIPS_PROGRAM,), None, "the baked images' colour mips")

    passes.append(PlannedPass(Pass.ENVIRONMENT, f"the {scene.environment.type} sky behind everything"))
    variant(Pass.ENVIRONMENT, ENVIRONMENT_PROGRAM, environment_defines(scene),
            "the sky" + (" (ENVIRONMENT_MAP: an equirect image)" if scene.environment.is_map else "")
            + (" (ENVIRONMENT_LIGHTING: its texture holds the prefiltered levels below the image)"
               if uses_environment_lighting(scene) else ""))
    if diffuse:
        passes.append(PlannedPass(Pass.DIFFUSE, f"{plural(len(diffuse), 'object')} with diffuse materials"))
        shadows = " (SHADOWS: a light casts shadows)" if scene.has_shadows else ""
        surface = frame_surface(method, bool(reflectors))
        written = " (WRITE_SURFACE: the position and object seen, for screen-space reflections)" if surface else ""
        if any(not g.object.moves for g in diffuse):
            variant(Pass.DIFFUSE, DIFFUSE_PROGRAM, diffuse_defines(scene, False, instanced=True, write_surface=surface),
                    "diffuse objects in the frame, those that do not move in one batch (INSTANCED)" + shadows + written)
        if any(g.object.moves for g in diffuse):
            variant(Pass.DIFFUSE, DIFFUSE_PROGRAM, diffuse_defines(scene, False, write_surface=surface),
                    "diffuse objects that move, one by one" + shadows + written)
    if glass:
        passes.append(PlannedPass(Pass.GLASS_INTERIORS, f"glass ({_names(glass)}): where refracted rays leave"))
        variant(Pass.GLASS_INTERIORS, INTERIOR_PROGRAM, None, "glass: its front and back faces from the eye")
    if reflectors:
        kinds = [f"mirrors ({_names(mirrors)})"] * bool(mirrors) + [f"glass ({_names(glass)})"] * bool(glass)
        passes.append(PlannedPass(Pass.REFLECTORS, " and ".join(kinds)))
        variant(Pass.REFLECTORS, SURFACE_PROGRAM, None, "the reflectors' surfaces, for the deferred mirror shader")
        defines = {**reflection_defines(METHODS[method].defines(algorithm), reflection_data, count_samples), **DEFERRED,
                   **glossy_defines(scene)}
        if mirrors:
            variant(Pass.REFLECTORS, DEFERRED_REFLECTOR_PROGRAM, reflector_defines(scene, defines, False),
                    f"mirrors, {method.option} method, deferred")
        if glass:
            variant(Pass.REFLECTORS, DEFERRED_REFLECTOR_PROGRAM, reflector_defines(scene, defines, True),
                    f"glass (GLASS), {method.option} method, deferred")
    if blended:
        passes.append(PlannedPass(Pass.TRANSPARENT, f"{plural(len(blended), 'object')} with blended materials "
                                  f"({_names(blended)}: glTF's alphaMode BLEND), over the frame back to front: one "
                                  f"draw call each (two for a closed solid), no memory"))
        variant(Pass.TRANSPARENT, DIFFUSE_PROGRAM, diffuse_defines(scene, False, transparent=True),
                "blended objects over the frame (ALPHA_BLEND: their alpha out)" + (
                    " (SHADOWS: a light casts shadows)" if scene.has_shadows else ""))
    memory = plan_memory(scene, method, algorithm, world, images, True in shown_in_bounces, reflection_data,
                         count_samples, image_plans)
    ordered = tuple(sorted(passes, key=lambda p: in_order(p.stage)))
    programs = {stage: tuple(key for key, (_, of) in variants.items() if of is stage) for stage in Pass}
    eye = METHODS[method].seen_from_eye
    eye_reads = (() if eye is None else eye.reads) + (("shadow maps",) if eye is not None and eye.shades
                                                      and scene.has_shadows else ())
    graph = build_graph([(p.stage, p.reason) for p in ordered], programs, METHODS[method].outputs,
                        _builds_pyramids(method, algorithm, images), (eye_reads, frame_surface(method, bool(reflectors))))
    return RenderPlan(scene.source, method, algorithm, ordered, tuple(images), tuple(skipped),
                      tuple(PlannedVariant(k, r) for k, (r, _) in variants.items()), memory, image_plans, graph,
                      scene.render.samples, texture_layout(scene).summary() if scene.textures else "",
                      tuple(o.name for o in scene.analytic_planes), tuple(o.name for o in scene.mesh_planes),
                      tuple(PlannedObject(obj.name, scene.object_label(i), obj.origin is not None)
                            for i, obj in enumerate(scene.objects)),
                      plan_limits(scene, method, image_plans, memory, reflected), ignored_in_files(scene))


def environment_lighting_reason(scene: Scene) -> str:
    """Why the prefilter runs and what it costs (ibl.py's rule: an equirect sky and a
    metallic-roughness material; nothing of it otherwise)."""
    pbr = sum(isinstance(m, MetallicRoughnessMaterial) for m in scene.materials)
    (first, _), (last, _) = level_size(1), level_size(IBL_LEVELS)
    return (f"{plural(pbr, 'metallic-roughness material')} lit by the equirect sky (ENVIRONMENT_LIGHTING): its "
            f"specular through GGX lobes of roughness {1 / IBL_LEVELS:g} to 1 into {IBL_LEVELS} levels ({first} to {last} "
            f"texels wide) below its image, {IBL_SAMPLES} filtered reads a texel ({prefilter_reads() / 1e6:.1f} M in all, "
            f"about {PREFILTER_SECONDS * 1e3:.0f} ms on llvmpipe: tools/prefilter_cost.py), its irradiance as nine "
            "spherical-harmonic terms (numpy, in the Lights block); once per sky, not per frame (reading a mipmapped "
            f"copy of the sky, {_source_bytes(scene) / 2**20:.2f} MiB, made for it and let go)")


def _source_bytes(scene: Scene) -> int:
    """The prefilter's transient source: the sky as RGB32F with its whole mip chain."""
    image = scene.environment.image
    if image is None:
        return 0
    height, width = image.shape[:2]
    levels = max(width, height).bit_length()
    return sum(max(1, width >> k) * max(1, height >> k) * 12 for k in range(levels))


def ignored_in_files(scene: Scene) -> tuple[tuple[str, tuple[str, ...]], ...]:
    """(file, what it uses that the loader does not implement) for each glTF file of the scene
    that uses some, in the order of its first object."""
    ignored = {obj.origin.file: obj.origin.ignored for obj in scene.objects if obj.origin is not None}
    return tuple((file, names) for file, names in ignored.items() if names)


def material_kinds(scene: Scene) -> str:
    """What the scene's materials call for, for `plan`: the metallic-roughness shading (the
    METALLIC_ROUGHNESS variant of every shading program) and the alpha mask (ALPHA_MASK) only where
    a material has them, so a scene without pays for neither."""
    pbr = [m for m in scene.materials if isinstance(m, MetallicRoughnessMaterial)]
    if not pbr:
        return ""
    masked = sum(m.masked for m in pbr)
    maps = sum(any(t is not None for t in m.maps) for m in pbr)
    normal_maps = sum(m.normal_texture is not None for m in pbr)
    parts = [f"{len(pbr)} metallic-roughness (their shading compiled in: METALLIC_ROUGHNESS)"]
    if uses_environment_lighting(scene):
        parts.append("lit by the equirect sky in place of the constant ambient (ENVIRONMENT_LIGHTING)")
    if maps:
        parts.append(f"{maps} with metallic-roughness, occlusion, emissive or normal maps")
    if normal_maps:
        parts.append(f"{normal_maps} normal-mapped (the shading normal turned in the tangents' frame: NORMAL_MAP)")
    if masked:
        parts.append(f"{masked} alpha-masked (every surface pass cuts them: ALPHA_MASK)")
    blended = sum(m.blend for m in pbr)
    if blended:
        parts.append(f"{blended} blended (the transparent pass and traced rays composite them: ALPHA_BLEND; baked "
                     f"images and shadow maps hold them where alpha >= {BLEND_IMAGE_CUTOFF}: ALPHA_MASK)")
    return ", of which " + ", ".join(parts)


#: What each glTF vertex attribute past the UVs is for, for `plan`.
ATTRIBUTE_USES = {"uvs1": "TEXCOORD_1 (a texture reads the second UV set: TEXCOORD_1)",
                  "colors": "COLOR_0 (vertex colours multiply the base colour: VERTEX_COLORS)",
                  "tangents": "tangents (a normal map turns the shading normal: NORMAL_MAP)"}


def mesh_attributes_line(scene: Scene, attributes: tuple[str, ...], traced: bool) -> str:
    """`plan`'s line on the glTF vertex attributes the scene's surfaces read (uniforms.mesh_attributes),
    each compiled in only where used, and what they cost: floats a vertex in the mesh buffers (every
    vertex of the scene carries them) and texels a triangle in the BVH."""
    floats = sum(EXTRA_ATTRIBUTES[name] for name in attributes)
    made = sum(1 for o in scene.objects if isinstance(o.shape, GltfShape) and o.shape.mesh.tangents is not None)
    bvh = (f", {triangle_texel_layout(attributes)['TRIANGLE_TEXELS'] - BVH_TRIANGLE_TEXELS} more texels a triangle in "
           "the BVH" if traced else "")
    return (f"vertex attributes: {', '.join(ATTRIBUTE_USES[name] for name in attributes)}; {4 * floats} more bytes a "
            f"vertex in the mesh buffers{bvh}" + (f"; {made} part(s) with tangents (the file's, or generated: "
                                                  "MikkTSpace, scene/tangents.py)" if "tangents" in attributes else ""))


def plan_limits(scene: Scene, method: Method, image_plans: dict[int, list[ImagePlan]], memory: dict[str, int],
                reflected: list[ObjectGeometry]) -> tuple[str, ...]:
    """One line per limit the scene meets (scene/limits.py's table): what it uses of a fixed cap,
    or, where none is left, which memory or GL figure bounds it and where that is checked."""
    render, spec = scene.render, METHODS[method]
    lines = [f"lights: {len(scene.lights)} of {MAX_LIGHTS} (a uniform array)",
             f"planes intersected exactly: {len(scene.analytic_planes)} of {MAX_ANALYTIC_PLANES} "
             "(the largest; any others are drawn as meshes)",
             f"render.max_bounces: {render.max_bounces} of {MAX_BOUNCES}"]
    capacity = depth_image_capacity(len(scene.objects))
    if issubclass(spec.stand_in, BakedImages) and image_plans:
        most = max(len(plans) for plans in image_plans.values())
        if capacity <= DEPTH_IMAGE_BLOCK_RECORDS:
            table = f"up to {DEPTH_IMAGE_BLOCK_RECORDS} records in a uniform block (GL 3.3), past it a storage buffer (GL 4.3)"
        else:
            found = (", the images found through lists of candidates by ray (made at render, not in the memory above)"
                     if lists_images(capacity) else "")
            table = f"a storage buffer of {capacity} records (GL 4.3){found}"
        lines.append(f"{spec.stand_in.image_noun}s of one mirror: {most} (any number: {table})")
        images = memory.get(spec.stand_in.image_noun + "s", 0) + memory.get(BAKE_DEPTH_BUFFER, 0)
        lines.append(f"{spec.stand_in.image_noun}s' memory: {images / 2**20:.2f} MiB of render.image_memory = "
                     f"{render.image_memory} MiB (past it every image is made smaller)")
    if "BVH" in memory:
        rows = -(-memory["BVH"] // (16 * BVH_TEXTURE_WIDTH))
        lines.append(f"traced objects: {len(reflected)} (any number: a two-level BVH of about {rows} float-texture rows of "
                     f"{BVH_TEXTURE_WIDTH} texels, at most GL_MAX_TEXTURE_SIZE rows, checked at render)")
    if spec.names_triangles:
        triangles = sum(len(g.local_mesh.indices) for g in reflected)
        lines.append(f"reflected triangles: {triangles} of {MAX_NAMED_TRIANGLES} (a float32 depth-image sample names one)")
    deforming = [obj for obj in scene.objects if obj.deforms]
    if deforming:
        refit = "the BVH refitted" if spec.traces is not None else "no BVH to refit"
        rebake = "the images that show them re-baked" if spec.bakes_images else "no images to re-bake"
        lines.append(f"deforming glTF parts (skins, morph targets): {len(deforming)}, made again at every time that "
                     f"moves them (the {Pass.DEFORM.value} pass: on the GPU where it can, on the CPU for the world "
                     f"too); {rebake}, {refit} (tools/deforming_cost.py measures each)")
    where = (f"a storage buffer (past {MATERIAL_BLOCK_RECORDS}, GL 4.3), within memory" if materials_in_storage(scene)
             else f"a uniform block (a storage buffer past {MATERIAL_BLOCK_RECORDS}), within GL_MAX_UNIFORM_BLOCK_SIZE "
                  "(16 KiB at GL's least), checked at render")
    lines.append(f"materials: {len(scene.materials)}{material_kinds(scene)} (any number: one record of "
                 f"{MATERIAL.dtype.itemsize} bytes each in {where}; and a copy, a record every "
                 f"{DRAWN_MATERIAL_STRIDE} bytes, of which a draw of one object binds its own)")
    if scene.textures:
        lines.append(f"image textures: {len(scene.textures)} (any number: in texture arrays, within GL_MAX_TEXTURE_SIZE, "
                     "GL_MAX_ARRAY_TEXTURE_LAYERS and GL_MAX_UNIFORM_BLOCK_SIZE, checked at render)")
    attributes = mesh_attributes(scene)
    if attributes:
        lines.append(mesh_attributes_line(scene, attributes, spec.traces is not None))
    lines.append(f"memory: {sum(memory.values()) / 2**20:.2f} MiB, against the driver's or --max-memory's budget "
                 "(checked at render)")
    return tuple(lines)


def frame_surface(method: Method, reflectors: bool) -> bool:
    """Does the frame's diffuse pass write the eye's surface (SSR's march reads it)?"""
    eye = METHODS[method].seen_from_eye
    return reflectors and eye is not None and eye.reads_frame


def plan_memory(scene: Scene, method: Method, algorithm: Algorithm, world: World,
                images: Sequence[PlannedImage], bounce_glass: bool = False, reflection_data: bool = False,
                count_samples: bool = False, image_plans: dict[int, list[ImagePlan]] | None = None) -> dict[str, int]:
    """Bytes of every GL texture, renderbuffer and buffer a Renderer makes for the plan's first
    frame, by allocation (tests/test_plan_memory.py counts what the renderer really makes), for
    `world`'s objects: `images` are the plan's baked images (`image_plans` their cameras, by
    reflector), `bounce_glass` whether one shows glass in a mirror.
    The renderer's own options add outputs: `reflection_data` and `count_samples`."""
    width, height = scene.render.size
    geometry = world.geometry
    memory = {"frame colour and depth": width * height * (16 + 4),
              "meshes": GpuMeshes.bytes_for(world.meshes, mesh_attributes(scene)),  # the eye's levels too
              "lights and planes": SceneBlocks.BYTES, "materials": materials_bytes(scene),
              "materials, a record a draw": drawn_materials_bytes(scene)}
    # The diffuse pass's batch of the objects that do not move (gpu/batches.py; a context without
    # OpenGL 4.3 draws them one by one, and makes none), as the eye draws them.
    still = [g for g in world.eye_drawn if not g.object.moves]
    if still:
        memory["object batch"] = batch_bytes(still)
    if scene.textures:
        memory["textures"] = GpuTextures.bytes_for(scene)
    if reflection_data:
        memory["reflection outputs"] = width * height * 16 * REFLECTION_OUTPUTS
    if count_samples:
        memory["sample counts"] = width * height * 4
    if any(g.object.is_reflector for g in geometry):
        memory["reflector surfaces"] = Surfaces.bytes_for((width, height))
    if scene.environment.is_map:
        memory["environment map"] = environment_map_bytes(scene)
    if scene.has_shadows:
        memory["shadow maps"] = (shadow_map_bytes(len(scene.shadowed_lights), scene.render.shadow_resolution)
                                 + MAX_LIGHTS * DEPTH_IMAGE_DTYPE.itemsize)
    glass = [g for g in geometry if g.object.is_glass]
    if glass:
        memory["glass interiors"] = len(glass) * (interior_bytes(max(scene.render.size)) + DEPTH_IMAGE_DTYPE.itemsize)
    reflectors = [g for g in geometry if g.object.is_reflector]
    reflected = [g for g in geometry if not g.object.is_reflector and g.index not in scene.analytic_plane_indices]
    stand_in = METHODS[method].stand_in
    if not reflectors:
        return memory
    if issubclass(stand_in, BakedImages):
        side = max((max(i.width, i.height) for i in images), default=1)
        memory[stand_in.image_noun + "s"] = ImpostorAtlas.bytes_for(
            len(images), side, stand_in.second_layer != SecondLayer.NONE, stand_in.keeps_triangle_ids,
            stand_in.keeps_back_colors, stand_in.keeps_beyond, bake_buffer=False)
        memory[BAKE_DEPTH_BUFFER] = ImpostorAtlas.bake_buffer_bytes(len(images), side)
        # The coarser levels its images draw their objects at (lod.py: loaded at the first bake).
        levels = bake_meshes([(plan.camera, plan.targets) for plans in (image_plans or {}).values() for plan in plans
                              if not plan.level]) if not stand_in.keeps_triangle_ids else []
        if levels:
            memory["bake levels"] = GpuMeshes.bytes_for(levels, mesh_attributes(scene))
        if stand_in.bakes_lazily(scene, len(images)):  # methods/entered_images.py
            memory["images entered by a frame's rays"] = EnteredImages.bytes_for(
                (width, height), depth_image_capacity(len(scene.objects)), len(reflectors))
        # Each mirror's table: its records and, in a scene of many objects, the lists of candidate
        # images by ray past them (methods/image_cells.py); the bounce images' tables likewise.
        tables, bounce_tables = stand_in.table_bytes(scene, reflectors, image_plans or {})
        memory[stand_in.image_noun + " records"] = tables
        marches = METHODS[method].marches_depth_images
        if marches and scene.render.max_bounces > 1 and len(reflectors) > 1:  # methods/bounces.py
            interior = interior_bytes(side) + DEPTH_IMAGE_DTYPE.itemsize if bounce_glass else 0
            memory["bounce baking"] = ImpostorAtlas.bytes_for(1, side, True) + side * side * 8 + bounce_tables + interior
        if _builds_pyramids(method, algorithm, images):
            memory["depth pyramids"] = pyramid_bytes(PyramidLayout.of_grid(*atlas_grid(len(images)), side), len(images))
        if _builds_colour_mips(scene, method, images):
            memory["colour mips"] = pyramid_bytes(PyramidLayout.of_grid(*atlas_grid(len(images)), side), len(images))
    eye = METHODS[method].seen_from_eye
    if eye is not None:
        memory[eye.image_plural] = eye.bytes_for((width, height), len(reflectors), scene.has_rough_mirrors)
    traced = METHODS[method].traces
    if traced is not None:
        memory["BVH"] = traced.bytes_for(scene, reflected, named=METHODS[method].names_triangles)
    return memory

