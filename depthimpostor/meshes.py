"""Triangle meshes: the `Mesh` container, procedural shapes and model files loaded with trimesh.

Every mesh is indexed triangles with smooth per-vertex normals, wound counter-clockwise seen from
outside so that back-face culling and the geometric normal agree with the shading normal. All shapes
are built in local coordinates, centred at the origin; scenes place them with `Mesh.transformed` or a
model matrix on the GPU.

The surface generators share one convention, which is the reason they read alike: a surface is a grid
of vertices indexed `a * count_b + b`, and a grid cell becomes the triangles (a,b) (a+1,b) (a+1,b+1)
and (a,b) (a+1,b+1) (a,b+1), whose geometric normal is the direction of dP/da x dP/db. Each generator
orders its two parameters so that this cross product points out of the solid. Closed directions wrap
around instead of repeating a seam column (no texture coordinates need one), so the closed shapes are
watertight by index, not only by position.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np

from depthimpostor.constants import EXTRA_ATTRIBUTES, EXTRA_DEFAULTS, MAX_COORDINATE
from depthimpostor.errors import DepthImpostorError


class MeshError(DepthImpostorError):
    """A mesh file could not be read, holds no triangles, or a shape was asked for with bad sizes."""

    exit_code = 2


@dataclass(frozen=True, eq=False)
class Mesh:
    """Indexed triangles with smooth normals; the arrays are read-only so that cached meshes stay intact.

    `eq=False` keeps identity hashing: renderers key their GPU buffers by the mesh object.
    """

    positions: np.ndarray  # (N, 3) float32, local coordinates
    normals: np.ndarray  # (N, 3) float32, unit length, per vertex
    indices: np.ndarray  # (M, 3) uint32, counter-clockwise seen from outside
    # (N, 2) float32 texture coordinates per vertex, or None. glTF's convention: (0, 0) is the
    # image's top-left corner (its first row), v grows downwards. glTF parts, planes and boxes
    # have them (textures.py; scene_format.md says which shapes have none).
    uvs: np.ndarray | None = None
    # glTF's other vertex attributes, where a file gives them (scene/gltf_file.py), else None:
    # (N, 4) float32 tangents (xyz unit, w the bitangent's sign: B = w N x T, glTF 3.7.2.1), from
    # the file's TANGENT or generated where a normal map needs them (scene/tangents.py: MikkTSpace,
    # which may split a vertex, so N may exceed the file's count); (N, 4)
    # float32 linear RGBA vertex colours (COLOR_0, alpha 1 where the file gives RGB); (N, 2) float32
    # TEXCOORD_1, in the convention of `uvs`.
    tangents: np.ndarray | None = None
    colors: np.ndarray | None = None
    uvs1: np.ndarray | None = None

    def __post_init__(self) -> None:
        positions = _frozen(self.positions, np.float32, "positions")
        normals = _frozen(self.normals, np.float32, "normals")
        raw_indices = np.asarray(self.indices)
        if raw_indices.size and (raw_indices.min() < 0 or raw_indices.max() >= len(positions)):
            raise ValueError(f"Mesh: indices must lie in [0, {len(positions)}), got "
                             f"[{raw_indices.min()}, {raw_indices.max()}]")
        indices = _frozen(raw_indices, np.uint32, "indices")
        if normals.shape != positions.shape:
            raise ValueError(f"Mesh: normals {normals.shape} do not match positions {positions.shape}")
        if not (np.isfinite(positions).all() and np.isfinite(normals).all()):
            raise ValueError("Mesh: positions and normals must be finite")
        if self.uvs is not None:
            uvs = np.array(self.uvs, dtype=np.float32, order="C", copy=True)
            if uvs.shape != (len(positions), 2) or not np.isfinite(uvs).all():
                raise ValueError(f"Mesh: uvs must be finite, of shape ({len(positions)}, 2), got {uvs.shape}")
            uvs.flags.writeable = False
            object.__setattr__(self, "uvs", uvs)
        for name, width in EXTRA_ATTRIBUTES.items():
            values = getattr(self, name)
            if values is not None:
                array = np.array(values, dtype=np.float32, order="C", copy=True)
                if array.shape != (len(positions), width) or not np.isfinite(array).all():
                    raise ValueError(f"Mesh: {name} must be finite, of shape ({len(positions)}, {width}), got {array.shape}")
                array.flags.writeable = False
                object.__setattr__(self, name, array)
        # The dataclass is frozen; these assignments only replace the arrays by checked copies.
        object.__setattr__(self, "positions", positions)
        object.__setattr__(self, "normals", normals)
        object.__setattr__(self, "indices", indices)

    def transformed(self, model: np.ndarray) -> Mesh:
        """The mesh under a 4x4 affine matrix acting on column vectors (`p' = model @ [p, 1]`).

        Normals go through the inverse transpose of the upper 3x3, which keeps them perpendicular to
        the surface under non-uniform scale. A mirroring matrix (negative determinant) turns
        counter-clockwise triangles clockwise, so the winding is flipped to stay outward.
        """
        matrix = np.asarray(model, dtype=np.float64)
        if matrix.shape != (4, 4) or not np.isfinite(matrix).all():
            raise ValueError(f"Mesh.transformed: expected a finite 4x4 matrix, got shape {matrix.shape}")
        if not np.allclose(matrix[3], (0.0, 0.0, 0.0, 1.0)):
            raise ValueError(f"Mesh.transformed: not an affine matrix, last row is {matrix[3]}")
        linear = matrix[:3, :3]
        determinant = float(np.linalg.det(linear))
        # Relative to the matrix's own scale: a flattening matrix would turn normals into 0/0 = NaN.
        if abs(determinant) <= 1e-12 * float(np.linalg.norm(linear)) ** 3:
            raise ValueError("Mesh.transformed: the 3x3 part is singular; normals are undefined")
        positions = self.positions.astype(np.float64) @ linear.T + matrix[:3, 3]
        # Row vectors times inv(L) are (inv(L)^T n)^T: the inverse transpose without a transpose.
        normals = _normalized_rows(self.normals.astype(np.float64) @ np.linalg.inv(linear))
        indices = self.indices[:, ::-1] if determinant < 0.0 else self.indices
        tangents = None
        if self.tangents is not None:
            # A tangent is a direction along the surface: it goes through the matrix itself. A
            # mirroring matrix turns N x T the other way round, so the bitangent's sign turns too.
            along = self.tangents[:, :3].astype(np.float64) @ linear.T
            lengths = np.linalg.norm(along, axis=1, keepdims=True)
            along = np.where(lengths > 0.0, along / np.maximum(lengths, 1e-300), 0.0)
            tangents = np.c_[along, self.tangents[:, 3] * np.sign(determinant)]
        return Mesh(positions, normals, indices, self.uvs, tangents, self.colors, self.uvs1)

    def with_attributes_of(self, other: Mesh) -> Mesh:
        """This mesh with `other`'s UVs and other vertex attributes (another mesh of the same
        vertices: a deformed or transformed copy)."""
        return Mesh(self.positions, self.normals, self.indices, other.uvs, other.tangents, other.colors, other.uvs1)

    @property
    def extra_attributes(self) -> tuple[str, ...]:
        """The names of the glTF attributes it has beyond position, normal and TEXCOORD_0."""
        return tuple(name for name in EXTRA_ATTRIBUTES if getattr(self, name) is not None)

    def bounding_sphere(self) -> tuple[np.ndarray, float]:
        """A sphere containing every vertex: the smaller of Ritter's sphere and the box-centred one.

        The radius is the largest distance from the chosen centre, computed in float64, so the
        containment holds exactly for the stored float32 positions.
        """
        cached: tuple[np.ndarray, float] | None = self.__dict__.get("_bounding_sphere")
        if cached is not None:  # the arrays are read-only, so the sphere never changes
            return cached[0].copy(), cached[1]
        if len(self.positions) == 0:
            raise ValueError("Mesh.bounding_sphere: the mesh has no vertices")
        points = self.positions.astype(np.float64)
        candidates = [ritter_centres(points[None])[0], 0.5 * (points.min(axis=0) + points.max(axis=0))]
        radii = [float(np.linalg.norm(points - centre, axis=1).max()) for centre in candidates]
        best = int(np.argmin(radii))
        object.__setattr__(self, "_bounding_sphere", (candidates[best], radii[best]))
        return candidates[best].copy(), radii[best]

    def interleaved(self) -> np.ndarray:
        """(N, 8) float32 rows `x y z nx ny nz u v` (u v zero without UVs), contiguous, ready for a
        GL vertex buffer."""
        uvs = self.uvs if self.uvs is not None else np.zeros((len(self.positions), 2), np.float32)
        return np.ascontiguousarray(np.hstack([self.positions, self.normals, uvs]), dtype=np.float32)

    def attribute(self, name: str) -> np.ndarray:
        """(N, width) float32 values of one of EXTRA_ATTRIBUTES: its own, or EXTRA_DEFAULTS."""
        values: np.ndarray | None = getattr(self, name)
        if values is not None:
            return values
        return np.tile(np.asarray(EXTRA_DEFAULTS[name], np.float32), (len(self.positions), 1))


def plane(width: float, depth: float, subdivisions: int = 1) -> Mesh:
    """A `width` x `depth` rectangle in XZ facing +Y, split into `subdivisions`^2 quads."""
    _require_positive("plane", width=width, depth=depth)
    _require_at_least("plane", 1, subdivisions=subdivisions)
    # Grid axis a runs along z and axis b along x, because z x x = +y is the outward side.
    z = np.linspace(-0.5 * depth, 0.5 * depth, subdivisions + 1)
    x = np.linspace(-0.5 * width, 0.5 * width, subdivisions + 1)
    zz, xx = np.meshgrid(z, x, indexing="ij")
    positions = np.stack([xx, np.zeros_like(xx), zz], axis=-1).reshape(-1, 3)
    normals = np.tile((0.0, 1.0, 0.0), (len(positions), 1))
    # Its tangents, for a normal map on a glTF rectangle placed as a plane: u grows along +x, v down
    # the image along +z, so N x T = -z is up the image (w = 1): reflected_scene.glsl's plane_tangent.
    tangents = np.tile((1.0, 0.0, 0.0, 1.0), (len(positions), 1))
    return Mesh(positions, normals, _grid_triangles(subdivisions + 1, subdivisions + 1, False, False),
                plane_uvs(positions, width, depth), tangents=tangents)


def plane_uvs(local: np.ndarray, width: float, depth: float) -> np.ndarray:
    """A plane's UVs: the image over the whole rectangle, u along +x and v along +z, so that seen
    from above (+Y) with -Z ahead, the image stands upright (its top row at -z). The mirror
    shader's analytic planes compute theirs by the same rule (reflected_scene.glsl)."""
    return np.stack([local[:, 0] / width + 0.5, local[:, 2] / depth + 0.5], axis=-1)


