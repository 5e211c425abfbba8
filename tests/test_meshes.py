"""Tests of depthimpostor.meshes: shape generators, transforms, bounding spheres and model loading."""

from __future__ import annotations

import math
import os
import subprocess
import sys
import textwrap
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from depthimpostor import textured_meshes

from depthimpostor.errors import DepthImpostorError
from depthimpostor.meshes import (
    Mesh,
    MeshError,
    box,
    clear_mesh_cache,
    cylinder,
    load_mesh_file,
    plane,
    sphere,
    torus,
    torus_knot,
)

BUNNY = Path(__file__).resolve().parents[2] / "shared" / "data" / "models" / "stanford-bunny.obj"

GENERATORS: dict[str, Callable[[], Mesh]] = {
    "plane": lambda: plane(2.0, 3.0, subdivisions=4),
    "box": lambda: box((1.0, 2.0, 3.0)),
    "sphere": lambda: sphere(1.5),
    "cylinder": lambda: cylinder(0.7, 2.0),
    "torus": lambda: torus(2.0, 0.5),
    "torus_knot": lambda: torus_knot(2, 3, 1.0, 0.12),
}


def triangle_corners(mesh: Mesh) -> np.ndarray:
    """(M, 3, 3) float64 corner positions of every triangle."""
    return mesh.positions.astype(np.float64)[mesh.indices.astype(np.int64)]


def geometric_normals(mesh: Mesh) -> np.ndarray:
    """Unnormalised (b - a) x (c - a) per triangle: outward for counter-clockwise winding."""
    corners = triangle_corners(mesh)
    return np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])


def signed_volume(mesh: Mesh) -> float:
    """Divergence theorem: positive for a closed mesh wound outward."""
    corners = triangle_corners(mesh)
    return float(np.einsum("ij,ij->i", corners[:, 0], np.cross(corners[:, 1], corners[:, 2])).sum() / 6)


def outward_fraction(mesh: Mesh) -> float:
    """Share of non-degenerate triangles whose winding agrees with their averaged vertex normals."""
    geometric = geometric_normals(mesh)
    shading = mesh.normals.astype(np.float64)[mesh.indices.astype(np.int64)].mean(axis=1)
    areas = np.linalg.norm(geometric, axis=1)
    # Zero-area triangles have no winding to check; none should exist, but they must not count as
    # agreeing either, so the count below also asserts there are few of them.
    valid = areas > 1e-12 * areas.max()
    assert valid.mean() > 0.99
    return float((np.einsum("ij,ij->i", geometric[valid], shading[valid]) > 0).mean())


def assert_closed_by_index(mesh: Mesh) -> None:
    """Every directed edge is met once the other way round: watertight and consistently wound."""
    tri = mesh.indices.astype(np.int64)
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    forward = {tuple(edge) for edge in edges.tolist()}
    assert len(forward) == len(edges), "an edge is used twice in the same direction"
    assert all((b, a) in forward for a, b in forward), "an edge has no opposite"


@pytest.mark.parametrize("name", GENERATORS)
def test_generator_arrays_are_well_formed(name: str) -> None:
    mesh = GENERATORS[name]()
    assert mesh.positions.dtype == np.float32 and mesh.positions.shape[1] == 3
    assert mesh.normals.dtype == np.float32 and mesh.normals.shape == mesh.positions.shape
    assert mesh.indices.dtype == np.uint32 and mesh.indices.shape[1] == 3
    assert mesh.positions.flags.c_contiguous and mesh.indices.flags.c_contiguous
    assert np.isfinite(mesh.positions).all() and np.isfinite(mesh.normals).all()
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=1), 1.0, atol=1e-6)
    assert int(mesh.indices.max()) < len(mesh.positions)
    # Every vertex is used: unreferenced ones would skew bounds and waste buffer space.
    assert len(np.unique(mesh.indices)) == len(mesh.positions)


@pytest.mark.parametrize("name", GENERATORS)
def test_generator_winding_is_outward(name: str) -> None:
    assert outward_fraction(GENERATORS[name]()) >= 0.99


@pytest.mark.parametrize("name", GENERATORS)
def test_bounding_sphere_contains_every_vertex(name: str) -> None:
    mesh = GENERATORS[name]()
    centre, radius = mesh.bounding_sphere()
    assert centre.dtype == np.float64 and centre.shape == (3,)
    distances = np.linalg.norm(mesh.positions.astype(np.float64) - centre, axis=1)
    assert distances.max() <= radius
    # Tight-ish: never worse than the sphere about the box centre.
    box_centre = 0.5 * (mesh.positions.min(axis=0) + mesh.positions.max(axis=0)).astype(np.float64)
    assert radius <= np.linalg.norm(mesh.positions - box_centre, axis=1).max() + 1e-9


