"""What start-up works out for many objects at once (issue 32: a scene of 1,000 objects started in
seconds) against the one-at-a-time steps it replaced, kept here as references: the depth images'
frusta, their records and view-projection matrices, the world vertices of objects of one mesh,
the image hierarchies, culling's triangle order, and the atlas that is no longer cleared when made.
"""

from __future__ import annotations

import moderngl
import numpy as np
import pytest
from numpy.typing import NDArray

from depthimpostor.constants import (
    BOUND_MARGIN, CLIP_TOLERANCE_PIXELS, CONTACT_DEPTH_TOLERANCE, MAX_SURFACE_SLOPE,
)
from depthimpostor.culling import _cones, _culled, _Cones, swept_spheres
from depthimpostor.geometry import ObjectGeometry, bounding_spheres, scene_geometry, world_vertex_groups
from depthimpostor.methods.atlas import ImpostorAtlas
from depthimpostor.methods.cubemaps import proxy_box
from depthimpostor.oracles.reference import DepthImageData
from depthimpostor.ppc import (
    PPC, FrustumFitError, depth_image_records, fit_frusta, orthonormal_frame, view_projections,
)
from depthimpostor.resolution import MirrorDensity
from depthimpostor.scene.model import BoxShape, CheckerMaterial, MirrorMaterial, SceneObject, SphereShape


