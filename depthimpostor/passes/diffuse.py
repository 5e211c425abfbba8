"""Diffuse (and checker) objects, rasterized with smooth normals.

The same shader draws them into the camera view and into depth images (the variant with
WRITE_DEPTH_IMAGE also stores the window depth in a 32-bit float attachment), so that a reflected
object is shaded exactly as the object itself.
"""

from __future__ import annotations

import numpy as np

from ..geometry import ObjectGeometry
from ..scene.model import Scene
from ..gpu.shaders import ProgramCache
from ..gpu.meshes import GpuMeshes
from ..gpu.uniforms import shading_defines, write, write_material


DIFFUSE_PROGRAM = ("mesh.vert", "diffuse.frag")


def diffuse_defines(scene: Scene, write_depth_image: bool, write_triangle_ids: bool = False,
                    back_layer: bool = False, write_surface: bool = False) -> dict[str, int]:
    """The variant drawing into the frame, or (`write_depth_image`) into baked images: their
    visible surface, or (`back_layer`) the colour and depth of the nearest back face; and
    (`write_triangle_ids`: the hybrid method's) the triangle seen at each sample too;
    (`write_surface`: the planar and SSR methods') the world position and object seen."""
    return {"WRITE_DEPTH_IMAGE": int(write_depth_image), **({"WRITE_TRIANGLE_ID": 1} if write_triangle_ids else {}),
            **({"BACK_LAYER": 1} if back_layer else {}), **({"WRITE_SURFACE": 1} if write_surface else {}),
            **shading_defines(scene)}


class DiffusePass:
    def __init__(
        self, programs: ProgramCache, scene: Scene, meshes: GpuMeshes, *, write_depth_image: bool,
        triangle_offsets: dict[int, int] | None = None, back_layer: bool = False, write_surface: bool = False,
    ) -> None:
        """`triangle_offsets` (by object index: where the object's triangles start in the list the
        ray-traced method's BVH is built from) makes the variant that writes each sample's triangle;
        `back_layer` the one drawing a depth image's back layer (see diffuse_defines)."""
        defines = diffuse_defines(scene, write_depth_image, triangle_offsets is not None, back_layer, write_surface)
        self.program = programs.get(*DIFFUSE_PROGRAM, defines)
        self.scene = scene  # for its texture slots
        self.meshes = meshes
        self.triangle_offsets = triangle_offsets

    def draw(self, items: list[ObjectGeometry], view_projection: np.ndarray) -> int:
        """Draw the objects; returns the number of draw calls."""
        for item in items:
            write_material(self.program, "u_material", item.object.material, self.scene)
            write(self.program, "u_object_id", item.index)
            if self.triangle_offsets is not None:
                write(self.program, "u_triangle_offset", self.triangle_offsets[item.index])
            self.meshes.draw(self.program, item, view_projection)
        return len(items)