def box(size: Sequence[float]) -> Mesh:
    """An axis-aligned box with extents `size` = (sx, sy, sz): 24 vertices, flat normals per face."""
    if len(size) != 3:
        raise MeshError(f"box: expected 3 sizes, got {len(size)}")
    _require_positive("box", sx=size[0], sy=size[1], sz=size[2])
    half = 0.5 * np.asarray(size, dtype=np.float64)
    positions: list[np.ndarray] = []
    normals: list[np.ndarray] = []
    indices: list[np.ndarray] = []
    uvs: list[np.ndarray] = []
    for axis in range(3):
        for sign in (1.0, -1.0):
            normal = np.zeros(3)
            normal[axis] = sign
            # u x v = normal, so the corners -u-v, +u-v, +u+v, -u+v run counter-clockwise about it.
            u = np.zeros(3)
            u[(axis + 1) % 3] = 1.0
            v = np.cross(normal, u)
            first = 4 * len(positions)  # four vertices per face already emitted
            corners = [normal * half + (su * u + sv * v) * half
                       for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
            positions.append(np.array(corners))
            normals.append(np.tile(normal, (4, 1)))
            indices.append(first + np.array([[0, 1, 2], [0, 2, 3]]))
            uvs.append(_box_face_uvs(positions[-1], normal, half))
    return Mesh(np.concatenate(positions), np.concatenate(normals), np.concatenate(indices), np.concatenate(uvs))


def _box_face_uvs(corners: np.ndarray, normal: np.ndarray, half: np.ndarray) -> np.ndarray:
    """One box face's UVs: the whole image on the face, upright seen from outside. On a side
    face, u runs to the viewer's right (up x normal) and v down (-Y); the top face is laid out as
    a plane (u along +x, v along +z), the bottom as the top seen from below (v along -z)."""
    if normal[1] != 0.0:
        right, down = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, normal[1]])
    else:
        right, down = np.cross((0.0, 1.0, 0.0), normal), np.array([0.0, -1.0, 0.0])
    extent = (float(np.abs(right) @ half), float(np.abs(down) @ half))
    return np.stack([corners @ right / (2 * extent[0]) + 0.5, corners @ down / (2 * extent[1]) + 0.5], axis=-1)