def test_bounding_sphere_of_an_offset_point_cloud() -> None:
    rng = np.random.default_rng(7)
    points = rng.normal(size=(500, 3)) * (3.0, 1.0, 0.2) + (10.0, -4.0, 2.0)
    mesh = Mesh(points, np.tile((0.0, 1.0, 0.0), (500, 1)), np.zeros((0, 3), np.uint32))
    centre, radius = mesh.bounding_sphere()
    assert np.linalg.norm(mesh.positions.astype(np.float64) - centre, axis=1).max() <= radius


def test_plane() -> None:
    mesh = plane(2.0, 3.0, subdivisions=4)
    assert mesh.positions.shape == (25, 3) and mesh.indices.shape == (32, 3)
    np.testing.assert_allclose(mesh.positions.min(axis=0), (-1.0, 0.0, -1.5))
    np.testing.assert_allclose(mesh.positions.max(axis=0), (1.0, 0.0, 1.5))
    np.testing.assert_array_equal(mesh.normals, np.tile((0.0, 1.0, 0.0), (25, 1)))
    # Counter-clockwise seen from +Y: every geometric normal points up.
    assert (geometric_normals(mesh)[:, 1] > 0).all()
    np.testing.assert_allclose(np.linalg.norm(geometric_normals(mesh), axis=1).sum() / 2, 6.0)


def test_box() -> None:
    mesh = box((1.0, 2.0, 3.0))
    assert mesh.positions.shape == (24, 3) and mesh.indices.shape == (12, 3)
    np.testing.assert_allclose(mesh.positions.min(axis=0), (-0.5, -1.0, -1.5))
    np.testing.assert_allclose(mesh.positions.max(axis=0), (0.5, 1.0, 1.5))
    assert signed_volume(mesh) == pytest.approx(6.0, rel=1e-6)
    # Flat faces: each triangle's vertex normals equal its geometric normal.
    geometric = geometric_normals(mesh)
    geometric /= np.linalg.norm(geometric, axis=1, keepdims=True)
    for corner in range(3):
        np.testing.assert_allclose(mesh.normals[mesh.indices[:, corner]], geometric, atol=1e-6)


def test_sphere() -> None:
    mesh = sphere(1.5, segments=96, rings=48)
    np.testing.assert_allclose(np.linalg.norm(mesh.positions, axis=1), 1.5, rtol=1e-6)
    np.testing.assert_allclose(mesh.normals, mesh.positions / 1.5, atol=1e-6)
    # The poles carry the exact analytic normal, not an average over degenerate triangles.
    top, bottom = np.argmax(mesh.positions[:, 1]), np.argmin(mesh.positions[:, 1])
    np.testing.assert_array_equal(mesh.normals[top], (0.0, 1.0, 0.0))
    np.testing.assert_array_equal(mesh.normals[bottom], (0.0, -1.0, 0.0))
    assert signed_volume(mesh) == pytest.approx(4.0 / 3.0 * math.pi * 1.5**3, rel=0.01)
    assert_closed_by_index(mesh)
    centre, radius = mesh.bounding_sphere()
    assert radius == pytest.approx(1.5, rel=1e-5)
    np.testing.assert_allclose(centre, 0.0, atol=1e-5)


def test_cylinder() -> None:
    mesh = cylinder(0.7, 2.0, segments=64)
    np.testing.assert_allclose(mesh.positions[:, 1].min(), -1.0)
    np.testing.assert_allclose(mesh.positions[:, 1].max(), 1.0)
    radial = np.linalg.norm(mesh.positions[:, [0, 2]], axis=1)
    assert radial.max() == pytest.approx(0.7, rel=1e-6)
    assert signed_volume(mesh) == pytest.approx(math.pi * 0.7**2 * 2.0, rel=0.01)
    # Rim vertices are split: the side has radial normals, the caps +-Y.
    on_rim = np.isclose(radial, 0.7) & np.isclose(np.abs(mesh.positions[:, 1]), 1.0)
    cap_normals = np.isclose(np.abs(mesh.normals[:, 1]), 1.0)
    assert (on_rim & cap_normals).sum() == (on_rim & ~cap_normals).sum() == 2 * 64


