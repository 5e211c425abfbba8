"""Mirrors: each pixel's reflected ray traced in GLSL against what the method stands in for the
reflected objects (depth images, or the real triangles), the analytic planes and the environment."""

from __future__ import annotations

from typing import Protocol

import moderngl
import numpy as np

from ..constants import Algorithm, Method
from ..geometry import ObjectGeometry
from ..ppc import PPC
from ..scene.model import MirrorMaterial, Scene
from ..shaders import ProgramCache
from .meshes import GpuMeshes
from .uniforms import shading_defines, write, write_analytic_planes, write_lighting


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


#: The colour outputs the reflection data adds (ray origin, ray direction, hit position).
REFLECTION_OUTPUTS = 3


def reflection_defines(
    method: Method, algorithm: Algorithm, write_reflection_data: bool = False, count_samples: bool = False
) -> dict[str, int]:
    """The mirror shader's variant: the method, and for depth images the intersection algorithm
    (the other methods have none, so that no two identical programs are compiled). The counting
    variant (the benchmark's) writes each ray's samples to the output after the others."""
    defines = {"METHOD": int(method)}
    if method == Method.DEPTH:
        defines["ALGORITHM"] = int(algorithm)
    if write_reflection_data:
        defines["WRITE_REFLECTION_DATA"] = 1
    if count_samples:
        defines["COUNT_SAMPLES"] = 1 + (REFLECTION_OUTPUTS if write_reflection_data else 0)
    return defines


class MirrorPass:
    def __init__(
        self,
        programs: ProgramCache,
        scene: Scene,
        meshes: GpuMeshes,
        reflected: ReflectedObjects,
        analytic_planes: list[ObjectGeometry],
        method: Method,
        algorithm: Algorithm,
        write_reflection_data: bool = False,
        count_samples: bool = False,
    ) -> None:
        defines = {**reflection_defines(method, algorithm, write_reflection_data, count_samples), **shading_defines(scene)}
        self.program = programs.get("mesh.vert", "mirror.frag", defines)
        self.meshes = meshes
        self.reflected = reflected
        write_lighting(self.program, scene)
        write_analytic_planes(self.program, scene, analytic_planes)

    def draw(self, mirrors: list[ObjectGeometry], camera: PPC, view_projection: np.ndarray) -> int:
        self.reflected.bind(self.program)
        write(self.program, "u_eye", tuple(camera.C))
        for mirror in mirrors:
            material = mirror.object.material
            if not isinstance(material, MirrorMaterial):
                raise TypeError(f"object {mirror.object.name!r} is not a mirror")
            self.reflected.bind_mirror(self.program, mirror)
            write(self.program, "u_tint", tuple(material.tint))
            write(self.program, "u_mirror_id", mirror.index)
            self.meshes.draw(self.program, mirror, view_projection)
        return len(mirrors)
