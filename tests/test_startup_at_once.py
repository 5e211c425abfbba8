"""Start-up steps worked out for every object or image at once (issue 32: a scene of 1,000 objects
starts in under 2 s) against the one-at-a-time steps they replaced, kept here as references, to
the bit: the objects' placement (model) matrices, the depth images' cameras from their frusta, what
culling's runs of mirror triangles find, a batch's instance records,
the material records.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from depthimpostor import culling
from depthimpostor.culling import _cones, _culled, _runs, swept_spheres
from depthimpostor.geometry import ObjectGeometry, linear_transforms, scene_geometry, triangle_offsets
from depthimpostor.gpu import uniforms
from depthimpostor.gpu.batches import INSTANCE_DTYPE, instance_records
from depthimpostor.ppc import PPC, FrustumFit, fit_frusta, fitted_cameras
from depthimpostor.scene.model import (
    Animation, BoxShape, CheckerMaterial, DiffuseMaterial, MetallicRoughnessMaterial, MirrorMaterial, PlaneShape, Scene,
    SceneObject, SphereShape, material_sides, placement_matrices,
)
from depthimpostor.constants import MATERIAL, MaterialKind
from depthimpostor.errors import SceneError
from depthimpostor.scene import limits, load_scene

DEFAULT_SCENE = Path(__file__).resolve().parent.parent / "scenes" / "default.toml"



def model_matrix_one_by_one(obj: SceneObject) -> np.ndarray:
    """SceneObject.model_matrix at time 0 of an object that does not move, as it was worked out
    alone: three np.eye turns and np.diag's scale, multiplied in turn."""
    def turn(axis: int, degrees: float) -> np.ndarray:
        c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
        i, j = ((1, 2), (2, 0), (0, 1))[axis]
        r = np.eye(3)
        r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
        return r

    rx, ry, rz = obj.rotation
    m = np.eye(4)
    m[:3, :3] = turn(2, rz) @ turn(1, ry) @ turn(0, rx) @ np.diag(obj.scale)
    m[:3, 3] = obj.position
    return m


def random_objects(count: int, seed: int) -> list[SceneObject]:
    """Objects turned by any angle (a third of them by round ones: 0, 90, 180, ..., whose sines
    and cosines are exact or nearly), scaled by any factor (negative ones mirror), anywhere."""
    rng = np.random.default_rng(seed)

    def angle() -> float:
        return float(rng.choice([0.0, 90.0, -90.0, 180.0, 270.0, 360.0, 45.0, 30.0])) if rng.random() < 0.3 \
            else float(rng.uniform(-720.0, 720.0))

    def factor() -> float:
        return float(rng.choice([1.0, -1.0, 0.5, 1e-3, 3.0]) * rng.uniform(0.1, 10.0)) if rng.random() < 0.7 else 1.0

    return [SceneObject(f"o{i}", SphereShape(1.0) if i % 2 else BoxShape((1.0, 2.0, 0.5)),
                        position=(float(rng.uniform(-50, 50)), float(rng.uniform(-5, 5)), float(rng.normal(0, 100))),
                        rotation=(angle(), angle(), angle()), scale=(factor(), factor(), factor()))
            for i in range(count)]


def test_placement_matrices_are_each_objects_own_to_the_bit() -> None:
    objects = random_objects(3000, 39)
    models = placement_matrices(objects)
    assert models.shape == (3000, 4, 4) and models.dtype == np.float64
    for model, obj in zip(models, objects, strict=True):
        reference = model_matrix_one_by_one(obj)
        assert model.tobytes() == reference.tobytes()  # signed zeros too
        assert model.tobytes() == obj.model_matrix().tobytes()


