"""Start-up's work over many vertices, done a chunk of sets at a time in arrays made once (issue 32:
a thousand objects' fits spent most of their time faulting in fresh pages), against the whole-array
steps it replaced, kept here as references: the same frusta and the same bounding spheres, to the bit.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.typing import NDArray

from depthimpostor import geometry, ppc
from depthimpostor.geometry import ObjectGeometry, scene_geometry, world_vertex_groups
from depthimpostor.meshes import ritter_centres
from depthimpostor.ppc import FrustumFit, fit_frusta, orthonormal_frames
from depthimpostor.scene.model import BoxShape, CheckerMaterial, SceneObject, SphereShape


def whole_array_extremes(eye: NDArray[np.float64], points: NDArray[np.floating], centres: NDArray[np.float64]
                         ) -> tuple[NDArray[np.float64], ...]:
    """fit_frusta's bounds as it found them before it worked in chunks: every set's points at once."""
    pts = np.array(points, dtype=np.float64)
    pts -= eye
    right, down, forward = (frame[:, :, None] for frame in orthonormal_frames(centres - eye, np.array([0.0, 1.0, 0.0])))
    z = np.matmul(pts, forward)[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        tan_x = np.matmul(pts, right)[..., 0] / z
        tan_y = np.matmul(pts, down)[..., 0] / z
    return z.min(axis=1), z.max(axis=1), tan_x.min(axis=1), tan_x.max(axis=1), tan_y.min(axis=1), tan_y.max(axis=1)


def clouds(rng: np.random.Generator, count: int, size: int) -> tuple[NDArray[np.float32], NDArray[np.float64]]:
    """`count` float32 clouds of `size` points around centres about the origin, some straight above
    and below it (the frame's steep case), and their centres."""
    directions = rng.normal(size=(count, 3))
    centres = directions / np.linalg.norm(directions, axis=1)[:, None] * rng.uniform(2.0, 9.0, (count, 1))
    centres[:2] = [(0.0, 6.0, 0.0), (0.0, -5.0, 0.0)][:count]
    points = centres[:, None] + rng.normal(size=(count, size, 3)) * rng.uniform(0.05, 0.8, (count, 1, 3))
    return points.astype(np.float32), centres


def fit_values(fit: FrustumFit | None) -> list[object]:
    assert fit is not None
    return [fit.eye.tolist(), fit.right.tolist(), fit.down.tolist(), fit.forward.tolist(), fit.tan_x, fit.tan_y, fit.depth]


@pytest.mark.parametrize("chunk", [1, 700, 2**16])  # a set a chunk, a few sets a chunk, all in one
def test_frusta_fitted_in_chunks_are_those_fitted_whole_to_the_bit(monkeypatch: pytest.MonkeyPatch, chunk: int) -> None:
    monkeypatch.setattr(ppc, "FIT_CHUNK_POINTS", chunk)
    rng = np.random.default_rng(39)
    eye = np.array([0.25, -0.5, 0.125])
    for count, size in ((37, 150), (5, 1000), (1, 3)):  # (the last chunk part full)
        points, centres = clouds(rng, count, size)
        fits = fit_frusta(eye, points, centres)
        reference = whole_array_extremes(eye, points, centres)
        for i, fit in enumerate(fits):
            assert fit is not None
            assert (fit.depth, fit.tan_x, fit.tan_y) == ((reference[0][i], reference[1][i]), (reference[2][i], reference[3][i]),
                                                        (reference[4][i], reference[5][i]))
            # ... and as each set fitted alone (PPC.fitted's call), the same camera to the bit.
            alone = fit_frusta(eye, points[i:i + 1], centres[i:i + 1])[0]
            assert fit_values(fit) == fit_values(alone)
            camera, own = fit.camera(64, 32), alone.camera(64, 32) if alone is not None else None
            assert own is not None and all(np.array_equal(getattr(camera, name), getattr(own, name)) for name in "Cabc")


def test_a_set_around_the_eye_is_refused_in_any_chunk(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(ppc, "FIT_CHUNK_POINTS", 100)
    rng = np.random.default_rng(4)
    points, centres = clouds(rng, 9, 40)
    points[6] = rng.normal(size=(40, 3))  # around the eye at the origin, in the fourth chunk of two sets
    assert [fit is None for fit in fit_frusta(np.zeros(3), points, centres)] == [i == 6 for i in range(9)]


def whole_array_spheres(items: list[ObjectGeometry]) -> list[tuple[NDArray[np.float64], float]]:
    """The bounding spheres of items of one mesh as they were found before placing worked in chunks."""
    models = np.stack([item.model_matrix for item in items])
    local = items[0].local_mesh.positions.astype(np.float64)
    points = np.matmul(local, models[:, :3, :3].transpose(0, 2, 1))
    points += models[:, None, :3, 3]
    columns = [points.astype(np.float32)[:, :, axis].astype(np.float64) for axis in range(3)]
    placed = models[:, :3, :3] @ ritter_centres(local[None])[0] + models[:, :3, 3]
    box = np.stack([0.5 * (column.min(axis=1) + column.max(axis=1)) for column in columns], axis=1)
    radii = [np.sqrt(sum(np.square(column - centre[:, axis, None]) for axis, column in enumerate(columns)).max(axis=1))
             for centre in (placed, box)]
    return [(placed[i], float(radii[0][i])) if radii[0][i] <= radii[1][i] else (box[i], float(radii[1][i]))
            for i in range(len(items))]


@pytest.mark.parametrize("chunk", [1, 1500, 2**15])
def test_objects_placed_in_chunks_have_the_whole_array_spheres_to_the_bit(monkeypatch: pytest.MonkeyPatch, chunk: int) -> None:
    monkeypatch.setattr(geometry, "PLACE_CHUNK_POINTS", chunk)
    rng = np.random.default_rng(8)
    objects = [SceneObject(f"object {i}", SphereShape(0.3) if i % 3 else BoxShape((0.4, 0.2, 0.3)),
                           CheckerMaterial((0.9, 0.2, 0.1), (0.1, 0.1, 0.1)), position=tuple(rng.uniform(-5, 5, 3)),
                           rotation=tuple(rng.uniform(0, 360, 3)), scale=(-1.5, 0.5, 1.0) if i == 4 else tuple(rng.uniform(0.5, 2.0, 3)))
               for i in range(70)]
    seen = 0
    for items, vertices in world_vertex_groups(scene_geometry(tuple(objects)), spheres=True):
        assert len(items) > 1  # (every object here is placed with others of its mesh)
        for item, placed, (centre, radius) in zip(items, vertices, whole_array_spheres(items), strict=True):
            np.testing.assert_array_equal(placed, item.world_mesh.positions)
            assert item.bounding_sphere[0].tolist() == centre.tolist() and item.bounding_sphere[1] == radius
            seen += 1
    assert seen == 70
