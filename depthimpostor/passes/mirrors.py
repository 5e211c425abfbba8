"""Mirrors: each pixel's reflected ray intersected with that mirror's depth images in GLSL."""

from __future__ import annotations

import moderngl
import numpy as np

from ..constants import Algorithm
from ..geometry import ObjectGeometry
from ..ppc import PPC
from ..scene.model import MirrorMaterial, Scene
from ..shaders import ProgramCache
from .impostors import ImpostorAtlas, ImpostorPass
from .meshes import GpuMeshes
from .uniforms import write, write_analytic_planes, write_lighting

#: Texture units and the uniform-block binding the reflected-scene chunk reads.
COLOR_ATLAS_UNIT = 0
DEPTH_ATLAS_UNIT = 1
DEPTH_IMAGES_BINDING = 0


def bind_impostors(program: moderngl.Program, atlas: ImpostorAtlas) -> None:
    """Point a program that includes lib/reflected_scene.glsl at the depth-image atlas."""
    atlas.color.use(COLOR_ATLAS_UNIT)
    atlas.depth.use(DEPTH_ATLAS_UNIT)
    write(program, "u_impostor_color", COLOR_ATLAS_UNIT)
    write(program, "u_impostor_depth", DEPTH_ATLAS_UNIT)
    if "DepthImages" in program:
        program["DepthImages"].binding = DEPTH_IMAGES_BINDING


def reflection_defines(algorithm: Algorithm, write_reflection_data: bool = False) -> dict[str, int]:
    defines = {"ALGORITHM": int(algorithm)}
    if write_reflection_data:
        defines["WRITE_REFLECTION_DATA"] = 1
    return defines


class MirrorPass:
    def __init__(
        self,
        programs: ProgramCache,
        scene: Scene,
        meshes: GpuMeshes,
        impostors: ImpostorPass,
        analytic_planes: list[ObjectGeometry],
        algorithm: Algorithm,
        write_reflection_data: bool = False,
    ) -> None:
        defines = reflection_defines(algorithm, write_reflection_data)
        self.program = programs.get("mesh.vert", "mirror.frag", defines)
        self.meshes = meshes
        self.impostors = impostors
        write_lighting(self.program, scene)
        write_analytic_planes(self.program, scene, analytic_planes)

    def draw(self, mirrors: list[ObjectGeometry], camera: PPC, view_projection: np.ndarray) -> int:
        bind_impostors(self.program, self.impostors.atlas)
        write(self.program, "u_eye", tuple(camera.C))
        for mirror in mirrors:
            material = mirror.object.material
            if not isinstance(material, MirrorMaterial):
                raise TypeError(f"object {mirror.object.name!r} is not a mirror")
            images = self.impostors.images_by_mirror[mirror.index]
            self.impostors.uniform_buffers[mirror.index].bind_to_uniform_block(DEPTH_IMAGES_BINDING)
            write(self.program, "u_depth_image_count", len(images))
            write(self.program, "u_tint", tuple(material.tint))
            write(self.program, "u_mirror_id", mirror.index)
            self.meshes.draw(self.program, mirror, view_projection)
        return len(mirrors)