def test_a_moving_objects_model_matrix_is_its_animation_after_its_placement() -> None:
    """model_matrix places an object through placement_matrices, moving or not: at any time its
    animation's matrix times the placement worked out alone, to the bit."""
    for i, obj in enumerate(random_objects(200, 3)):
        turning = dataclasses.replace(obj, animation=Animation("rotate", (0.0, 1.0, 0.0), 30.0) if i % 2 else
                                      Animation("orbit", (0.0, 0.0, 1.0), 45.0, centre=(1.0, 2.0, 3.0)))
        for time in (0.0, 0.7, 3.1):
            animated = turning.animation.matrix(time, turning.animation.pivot_of(turning.position))
            assert turning.model_matrix(time).tobytes() == (animated @ model_matrix_one_by_one(turning)).tobytes()


def test_linear_transforms_give_still_objects_their_own_model_matrices_and_leave_moving_ones() -> None:
    turning = SceneObject("turning", SphereShape(1.0), position=(3.0, 0.0, 0.0), rotation=(10.0, 20.0, 30.0),
                          animation=Animation("rotate", (0.0, 1.0, 0.0), 30.0))
    objects = (*random_objects(40, 2), turning)
    items = [item.at(0.7) for item in scene_geometry(objects)]
    linear_transforms(items)
    for item in items[:-1]:
        assert item.model_matrix.tobytes() == model_matrix_one_by_one(item.object).tobytes()
        item.model_matrix[0, 0] = 1e9  # each its own array: writing one leaves the others
    assert "model_matrix" not in items[-1].__dict__ or items[-1].model_matrix.tobytes() == \
        turning.model_matrix(0.7).tobytes()
    fresh = ObjectGeometry(items[-1].index, turning, items[-1].local_mesh, 0.7)
    assert items[-1].model_matrix.tobytes() == fresh.model_matrix.tobytes()
    assert all(item.model_matrix[0, 0] == 1e9 for item in items[:-1])


def camera_one_by_one(fit: FrustumFit, width: int, height: int) -> PPC:
    """FrustumFit.camera as it was before fitted_cameras: Python floats and one fit's vectors."""
    (x0, x1), (y0, y1) = fit.tan_x, fit.tan_y
    span_x = max(x1 - x0, 1e-9) * (1.0 + 2.0 / width)
    span_y = max(y1 - y0, 1e-9) * (1.0 + 2.0 / height)
    x0 -= span_x / width
    y0 -= span_y / height
    a = fit.right * (span_x / width)
    b = fit.down * (span_y / height)
    c = fit.forward + fit.right * x0 + fit.down * y0
    return PPC(fit.eye, a, b, c, int(width), int(height), fit.depth[0] * 0.995, fit.depth[1] * 1.005)


def test_cameras_made_together_are_those_made_one_by_one_to_the_bit() -> None:
    rng = np.random.default_rng(32)
    directions = rng.normal(size=(300, 3))
    centres = directions / np.linalg.norm(directions, axis=1)[:, None] * rng.uniform(3.0, 8.0, (300, 1))
    clouds = centres[:, None] + rng.normal(size=(300, 50, 3)) * rng.uniform(0.01, 0.8, (300, 1, 3))
    clouds[5] = centres[5]  # every point at one place: the 1e-9 spans
    eye = np.array([0.3, -0.2, 0.1])
    fits = [fit for fit in fit_frusta(eye, clouds, centres) if fit is not None]
    assert len(fits) == 300
    for width, height in ((128, 128), (64, 16), (1, 3)):
        for camera, fit in zip(fitted_cameras(fits, width, height), fits, strict=True):
            reference = camera_one_by_one(fit, width, height)
            for name in ("C", "a", "b", "c"):
                assert getattr(camera, name).tobytes() == getattr(reference, name).tobytes()
            assert (camera.width, camera.height, camera.near, camera.far) == \
                (reference.width, reference.height, reference.near, reference.far)
            assert type(camera.near) is float and type(camera.width) is int
            assert fit.camera(width, height).a.tobytes() == reference.a.tobytes()
    assert fitted_cameras([], 8, 8) == []


