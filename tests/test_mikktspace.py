"""scene/mikktspace.py against mikktspace.c, and scene/tangents.py's split of the vertices whose
corners MikkTSpace gives different tangents. The reference tangents (tests/data/mikktspace/
reference.npz) are the C's, made by make_reference.py beside them with the throwaway driver
reference.c (neither is built here: the tests need no compiler)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from depthimpostor.scene.mikktspace import mikktspace
from depthimpostor.scene.tangents import generated_tangents

REFERENCE = np.load(Path(__file__).parent / "data" / "mikktspace" / "reference.npz")
NAMES = sorted({key.split("/")[0] for key in REFERENCE.files})


def _mesh(name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    positions, normals, faces, uvs = (REFERENCE[f"{name}/{key}"] for key in ("positions", "normals", "faces", "uvs"))
    return positions.astype(np.float64), normals.astype(np.float64), faces.astype(np.int64), uvs.astype(np.float64)


def test_the_meshes_hold_what_they_test() -> None:
    """Each reference mesh has the case it is named for (else its test could not fail there)."""
    assert set(NAMES) == {"sphere", "mirrored", "collapsed", "degenerate", "nonmanifold", "clearcoat"}
    for name in ("mirrored", "collapsed", "nonmanifold"):  # both orientations of the UV map
        assert set(np.unique(REFERENCE[f"{name}/tangents"][..., 3])) == {-1.0, 1.0}, name
    _, _, faces, uvs = _mesh("collapsed")  # triangles of no UV area (GROUP_WITH_ANY)
    d1, d2 = uvs[faces[:, 1]] - uvs[faces[:, 0]], uvs[faces[:, 2]] - uvs[faces[:, 0]]
    assert (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0] == 0.0).sum() > 10
    positions, _, faces, _ = _mesh("degenerate")
    corners = positions[faces]
    assert ((corners[:, 0] == corners[:, 1]).all(1) | (corners[:, 1] == corners[:, 2]).all(1)
            | (corners[:, 0] == corners[:, 2]).all(1)).sum() >= 2
    _, _, faces, _ = _mesh("nonmanifold")
    edges = np.sort(np.stack([faces, np.roll(faces, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
    assert np.unique(edges, axis=0, return_counts=True)[1].max() >= 3
    assert len(_mesh("clearcoat")[2]) > 2000


@pytest.mark.parametrize("name", NAMES)
def test_the_port_gives_mikktspace_cs_tangents(name: str) -> None:
    """Every corner's tangent and sign within 1e-5 of mikktspace.c's genTangSpaceDefault (float32
    there, so rounding apart): welding, degenerate triangles, groups by orientation (and the order
    in which triangles of no UV area join them), angle weights and subgroups of opposed tangents."""
    made = mikktspace(*_mesh(name))
    reference = REFERENCE[f"{name}/tangents"]
    assert made.shape == reference.shape
    np.testing.assert_allclose(made, reference, rtol=0.0, atol=1e-5)


def test_a_mirror_seam_splits_its_vertices() -> None:
    """Where the UVs mirror through shared vertices, the seam's vertices split in two (one per
    orientation), appended after the others; every corner has MikkTSpace's tangent with glTF's
    sign (negated: the bitangent points up the image), on the triangles it had."""
    positions, normals, faces, uvs = _mesh("mirrored")
    made = generated_tangents(positions, normals, faces, uvs)
    seam = np.flatnonzero(np.isclose(positions[:, 0], 0.0))
    assert len(made.vertices) == len(positions) + len(seam)
    np.testing.assert_array_equal(made.vertices[: len(positions)], np.arange(len(positions)))
    assert set(made.vertices[len(positions):]) == set(seam)
    np.testing.assert_array_equal(made.vertices[made.faces], faces)
    expected = REFERENCE["mirrored/tangents"].astype(np.float64) * (1.0, 1.0, 1.0, -1.0)
    np.testing.assert_allclose(made.tangents[made.faces], expected, atol=1e-5)


def test_a_mesh_whose_corners_agree_keeps_its_vertices() -> None:
    """The UV sphere (its seam doubled in the file already): no vertex splits."""
    positions, normals, faces, uvs = _mesh("sphere")
    made = generated_tangents(positions, normals, faces, uvs)
    np.testing.assert_array_equal(made.vertices, np.arange(len(positions)))
    np.testing.assert_array_equal(made.faces, faces)
    np.testing.assert_allclose(np.linalg.norm(made.tangents[:, :3], axis=1), 1.0, atol=1e-6)
    assert np.abs(np.einsum("ij,ij->i", made.tangents[:, :3], normals)).max() < 1e-6
