"""`--method planar`: planar reflections, the flat mirror's answer engines ship (three.js's
Reflector, Unreal's planar reflections). Per mirror and frame, the scene (the diffuse objects and
analytic planes) is rendered again through the eye reflected in the mirror's plane into targets of
the frame's size; the mirror shader reads them at its own pixel (lib/planar.glsl). For a flat
mirror the reflected ray of a pixel is the reflected eye's ray of that pixel, so the lookup is
exact up to rasterization.

What is behind the mirror must not show: the render's near plane is the mirror's plane (Lengyel's
oblique near plane, "Oblique View Frustum Depth Projection and Clipping", JGT 10(2), 2005, here on
the eye's reversed-Z projection: see `oblique_view_projection`). Other mirrors and glass are not
in the render, as the depth method shows none with render.max_bounces = 1 and the truth traces none.

A mirror is flat when it is a `plane` shape or a mesh whose triangles all lie in one plane (within
FLATNESS of its size) and face one way; glass and curved reflectors are refused by name.
"""

from __future__ import annotations

import re

import moderngl
import numpy as np

from ..errors import SceneError
from ..eye import clear_depth, make_depth_buffer, reversed_z
from ..geometry import ObjectGeometry, scene_geometry
from ..gpu.bindings import TextureUnit
from ..gpu.meshes import GpuMeshes
from ..gpu.scene_blocks import DrawnMaterials
from ..gpu.shaders import ProgramCache
from ..gpu.uniforms import bind_texture
from ..passes.diffuse import DIFFUSE_PROGRAM, DiffusePass, diffuse_defines
from ..ppc import PPC
from ..scene.model import PlaneShape, Scene
from .seen_from_eye import SeenFromEye

#: A mesh is flat when no vertex is farther than this share of its bounding radius from the plane
#: of its triangles: float32 vertices of a rotated plane lie within ~1e-7 of it; a tessellated
#: sphere's vertices, a share of ~1 away.
FLATNESS = 1e-5

#: The oblique projection's scale k, as a share of the largest k that keeps every point beyond the
#: mirror inside the frustum's far side (clip z >= 0 needs k P <= w: see oblique_view_projection).
#: Half: a margin for rounding, at the cost of one bit of the depth's precision.
OBLIQUE_MARGIN = 0.5


def _shape_name(item: ObjectGeometry) -> str:
    return re.sub(r"(?<!^)(?=[A-Z])", "_", type(item.object.shape).__name__.removesuffix("Shape")).lower()


def mirror_plane(item: ObjectGeometry) -> tuple[np.ndarray, float] | None:
    """(unit outward normal n, offset h) of a flat reflector's plane n . x = h, or None where its
    triangles do not lie in one plane facing one way. Outward: counter-clockwise triangles, the
    mirror's reflecting side."""
    mesh = item.world_mesh
    points = np.asarray(mesh.positions, np.float64)
    corners = points[np.asarray(mesh.indices, np.int64)]
    areas = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    total = areas.sum(axis=0)
    length = float(np.linalg.norm(total))
    # Triangles facing both ways (a closed or folded mesh) cancel: their sum is shorter than the parts'.
    if length <= 0.0 or length < (1.0 - FLATNESS) * float(np.linalg.norm(areas, axis=1).sum()):
        return None
    normal = total / length
    centre, radius = item.bounding_sphere
    offset = float(normal @ centre)
    if np.abs(points @ normal - offset).max() > FLATNESS * max(float(radius), 1e-30):
        return None
    return normal, offset


def not_flat(item: ObjectGeometry) -> str | None:
    """What a reflector is when it is not a flat mirror ("glass", "a sphere"), or None."""
    if item.object.is_glass:
        return "glass"
    return None if isinstance(item.object.shape, PlaneShape) or mirror_plane(item) is not None else f"a {_shape_name(item)}"


def all_flat_mirrors(scene: Scene) -> bool:
    """Is every reflector of the scene (where it starts) a flat mirror?"""
    return all(not_flat(item) is None for item in scene_geometry(scene.objects) if item.object.is_reflector)


def check_flat_mirrors(scene: Scene, reflectors: list[ObjectGeometry]) -> None:
    """SceneError naming the first reflector that is not a flat mirror."""
    for item in reflectors:
        what = not_flat(item)
        if what is not None:
            raise SceneError(scene.source, scene.object_label(item.index),
                             f'--method planar needs flat mirrors; "{item.object.name}" is {what}')


def reflection_matrix(normal: np.ndarray, offset: float) -> np.ndarray:
    """World -> world: the mirror image x - 2 n (n . x - h) in the plane n . x = h."""
    matrix = np.eye(4)
    matrix[:3, :3] -= 2.0 * np.outer(normal, normal)
    matrix[:3, 3] = 2.0 * offset * normal
    return matrix