def test_torus() -> None:
    mesh = torus(2.0, 0.5)
    radial = np.linalg.norm(mesh.positions[:, [0, 2]], axis=1)
    assert radial.max() == pytest.approx(2.5, rel=1e-6)
    assert radial.min() == pytest.approx(1.5, rel=1e-6)
    assert np.abs(mesh.positions[:, 1]).max() == pytest.approx(0.5, rel=1e-6)
    assert signed_volume(mesh) == pytest.approx(2.0 * math.pi**2 * 2.0 * 0.5**2, rel=0.02)
    assert_closed_by_index(mesh)


def test_torus_knot() -> None:
    radius, tube, segments, sides = 1.0, 0.12, 256, 24
    mesh = torus_knot(2, 3, radius, tube, segments=segments, sides=sides)
    radial = np.linalg.norm(mesh.positions[:, [0, 2]], axis=1)
    assert radius <= radial.max() <= radius + tube + 1e-6
    assert np.abs(mesh.positions[:, 1]).max() <= radius / 3 + tube + 1e-6
    assert_closed_by_index(mesh)
    # The tube surface lies at distance `tube` from the curve, along its normal.
    rings = mesh.positions.reshape(sides, segments, 3).astype(np.float64)
    normals = mesh.normals.reshape(sides, segments, 3).astype(np.float64)
    centres = rings - tube * normals
    np.testing.assert_allclose(centres, np.broadcast_to(centres.mean(axis=0), centres.shape), atol=1e-5)
    # Normals are perpendicular to the curve and the frame never flips between neighbouring rings.
    curve = centres.mean(axis=0)
    tangent = np.roll(curve, -1, axis=0) - np.roll(curve, 1, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    assert np.abs(np.einsum("sij,ij->si", normals, tangent)).max() < 0.01
    assert np.einsum("sij,sij->si", normals, np.roll(normals, -1, axis=1)).min() > 0.95
    # A thin tube's volume is pi tube^2 times the curve length (polygon sections make it a bit less).
    length = np.linalg.norm(np.roll(curve, -1, axis=0) - curve, axis=1).sum()
    assert signed_volume(mesh) == pytest.approx(math.pi * tube**2 * length, rel=0.03)


def test_torus_knot_needs_coprime_windings() -> None:
    with pytest.raises(MeshError, match="coprime"):
        torus_knot(2, 4, 1.0, 0.1)


@pytest.mark.parametrize(
    "make",
    [
        lambda: plane(0.0, 1.0),
        lambda: box((1.0, -1.0, 1.0)),
        lambda: box((1.0, 1.0)),
        lambda: sphere(1.0, segments=2),
        lambda: cylinder(float("nan"), 1.0),
        lambda: torus(1.0, 0.2, sides=2),
    ],
)
def test_bad_sizes_raise_mesh_error(make: Callable[[], Mesh]) -> None:
    with pytest.raises(MeshError):
        make()


def rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """3x3 rotation matrix about a unit axis (Rodrigues)."""
    x, y, z = axis / np.linalg.norm(axis)
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * k @ k


def affine(linear: np.ndarray, translation: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> np.ndarray:
    model = np.eye(4)
    model[:3, :3] = linear
    model[:3, 3] = translation
    return model


SCALE_ROTATE = rotation(np.array([1.0, 2.0, 0.5]), 0.8) @ np.diag([3.0, 0.5, 1.7])


def test_transformed_plane_normals_stay_perpendicular() -> None:
    # Tilt the plane first: a normal along a scale axis would survive even a wrong normal matrix.
    tilted = plane(2.0, 2.0, subdivisions=3).transformed(affine(rotation(np.array([1.0, 0.0, 1.0]), 0.6)))
    moved = tilted.transformed(affine(SCALE_ROTATE, (1.0, -2.0, 0.5)))
    corners = triangle_corners(moved)
    shading = moved.normals.astype(np.float64)[moved.indices.astype(np.int64)]
    np.testing.assert_allclose(np.linalg.norm(moved.normals, axis=1), 1.0, atol=1e-6)
    for start, end in ((0, 1), (1, 2), (2, 0)):
        edge = corners[:, end] - corners[:, start]
        edge /= np.linalg.norm(edge, axis=1, keepdims=True)
        for corner in range(3):
            assert np.abs(np.einsum("ij,ij->i", edge, shading[:, corner])).max() < 1e-5
    assert outward_fraction(moved) == 1.0
    np.testing.assert_allclose(moved.positions.mean(axis=0), (1.0, -2.0, 0.5), atol=1e-6)


def test_transformed_sphere_normals_match_the_ellipsoid() -> None:
    moved = sphere(1.0, segments=48, rings=24).transformed(affine(SCALE_ROTATE))
    # The image is the ellipsoid x^T A x = 1 with A = (L L^T)^-1; its normal is along A x.
    quadric = np.linalg.inv(SCALE_ROTATE @ SCALE_ROTATE.T)
    expected = moved.positions.astype(np.float64) @ quadric.T
    expected /= np.linalg.norm(expected, axis=1, keepdims=True)
    np.testing.assert_allclose(moved.normals, expected, atol=1e-5)
    assert outward_fraction(moved) >= 0.99
    assert signed_volume(moved) == pytest.approx(
        signed_volume(sphere(1.0, 48, 24)) * np.linalg.det(SCALE_ROTATE), rel=1e-5)


def test_transformed_mirror_flips_winding() -> None:
    original = torus(2.0, 0.5, segments=32, sides=12)
    mirror = affine(np.diag([-1.0, 1.0, 1.0]) @ SCALE_ROTATE)
    moved = original.transformed(mirror)
    np.testing.assert_array_equal(moved.indices, original.indices[:, ::-1])
    assert outward_fraction(moved) >= 0.99
    assert signed_volume(moved) > 0.0
    # A proper rotation keeps the winding as it was.
    np.testing.assert_array_equal(original.transformed(affine(SCALE_ROTATE)).indices, original.indices)


def test_transformed_rejects_singular_and_projective_matrices() -> None:
    with pytest.raises(ValueError, match="singular"):
        box((1.0, 1.0, 1.0)).transformed(affine(np.diag([1.0, 0.0, 1.0])))
    projective = np.eye(4)
    projective[3, 2] = -1.0
    with pytest.raises(ValueError, match="affine"):
        box((1.0, 1.0, 1.0)).transformed(projective)


def test_interleaved_layout() -> None:
    mesh = sphere(1.0, segments=8, rings=4)
    rows = mesh.interleaved()
    assert rows.dtype == np.float32 and rows.shape == (len(mesh.positions), 8)
    assert rows.flags.c_contiguous
    np.testing.assert_array_equal(rows[:, :3], mesh.positions)
    np.testing.assert_array_equal(rows[:, 3:6], mesh.normals)
    np.testing.assert_array_equal(rows[:, 6:], 0.0)  # a sphere has no UVs: zeros
    textured = box((1.0, 2.0, 3.0))
    assert textured.uvs is not None
    np.testing.assert_array_equal(textured.interleaved()[:, 6:], textured.uvs)


@pytest.mark.parametrize("make", [lambda: textured_meshes.sphere(1.0, 16, 8), lambda: textured_meshes.cylinder(1.0, 2.0, 16),
                                  lambda: textured_meshes.torus(1.0, 0.3, 16, 8)], ids=["sphere", "cylinder", "torus"])
def test_textured_round_shapes_have_the_same_triangles_and_uvs_in_the_unit_square(make: Callable[[], Mesh]) -> None:
    mesh = make()
    assert mesh.uvs is not None and mesh.uvs.min() >= 0.0 and mesh.uvs.max() <= 1.0
    assert outward_fraction(mesh) >= 0.99
    assert len(np.unique(mesh.indices)) == len(mesh.positions)


def test_plane_and_box_uvs_show_the_image_upright_from_outside() -> None:
    # The plane: u along +x, v along +z (the image's top row at -z).
    flat = plane(2.0, 4.0)
    assert flat.uvs is not None
    np.testing.assert_allclose(flat.uvs, np.c_[flat.positions[:, 0] / 2.0 + 0.5, flat.positions[:, 2] / 4.0 + 0.5])
    # The box's +Z face: u to the right (+x), v down (-y), as a viewer in front of it sees it.
    cube = box((2.0, 2.0, 2.0))
    assert cube.uvs is not None
    front = cube.normals[:, 2] > 0.5
    np.testing.assert_allclose(cube.uvs[front], np.c_[cube.positions[front, 0] / 2 + 0.5, 0.5 - cube.positions[front, 1] / 2])


def test_mesh_arrays_are_read_only() -> None:
    mesh = box((1.0, 1.0, 1.0))
    with pytest.raises(ValueError):
        mesh.positions[0, 0] = 5.0


def test_mesh_rejects_out_of_range_indices() -> None:
    with pytest.raises(ValueError, match="indices"):
        Mesh(np.zeros((3, 3)), np.tile((0.0, 0.0, 1.0), (3, 1)), np.array([[0, 1, 3]]))


def write_icosphere(path: Path, subdivisions: int = 2) -> int:
    """Write a trimesh icosphere as OBJ and return its triangle count."""
    import trimesh

    shape = trimesh.creation.icosphere(subdivisions=subdivisions, radius=2.0)
    shape.export(path)
    return len(shape.faces)


def test_load_obj_written_by_trimesh(tmp_path: Path) -> None:
    clear_mesh_cache()
    path = tmp_path / "ball.obj"
    triangles = write_icosphere(path)
    mesh = load_mesh_file(path)
    assert mesh.indices.shape == (triangles, 3) and mesh.indices.dtype == np.uint32
    assert mesh.positions.dtype == np.float32 and mesh.normals.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(mesh.positions, axis=1), 2.0, rtol=1e-5)
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=1), 1.0, atol=1e-6)
    # Smooth normals of a sphere point along the position; the winding is outward.
    assert np.einsum("ij,ij->i", mesh.normals, mesh.positions / 2.0).min() > 0.98
    assert outward_fraction(mesh) == 1.0
    assert_closed_by_index(mesh)