def sphere(radius: float, segments: int = 96, rings: int = 48) -> Mesh:
    """A UV sphere: `segments` meridians, `rings` bands from pole to pole, one vertex per pole.

    Normals are the analytic unit directions, positions are `radius` times them; the poles get
    (0, +-1, 0) exactly instead of a normal averaged from degenerate triangles.
    """
    _require_positive("sphere", radius=radius)
    _require_at_least("sphere", 3, segments=segments)
    _require_at_least("sphere", 2, rings=rings)
    # Axis a is the longitude phi and axis b the colatitude theta (north to south): dP/dphi x
    # dP/dtheta points outward for x = sin(theta) cos(phi), z = sin(theta) sin(phi).
    phi = 2.0 * np.pi * np.arange(segments) / segments
    theta = np.pi * np.arange(1, rings) / rings
    pp, tt = np.meshgrid(phi, theta, indexing="ij")
    bands = np.stack([np.sin(tt) * np.cos(pp), np.cos(tt), np.sin(tt) * np.sin(pp)], axis=-1)
    normals = np.concatenate([bands.reshape(-1, 3), [(0.0, 1.0, 0.0), (0.0, -1.0, 0.0)]])
    north, south = len(normals) - 2, len(normals) - 1
    ring_count = rings - 1
    first_ring = np.arange(segments) * ring_count
    last_ring = first_ring + ring_count - 1
    indices = np.concatenate([
        _grid_triangles(segments, ring_count, True, False),
        _fan_triangles(north, first_ring[::-1]),
        _fan_triangles(south, last_ring),
    ])
    return Mesh(radius * normals, normals, indices)


