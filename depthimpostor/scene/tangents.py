"""Tangents for a normal map where a glTF file gives none (glTF 2.0, 3.7.2.1: "When tangents are
not specified, client implementations SHOULD calculate tangents using default MikkTSpace
algorithms with the specified vertex positions, normals, and texture coordinates").

This is not MikkTSpace, but the per-vertex accumulation it refines (Lengyel's method), in numpy:
each triangle's tangent dP/du and "up the image" direction -dP/dv (glTF's bitangent: v grows down
the image) are summed at its corners, weighted by the triangle's area in UV space (the sums of the
unnormalized solutions), then each vertex's tangent is made perpendicular to its normal
(Gram-Schmidt) and its sign w chosen so that w N x T points along the summed bitangent. Where it
differs from MikkTSpace (Mikkelsen 2008, mikktspace.c), and so from a baker's normal map:
- MikkTSpace weights each corner by its angle and splits a vertex whose triangles disagree on the
  sign (mirrored UVs) or whose tangents point too far apart; here a shared vertex averages them,
  so at a UV mirror seam the tangent is the mean of the two sides (the bumps there are bent).
- Degenerate UV triangles (no area in UV space) add nothing here; MikkTSpace gives them the
  tangents of their neighbours. A vertex with none left gets any unit vector perpendicular to
  its normal (a normal map then turns its bumps arbitrarily there, as on any seam).
On a smooth, unmirrored, unsplit UV layout (a plane, a sphere, most scanned models) the two agree
to within the averaging weights (tests/test_normal_maps.py compares a file's tangents with these).
"""

from __future__ import annotations

import numpy as np

Array = np.ndarray


def generated_tangents(positions: Array, normals: Array, faces: Array, uvs: Array) -> Array:
    """(N, 4) unit tangents and signs for a mesh's vertices, from the UV set a normal map reads."""
    p = np.asarray(positions, np.float64)
    n = np.asarray(normals, np.float64)
    uv = np.asarray(uvs, np.float64)
    corners = np.asarray(faces, np.int64)
    e1, e2 = p[corners[:, 1]] - p[corners[:, 0]], p[corners[:, 2]] - p[corners[:, 0]]
    d1, d2 = uv[corners[:, 1]] - uv[corners[:, 0]], uv[corners[:, 2]] - uv[corners[:, 0]]
    # dP/du and dP/dv times the UV triangle's signed double area (so that a large triangle weighs
    # more, and a degenerate one, of no area, nothing).
    area = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    sign = np.where(area < 0.0, -1.0, 1.0)[:, None]
    along_u = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * sign
    along_v = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * sign
    tangent, down = np.zeros_like(p), np.zeros_like(p)
    for k in range(3):
        np.add.at(tangent, corners[:, k], along_u)
        np.add.at(down, corners[:, k], along_v)
    summed = np.linalg.norm(tangent, axis=1)
    tangent -= n * np.einsum("ij,ij->i", tangent, n)[:, None]
    length = np.linalg.norm(tangent, axis=1)
    # No UV gradient at the vertex, or one along the normal (what is left of it is rounding): any
    # direction perpendicular to the normal.
    length = np.where(length > 1e-6 * summed, length, 0.0)
    fallback = np.cross(n, np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]]))
    fallback /= np.maximum(np.linalg.norm(fallback, axis=1, keepdims=True), 1e-300)
    tangent = np.where((length > 1e-20)[:, None], tangent / np.maximum(length, 1e-300)[:, None], fallback)
    # glTF's bitangent points up the image, against dP/dv.
    handedness = np.where(np.einsum("ij,ij->i", np.cross(n, tangent), -down) < 0.0, -1.0, 1.0)
    return np.c_[tangent, handedness]