def fitted_one_by_one(eye: NDArray[np.float64], points: NDArray[np.float64], center: NDArray[np.float64],
                      width: int, height: int) -> PPC:
    """PPC.fitted as it was before fit_frusta: one point set, its own steps."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3) - eye
    right, down, forward = orthonormal_frame(np.asarray(center, float) - eye, np.array([0.0, 1.0, 0.0]))
    z = pts @ forward
    extent = float(np.max(np.linalg.norm(pts, axis=1)))
    if extent == 0.0 or float(z.min()) <= 1e-3 * extent:
        raise FrustumFitError("refused")
    tan_x, tan_y = (pts @ right) / z, (pts @ down) / z
    x0, x1, y0, y1 = float(tan_x.min()), float(tan_x.max()), float(tan_y.min()), float(tan_y.max())
    span_x = max(x1 - x0, 1e-9) * (1.0 + 2.0 / width)
    span_y = max(y1 - y0, 1e-9) * (1.0 + 2.0 / height)
    x0 -= span_x / width
    y0 -= span_y / height
    a, b = right * (span_x / width), down * (span_y / height)
    return PPC(eye, a, b, forward + right * x0 + down * y0, width, height, float(z.min()) * 0.995, float(z.max()) * 1.005)


def random_sets(rng: np.random.Generator, count: int, size: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """`count` clouds of `size` float32 points around centres spread about the origin (some above
    and below it, where the frame's up hint is steep), and their centres."""
    directions = rng.normal(size=(count, 3))
    centres = directions / np.linalg.norm(directions, axis=1)[:, None] * rng.uniform(3.0, 8.0, (count, 1))
    centres[:3] = [(0.0, 6.0, 0.0), (0.0, -5.0, 0.0), (0.01, 7.0, 0.0)]  # straight up and down
    clouds = centres[:, None] + rng.normal(size=(count, size, 3)) * rng.uniform(0.05, 0.5, (count, 1, 3))
    return clouds.astype(np.float32).astype(np.float64), centres


def test_frusta_fitted_together_are_those_fitted_one_by_one() -> None:
    rng = np.random.default_rng(32)
    clouds, centres = random_sets(rng, 40, 300)
    eye = np.array([0.3, -0.2, 0.1])
    fits = fit_frusta(eye, clouds, centres)
    for fit, cloud, centre in zip(fits, clouds, centres, strict=True):
        assert fit is not None
        for width, height in ((64, 64), (128, 32)):
            camera, reference = fit.camera(width, height), fitted_one_by_one(eye, cloud, centre, width, height)
            for name in ("C", "a", "b", "c"):
                np.testing.assert_allclose(getattr(camera, name), getattr(reference, name), rtol=1e-6, atol=1e-12)
            assert camera.near == pytest.approx(reference.near, rel=1e-6)
            assert camera.far == pytest.approx(reference.far, rel=1e-6)
            assert (camera.width, camera.height) == (width, height)


def test_a_set_around_the_eye_is_refused_alone() -> None:
    rng = np.random.default_rng(3)
    clouds, centres = random_sets(rng, 5, 50)
    clouds[2] = rng.normal(size=(50, 3))  # around the eye at the origin
    fits = fit_frusta(np.zeros(3), clouds, centres)
    assert [fit is None for fit in fits] == [False, False, True, False, False]
    with pytest.raises(FrustumFitError):
        PPC.fitted(np.zeros(3), clouds[2], centres[2], 16, 16)


def scattered_objects(count: int) -> list[SceneObject]:
    """Spheres and boxes sharing two meshes, turned, scaled (one mirrored) and moved about, and a mirror."""
    rng = np.random.default_rng(11)
    objects = [SceneObject("mirror", SphereShape(1.0), MirrorMaterial(), position=(0.0, 1.0, 0.0))]
    for i in range(count):
        shape = SphereShape(0.2) if i % 2 else BoxShape((0.3, 0.2, 0.25))
        scale = (-1.2, 0.8, 1.0) if i == 5 else tuple(rng.uniform(0.5, 2.0, 3))
        objects.append(SceneObject(f"object {i}", shape, CheckerMaterial((0.9, 0.2, 0.1), (0.1, 0.1, 0.1)), position=tuple(rng.uniform(-6, 6, 3)),
                                   rotation=tuple(rng.uniform(0, 360, 3)), scale=scale))
    return objects


def test_world_vertices_placed_together_are_the_world_meshes_to_the_bit() -> None:
    geometry = scene_geometry(tuple(scattered_objects(60)))
    seen = 0
    for items, vertices in world_vertex_groups(geometry[1:]):
        assert vertices.dtype == np.float32 and vertices.shape[0] == len(items)
        for item, placed in zip(items, vertices, strict=True):
            np.testing.assert_array_equal(placed, item.world_mesh.positions)
            seen += 1
    assert seen == 60
    # The batches' bounding spheres are the properties' (Mesh.bounding_sphere's second candidate,
    # the box centre, wins for a box; the placed Ritter centre may win for a sphere).
    fresh = scene_geometry(tuple(scattered_objects(60)))
    for (centre, radius), item in zip(bounding_spheres(fresh), geometry, strict=True):
        mesh_centre, mesh_radius = item.world_mesh.bounding_sphere()
        assert radius <= mesh_radius * (1.0 + 1e-12) or np.allclose(centre, mesh_centre)
        assert np.all(np.linalg.norm(item.world_mesh.positions - centre, axis=1) <= radius)


def random_cameras(count: int) -> list[PPC]:
    rng = np.random.default_rng(5)
    clouds, centres = random_sets(rng, count, 60)
    fits = fit_frusta(np.zeros(3), clouds, centres)
    return [fit.camera(int(rng.choice([32, 64, 256])), int(rng.choice([32, 64]))) for fit in fits if fit is not None]


def hit_bound_one_by_one(camera: PPC, around: tuple[NDArray[np.float64], float]) -> NDArray[np.float64]:
    """PPC.hit_bound's steps for one camera."""
    grow = CLIP_TOLERANCE_PIXELS / max(camera.width, camera.height)
    w_far = camera.w_far * (1.0 + grow)
    texel = (np.linalg.norm(camera.a) + np.linalg.norm(camera.b)) * w_far
    rays = camera.ray_direction(np.array([0.0, 0.0, camera.width, camera.width]),
                                np.array([0.0, camera.height, 0.0, camera.height]))
    depth = CONTACT_DEPTH_TOLERANCE * w_far * w_far * (1.0 / camera.w_near - 1.0 / camera.w_far) * max(
        np.linalg.norm(rays, axis=1))
    radius = (around[1] + texel + depth) * (1.0 + BOUND_MARGIN)
    centre, frustum = camera.bound()
    return np.array([*around[0], radius]) if radius < frustum else np.array([*centre, frustum])


def test_records_made_together_are_each_cameras_own() -> None:
    cameras = random_cameras(30)
    rng = np.random.default_rng(9)
    # Half the images show one object (a sphere about the frustum's middle, some larger than it).
    arounds = [(camera.unproject(camera.width / 2, camera.height / 2, 1.5), float(rng.uniform(0.01, 50.0)))
               if i % 2 else None for i, camera in enumerate(cameras)]
    records = depth_image_records(cameras, list(range(len(cameras))), [(i, 2 * i) for i in range(len(cameras))],
                                  [(i, i, 3) for i in range(len(cameras))], arounds)
    for record, camera, around in zip(records, cameras, arounds, strict=True):
        for name, vector in (("a", camera.a), ("b", camera.b), ("c", camera.c)):
            np.testing.assert_allclose(record[name][:3], vector, rtol=1e-6)
        for row in range(3):
            np.testing.assert_allclose(record[f"inverse_row{row}"][:3], camera.inverse[row], rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(record["depth_range"], (camera.w_near, camera.w_far, camera.width, camera.height),
                                   rtol=1e-6)
        step = MAX_SURFACE_SLOPE * max(np.linalg.norm(camera.a), np.linalg.norm(camera.b)) / camera.focal
        np.testing.assert_allclose(record["surface"][:3], (step, 1 / camera.w_near, 1 / camera.w_near - 1 / camera.w_far),
                                   rtol=1e-6)
        centre, radius = camera.bound()
        np.testing.assert_allclose(record["bound"], (*centre, radius), rtol=1e-6)
        expected = np.array([*centre, radius]) if around is None else hit_bound_one_by_one(camera, around)
        np.testing.assert_allclose(record["hit_bound"], expected, rtol=1e-6)
        single = camera.depth_image_record(int(record["eye"][3]), tuple(record["tile"][:2]), tuple(record["pyramid"][:3]),
                                           around)
        assert single.tobytes() == record.tobytes()


def test_view_projections_made_together_are_each_cameras_own() -> None:
    cameras = random_cameras(30)
    # Looking straight down and up: orthonormal_frame's steep branch.
    cameras += [PPC.look_at((0.0, 5.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 40.0, 32, 32),
                PPC.look_at((0.0, -5.0, 0.0), (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), 40.0, 64, 32)]
    matrices = view_projections(cameras)
    for matrix, camera in zip(matrices, cameras, strict=True):
        np.testing.assert_allclose(matrix, camera.view_projection, rtol=1e-6, atol=1e-9)


def test_culling_does_not_depend_on_the_order_of_the_mirror_triangles() -> None:
    geometry = scene_geometry(tuple(scattered_objects(80)))
    cones = _cones(geometry[0])
    assert cones is not None
    centres, radii = swept_spheres(geometry[1:])
    order = np.random.default_rng(2).permutation(len(cones.corners))
    shuffled = _Cones(cones.corners[order], cones.reach_axis[order], cones.out_of_reach[order], cones.flat)
    culled = _culled([cones], centres, radii)
    np.testing.assert_array_equal(culled, _culled([shuffled], centres, radii))
    assert not culled.all()


def test_an_atlas_written_by_hand_has_no_back_colour_and_no_second_run_elsewhere(ctx: moderngl.Context) -> None:
    """Making an atlas clears nothing (the first bake clears it whole); a tile written by hand
    first clears what the bake would have: the back colour to (1, 1, 1, 0), the second runs to 0."""
    atlas = ImpostorAtlas(ctx, 2, 8, back_colors=True, beyond=True)
    try:
        camera = PPC.look_at((0.0, 0.0, 3.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), 40.0, 8, 8)
        data = DepthImageData(camera, np.full((8, 8, 3), 0.5), np.full((8, 8), 0.5, np.float32), 1,
                              np.full((8, 8), 0.7, np.float32))
        atlas.write(atlas.tile_origin(0), data)
        other = (*atlas.tile_origin(1), 8, 8)
        assert atlas.back_color is not None and atlas.beyond is not None
        back = np.frombuffer(atlas.back_color.read(), np.uint8).reshape(atlas.size[1], atlas.size[0], 4)
        x, y = other[:2]
        np.testing.assert_array_equal(back[y:y + 8, x:x + 8], np.broadcast_to((255, 255, 255, 0), (8, 8, 4)))
        beyond = np.frombuffer(atlas.beyond.read(), np.float32).reshape(atlas.size[1], atlas.size[0])
        np.testing.assert_array_equal(beyond[y:y + 8, x:x + 8], 0.0)
        assert not atlas.unwritten
    finally:
        atlas.release()


def test_the_proxy_box_is_the_world_meshes_bounds() -> None:
    geometry = scene_geometry(tuple(scattered_objects(40)))
    lower, upper = proxy_box(geometry[0], geometry[1:])
    fresh = scene_geometry(tuple(scattered_objects(40)))
    points = np.concatenate([item.world_mesh.positions for item in fresh])
    np.testing.assert_array_equal(lower, points.min(axis=0))
    np.testing.assert_array_equal(upper, points.max(axis=0))


def pixels_per_radian_alone(view: PPC, mirror: ObjectGeometry, target: ObjectGeometry) -> float:
    """resolution.reflected_pixels_per_radian as it was before MirrorDensity: every mirror
    triangle's figures worked out again for each object."""
    def unit(v: NDArray[np.float64]) -> NDArray[np.float64]:
        length = np.linalg.norm(v, axis=-1, keepdims=True)
        return v / np.where(length > 0.0, length, 1.0)

    mesh = mirror.world_mesh
    corners = mesh.positions[mesh.indices].astype(np.float64)
    normals = unit(mesh.normals[mesh.indices].astype(np.float64))
    face = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    incoming = unit(corners - view.C)
    projected = view.project(corners)
    inside = (projected[..., 0] >= 0) & (projected[..., 0] <= view.width) & \
             (projected[..., 1] >= 0) & (projected[..., 1] <= view.height)
    seen = (np.einsum("tj,tj->t", face, corners[:, 0] - view.C) < 0.0) & np.all(projected[..., 2] > 0.0, axis=1) \
        & np.any(inside, axis=1)
    reflected = incoming - 2.0 * np.einsum("tij,tij->ti", incoming, normals)[..., None] * normals
    mean = unit(reflected.sum(axis=1))
    spread = np.arccos(np.clip(np.einsum("tij,tj->ti", reflected, mean), -1.0, 1.0)).max(axis=1)
    centre, radius = target.bounding_sphere
    centroid = corners.mean(axis=1)
    toward = np.asarray(centre, np.float64) - centroid
    distance = np.maximum(np.linalg.norm(toward, axis=1), 1e-300)
    sphere_angle = np.arcsin(np.clip(radius / distance, 0.0, 1.0))
    extent = np.linalg.norm(corners - centroid[:, None], axis=2).max(axis=1)
    apex_angle = np.arcsin(np.clip(extent / distance, 0.0, 1.0))
    angle = np.arccos(np.clip(np.einsum("tj,tj->t", unit(toward), mean), -1.0, 1.0))
    chosen = seen & (angle <= sphere_angle + spread + apex_angle)
    if not chosen.any():
        return 0.0
    uv, r = projected[chosen][..., :2], reflected[chosen]
    edge_1, edge_2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    area = 0.5 * np.abs(edge_1[:, 0] * edge_2[:, 1] - edge_1[:, 1] * edge_2[:, 0])
    triple = np.abs(np.einsum("tj,tj->t", r[:, 0], np.cross(r[:, 1], r[:, 2])))
    denominator = 1.0 + np.einsum("tj,tj->t", r[:, 0], r[:, 1]) + np.einsum("tj,tj->t", r[:, 1], r[:, 2]) \
        + np.einsum("tj,tj->t", r[:, 2], r[:, 0])
    total = float((2.0 * np.arctan2(triple, denominator)).sum())
    return float(np.sqrt(float(area.sum()) / total)) if total > 0.0 else 0.0


def test_a_mirrors_density_made_once_gives_each_objects_own_to_the_bit() -> None:
    """impostor_resolution = "auto" works a mirror's reflected pixels out once for all its images
    (MirrorDensity), in blocks of objects: each object's figure is the one worked out for it alone, some of them 0
    (objects the view cannot see in the mirror)."""
    geometry = scene_geometry(tuple(scattered_objects(150)))  # more than a block of objects (_TARGETS_AT_ONCE)
    view = PPC.look_at((0.5, 2.5, 7.0), (0.0, 1.0, 0.0), (0.0, 1.0, 0.0), 45.0, 320, 180)
    figures = MirrorDensity(view, geometry[0]).pixels_per_radian_of(geometry[1:])
    assert figures == [pixels_per_radian_alone(view, geometry[0], item) for item in geometry[1:]]
    assert any(figures) and not all(figures)