def test_culling_runs_cover_every_triangle_once_growing_to_the_longest() -> None:
    for triangles in (0, 1, 3, 4, 5, 60, 61, 9024):
        runs = _runs(triangles)
        assert [i for first, last in runs for i in range(first, last)] == list(range(triangles))
        sizes = [last - first for first, last in runs]
        assert all(size <= culling._TRIANGLE_RUN for size in sizes)
        assert sizes[:-1] == [min(culling._FIRST_RUN * 2**k, culling._TRIANGLE_RUN) for k in range(len(sizes) - 1)]


@pytest.mark.parametrize("mirror", [SphereShape(1.0), PlaneShape((3.0, 2.0)), BoxShape((1.0, 2.0, 0.5))])
def test_culling_in_growing_runs_finds_what_every_triangle_at_once_found(monkeypatch: pytest.MonkeyPatch,
                                                                         mirror: object) -> None:
    """The runs (few triangles first, then more) cull the spheres that every triangle tested
    against every sphere in one run culls (what a sphere's tests give does not depend on the
    run it is in: each is its own element's arithmetic)."""
    rng = np.random.default_rng(5)
    objects = [SceneObject("mirror", mirror, MirrorMaterial(), rotation=(20.0, 30.0, 0.0))]  # type: ignore[arg-type]
    objects += [SceneObject(f"o{i}", SphereShape(float(rng.uniform(0.05, 0.6))), position=tuple(rng.uniform(-4, 4, 3)))
                for i in range(400)]
    geometry = scene_geometry(tuple(objects))
    cones = _cones(geometry[0])
    assert cones is not None
    centres, radii = swept_spheres(geometry[1:])
    culled = _culled([cones], centres, radii)
    monkeypatch.setattr(culling, "_FIRST_RUN", len(cones.corners))
    monkeypatch.setattr(culling, "_TRIANGLE_RUN", len(cones.corners))
    assert _runs(len(cones.corners)) == [(0, len(cones.corners))]
    np.testing.assert_array_equal(culled, _culled([cones], centres, radii))
    assert not culled.all()
    assert culled.any() or isinstance(mirror, BoxShape)  # (a box's faces face every way: it reaches everything)


def instance_records_one_by_one(items: list[ObjectGeometry], scene: Scene,
                                offsets: dict[int, int] | None) -> np.ndarray:
    """batches.instance_records as it was: a record at a time."""
    records = np.zeros(len(items), INSTANCE_DTYPE)
    for record, item in zip(records, items, strict=True):
        record["model"] = item.model_matrix[:3]
        record["normal_matrix"] = item.normal_matrix.T
        offset = offsets[item.index] if offsets is not None else 0
        record["ids"] = (scene.material_index(item.object.material), item.index, offset, 0)
    return records


@pytest.mark.parametrize("with_offsets", [False, True])
def test_instance_records_made_together_are_those_made_one_by_one(with_offsets: bool) -> None:
    objects = tuple(random_objects(60, 7))
    objects = tuple(o if i % 3 else SceneObject(o.name, o.shape, CheckerMaterial((0.9, 0.2, 0.1), (0.1, 0.1, 0.1)),
                                                o.position, o.rotation, o.scale) for i, o in enumerate(objects))
    scene = dataclasses.replace(load_scene(DEFAULT_SCENE), objects=objects)
    items = scene_geometry(objects)
    linear_transforms(items)
    offsets = triangle_offsets(items) if with_offsets else None
    made = instance_records(items, scene, offsets)
    assert made.tobytes() == instance_records_one_by_one(items, scene, offsets).tobytes()
    assert instance_records([], scene).shape == (0,)


