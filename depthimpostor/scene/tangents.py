"""Tangents for a normal map where a glTF file gives none (glTF 2.0, 3.7.2.1: "When tangents are
not specified, client implementations SHOULD calculate tangents using default MikkTSpace
algorithms with the specified vertex positions, normals, and texture coordinates").

They are MikkTSpace's (scene/mikktspace.py, a numpy port of mikktspace.c's genTangSpaceDefault,
checked against it by tests/test_mikktspace.py), with two conventions of glTF's:
- The sign w is mikktspace.c's negated. MikkTSpace's bitangent, sign N x T, runs along +v, and
  glTF's v runs down the image, while its normal maps' green runs up it: glTF's bitangent w N x T
  points against dP/dv. (Negating is what MikkTSpace on (u, 1 - v) gives, up to that subtraction's
  rounding: three.js's computeMikkTSpaceTangents does it for glTF with its negateSign; Blender runs
  MikkTSpace on its own UVs, whose v runs up.)
- MikkTSpace gives a tangent per triangle corner; a glTF vertex holds one. Where the corners of a
  vertex get different ones (a UV mirror seam through shared vertices, a fan MikkTSpace splits,
  a degenerate triangle), the vertex is split: one copy per distinct tangent, appended after the
  mesh's vertices, its triangles re-indexed (the vertex keeps the tangent of its first corner).
  A mesh where no vertex splits keeps its vertices and indices as they were. three.js's
  computeMikkTSpaceTangents de-indexes the geometry instead (every corner its own vertex);
  Blender's glTF exporter keeps a vertex per distinct combination of its loops' attributes,
  tangent included, as here.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from depthimpostor.scene.mikktspace import distinct_rows, mikktspace

Array = np.ndarray

#: The tangent of a vertex no triangle uses (it is never drawn): any unit one.
UNUSED = (1.0, 0.0, 0.0, 1.0)


class Tangents(NamedTuple):
    """A mesh's generated tangents, on its vertices split where MikkTSpace needs it."""

    tangents: Array  # (K, 4) unit tangents and signs w (B = w N x T)
    vertices: Array  # (K,) the vertex each of the K comes from (the first N: 0 .. N - 1)
    faces: Array  # (M, 3) the faces, indexing the K


def generated_tangents(positions: Array, normals: Array, faces: Array, uvs: Array) -> Tangents:
    """MikkTSpace's tangents for a mesh's N vertices (`normals` unit), from the UV set a normal map
    reads, on its vertices split where two corners of one get different ones."""
    faces = np.asarray(faces, np.int64).reshape(-1, 3)
    count = len(positions)
    corners = mikktspace(positions, normals, faces, uvs).reshape(-1, 4)
    corners[:, 3] = -corners[:, 3]  # glTF's bitangent points up the image, against dP/dv
    vertex = faces.ravel()
    first_of_vertex = np.full(count, len(vertex), np.int64)
    np.minimum.at(first_of_vertex, vertex, np.arange(len(vertex)))
    # A corner whose tangent is its vertex's first corner's stays on the vertex; the others (few)
    # go to one new vertex per distinct (vertex, tangent), in the order of their first corners.
    moved = np.flatnonzero((corners != corners[first_of_vertex[vertex]]).any(axis=1))
    kind = distinct_rows(np.c_[vertex[moved], corners[moved]])
    first = np.full(len(moved) and int(kind.max()) + 1, len(moved), np.int64)
    np.minimum.at(first, kind, np.arange(len(moved)))
    rank = np.empty(len(first), np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    slot = vertex.copy()
    slot[moved] = count + rank[kind]
    tangents = np.tile(UNUSED, (count + len(first), 1))
    tangents[slot] = corners
    added = np.empty(len(first), np.int64)
    added[rank] = vertex[moved[first]]
    return Tangents(tangents, np.r_[np.arange(count), added], slot.reshape(-1, 3))
