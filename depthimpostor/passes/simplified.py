"""The simplified-geometry method: every reflected object's mesh decimated, and the reflected rays
traced against the fewer triangles with the ray-traced method's BVH and traversal.

Decimation is fast-simplification's quadric edge collapse (a well-kept wrapper of Sven Forstmann's
Fast-Quadric-Mesh-Simplification), to at most `render.simplified_triangles` triangles per object.
Our meshes duplicate vertices along creases and seams (a box has 24), which would cut the surface
into patches that collapse independently, so positions are welded first (trimesh). The result's
normals come from trimesh's smooth shading with creases kept above 30 degrees: smooth where the
surface was smooth, flat faces staying flat.
"""

from __future__ import annotations

import math

import fast_simplification
import moderngl
import numpy as np
import trimesh
import trimesh.graph

from ..geometry import ObjectGeometry
from ..meshes import Mesh
from ..scene.model import Scene
from .triangles import TrianglePass

#: Faces meeting at a sharper angle than this keep separate normals in the simplified mesh.
CREASE_ANGLE_DEGREES = 30.0


def simplified_mesh(mesh: Mesh, target_triangles: int) -> Mesh:
    """`mesh` with at most `target_triangles` triangles (itself if it has no more already)."""
    if len(mesh.indices) <= target_triangles:
        return mesh
    welded = trimesh.Trimesh(mesh.positions, mesh.indices, process=True)
    points, faces = fast_simplification.simplify(
        np.asarray(welded.vertices, np.float64), np.asarray(welded.faces, np.int32), target_count=target_triangles
    )
    decimated = trimesh.Trimesh(points, faces, process=True)
    shaded = trimesh.graph.smooth_shade(decimated, angle=math.radians(CREASE_ANGLE_DEGREES))
    return Mesh(np.asarray(shaded.vertices), np.asarray(shaded.vertex_normals), np.asarray(shaded.faces))


class SimplifiedPass(TrianglePass):
    noun = "simplified triangle"

    def __init__(self, ctx: moderngl.Context, scene: Scene, reflected: list[ObjectGeometry]) -> None:
        target = scene.render.simplified_triangles
        self.original_triangle_count = sum(len(item.world_mesh.indices) for item in reflected)
        super().__init__(ctx, scene, reflected, [simplified_mesh(item.world_mesh, target) for item in reflected])