def test_load_is_cached_until_the_file_changes(tmp_path: Path) -> None:
    clear_mesh_cache()
    path = tmp_path / "ball.obj"
    write_icosphere(path, subdivisions=1)
    first = load_mesh_file(path)
    assert load_mesh_file(tmp_path / "." / "ball.obj") is first
    triangles = write_icosphere(path, subdivisions=2)
    stat = path.stat()
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns + 10**9))  # filesystems with coarse mtimes
    second = load_mesh_file(path)
    assert second is not first and len(second.indices) == triangles


def test_load_stanford_bunny() -> None:
    if not BUNNY.is_file():
        pytest.skip(f"the Stanford bunny is not at {BUNNY}")
    mesh = load_mesh_file(BUNNY)
    assert len(mesh.indices) == pytest.approx(69451, rel=0.01)
    assert np.isfinite(mesh.normals).all()
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=1), 1.0, atol=1e-5)
    assert outward_fraction(mesh) >= 0.99
    assert load_mesh_file(BUNNY) is mesh


# Run first in a fresh interpreter: makes scipy unimportable, as on a machine without it.
_WITHOUT_SCIPY = textwrap.dedent("""
    import importlib.abc, sys

    class NoScipy(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path, target=None):
            if name.split(".")[0] == "scipy":
                raise ModuleNotFoundError(f"No module named {name!r}", name=name)
            return None

    sys.meta_path.insert(0, NoScipy())
""")


