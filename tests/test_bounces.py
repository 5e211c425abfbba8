"""Reflections of reflections (render.max_bounces): mirrors in each other's depth images, drawn
with the mirror shader from the other mirror's centre, against the recursive Embree truth."""

from __future__ import annotations

import dataclasses

import moderngl
import numpy as np
import pytest

from conftest import SCENES, assert_finite
from depthimpostor.oracles.compare import compare
from depthimpostor.constants import Method
from depthimpostor.errors import SceneError
from depthimpostor.renderer import Renderer
from depthimpostor.scene import load_scene


def two_mirrors(bounces: int):  # type: ignore[no-untyped-def]
    scene = load_scene(SCENES / "two_mirrors.toml").with_overrides(size=(320, 180))
    return dataclasses.replace(scene, render=dataclasses.replace(scene.render, max_bounces=bounces))


@pytest.mark.parametrize("bounces", [2, 3])
def test_mirrors_reflect_each_other_as_the_truth_does(ctx: moderngl.Context, bounces: int) -> None:
    with Renderer(ctx, two_mirrors(bounces), reflection_data=True) as renderer:
        renderer.render()
        assert_finite(renderer.read_color_float())
        data = renderer.read_reflection_data()
        comparison = compare(renderer)
        mirror_ids = {g.index for g in renderer.world.mirrors}
        images = renderer.graph.impostors.depth_images if renderer.graph.impostors is not None else []
    # Per mirror: the box, and the other mirror once per bounce from 2 up.
    assert len(images) == 2 * (1 + (bounces - 1))
    seen_mirror = np.isin(data.object_id[data.mirror_mask], list(mirror_ids)).mean()
    assert seen_mirror > 0.05, "each mirror shows the other"
    figures = comparison.figures
    assert figures.wrong_object_share < 0.01, f"{100 * figures.wrong_object_share:.2f} % wrong object"
    # The other mirror's reflections are baked for the first mirror's centre, not for each point
    # of it: the colour error lives there (docs/methods_and_results.md's figures).
    assert figures.color_rmse < 0.07, f"colour RMSE {figures.color_rmse:.4f}"


def test_one_bounce_leaves_mirrors_out_of_mirrors(ctx: moderngl.Context) -> None:
    """At max_bounces = 1 (the default) neither the render nor the truth sees a mirror in a
    mirror, and the images are the diffuse objects' alone; the bounce-2 truth differs from it."""
    with Renderer(ctx, two_mirrors(1), reflection_data=True) as renderer:
        renderer.render()
        data = renderer.read_reflection_data()
        figures = compare(renderer).figures
        assert renderer.graph.impostors is not None and len(renderer.graph.impostors.depth_images) == 2
        assert renderer.graph.impostors.bounces is None
        assert not np.isin(data.object_id, [g.index for g in renderer.world.mirrors]).any()
    assert figures.wrong_object_share < 0.01


def test_other_methods_refuse_more_than_one_bounce(ctx: moderngl.Context) -> None:
    with pytest.raises(SceneError) as caught:
        Renderer(ctx, two_mirrors(2), method=Method.CUBEMAP)
    assert caught.value.path == "render.max_bounces"