@pytest.mark.parametrize("far", [0.0, 1e18 - 5.0, 1e18 - 1e3, 1e18 + 1e3, 0.7e18, 1e300, math.inf])
def test_reach_checks_refuse_objects_past_the_coordinate_limit(far: float) -> None:
    """Objects at, below and past MAX_COORDINATE (one orbiting a far centre, one scaled far): the
    first that reaches past it is refused, by name; none below it is."""
    rng = np.random.default_rng(8)
    objects = [SceneObject(f"o{i}", SphereShape(float(rng.uniform(0.1, 2.0))), position=tuple(rng.uniform(-9, 9, 3)),
                           scale=(float(rng.uniform(0.5, 2.0)),) * 3) for i in range(30)]
    objects[7] = dataclasses.replace(objects[7], position=(far, 0.0, 0.0))
    objects[9] = dataclasses.replace(objects[9], position=(0.0, far * 0.6, 0.0),
                                     animation=Animation("orbit", (0.0, 1.0, 0.0), 10.0, (0.0, 0.0, far * 0.8)))
    objects[11] = dataclasses.replace(objects[11], position=(0.0, 0.0, 0.0), scale=(far / 2.0, 1.0, 1.0))
    scene = dataclasses.replace(load_scene(DEFAULT_SCENE), objects=tuple(objects))
    if far < 0.7e18:
        limits.check_scene(scene)
    else:
        with pytest.raises(SceneError, match="within 1e\\+18 of the origin") as raised:
            limits.check_scene(scene)
        assert scene.object_label(7 if far > 1e18 else 9) in str(raised.value)


def material_records_one_by_one(scene: Scene) -> np.ndarray:
    """uniforms.material_records as it was: a record at a time."""
    records = np.zeros(uniforms.material_count(scene), MATERIAL.dtype)
    records["metallic_roughness_texture"] = records["occlusion_texture"] = records["emissive_texture"] = -1
    records["normal_texture"] = -1
    records["alpha_cutoff"], records["alpha"] = -1.0, 1.0
    for record, material in zip(records, scene.materials, strict=False):
        if isinstance(material, CheckerMaterial):
            record["kind"], record["color_a"], record["color_b"] = MaterialKind.CHECKER, material.color_a, material.color_b
            record["scale"] = material.scale
        elif isinstance(material, DiffuseMaterial):
            record["kind"], record["color_a"], record["color_b"] = MaterialKind.DIFFUSE, material.color, material.color
            record["scale"] = 1.0
        record["texture"] = scene.texture_slot(material)
        record["double_sided"] = material_sides(material)
        if isinstance(material, MetallicRoughnessMaterial):
            record["kind"] = MaterialKind.METALLIC_ROUGHNESS
            record["emissive"], record["metallic"], record["roughness"] = (material.emissive, material.metallic,
                                                                           material.roughness)
            (record["metallic_roughness_texture"], record["occlusion_texture"], record["emissive_texture"],
             record["normal_texture"]) = (scene.slot_of(texture) for texture in material.maps)
            record["normal_scale"] = material.normal_scale
            record["occlusion_strength"] = material.occlusion_strength
            if material.image_cutoff is not None:
                record["alpha_cutoff"], record["alpha"] = material.image_cutoff, material.alpha
            record["blend"] = int(material.blend)
    return records


@pytest.mark.parametrize("name", ["default.toml", "showcase.toml", "textured_near_mirror.toml", "blend_near_mirror.toml",
                                  "checker_near_mirror.toml", "two_mirrors.toml"])
def test_material_records_made_a_field_at_a_time_are_those_made_a_record_at_a_time(name: str) -> None:
    scene = load_scene(DEFAULT_SCENE.parent / name)
    assert uniforms.material_records(scene).tobytes() == material_records_one_by_one(scene).tobytes()


def test_material_records_of_many_materials_are_those_made_a_record_at_a_time() -> None:
    objects = tuple(SceneObject(o.name, o.shape, CheckerMaterial((0.9, 0.2, 0.1), (0.1, 0.1, float(i) / 7.0), scale=2.5)
                                if i % 3 == 0 else DiffuseMaterial((float(i) / 60.0, 0.3, 1.0 / 3.0), double_sided=i % 2 == 0),
                                o.position) for i, o in enumerate(random_objects(60, 3)))
    scene = dataclasses.replace(load_scene(DEFAULT_SCENE), objects=objects)
    assert uniforms.material_records(scene).tobytes() == material_records_one_by_one(scene).tobytes()