def cylinder(radius: float, height: float, segments: int = 64) -> Mesh:
    """A capped cylinder about Y, y in [-height/2, height/2]; caps have their own rim vertices."""
    _require_positive("cylinder", radius=radius, height=height)
    _require_at_least("cylinder", 3, segments=segments)
    phi = 2.0 * np.pi * np.arange(segments) / segments
    radial = np.stack([np.cos(phi), np.zeros_like(phi), np.sin(phi)], axis=-1)
    top, bottom = np.array([0.0, 0.5 * height, 0.0]), np.array([0.0, -0.5 * height, 0.0])
    # Side: axis a is phi, axis b runs top to bottom, the order in which dP/da x dP/db is outward.
    side = np.stack([radius * radial + top, radius * radial + bottom], axis=1).reshape(-1, 3)
    side_normals = np.repeat(radial, 2, axis=0)
    rim = np.arange(segments)
    top_first, bottom_first = 2 * segments, 3 * segments + 1
    positions = np.concatenate([side, radius * radial + top, [top],
                                radius * radial + bottom, [bottom]])
    normals = np.concatenate([side_normals, np.tile((0.0, 1.0, 0.0), (segments + 1, 1)),
                              np.tile((0.0, -1.0, 0.0), (segments + 1, 1))])
    indices = np.concatenate([
        _grid_triangles(segments, 2, True, False),
        # Increasing phi turns clockwise seen from +Y, so the top fan walks the rim backwards.
        _fan_triangles(top_first + segments, top_first + rim[::-1]),
        _fan_triangles(bottom_first + segments, bottom_first + rim),
    ])
    return Mesh(positions, normals, indices)


