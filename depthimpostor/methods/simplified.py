"""The simplified-geometry method: every reflected object's mesh decimated (in its own space, once
per distinct mesh), and the reflected rays traced against the fewer triangles with the ray-traced
method's two-level BVH and traversal.

Decimation is fast-simplification's quadric edge collapse (a well-kept wrapper of Sven Forstmann's
Fast-Quadric-Mesh-Simplification), to at most `render.simplified_triangles` triangles per object.
Our meshes duplicate vertices along creases and seams (a box has 24), which would cut the surface
into patches that collapse independently, so positions are welded first (`welded`: trimesh's
merge of vertices, done in numpy to spare the import). The result's
normals are smoothed across edges and split at creases sharper than 30 degrees: smooth where the
surface was smooth, flat faces staying flat. (trimesh.graph.smooth_shade does the same but needs
scipy or networkx for its graph search, a heavy dependency for twenty lines of numpy.)
"""

from __future__ import annotations

import math
from weakref import WeakKeyDictionary

import moderngl
import numpy as np

from ..geometry import ObjectGeometry
from ..meshes import Mesh
from ..scene.model import Scene
from .triangles import TrianglePass

#: Faces meeting at a sharper angle than this keep separate normals in the simplified mesh.
CREASE_ANGLE_DEGREES = 30.0


def simplified_mesh(mesh: Mesh, target_triangles: int) -> Mesh:
    """`mesh` decimated toward `target_triangles` triangles (itself if it has no more already).

    The simplifier refuses collapses that would flip a triangle, so a mesh may keep more: a
    64-sided cylinder (long thin sides, one ring at each end) stays at its 256 triangles."""
    if len(mesh.indices) <= target_triangles:
        return mesh
    # Imported here: only a scene with meshes to decimate needs it.
    import fast_simplification

    vertices, welded_faces = welded(mesh.positions, mesh.indices)
    points, faces = fast_simplification.simplify(vertices, welded_faces.astype(np.int32), target_count=target_triangles)
    simplified = crease_shaded(np.asarray(points, np.float64), np.asarray(faces, np.int64))
    return simplified if mesh.uvs is None and not mesh.extra_attributes else with_carried_uvs(mesh, mesh.uvs, simplified)


#: Decimal digits of a position that welding compares: trimesh's merge tolerance (tol.merge = 1e-8).
WELD_DIGITS = 8


