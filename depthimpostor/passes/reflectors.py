"""Mirrors and glass: each pixel's reflected ray (and, for glass, its refracted one) traced in GLSL
against what the method stands in for the reflected objects (depth images, or the real
triangles), the analytic planes and the environment."""

from __future__ import annotations

from typing import Protocol

import moderngl
import numpy as np

from ..gpu.bindings import TextureUnit
from ..gpu.gl_state import NO_DEPTH_TEST, RasterState, Winding, raster_state
from ..constants import Algorithm, Method, depth_image_capacity, depth_image_defines
from ..geometry import ObjectGeometry
from ..ppc import PPC
from ..scene.model import GlassMaterial, MirrorMaterial, Scene
from ..gpu.shaders import ProgramCache
from ..oracles.truth import MIRROR_BACKING_ALBEDO
from .glass import GlassInterior, interior_camera, pixel_angle
from ..methods.atlas import BAKE_CULLS_FRONT_FACES
from ..gpu.meshes import GpuMeshes
from ..gpu.uniforms import blend_defines, environment_defines, shading_defines, write
from ..node import Frame, GraphFacts, Node, Pass


class Surfaces(Protocol):
    """The frame's reflector surfaces (targets.py): float position and normal targets sharing the
    frame's depth, cleared before the reflectors are drawn into them."""

    framebuffer: moderngl.Framebuffer

    def next_frame(self) -> int: ...

    def use(self) -> None: ...


class ReflectedObjects(Protocol):
    """A method's stand-in for the reflected objects (ImpostorPass, CubeMapPass, BillboardPass,
    TrianglePass, SimplifiedPass): what it bakes, and what it binds for the mirror shader once per
    draw and per mirror."""

    @property
    def bytes(self) -> int: ...

    def describe(self) -> str: ...

    def bake(self) -> int:
        """Render what the method renders ahead of the mirrors; returns the draw calls."""
        ...

    def bind(self, program: moderngl.Program) -> None: ...

    def bind_reflector(self, program: moderngl.Program, mirror: ObjectGeometry) -> None: ...

    def release(self) -> None: ...


#: The colour outputs the reflection data adds (ray origin, ray direction, hit position, normal).
REFLECTION_OUTPUTS = 4


def reflection_defines(
    method_defines: dict[str, int], write_reflection_data: bool = False, count_samples: bool = False
) -> dict[str, int]:
    """The mirror shader's variant: the method's own (MethodSpec.defines), and the outputs. The
    counting variant (the benchmark's) writes each ray's samples to the output after the others."""
    defines = dict(method_defines)
    if write_reflection_data:
        defines["WRITE_REFLECTION_DATA"] = 1
    if count_samples:
        defines["COUNT_SAMPLES"] = 1 + (REFLECTION_OUTPUTS if write_reflection_data else 0)
    return defines


REFLECTOR_PROGRAM = ("mesh.vert", "reflector.frag")
#: The frame's reflectors, deferred: their surfaces rasterized first (SURFACE_PROGRAM), then the
#: mirror shader run over each reflector's screen rectangle on those (DEFERRED_REFLECTOR_PROGRAM
#: with DEFERRED). The bounce bakes draw reflectors into depth images forward (REFLECTOR_PROGRAM).
SURFACE_PROGRAM = ("mesh.vert", "reflector_surface.frag")
DEFERRED_REFLECTOR_PROGRAM = ("screen_rect.vert", "reflector.frag")
DEFERRED = {"DEFERRED": 1}


def reflector_defines(scene: Scene, defines: dict[str, int], glass: bool) -> dict[str, int]:
    """The mirror shader's variant for mirrors or (GLASS) for glass, under the scene's lights and environment."""
    # PLANE_COUNT: a constant loop bound (lib/reflected_scene.glsl): the scene chooses at most
    # MAX_ANALYTIC_PLANES planes to intersect exactly (Scene.analytic_plane_indices).
    planes = len(scene.analytic_planes)
    return {**defines, **shading_defines(scene), **environment_defines(scene), "PLANE_COUNT": planes,
            **depth_image_defines(depth_image_capacity(len(scene.objects))),
            **({"GLASS": 1} if glass else {}), **blend_defines(scene, True)}


def glossy_defines(scene: Scene) -> dict[str, int]:
    """The frame's mirror variant in a scene with a rough mirror (GLOSSY: a cone about each
    reflected ray, lib/glossy.glsl); none otherwise, so that a perfect mirror's frame is the very
    program it always was. Reflectors drawn into other reflectors' images stay sharp."""
    return {"GLOSSY": 1} if scene.has_rough_mirrors else {}


def reflector_roughness(item: ObjectGeometry) -> float:
    """u_roughness of a reflector: a mirror's roughness, 0 for glass (a perfect surface)."""
    material = item.object.material
    return material.roughness if isinstance(material, MirrorMaterial) else 0.0


