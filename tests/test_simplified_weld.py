"""The simplified method welds a mesh's vertices of one position before decimating it
(methods/simplified.welded), in numpy, as trimesh's `Trimesh(..., process=True)` did: the same
arrays to the bit, so that the decimation, and every simplified frame, is the one it was."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from depthimpostor import meshes
from depthimpostor.meshes import Mesh, load_mesh_file
from depthimpostor.methods.simplified import welded

SCENES = Path(__file__).resolve().parents[1] / "scenes"


def shipped_and_procedural() -> list[tuple[str, Mesh]]:
    made = [("sphere", meshes.sphere(0.5)), ("box", meshes.box((1.0, 2.0, 0.5))), ("cylinder", meshes.cylinder(0.3, 1.0)),
            ("torus", meshes.torus(1.0, 0.25)), ("torus knot", meshes.torus_knot(2, 3, 1.0, 0.2)),
            ("plane", meshes.plane(2.0, 3.0, 4)), ("bunny", load_mesh_file(SCENES / "stanford-bunny.ply"))]
    return made


@pytest.mark.parametrize(("name", "mesh"), shipped_and_procedural(), ids=[name for name, _ in shipped_and_procedural()])
def test_welded_is_trimeshs_merge_to_the_bit(name: str, mesh: Mesh) -> None:
    reference = trimesh.Trimesh(mesh.positions, mesh.indices, process=True)
    vertices, faces = welded(mesh.positions, mesh.indices)
    assert vertices.dtype == np.float64 and faces.dtype == np.int64
    np.testing.assert_array_equal(vertices, reference.vertices)
    np.testing.assert_array_equal(faces, reference.faces)
    if name in ("box", "cylinder"):  # their creases' vertices were joined
        assert len(vertices) < len(mesh.positions)


def test_welded_drops_unreferenced_vertices_and_joins_positions_within_the_tolerance() -> None:
    """Vertices no face names go; positions equal to 8 decimals are one vertex (the first one's);
    the order is that of first use, as trimesh keeps it."""
    rng = np.random.default_rng(7)
    points = rng.uniform(-1.0, 1.0, (40, 3))
    points[30:] = points[:10] + 1e-10  # the same positions, but for less than the tolerance
    faces = rng.integers(0, 40, (60, 3))
    faces[faces == 17] = 18  # vertex 17 unreferenced
    reference = trimesh.Trimesh(points, faces, process=True)
    vertices, welded_faces = welded(points, faces)
    np.testing.assert_array_equal(vertices, reference.vertices)
    np.testing.assert_array_equal(welded_faces, reference.faces)
    assert len(vertices) <= 29