def torus(major: float, minor: float, segments: int = 96, sides: int = 32) -> Mesh:
    """A torus about the Y axis: tube centre circle of radius `major` in XZ, tube radius `minor`."""
    _require_positive("torus", major=major, minor=minor)
    _require_at_least("torus", 3, segments=segments, sides=sides)
    # Axis a is the angle around the tube and axis b the angle around Y: that order is outward.
    around_tube = 2.0 * np.pi * np.arange(sides) / sides
    around_axis = 2.0 * np.pi * np.arange(segments) / segments
    vv, uu = np.meshgrid(around_tube, around_axis, indexing="ij")
    normals = np.stack([np.cos(vv) * np.cos(uu), np.sin(vv), np.cos(vv) * np.sin(uu)], axis=-1)
    centres = major * np.stack([np.cos(uu), np.zeros_like(uu), np.sin(uu)], axis=-1)
    positions = centres + minor * normals
    indices = _grid_triangles(sides, segments, True, True)
    return Mesh(positions.reshape(-1, 3), normals.reshape(-1, 3), indices)


def torus_knot(p: int, q: int, radius: float, tube: float,
               segments: int = 256, sides: int = 24) -> Mesh:
    """A tube of radius `tube` around the (p, q) torus knot, winding p times about the Y axis.

    The curve, for t in [0, 2 pi), lies on a torus about Y with radii 2R/3 and R/3 (R = `radius`):
        r(t) = R (2 + cos(q t)) / 3,   C(t) = (r(t) cos(p t), R sin(q t) / 3, r(t) sin(p t)),
    so it reaches `radius` from the axis in XZ and `radius / 3` in Y, plus `tube` for the surface.
    `tube` should stay well under R/3 or the strands intersect. p and q must be coprime, or the
    curve is a link traced more than once. Tube frames are rotation-minimising (parallel transport)
    with the closing twist spread evenly, so they never flip where the curvature vanishes.
    """
    _require_positive("torus_knot", radius=radius, tube=tube)
    _require_at_least("torus_knot", 1, p=p, q=q)
    _require_at_least("torus_knot", 3, segments=segments, sides=sides)
    if math.gcd(p, q) != 1:
        raise MeshError(f"torus_knot: p and q must be coprime, got p={p}, q={q}")
    t = 2.0 * np.pi * np.arange(segments) / segments
    r = radius * (2.0 + np.cos(q * t)) / 3.0
    dr = -radius * q * np.sin(q * t) / 3.0
    curve = np.stack([r * np.cos(p * t), radius * np.sin(q * t) / 3.0, r * np.sin(p * t)], axis=-1)
    tangent = _normalized_rows(np.stack([
        dr * np.cos(p * t) - p * r * np.sin(p * t),
        radius * q * np.cos(q * t) / 3.0,
        dr * np.sin(p * t) + p * r * np.cos(p * t),
    ], axis=-1))
    frame_n = _closed_transport_frames(curve, tangent)
    frame_b = np.cross(tangent, frame_n)
    # Axis a is the angle around the tube and axis b runs along the curve: B x T = N is outward.
    angle = 2.0 * np.pi * np.arange(sides) / sides
    normals = (np.cos(angle)[:, None, None] * frame_n[None]
               + np.sin(angle)[:, None, None] * frame_b[None])
    positions = curve[None] + tube * normals
    indices = _grid_triangles(sides, segments, True, True)
    return Mesh(positions.reshape(-1, 3), normals.reshape(-1, 3), indices)