def bounce_defines() -> dict[str, int]:
    """The variant drawing a reflector into another's depth image (render.max_bounces > 1): the
    optimized march, since a bake's images are the same whatever the frame's algorithm."""
    return {"METHOD": int(Method.DEPTH), "ALGORITHM": int(Algorithm.OPTIMIZED), "WRITE_DEPTH_IMAGE": 1}


def reflector_program(programs: ProgramCache, scene: Scene, defines: dict[str, int], glass: bool,
                      stages: tuple[str, str] = REFLECTOR_PROGRAM) -> moderngl.Program:
    """The mirror shader's variant for mirrors or (GLASS) for glass (the cache writes the scene's
    lights and analytic planes into it): the bounce bakes', or (DEFERRED_REFLECTOR_PROGRAM) the frame's."""
    program = programs.get(*stages, reflector_defines(scene, defines, glass))
    write(program, "u_backing_albedo", MIRROR_BACKING_ALBEDO)
    return program


def reflector_tint(item: ObjectGeometry) -> tuple[float, float, float]:
    """u_tint of a mirror or a glass object: what it multiplies the light it reflects (a mirror)
    or transmits (glass) by."""
    material = item.object.material
    if not isinstance(material, (MirrorMaterial, GlassMaterial)):
        raise TypeError(f"object {item.object.name!r} is neither a mirror nor glass")
    return material.tint


#: GL's front_face that makes a mirror's outward (counter-clockwise) faces GL's front faces, for
#: reflector.frag's gl_FrontFacing (a mirror's back is its backing): every PPC projection, the
#: frame's and a depth image's alike, puts image row 0 at window y = 0 and so turns them clockwise.
OUTWARD_FRONT_FACE: Winding = "cw" if BAKE_CULLS_FRONT_FACES == "back" else "ccw"


#: Reflectors are drawn with OUTWARD_FRONT_FACE (their shader tells a mirror's front from its
#: backing by gl_FrontFacing); the other passes' culling (BAKE_CULLS_FRONT_FACES) is set for GL's
#: default winding.
REFLECTORS = RasterState(front_face=OUTWARD_FRONT_FACE)


def write_glass(program: moderngl.Program, item: ObjectGeometry) -> None:
    """The glass-only uniforms of a GLASS program."""
    material = item.object.material
    if not isinstance(material, GlassMaterial):
        raise TypeError(f"object {item.object.name!r} is not glass")
    write(program, "u_ior", material.ior)


def screen_rectangle(item: ObjectGeometry, camera: PPC) -> tuple[float, float, float, float]:
    """Normalized device coordinates (x0, y0, x1, y1) holding every pixel of `item` that `camera`
    sees, from its bounding sphere's box: a projective map keeps the box's projection inside the
    hull of its projected corners, as long as they are all in front of the eye (else the viewport,
    whole)."""
    centre, radius = item.bounding_sphere
    corners = np.array([[x, y, z, 1.0] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], np.float64)
    corners[:, :3] = centre + radius * corners[:, :3]
    clip = corners @ np.asarray(camera.view_projection, np.float64).T
    if not np.all(clip[:, 3] > 1e-6 * max(radius, 1e-30)):
        return (-1.0, -1.0, 1.0, 1.0)
    ndc = clip[:, :2] / clip[:, 3:4]
    # Half a pixel beyond, for the rounding of the rasterizer's pixel centres.
    margin = np.array([1.0 / camera.width, 1.0 / camera.height])
    low = np.clip(ndc.min(axis=0) - margin, -1.0, 1.0)
    high = np.clip(ndc.max(axis=0) + margin, -1.0, 1.0)
    return (float(low[0]), float(low[1]), float(high[0]), float(high[1]))


