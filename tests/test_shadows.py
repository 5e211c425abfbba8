"""Shadows: shadow maps from the lights, marched like mirrors' depth images, against shadow rays
traced with Embree through the real casters. No acne at any angle to the light, no light leaking
where a caster touches the floor, and nothing made for a scene that casts no shadow."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import moderngl
import numpy as np
import pytest

from conftest import assert_finite
from depthimpostor.oracles.compare import Comparison, compare
from depthimpostor.errors import SceneError
from depthimpostor.renderer import Renderer
from depthimpostor.scene.loader import parse_scene
from depthimpostor.scene.model import Scene

FLOOR = {"name": "floor", "shape": {"type": "plane", "size": [12.0, 12.0]},
         "material": {"type": "checker", "color_a": [0.8, 0.8, 0.8], "color_b": [0.55, 0.55, 0.55]}}
BOX = {"name": "box", "shape": {"type": "box", "size": [0.8, 0.8, 0.8]},
       "material": {"type": "diffuse", "color": [0.85, 0.2, 0.15]}, "position": [-0.8, 0.4, 0.3],
       "rotation": [0.0, 30.0, 0.0]}
BALL = {"name": "ball", "shape": {"type": "sphere", "radius": 0.5},
        "material": {"type": "diffuse", "color": [0.2, 0.5, 0.9]}, "position": [0.9, 0.5, 0.0]}


def light(shadows: str = "hard", **extra: Any) -> dict[str, Any]:
    return {"type": "point", "position": [2.0, 5.0, 2.0], "intensity": 0.9, "shadows": shadows, **extra}


def make_scene(lights: list[dict[str, Any]], objects: list[dict[str, Any]], size: tuple[int, int] = (240, 160),
               eye: tuple[float, float, float] = (0.0, 2.5, 5.0)) -> Scene:
    data = {"render": {"size": list(size), "ambient": 0.2},
            "camera": {"eye": list(eye), "target": [0.0, 0.4, 0.0]},
            "lights": lights, "objects": objects}
    return parse_scene(data, "test scene", Path("."))


def render_and_compare(ctx: moderngl.Context, scene: Scene) -> Comparison:
    with Renderer(ctx, scene, reflection_data=True) as renderer:
        renderer.render()
        assert_finite(renderer.read_color_float())
        return compare(renderer)


def direct_error(comparison: Comparison) -> np.ndarray:
    """Per measured direct pixel: the largest channel's colour error against the truth."""
    return np.abs(comparison.render - comparison.truth).max(axis=2)[comparison.direct_mask]


@pytest.mark.parametrize("kind", ["hard", "soft"])
def test_shadows_match_the_traced_truth(ctx: moderngl.Context, kind: str) -> None:
    extra = {"radius": 0.4} if kind == "soft" else {}
    scene = make_scene([light(kind, **extra)], [FLOOR, BOX, BALL])
    comparison = render_and_compare(ctx, scene)
    figures = comparison.figures
    errors = direct_error(comparison)
    assert figures.direct_pixels > 0.9 * 240 * 160
    # Differences sit on shadow edges only: a one-texel band of the shadow map (hard), or the
    # steps of the penumbra where a ray grazes a caster's silhouette (soft).
    assert figures.direct_rmse < 0.012, f"direct RMSE {figures.direct_rmse:.4f}"
    # About 1.4 % of these pixels are in shadow (the next test): a tenth of that may be off.
    assert np.mean(errors > 0.1) < 0.0015, f"{100 * np.mean(errors > 0.1):.3f} % of pixels off by > 0.1"


def test_shadows_darken_what_the_truth_darkens(ctx: moderngl.Context) -> None:
    """The test above cannot pass by accident: the same scene without shadows is far from a
    truth with them (the shadows are there, and large)."""
    with_shadows = render_and_compare(ctx, make_scene([light("hard")], [FLOOR, BOX, BALL]))
    unshadowed_scene = make_scene([light("none")], [FLOOR, BOX, BALL])
    with Renderer(ctx, unshadowed_scene) as renderer:
        renderer.render()
        plain = np.clip(renderer.read_color_float(), 0, 1)[with_shadows.direct_mask]
    assert np.mean(np.abs(plain - with_shadows.truth[with_shadows.direct_mask]).max(axis=1) > 0.1) > 0.012