_MESH_CACHE: dict[Path, tuple[int, Mesh]] = {}


#: What reads a model file into a trimesh mesh in place of trimesh's own loader: given the
#: resolved path and the path as shown (geometry.py gives glTF files to scene/gltf.py's reader).
MeshReader = Callable[[Path, Path], Any]


def load_mesh_file(path: Path, reader: MeshReader | None = None) -> Mesh:
    """A model file (OBJ, PLY, STL, ... anything trimesh reads, or what `reader` reads) as one
    smooth-shaded mesh.

    Parsed once per (resolved path, modification time): scenes and tests that name the same model
    share the result, and editing the file on disk makes the next call parse it again.
    """
    shown = Path(path)
    try:
        resolved = shown.resolve(strict=True)
        modified = resolved.stat().st_mtime_ns
    except OSError as error:
        raise MeshError(f"{shown}: cannot read mesh file: {error.strerror or error}") from error
    if not resolved.is_file():
        raise MeshError(f"{shown}: cannot read mesh file: not a regular file")
    cached = _MESH_CACHE.get(resolved)
    if cached is not None and cached[0] == modified:
        return cached[1]
    mesh = _parse_mesh_file(resolved, shown, reader)
    _MESH_CACHE[resolved] = (modified, mesh)
    return mesh


def clear_mesh_cache() -> None:
    """Forget every parsed model file (tests use it to time or re-check a first load)."""
    _MESH_CACHE.clear()


def _parse_mesh_file(resolved: Path, shown: Path, reader: MeshReader | None) -> Mesh:
    import trimesh  # only loading files needs it; the procedural shapes do not

    try:
        # trimesh merges vertices by rounding coordinates to int64 steps of 1e-8, which numpy warns
        # about past 9e10; coordinates that large are refused below, in one line.
        with np.errstate(invalid="ignore", over="ignore"):
            loaded = trimesh.load(str(resolved), force="mesh") if reader is None else reader(resolved, shown)
    except DepthImpostorError:
        raise
    except Exception as error:  # trimesh's parsers raise anything on a bad file; the user needs the name
        raise MeshError(f"{shown}: cannot read mesh file: {type(error).__name__}: {error}") from error
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise MeshError(f"{shown}: the file holds no triangles")
    largest = float(np.abs(loaded.vertices).max())
    if not largest <= MAX_COORDINATE:  # also NaN; float32 turns what is past 3.4e38 into inf
        raise MeshError(f"{shown}: expected vertex coordinates of magnitude at most {MAX_COORDINATE:g} (float32 "
                        f"geometry squares distances), got {largest:g}")
    uvs = _file_uvs(loaded)
    if uvs is not None:  # a file's stray vertices would only widen its bounds
        loaded.remove_unreferenced_vertices()  # (trimesh drops their UVs with them)
        uvs = _file_uvs(loaded)
    if uvs is None:
        # Loaders keep vertices split where texture coordinates or file normals differ; normals
        # averaged over such split vertices show creases along UV seams, so merge by position alone.
        loaded.merge_vertices(merge_tex=True, merge_norm=True)
        loaded.remove_unreferenced_vertices()
        merged, faces = np.arange(len(loaded.vertices)), np.asarray(loaded.faces)
    else:
        # With texture coordinates the split vertices stay (a seam has two UVs at one point), and
        # each takes the normal of all the faces at its position, as the merged mesh would give it.
        from trimesh import grouping

        # Grouped as merge_vertices groups them (coordinates rounded to trimesh's merge tolerance).
        unique_rows = cast(Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]], grouping.unique_rows)
        _, merged = unique_rows(np.asarray(loaded.vertices))
        faces = np.asarray(loaded.faces)
    normals = corner_weighted_normals(int(merged.max()) + 1, merged[faces], np.asarray(loaded.face_normals),
                                      np.asarray(loaded.face_angles))[merged]
    # A vertex touched only by zero-area faces gets a zero sum; any unit vector is as good there
    # and keeps NaN out of the shading. 1e-13 is trimesh's own zero for a vector's length.
    lengths = np.linalg.norm(normals, axis=1)
    normals[~(lengths > 1e-13)] = (0.0, 1.0, 0.0)
    return Mesh(np.asarray(loaded.vertices), _normalized_rows(normals), faces, uvs)


