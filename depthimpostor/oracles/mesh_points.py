"""The mesh's attributes at the truth's exact hits: lib/mesh_point.glsl's MeshPoint in numpy, one
array a field, interpolated at a hit's barycentrics as lib/triangles.glsl's triangle_point does it
(the tangent in the world: the truth traces world-space meshes, whose tangents Mesh.transformed
turned). A field the scene's shaders leave out holds its default (constants.EXTRA_DEFAULTS), as
lib/mesh_point.glsl's mesh_point gives it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..constants import EXTRA_DEFAULTS
from ..meshes import Mesh
from ..scene.model import Texture
from ..textures import texture_alpha_bilinear, texture_bilinear

Array = np.ndarray


@dataclass(frozen=True, eq=False)
class MeshPoints:
    uv: Array  # (n, 2) TEXCOORD_0
    uv1: Array  # (n, 2) TEXCOORD_1
    color: Array  # (n, 4) COLOR_0, linear RGBA
    tangent: Array  # (n, 4) world space, not unit; w the bitangent's sign

    @staticmethod
    def defaults(count: int) -> MeshPoints:
        """`count` points at the origin of UV space with every other attribute at its default."""
        return MeshPoints(np.zeros((count, 2)), np.tile(EXTRA_DEFAULTS["uvs1"], (count, 1)),
                          np.tile(EXTRA_DEFAULTS["colors"], (count, 1)), np.tile(EXTRA_DEFAULTS["tangents"], (count, 1)))

    @staticmethod
    def of_uvs(uvs: Array) -> MeshPoints:
        """Points with UVs `uvs` and the defaults (a plane's, or a probe's)."""
        points = MeshPoints.defaults(len(uvs))
        points.uv[:] = uvs
        return points

    @staticmethod
    def on_triangles(mesh: Mesh, triangles: Array, u: Array, v: Array) -> MeshPoints:
        """The points at barycentrics (u, v) (those of corners 1 and 2) of `triangles` (rows of
        `mesh`'s vertex indices): each attribute the mesh has, interpolated; the defaults else."""
        def interpolated(values: Array) -> Array:
            values = values.astype(np.float64)
            return ((1 - u - v)[:, None] * values[triangles[:, 0]] + u[:, None] * values[triangles[:, 1]]
                    + v[:, None] * values[triangles[:, 2]])

        points = MeshPoints.defaults(len(triangles))
        for field, values in (("uv", mesh.uvs), ("uv1", mesh.uvs1), ("color", mesh.colors), ("tangent", mesh.tangents)):
            if values is not None:
                getattr(points, field)[:] = interpolated(values)
        return points

    def __getitem__(self, chosen: Array) -> MeshPoints:
        return MeshPoints(self.uv[chosen], self.uv1[chosen], self.color[chosen], self.tangent[chosen])

    def put(self, chosen: Array, points: MeshPoints) -> None:
        """Each field's rows `chosen` set to `points`'."""
        for field in ("uv", "uv1", "color", "tangent"):
            getattr(self, field)[chosen] = getattr(points, field)

    def turn_to_back(self, chosen: Array) -> None:
        """lib/mesh_point.glsl's turn_to_back for the points `chosen` (a bool mask), the normal's
        half left to the caller: their tangent frame turned (the tangent and the bitangent's sign),
        so that a normal map on a back face seen turns whole."""
        self.tangent[chosen] = -self.tangent[chosen]

    def uvs_of(self, texture: Texture) -> Array:
        """The UV set `texture` reads (lib/material_texture.glsl's texture_uv)."""
        return self.uv1 if texture.uv_set == 1 else self.uv


def texel(texture: Texture, points: MeshPoints) -> Array:
    """lib/material_texture.glsl's material_texel for traced rays: the texture's linear RGB at the
    points (level 0, bilinear: textures.texture_bilinear), on the UV set it reads."""
    return texture_bilinear(texture, points.uvs_of(texture))


def texel_alpha(texture: Texture, points: MeshPoints) -> Array:
    """material_texel_rgba(...).a for traced rays, on the UV set the texture reads."""
    return texture_alpha_bilinear(texture, points.uvs_of(texture))