@pytest.mark.parametrize("angle", [0.0, 30.0, 60.0, 75.0, 85.0])
def test_no_acne_at_any_angle_to_the_light(ctx: moderngl.Context, angle: float) -> None:
    """A slab lit at up to 85 degrees from its normal, a sphere (every angle at once) and a torus
    (curvature of both signs) on it: lit surfaces stay lit. The normal offset clears one texel's
    depth variation at every slope (constants.SHADOW_NORMAL_OFFSET_TEXELS)."""
    slab = {"name": "slab", "shape": {"type": "box", "size": [5.0, 0.2, 5.0]},
            "material": {"type": "diffuse", "color": [0.8, 0.8, 0.8]}, "position": [0.0, -0.1, 0.0]}
    torus = {"name": "torus", "shape": {"type": "torus", "major": 0.5, "minor": 0.2},
             "material": {"type": "diffuse", "color": [0.3, 0.8, 0.3]}, "position": [1.0, 0.2, 0.5]}
    ball = dict(BALL, position=[-1.0, 0.5, 0.5])
    theta = np.radians(angle)
    position = [8.0 * np.sin(theta), 8.0 * np.cos(theta), 0.0]
    scene = make_scene([{"type": "point", "position": position, "intensity": 1.0, "shadows": "hard"}],
                       [slab, ball, torus], eye=(0.0, 5.0, 3.0))
    comparison = render_and_compare(ctx, scene)
    darker = (comparison.truth - comparison.render).max(axis=2)[comparison.direct_mask]
    # Acne is lit surface drawn in shadow: darker than the truth by a good part of the light
    # (cos 85 degrees = 0.09 of it on the slab: the threshold is below that). Allowed: the pixels
    # along the true shadows' edges.
    assert np.mean(darker > 0.05) < 0.004, f"{np.mean(darker > 0.05) * 100:.2f} % of pixels darker than the truth"


def test_no_light_leaks_where_a_caster_touches_the_floor(ctx: moderngl.Context) -> None:
    """A box resting on the floor, lit from low on one side: its long shadow starts at its base.
    Floor pixels next to the base are as dark as the truth's (no lit seam under the box)."""
    box = dict(BOX, position=[0.0, 0.4, 0.0], rotation=[0.0, 0.0, 0.0])
    low = {"type": "point", "position": [4.0, 1.5, 0.0], "intensity": 1.0, "shadows": "hard"}
    comparison = render_and_compare(ctx, make_scene([low], [FLOOR, box], eye=(-1.5, 3.0, 3.5)))
    brighter = (comparison.render - comparison.truth).max(axis=2)[comparison.direct_mask]
    assert np.mean(brighter > 0.1) < 0.003, f"{np.mean(brighter > 0.1) * 100:.2f} % of pixels lit that are dark"


def test_shadow_maps_are_baked_once_and_only_where_something_casts(ctx: moderngl.Context) -> None:
    scene = make_scene([light("soft", radius=0.3), light("none")], [FLOOR, BOX])
    with Renderer(ctx, scene) as renderer:
        for _ in range(3):
            renderer.render()
        renderer.look_at(dataclasses.replace(scene.camera, eye=(1.0, 3.0, 4.0)))
        renderer.render()
        assert renderer.graph.shadow_maps is not None and len(renderer.graph.shadow_maps.cameras) == 1
        assert renderer.stats.shadow_maps_baked == 1, "the camera moved, the lights did not: nothing to re-bake"
        assert any("SHADOWS" in dict(defines) for (*_, defines) in renderer.programs.variants)
    for lights, objects in (([light("none")], [FLOOR, BOX]), ([light("hard")], [FLOOR])):
        with Renderer(ctx, make_scene(lights, objects)) as renderer:
            renderer.render()
            assert renderer.graph.shadow_maps is None
            assert not any("SHADOWS" in dict(defines) for (*_, defines) in renderer.programs.variants)


@pytest.mark.parametrize(("light_table", "path", "message"), [
    ({"type": "directional", "direction": [0, -1, 0], "shadows": "hard"}, "lights[0].shadows", "point light"),
    ({"type": "point", "position": [0, 5, 0], "shadows": "soft"}, "lights[0].radius", "missing required field"),
    ({"type": "point", "position": [0, 5, 0], "shadows": "hard", "radius": 0.2}, "lights[0].radius", 'unless shadows = "soft"'),
    ({"type": "point", "position": [0, 5, 0], "shadows": "sharp"}, "lights[0].shadows", "one of: none, hard, soft"),
])
def test_shadow_settings_are_checked(light_table: dict[str, Any], path: str, message: str) -> None:
    with pytest.raises(SceneError) as caught:
        make_scene([light_table], [FLOOR, BOX])
    assert caught.value.path == path and message in str(caught.value)


def test_a_light_among_its_casters_is_refused_by_name(ctx: moderngl.Context) -> None:
    among = {"type": "point", "position": [0.0, 0.4, 0.3], "shadows": "hard"}
    scene = make_scene([among], [FLOOR, dict(BOX, position=[-1.5, 0.4, 0.3]), dict(BALL, position=[1.5, 0.5, 0.3])])
    with pytest.raises(SceneError) as caught:
        Renderer(ctx, scene)
    assert caught.value.path == "lights[0].position"
