"""Mirrors and glass: each pixel's reflected ray (and, for glass, its refracted one) traced in GLSL
against what the method stands in for the reflected objects (depth images, or the real
triangles), the analytic planes and the environment."""

from __future__ import annotations

from typing import Protocol

import moderngl

from ..gpu.gl_state import RasterState, Winding, raster_state
from ..constants import MAX_ANALYTIC_PLANES, Algorithm, Method
from ..geometry import ObjectGeometry
from ..ppc import PPC
from ..scene.model import GlassMaterial, MirrorMaterial, Scene
from ..gpu.shaders import ProgramCache
from ..oracles.truth import MIRROR_BACKING_ALBEDO
from .glass import GlassInterior, interior_camera, pixel_angle
from ..methods.atlas import BAKE_CULLS_FRONT_FACES
from ..gpu.meshes import GpuMeshes
from ..gpu.uniforms import environment_defines, shading_defines, write


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

    def bind_mirror(self, program: moderngl.Program, mirror: ObjectGeometry) -> None: ...

    def release(self) -> None: ...


#: The colour outputs the reflection data adds (ray origin, ray direction, hit position, normal).
REFLECTION_OUTPUTS = 4


def reflection_defines(
    method: Method, algorithm: Algorithm, write_reflection_data: bool = False, count_samples: bool = False
) -> dict[str, int]:
    """The mirror shader's variant: the method, and for depth images the intersection algorithm
    (the other methods have none, so that no two identical programs are compiled). The counting
    variant (the benchmark's) writes each ray's samples to the output after the others."""
    defines = {"METHOD": int(method)}
    if method.marches_depth_images:
        defines["ALGORITHM"] = int(algorithm)
    if write_reflection_data:
        defines["WRITE_REFLECTION_DATA"] = 1
    if count_samples:
        defines["COUNT_SAMPLES"] = 1 + (REFLECTION_OUTPUTS if write_reflection_data else 0)
    return defines


REFLECTOR_PROGRAM = ("mesh.vert", "mirror.frag")


def reflector_defines(scene: Scene, defines: dict[str, int], glass: bool) -> dict[str, int]:
    """The mirror shader's variant for mirrors or (GLASS) for glass, under the scene's lights and environment."""
    # PLANE_COUNT: a constant loop bound (lib/reflected_scene.glsl); more than MAX_ANALYTIC_PLANES is
    # refused when the planes are written.
    planes = min(len(scene.analytic_planes), MAX_ANALYTIC_PLANES)
    return {**defines, **shading_defines(scene), **environment_defines(scene), "PLANE_COUNT": planes,
            **({"GLASS": 1} if glass else {})}


def bounce_defines() -> dict[str, int]:
    """The variant drawing a reflector into another's depth image (render.max_bounces > 1): the
    optimized march, since a bake's images are the same whatever the frame's algorithm."""
    return {**reflection_defines(Method.DEPTH, Algorithm.OPTIMIZED), "WRITE_DEPTH_IMAGE": 1}


def reflector_program(programs: ProgramCache, scene: Scene, defines: dict[str, int], glass: bool) -> moderngl.Program:
    """The mirror shader's variant for mirrors or (GLASS) for glass (the cache writes the scene's
    lights and analytic planes into it): shared by the frame's pass and the bounce bakes."""
    program = programs.get(*REFLECTOR_PROGRAM, reflector_defines(scene, defines, glass))
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
#: mirror.frag's gl_FrontFacing (a mirror's back is its backing): every PPC projection, the
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


class MirrorPass:
    """Draws the mirrors and the glass objects (the reflectors) over the frame. Glass has its own
    program (the GLASS variant), made only when the scene has glass, and an interior image per
    glass object, made again only when the eye or the glass has moved since it was made."""

    def __init__(
        self,
        programs: ProgramCache,
        scene: Scene,
        meshes: GpuMeshes,
        reflected: ReflectedObjects,
        method: Method,
        algorithm: Algorithm,
        write_reflection_data: bool = False,
        count_samples: bool = False,
        interiors: dict[int, GlassInterior] | None = None,
    ) -> None:
        defines = reflection_defines(method, algorithm, write_reflection_data, count_samples)
        self.programs = {
            glass: reflector_program(programs, scene, defines, glass) if present else None
            for glass, present in ((False, bool(scene.mirrors)), (True, bool(scene.glass)))
        }
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
             tint_retraced: bool = False) -> int:
        """Draw the reflectors into `framebuffer` as `camera` sees them; returns the draw calls.
        `tint_retraced` tints the pixels whose ray the hybrid method traced (other methods have none)."""
        draws = 0
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
            self.reflected.bind_mirror(program, item)
            write(program, "u_eye", tuple(camera.C))
            write(program, "u_tint", reflector_tint(item))
            write(program, "u_mirror_id", item.index)
            write(program, "u_tint_retraced", tint_retraced)
            with raster_state(program.ctx, REFLECTORS):
                self.meshes.draw(program, item, camera.view_projection)
            draws += 1
        return draws
