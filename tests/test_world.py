"""The world (depthimpostor/world.py): the scene at one time, read by the plan and the renderer, with
what can reach what worked out once per pair; and nothing planned twice (issue 22)."""

from __future__ import annotations

import moderngl
import numpy as np
import pytest

import depthimpostor.culling as culling
import depthimpostor.geometry as geometry
import depthimpostor.methods.baked_images as baked_images
from conftest import SCENES
from depthimpostor.constants import Algorithm, Method
from depthimpostor.geometry import BATCHED_SPHERES, bounding_spheres, scene_geometry
from depthimpostor.renderer import Renderer
from depthimpostor.scene import load_scene
from depthimpostor.scene.model import BoxShape, SceneObject, Shape, SphereShape, TorusKnotShape
from depthimpostor.world import World

LECTURE = SCENES / "lecture_8x9.toml"
CAROUSEL = SCENES / "carousel.toml"


@pytest.fixture
def culling_calls(monkeypatch: pytest.MonkeyPatch) -> list[tuple[int, int]]:
    """Every call of culling.reaches, as (reflectors, targets)."""
    calls: list[tuple[int, int]] = []
    original = culling.reaches

    def counted(reflectors, targets):  # type: ignore[no-untyped-def]
        calls.append((len(reflectors), len(targets)))
        return original(reflectors, targets)

    monkeypatch.setattr("depthimpostor.world.reaches", counted)
    monkeypatch.setattr("depthimpostor.culling.reaches", counted)
    return calls


def test_each_pair_is_culled_once_and_settings_cull_nothing_again(ctx: moderngl.Context,
                                                                   culling_calls: list[tuple[int, int]]) -> None:
    scene = load_scene(LECTURE).with_overrides(size=(64, 36), impostor_resolution=16)
    with Renderer(ctx, scene) as renderer:
        pairs = sum(rows * columns for rows, columns in culling_calls)
        assert pairs == len(renderer.world.reflectors) * len(renderer.world.reflected_objects) == 72
        made = len(culling_calls)
        renderer.set_algorithm(Algorithm.HIERARCHICAL)
        renderer.set_method(Method.CUBEMAP)
        renderer.set_impostor_resolution(32)
        assert len(culling_calls) == made, "a setting changed no object, but the culling ran again"


def test_the_stand_in_bakes_the_plans_images_without_planning_them_again(
        ctx: moderngl.Context, monkeypatch: pytest.MonkeyPatch) -> None:
    planned = []
    original = baked_images.per_object_plan

    def counted(*args, **kwargs):  # type: ignore[no-untyped-def]
        planned.append(1)
        return original(*args, **kwargs)

    monkeypatch.setattr("depthimpostor.methods.impostors.per_object_plan", counted)
    scene = load_scene(LECTURE).with_overrides(size=(64, 36), impostor_resolution=16)
    with Renderer(ctx, scene) as renderer:
        assert len(planned) == 1
        # The very cameras the plan fitted: the stand-in fitted none of its own.
        planned_cameras = {id(image.camera) for plans in renderer.plan.image_plans.values() for image in plans}
        baked = renderer.graph.impostors.depth_images  # type: ignore[union-attr]
        assert len(baked) == 72 and all(id(image.camera) in planned_cameras for image in baked)
        # Another algorithm, or a method with the same stand-in, plans the same images: not again
        # (World.planned); another resolution plans its own.
        renderer.set_algorithm(Algorithm.HIERARCHICAL)
        renderer.set_method(Method.HYBRID)
        renderer.set_method(Method.DEPTH)
        assert len(planned) == 2  # the hybrid's stand-in plans (and keeps) its own images once
        renderer.set_impostor_resolution(32)
        assert len(planned) == 3


def test_a_later_world_keeps_the_still_pairs_and_says_what_moved() -> None:
    scene = load_scene(CAROUSEL)
    world = World(scene)
    world.reaches(world.reflectors, world.reflected_objects)
    later = world.at(2.0)
    moving = {g.index for g in world.geometry if g.object.moves}
    assert moving and later.moved(world) == moving
    later.reaches(later.reflectors, later.reflected_objects)
    still_reflectors = [r for r in later.reflectors if r.index not in moving]
    still_targets = [t for t in later.reflected_objects if t.index not in moving]
    worked_out = len(later.reflectors) * len(later.reflected_objects) - len(still_reflectors) * len(still_targets)
    assert later.reach_pairs_computed <= worked_out < len(later.reflectors) * len(later.reflected_objects)
    assert later.reaches(later.reflectors, later.reflected_objects) == culling.reaches(later.reflectors,
                                                                                      later.reflected_objects)


@pytest.mark.parametrize("shape", [SphereShape(0.3), BoxShape((0.2, 0.5, 0.1)), TorusKnotShape(2, 3, 0.4, 0.1)])
def test_bounding_spheres_together_are_each_ones_own(shape: Shape, monkeypatch: pytest.MonkeyPatch) -> None:
    """Many objects of one mesh get their bounding spheres worked out together (and in chunks):
    each holds every float32 vertex of its world mesh, and is about as tight as the one that mesh
    gives alone, under any placement, scale or turn."""
    rng = np.random.default_rng(5)
    objects = tuple(SceneObject(name=f"o{i}", shape=shape, position=tuple(rng.normal(size=3) * 4),
                                rotation=tuple(rng.uniform(0.0, 360.0, 3)), scale=tuple(rng.uniform(0.2, 3.0, 3)))
                    for i in range(2 * BATCHED_SPHERES + 3))
    monkeypatch.setattr(geometry, "BATCH_POINTS", 7 * len(scene_geometry(objects[:1])[0].local_mesh.positions))
    together = bounding_spheres(scene_geometry(objects))
    alone = [item.world_mesh.bounding_sphere() for item in scene_geometry(objects)]
    assert len(together) == len(alone)
    for item, (centre, radius), (_, own_radius) in zip(scene_geometry(objects), together, alone, strict=True):
        points = item.world_mesh.positions.astype(np.float64)
        assert np.linalg.norm(points - centre, axis=1).max() <= radius
        assert radius <= 1.1 * own_radius
