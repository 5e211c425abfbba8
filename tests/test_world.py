"""The world (depthimpostor/world.py): the scene at one time, read by the plan and the renderer, with
what can reach what worked out once per pair; and nothing planned twice (issue 22)."""

from __future__ import annotations

import moderngl
import pytest

import depthimpostor.culling as culling
import depthimpostor.methods.baked_images as baked_images
from conftest import SCENES
from depthimpostor.constants import Algorithm, Method
from depthimpostor.renderer import Renderer
from depthimpostor.scene import load_scene
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