def oblique_view_projection(camera: PPC, normal: np.ndarray, offset: float, reversed_: bool) -> np.ndarray | None:
    """The view-projection of the eye reflected in the plane n . x = h, applied to the scene's own
    (unreflected) points, with its near plane at the mirror: the depth row is replaced, as in
    Lengyel's oblique frustum, by one whose near clip is P(x) = n . x - h >= 0 (the reflecting side).

    Reversed-Z (clip 0 <= z <= w, nearer is greater): z = w - k P, so z <= w is P >= 0 and the depth
    z / w = 1 - k P / w falls along every ray of a pixel as the point recedes. OpenGL's depth
    (-w <= z <= w, nearer is less): z = -w + k P. The far side (z >= 0, or z <= w) holds every point
    beyond the mirror while k P <= w: along a pixel's ray r (w(r) = 1) the reflected point at w = s
    has P / w = -P(eye) / s - n . r < -n . r (the eye is in front), whose largest over the frame is
    at a corner. None where the eye is not in front of the plane or no pixel's ray meets it."""
    facing = float(normal @ camera.C) - offset
    corners = [camera.a * u + camera.b * v + camera.c for u in (0.0, camera.width) for v in (0.0, camera.height)]
    bound = max(-float(normal @ ray) for ray in corners)
    if facing <= 0.0 or bound <= 0.0:
        return None
    matrix = np.asarray(camera.view_projection, np.float64) @ reflection_matrix(normal, offset)
    plane = np.array([*normal, -offset])
    k = OBLIQUE_MARGIN / bound
    matrix[2] = matrix[3] - k * plane if reversed_ else -matrix[3] + k * plane
    return matrix


class PlanarPass(SeenFromEye):
    """Per flat mirror, its render of the scene through its plane: colour, and world position with
    the object id, with a depth buffer of its own, all of the frame's size."""

    image_noun = "planar reflection"
    image_plural = "planar reflections"
    per_reflector = True
    writes = ("planar images",)
    shades = True

    @classmethod
    def variants(cls, scene: Scene) -> list[tuple[tuple[str, ...], dict[str, int] | None, str]]:
        return [(DIFFUSE_PROGRAM, diffuse_defines(scene, False, write_surface=True),
                 "planar reflections: the scene through each mirror's plane, with the position and object seen")]

    def __init__(self, ctx: moderngl.Context, programs: ProgramCache, scene: Scene, meshes: GpuMeshes,
                 materials: DrawnMaterials, reflectors: list[ObjectGeometry]) -> None:
        super().__init__(ctx, programs, scene, meshes, materials, reflectors)
        check_flat_mirrors(scene, reflectors)
        self.diffuse = DiffusePass(programs, scene, meshes, materials, write_depth_image=False, write_surface=True)
        self.mirrors = [item.index for item in reflectors]
        self.targets: dict[int, tuple[moderngl.Texture, moderngl.Texture, moderngl.Renderbuffer,
                                      moderngl.Framebuffer]] = {}

    @classmethod
    def bytes_for(cls, size: tuple[int, int], reflectors: int, glossy: bool = False) -> int:
        # A flat mirror's image is exact: a rough one reads it as it is (no mips; docs say so).
        return reflectors * size[0] * size[1] * (16 + 16 + 4)  # colour, surface, depth

    def _ensure(self, size: tuple[int, int]) -> None:
        if self.size == size:
            return
        self._release_targets()
        for index in self.mirrors:
            color, surface = self.ctx.texture(size, 4, dtype="f4"), self.ctx.texture(size, 4, dtype="f4")
            for texture in (color, surface):
                texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
            depth = make_depth_buffer(self.ctx, size)
            self.targets[index] = (color, surface, depth, self.ctx.framebuffer([color, surface], depth))
        self.size = size

    def make(self, camera: PPC, diffuse: list[ObjectGeometry], reflectors: list[ObjectGeometry],
             frame: moderngl.Framebuffer) -> int:
        self._ensure((camera.width, camera.height))
        reversed_ = reversed_z(self.ctx) is not None
        draws = 0
        for item in reflectors:
            framebuffer = self.targets[item.index][3]
            framebuffer.use()
            framebuffer.clear(0.0, 0.0, 0.0, 0.0, depth=clear_depth(self.ctx))
            plane = mirror_plane(item)
            matrix = oblique_view_projection(camera, *plane, reversed_) if plane is not None else None
            if matrix is not None:  # else the eye sees the mirror's backing, or not the mirror
                draws += self.diffuse.draw(diffuse, matrix, mirrored_view=True)
            self.made += 1
        frame.use()
        return draws

    def bind_reflector(self, program: moderngl.Program, mirror: ObjectGeometry) -> None:
        color, surface, _, _ = self.targets[mirror.index]
        bind_texture(program, "u_screen_color", color, TextureUnit.SCREEN_COLOR)
        bind_texture(program, "u_screen_surface", surface, TextureUnit.SCREEN_SURFACE)

    def _release_targets(self) -> None:
        for color, surface, depth, framebuffer in self.targets.values():
            for item in (framebuffer, color, surface, depth):
                item.release()
        self.targets = {}
        self.size = None

    def release(self) -> None:
        self._release_targets()
