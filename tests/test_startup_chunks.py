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
from depthimpostor.methods import image_cells
from depthimpostor.methods.billboards import quad_hit_bounds
from depthimpostor.constants import BOUND_MARGIN
from depthimpostor.ppc import PPC, FrustumFit, depth_image_records, fit_frusta, orthonormal_frames
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


def test_normal_matrices_worked_out_together_are_each_objects_own() -> None:
    objects = [SceneObject(f"object {i}", SphereShape(0.3), CheckerMaterial((0.9, 0.2, 0.1), (0.1, 0.1, 0.1)),
                           position=(float(i), 0.0, 0.0), rotation=(10.0 * i, 7.0 * i, 3.0 * i),
                           scale=(-1.5, 0.5, 1.0) if i == 4 else (0.5 + 0.1 * i, 1.0, 2.0 - 0.05 * i)) for i in range(30)]
    together, alone = scene_geometry(tuple(objects)), scene_geometry(tuple(objects))
    geometry.linear_transforms(together)
    for item, own in zip(together, alone, strict=True):
        assert "normal_matrix" in item.__dict__ and "determinant" in item.__dict__
        assert item.normal_matrix.tolist() == own.normal_matrix.tolist() and item.determinant == own.determinant
    assert together[4].determinant < 0.0


def test_a_singular_transform_leaves_every_normal_matrix_to_its_property() -> None:
    flat = SceneObject("flat", SphereShape(0.3), CheckerMaterial((0.9, 0.2, 0.1), (0.1, 0.1, 0.1)), scale=(1.0, 0.0, 1.0))
    items = scene_geometry((flat, *(SceneObject(f"ball {i}", SphereShape(0.3), CheckerMaterial((0.9, 0.2, 0.1), (0.1, 0.1, 0.1)),
                                                position=(float(i), 1.0, 0.0)) for i in range(3))))
    geometry.linear_transforms(items)
    assert not any("normal_matrix" in item.__dict__ for item in items)
    with pytest.raises(np.linalg.LinAlgError):
        _ = items[0].normal_matrix