def _file_uvs(loaded: Any) -> np.ndarray | None:
    """The loaded mesh's per-vertex texture coordinates (OBJ's `vt`; whatever trimesh reads), in
    the project's convention, v down from the image's top row as glTF's (files put v = 0 at the
    bottom row); None where the file has none, or none that is finite for every vertex."""
    uv = getattr(loaded.visual, "uv", None)
    if uv is None:
        return None
    uv = np.asarray(uv, np.float64)
    if uv.shape != (len(loaded.vertices), 2) or not np.isfinite(uv).all():
        return None
    return np.stack([uv[:, 0], 1.0 - uv[:, 1]], axis=1)


def corner_weighted_normals(vertex_count: int, faces: np.ndarray, face_normals: np.ndarray,
                            face_angles: np.ndarray) -> np.ndarray:
    """Each vertex's sum of its faces' unit normals weighted by the corner angle at it (Thuermer &
    Wuethrich), unnormalized: trimesh's `vertex_normals` before it scales them to unit length.

    Summed here with `np.bincount` because trimesh sums them through a scipy sparse matrix, and
    without scipy falls back, with a logged traceback, to a Python loop over the vertices that is
    about 9 times slower on the bunny. Faces whose normal is not unit length (trimesh's zero normal
    for a degenerate face) add nothing, as in trimesh.
    """
    usable = np.einsum("ij,ij->i", face_normals, face_normals) > 0.5
    corners = faces[usable].ravel()
    weighted = face_angles[usable][:, :, None] * face_normals[usable][:, None, :]  # (F, 3 corners, 3)
    return np.stack([np.bincount(corners, weighted[..., axis].ravel(), minlength=vertex_count)
                     for axis in range(3)], axis=1)


def _frozen(values: np.ndarray, dtype: type[np.generic], name: str) -> np.ndarray:
    """A contiguous read-only (K, 3) copy of `values` in `dtype`."""
    array = np.array(values, dtype=dtype, order="C", copy=True)
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"Mesh: {name} must have shape (K, 3), got {array.shape}")
    array.flags.writeable = False
    return array


def _normalized_rows(vectors: np.ndarray) -> np.ndarray:
    """Each row scaled to unit length (callers guarantee the rows are not zero)."""
    return vectors / np.linalg.norm(vectors, axis=1, keepdims=True)


def _grid_triangles(count_a: int, count_b: int, wrap_a: bool, wrap_b: bool) -> np.ndarray:
    """Two triangles per cell of a grid of vertices `a * count_b + b`, wound along dP/da x dP/db."""
    cells_a = count_a if wrap_a else count_a - 1
    cells_b = count_b if wrap_b else count_b - 1
    a, b = np.meshgrid(np.arange(cells_a), np.arange(cells_b), indexing="ij")
    a1, b1 = (a + 1) % count_a, (b + 1) % count_b
    v00, v10, v11, v01 = a * count_b + b, a1 * count_b + b, a1 * count_b + b1, a * count_b + b1
    first = np.stack([v00, v10, v11], axis=-1).reshape(-1, 3)
    second = np.stack([v00, v11, v01], axis=-1).reshape(-1, 3)
    return np.concatenate([first, second])