def test_load_without_scipy_prints_nothing_and_keeps_the_normals(tmp_path: Path) -> None:
    """trimesh sums vertex normals through a scipy sparse matrix; without scipy it logged a
    traceback and looped in Python (9 times slower on the bunny). Ours need numpy alone."""
    import trimesh

    rng = np.random.default_rng(21)
    lumpy = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    lumpy.vertices = lumpy.vertices * rng.uniform(0.7, 1.3, (len(lumpy.vertices), 1))  # unequal corner angles
    path = tmp_path / "lumpy.obj"
    lumpy.export(path)
    script = _WITHOUT_SCIPY + textwrap.dedent(f"""
        import numpy as np
        from pathlib import Path
        from depthimpostor.meshes import load_mesh_file
        np.save({str(tmp_path / "normals.npy")!r}, load_mesh_file(Path({str(path)!r})).normals)
        assert "scipy" not in sys.modules
    """)
    run = subprocess.run([sys.executable, "-c", script], check=False, capture_output=True, text=True, timeout=120,
                         cwd=Path(__file__).resolve().parents[1])
    assert run.returncode == 0 and run.stderr == "", run.stderr
    reference = trimesh.load(str(path), force="mesh")
    reference.merge_vertices(merge_tex=True, merge_norm=True)
    np.testing.assert_allclose(np.load(tmp_path / "normals.npy"), reference.vertex_normals, atol=1e-6)


@pytest.mark.parametrize(
    ("name", "content"),
    [
        ("garbage.obj", b"this is not\x00 a mesh \xff\xfe\n"),
        ("empty.obj", b""),
        ("points.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\n"),
        ("garbage.ply", b"ply\nformat nonsense\n"),
    ],
)
def test_load_unreadable_file_raises_mesh_error(tmp_path: Path, name: str, content: bytes) -> None:
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(MeshError, match=name) as caught:
        load_mesh_file(path)
    assert isinstance(caught.value, DepthImpostorError) and caught.value.exit_code == 2


def test_load_missing_file_raises_mesh_error(tmp_path: Path) -> None:
    with pytest.raises(MeshError, match="missing.obj"):
        load_mesh_file(tmp_path / "missing.obj")
    with pytest.raises(MeshError, match="not a regular file"):
        load_mesh_file(tmp_path)