def face_ranges_as_they_were(spheres: NDArray[np.float64], centre: NDArray[np.float64], radius: float,
                             size: image_cells.GridSize, face: int) -> tuple[NDArray[np.int64], ...]:
    """image_cells._face_ranges of one face, as it was found before the six were found at once."""
    axis, first, second = image_cells.FACE_AXES[face // 2]
    margin = image_cells.MARGIN
    reach = max(radius, 1e-12) * (1.0 + margin)
    extent = 2.0 * reach
    offset = spheres[:, :3] - centre
    r = spheres[:, 3] + margin * (np.linalg.norm(offset, axis=1) + spheres[:, 3] + reach)
    depth = (-1.0 if face % 2 else 1.0) * offset[:, axis]
    near, far = np.maximum(depth - r, -reach), depth + r
    edges = np.linspace(-1.0, 1.0, size.directions + 1)
    lower, upper = edges[:-1] - margin, edges[1:] + margin
    corners = np.stack([near[:, None] * lower, near[:, None] * upper, far[:, None] * lower, far[:, None] * upper])
    ranges = []
    for along in (offset[:, first], offset[:, second]):
        cell = size.offsets / (2.0 * extent)
        low = np.maximum(np.floor(((along - r)[:, None] - corners.max(axis=0) + extent) * cell - margin).astype(np.int64), 0)
        high = np.minimum(np.floor(((along + r)[:, None] - corners.min(axis=0) + extent) * cell + margin).astype(np.int64),
                          size.offsets - 1)
        ranges += [low, np.where((far >= -reach)[:, None], np.maximum(high - low + 1, 0), 0)]
    return ranges[0], ranges[1], ranges[2], ranges[3]


def lists_as_they_were(spheres: NDArray[np.float64], centre: NDArray[np.float64], radius: float) -> NDArray[np.int32]:
    """image_cells.image_cells as it was before the keys were made at once: each face's ranges apart,
    its (cell, image) pairs gathered from index arrays, concatenated, sorted as cell * count + image,
    split by division."""
    size = image_cells.grid_size(len(spheres))
    cells, entries = [], []
    for face in range(6):
        low1, count1, low2, count2 = face_ranges_as_they_were(spheres, centre, radius, size, face)
        image1, u_cell, q1 = image_cells._rows(count1, low1)
        image2, v_cell, q2 = image_cells._rows(count2, low2)
        per_image2 = np.bincount(image2, minlength=len(spheres))
        start2 = np.concatenate([[0], np.cumsum(per_image2)[:-1]])
        repeats = per_image2[image1]
        pair1 = np.repeat(np.arange(len(image1)), repeats)
        pair2 = start2[image1[pair1]] + np.arange(len(pair1)) - np.repeat(np.cumsum(repeats) - repeats, repeats)
        d, o = size.directions, size.offsets
        cells.append((((face * d + u_cell[pair1]) * d + v_cell[pair2]) * o + q1[pair1]) * o + q2[pair2])
        entries.append(image1[pair1])
    count = max(len(spheres), 1)
    keys = np.concatenate([*cells, np.full(len(spheres), size.cells)]) * count + np.concatenate([*entries, np.arange(len(spheres))])
    keys.sort()
    starts = size.cells + 2 + np.concatenate([[0], np.cumsum(np.bincount(keys // count, minlength=size.cells + 1))])
    return np.concatenate([starts, keys % count]).astype(np.int32)


@pytest.mark.parametrize("count", [0, 1, 3, 40, 300, 1500])  # (past 256 images, the finer grid)
def test_the_lists_made_by_keys_at_once_are_those_made_before(count: int) -> None:
    rng = np.random.default_rng(count)
    spheres = np.column_stack([rng.normal(size=(count, 3)) * 4.0, rng.uniform(0.01, 1.5, count)])
    spheres[:count // 10, :3] = rng.normal(size=(count // 10, 3)) * 0.3  # some about the mirror, in reach of every cell
    centre, radius = rng.normal(size=3) * 0.2, float(rng.uniform(0.2, 1.0))
    made = image_cells.image_cells(spheres, centre, radius)
    assert made.dtype == np.int32 and made.tolist() == lists_as_they_were(spheres, centre, radius).tolist()
    assert len(image_cells.cells_table(spheres, centre, radius)) == image_cells.cells_table_bytes(spheres, centre, radius)


def quad_bounds_one_by_one(records: NDArray[np.void], cameras: list[PPC],
                           arounds: list[tuple[NDArray[np.float64], float] | None]) -> None:
    """quad_hit_bounds as it was before its steps took every billboard at once: each row its own."""
    for row, (camera, around) in enumerate(zip(cameras, arounds, strict=True)):
        if around is None:
            continue
        centre, r = np.asarray(around[0], np.float64), float(around[1])
        d = float(np.linalg.norm(centre - camera.C))
        quad_w = float(((centre - camera.C) @ np.linalg.inv(np.column_stack([camera.a, camera.b, camera.c])).T)[2])
        texel = (np.linalg.norm(camera.a) + np.linalg.norm(camera.b)) * quad_w
        with np.errstate(invalid="ignore", divide="ignore"):
            radius = (r * d / np.sqrt(d * d - r * r) + texel) * (1.0 + BOUND_MARGIN)
        tighter = d > r and radius < records["bound"][row][3]
        records["hit_bound"][row] = (*centre, radius) if tighter else records["bound"][row]


def test_billboards_bounds_taken_together_are_each_ones_own() -> None:
    rng = np.random.default_rng(12)
    points, centres = clouds(rng, 60, 40)
    points[::7] = (centres[::7, None] + rng.normal(size=(len(points[::7]), 40, 3)) * [0.01, 0.01, 2.0]).astype(np.float32)  # rods
    fits = fit_frusta(np.zeros(3), points, centres)
    cameras = [fit.camera(64, 64) for fit in fits if fit is not None]
    arounds: list[tuple[NDArray[np.float64], float] | None] = [
        None if i % 5 == 3 else (centre, float(np.linalg.norm(cloud - centre, axis=1).max()))
        for i, (cloud, centre) in enumerate(zip(points, centres, strict=True)) if fits[i] is not None]
    made = depth_image_records(cameras, [0] * len(cameras), [(0, 0)] * len(cameras), [(0, 0, 0)] * len(cameras), arounds)
    reference = made.copy()
    quad_hit_bounds(made, cameras, arounds)
    quad_bounds_one_by_one(reference, cameras, arounds)
    assert made.tobytes() == reference.tobytes()
    assert (made["hit_bound"][:, 3] < made["bound"][:, 3]).sum() > len(cameras) // 2  # (most are the quads' own)