def _fan_triangles(centre: int, ring: np.ndarray) -> np.ndarray:
    """Triangles (centre, ring[i], ring[i+1]) around a closed ring: counter-clockwise if the ring is."""
    return np.stack([np.full(len(ring), centre), ring, np.roll(ring, -1)], axis=-1)


def _closed_transport_frames(curve: np.ndarray, tangent: np.ndarray) -> np.ndarray:
    """Unit normals along a closed sampled curve, rotation-minimising up to an even closing twist.

    The double-reflection method (Wang et al. 2008, "Computation of rotation minimizing frames")
    carries the first normal along the samples and back to the start; the angle it comes back
    rotated by is then undone a fraction at a time so that the frame closes without a seam.
    """
    count = len(curve)
    first = np.cross(tangent[0], np.eye(3)[int(np.argmin(np.abs(tangent[0])))])
    normals = np.empty((count + 1, 3))
    normals[0] = first / np.linalg.norm(first)
    for i in range(count):
        j = (i + 1) % count
        step = curve[j] - curve[i]
        step_sq = float(step @ step)
        reflected_n = normals[i] - (2.0 / step_sq) * float(step @ normals[i]) * step
        reflected_t = tangent[i] - (2.0 / step_sq) * float(step @ tangent[i]) * step
        fix = tangent[j] - reflected_t
        fix_sq = float(fix @ fix)
        # A straight step reflects the tangent onto itself: then the second reflection is identity.
        if fix_sq > 1e-30:
            reflected_n = reflected_n - (2.0 / fix_sq) * float(fix @ reflected_n) * fix
        normals[i + 1] = reflected_n / np.linalg.norm(reflected_n)
    closing = math.atan2(float(np.cross(normals[0], normals[count]) @ tangent[0]),
                         float(normals[0] @ normals[count]))
    twist = -closing * np.arange(count) / count
    frames = normals[:count]
    # Rodrigues' rotation about the tangent; the normal is perpendicular to it, so no third term.
    rotated = (np.cos(twist)[:, None] * frames
               + np.sin(twist)[:, None] * np.cross(tangent, frames))
    return _normalized_rows(rotated)


def ritter_centres(points: np.ndarray) -> np.ndarray:
    """The centre of Ritter's bounding sphere of each of a stack of point sets ((N, V, 3)
    float64), grown towards the farthest outlier a bounded number of times, all in one pass of
    numpy (each set stops where it alone would). Each step takes in the farthest point; a few
    dozen steps settle any real model, and the callers measure the final radius from the centre
    anyway, so stopping early is still correct."""
    rows = np.arange(len(points))
    start = points[rows, np.argmax(np.linalg.norm(points - points[:, :1], axis=2), axis=1)]
    end = points[rows, np.argmax(np.linalg.norm(points - start[:, None], axis=2), axis=1)]
    centre, radius = 0.5 * (start + end), 0.5 * np.linalg.norm(end - start, axis=1)
    growing = np.ones(len(points), bool)
    for _ in range(64):
        distances = np.linalg.norm(points - centre[:, None], axis=2)
        far = np.argmax(distances, axis=1)
        farthest = distances[rows, far]
        growing &= ~(farthest <= radius)
        if not growing.any():
            break
        new_radius = 0.5 * (radius + farthest)
        share = 1.0 - np.divide(new_radius, farthest, out=np.ones_like(farthest), where=growing)
        centre = np.where(growing[:, None], centre + share[:, None] * (points[rows, far] - centre), centre)
        radius = np.where(growing, new_radius, radius)
    return centre


def _require_positive(shape: str, **values: float) -> None:
    for name, value in values.items():
        if not (math.isfinite(value) and value > 0.0):
            raise MeshError(f"{shape}: {name} must be a positive number, got {value!r}")


def _require_at_least(shape: str, minimum: int, **values: int) -> None:
    for name, value in values.items():
        if int(value) != value or value < minimum:
            raise MeshError(f"{shape}: {name} must be an integer >= {minimum}, got {value!r}")