def welded(positions: np.ndarray, indices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The mesh with its vertices of one position merged: (float64 vertices, int64 faces), the
    arrays `trimesh.Trimesh(positions, indices, process=True)` makes, to the bit (its
    merge_vertices: positions times 10^WELD_DIGITS rounded to integers, the referenced vertices
    kept in the order they first occur). Done here because importing trimesh (with scipy) took
    longer than the rest of a 1,000-object scene's start-up (issue 32); tests/test_simplified_weld.py
    holds it against trimesh. Non-finite positions (which trimesh would drop first) are not welded."""
    points = np.asarray(positions, np.float64)
    faces = np.asarray(indices, np.int64).reshape(-1, 3)
    if len(points) == 0 or len(faces) == 0 or not np.isfinite(points).all():
        return points, faces
    referenced = np.zeros(len(points), dtype=bool)
    referenced[faces] = True
    keys = np.round(points * 10**WELD_DIGITS).astype(np.int64)[referenced]
    _, first, group = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)  # the groups in the order their first vertex occurs
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    inverse = np.zeros(len(points), dtype=np.int64)
    inverse[referenced] = rank[group.reshape(-1)]
    kept = np.flatnonzero(referenced)[first[order]]
    return points[kept], inverse[faces]


def with_carried_uvs(original: Mesh, original_uvs: np.ndarray | None, simplified: Mesh) -> Mesh:
    """`simplified` (3 vertices a triangle, crease_shaded's) with UVs from `original`: each triangle
    takes the UV layout of the original triangle whose centroid is nearest its own, extended
    linearly over its plane. One chart a triangle keeps a seam from smearing the whole image across
    a triangle that straddles it (the welding before decimation joins the seam's two sides). The
    glTF attributes past them (TEXCOORD_1, colours, tangents) are carried alike."""
    corners = original.positions[original.indices].astype(np.float64)  # (n, 3, 3)
    centroids = corners.mean(axis=1)
    mine = simplified.positions.reshape(-1, 3, 3).astype(np.float64)
    nearest = np.concatenate([
        np.argmin(((chunk.mean(axis=1)[:, None, :] - centroids[None]) ** 2).sum(axis=2), axis=1)
        for chunk in np.array_split(mine, max(1, len(mine) * len(centroids) // 2**22))
    ])
    # Barycentric coordinates of each corner in the plane of its original triangle (least squares).
    p0, edges = corners[nearest, 0], corners[nearest, 1:] - corners[nearest, :1]  # (m, 3), (m, 2, 3)
    gram = np.einsum("mij,mkj->mik", edges, edges)
    rhs = np.einsum("mij,mcj->mci", edges, mine - p0[:, None, :])
    weights = np.linalg.solve(gram[:, None].repeat(3, axis=1), rhs[..., None])[..., 0]  # (m, 3 corners, 2)

    def carried(values: np.ndarray | None) -> np.ndarray | None:
        if values is None:
            return None
        v = values[original.indices[nearest]].astype(np.float64)  # (m, 3, width)
        extended = v[:, None, 0] + weights[..., :1] * (v[:, None, 1] - v[:, None, 0]) + weights[..., 1:] * (v[:, None, 2] - v[:, None, 0])
        return extended.reshape(-1, values.shape[1])

    colors = carried(original.colors)
    return Mesh(simplified.positions, simplified.normals, simplified.indices, carried(original_uvs),
                carried(original.tangents), None if colors is None else np.clip(colors, 0.0, 1.0), carried(original.uvs1))


def crease_shaded(positions: np.ndarray, faces: np.ndarray) -> Mesh:
    """Per-corner normals: the area-weighted mean of the normals of the faces around the corner's
    vertex that meet the corner's face at under CREASE_ANGLE_DEGREES. Every corner gets its own
    vertex (3 per triangle), which is all a mesh traced through a BVH needs."""
    area_normals = np.cross(positions[faces[:, 1]] - positions[faces[:, 0]], positions[faces[:, 2]] - positions[faces[:, 0]])
    lengths = np.linalg.norm(area_normals, axis=1, keepdims=True)
    unit = area_normals / np.where(lengths > 0.0, lengths, 1.0)
    corner_vertex = faces.reshape(-1)
    corner_face = np.repeat(np.arange(len(faces)), 3)
    # Corners grouped by vertex: each vertex's faces are one contiguous run.
    order = np.argsort(corner_vertex, kind="stable")
    starts = np.searchsorted(corner_vertex[order], np.arange(positions.shape[0] + 1))
    cosine = math.cos(math.radians(CREASE_ANGLE_DEGREES))
    normals = np.zeros((len(corner_vertex), 3))
    for vertex in range(positions.shape[0]):
        corners = order[starts[vertex] : starts[vertex + 1]]
        around = corner_face[corners]
        # weights[i, j]: does face j count toward the normal of corner i?
        weights = (unit[around] @ unit[around].T) >= cosine
        normals[corners] = weights @ area_normals[around]
    lengths = np.linalg.norm(normals, axis=1, keepdims=True)
    # A corner of a degenerate face alone has a zero sum: it takes its face's (or any) direction.
    normals = np.where(lengths > 0.0, normals / np.where(lengths > 0.0, lengths, 1.0), (0.0, 1.0, 0.0))
    return Mesh(positions[corner_vertex], normals, np.arange(len(corner_vertex)).reshape(-1, 3))


class SimplifiedPass(TrianglePass):
    noun = "simplified triangle"

    @classmethod
    def traced_meshes(cls, scene: Scene, reflected: list[ObjectGeometry]) -> list[Mesh]:
        """Each object's mesh decimated in its own space, once per distinct mesh (objects sharing a
        mesh share its decimation, and so its bottom-level hierarchy). A glTF part that deforms is
        traced whole: it has another mesh at each time, whose decimation (seconds for a large one)
        would change its triangles, where the hierarchy is refitted over the same ones."""
        return [item.local_mesh if item.object.deforms else _simplified_once(item.local_mesh, scene.render.simplified_triangles)
                for item in reflected]

    def __init__(self, ctx: moderngl.Context, scene: Scene, reflected: list[ObjectGeometry]) -> None:
        self.original_triangle_count = sum(len(item.local_mesh.indices) for item in reflected)
        super().__init__(ctx, scene, reflected)


#: Decimations made, by mesh and target: the plan counts the memory of the simplified meshes and the
#: pass then traces them, and a mesh's decimation takes seconds. Weak: a mesh no scene holds any
#: more takes its decimations with it.
_DECIMATED: WeakKeyDictionary[Mesh, dict[int, Mesh]] = WeakKeyDictionary()


def _simplified_once(mesh: Mesh, target_triangles: int) -> Mesh:
    if len(mesh.indices) <= target_triangles:
        return mesh  # (not kept: a value that holds its key would keep it alive)
    by_target = _DECIMATED.setdefault(mesh, {})
    if target_triangles not in by_target:
        by_target[target_triangles] = simplified_mesh(mesh, target_triangles)
    return by_target[target_triangles]