class ReflectorPass:
    """Draws the mirrors and the glass objects (the reflectors) over the frame, deferred: each
    reflector's surface is rasterized into the frame's surface targets (position, normal and id,
    reflector_surface.frag) with a trivial shader, and the mirror shader then runs once per pixel
    over the reflector's screen rectangle, reading them. Glass has its own program (the GLASS
    variant), made only when the scene has glass, and an interior image per glass object, made
    again only when the eye or the glass has moved since it was made."""

    def __init__(
        self,
        programs: ProgramCache,
        scene: Scene,
        meshes: GpuMeshes,
        reflected: ReflectedObjects,
        method_defines: dict[str, int],
        write_reflection_data: bool = False,
        count_samples: bool = False,
        interiors: dict[int, GlassInterior] | None = None,
    ) -> None:
        defines = {**reflection_defines(method_defines, write_reflection_data, count_samples), **DEFERRED,
                   **glossy_defines(scene)}
        self.programs = {
            glass: reflector_program(programs, scene, defines, glass, DEFERRED_REFLECTOR_PROGRAM) if present else None
            for glass, present in ((False, bool(scene.mirrors)), (True, bool(scene.glass)))
        }
        self.surface_program = programs.get(*SURFACE_PROGRAM)
        self.rectangles: dict[moderngl.Program, moderngl.VertexArray] = {}  # each program's screen rectangle
        self.interiors = interiors or {}
        if len(self.interiors) != len(scene.glass):
            raise ValueError("a scene with glass needs a GlassInterior per glass object")
        self.meshes = meshes
        self.reflected = reflected

    def make_interiors(self, reflectors: list[ObjectGeometry], camera: PPC) -> int:
        """The interior image of each glass object the eye or the glass has moved since it was made
        (the render graph's glass-interior node); returns the draw calls."""
        draws = 0
        for item in reflectors:
            if not item.object.is_glass:
                continue
            interior = self.interiors[item.index]
            seen_from = (tuple(camera.C), pixel_angle(camera), item.time)  # what the image depends on
            if interior.seen_from != seen_from:
                draws += interior.bake(item, interior_camera(camera.C, item, seen_from[1], interior.size))
                interior.seen_from = seen_from
        return draws

    def draw(self, reflectors: list[ObjectGeometry], camera: PPC, framebuffer: moderngl.Framebuffer,
             surfaces: Surfaces, tint_retraced: bool = False) -> int:
        """Draw the reflectors into `framebuffer` as `camera` sees them, through the frame's
        `surfaces`; returns the draw calls. `tint_retraced` tints the pixels whose ray the hybrid
        method traced (other methods have none)."""
        stamp = surfaces.next_frame()
        write(self.surface_program, "u_surface_stamp", stamp)
        surfaces.framebuffer.use()
        with raster_state(self.surface_program.ctx, REFLECTORS):
            for item in reflectors:
                write(self.surface_program, "u_mirror_id", item.index)
                self.meshes.draw(self.surface_program, item, camera.view_projection)
        surfaces.use()
        draws = len(reflectors)
        for item in reflectors:
            glass = item.object.is_glass
            program = self.programs[glass]
            if program is None:
                raise TypeError(f"object {item.object.name!r} is not a reflector of this pass's scene")
            if glass:
                interior = self.interiors[item.index]
                interior.bind(program)
                write_glass(program, item)
            framebuffer.use()
            self.reflected.bind(program)
            self.reflected.bind_reflector(program, item)
            write(program, "u_eye", tuple(camera.C))
            write(program, "u_tint", reflector_tint(item))
            write(program, "u_roughness", reflector_roughness(item))
            write(program, "u_mirror_id", item.index)
            write(program, "u_tint_retraced", tint_retraced)
            write(program, "u_surface_stamp", stamp)
            write(program, "u_rect", screen_rectangle(item, camera))
            # Every pixel of the rectangle is this reflector's or left alone (discarded): the
            # surfaces' depth test has already chosen the visible one.
            with raster_state(program.ctx, NO_DEPTH_TEST):
                self._rectangle(program).render(moderngl.TRIANGLE_STRIP, vertices=4)
            draws += 1
        return draws

    def _rectangle(self, program: moderngl.Program) -> moderngl.VertexArray:
        """`program`'s screen rectangle (no vertex buffer: screen_rect.vert), made on its first draw,
        and where it finds the surfaces."""
        if program not in self.rectangles:
            write(program, "u_surface_position", TextureUnit.SURFACE_POSITION)
            write(program, "u_surface_normal", TextureUnit.SURFACE_NORMAL)
            self.rectangles[program] = program.ctx.vertex_array(program, [])
        return self.rectangles[program]

    def release(self) -> None:
        for vertex_array in self.rectangles.values():
            vertex_array.release()


class ReflectorsNode(Node):
    """The graph's reflector node: the mirrors and glass, deferred (ReflectorPass.draw), last."""

    stage = Pass.REFLECTORS
    when = "every frame"
    mirror_time = True

    @staticmethod
    def reads(facts: GraphFacts) -> tuple[str, ...]:
        """What the mirror variant samples: the stand-in, the eye's surface (SSR), the pyramids
        where it marches hierarchically, and what was made of the colour mips, bounce images,
        glass interiors and shadow maps."""
        pyramids = ("depth pyramids",) if facts.reads_pyramids else ()
        return ("frame colour", "frame depth", *facts.stand_in, *facts.surface, *pyramids,
                *facts.made("colour mips", "bounce images", "glass interiors", "shadow maps", "environment lighting"))

    @staticmethod
    def writes(facts: GraphFacts) -> tuple[str, ...]:
        return ("frame colour", "frame depth")

    def run(self, frame: Frame) -> bool:
        graph, targets = self.graph, frame.targets
        if graph.reflector_pass is None:
            return False
        if targets.surfaces is None:
            raise RuntimeError("a frame with reflectors has their surface targets")
        graph.stats.draw_calls += graph.reflector_pass.draw(graph.world.reflectors, frame.camera, targets.framebuffer,
                                                            targets.surfaces, graph.tint_retraced)
        return True
