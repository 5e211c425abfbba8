"""One-sided mirrors: a mirror reflects on its front side alone (where its counter-clockwise faces
face); its back is a matte grey backing, shaded as any diffuse surface, in the frame, in other
mirrors' depth images (render.max_bounces > 1) and in the Embree truth alike. Glass has no backing
(its back faces are what the eye inside it sees): tests/test_glass.py holds it to that."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import moderngl
import numpy as np

from conftest import assert_finite
from depthimpostor.oracles.compare import Comparison, compare
from depthimpostor.constants import NO_OBJECT
from depthimpostor.renderer import Renderer
from depthimpostor.targets import ReflectionData
from depthimpostor.scene.loader import parse_scene
from depthimpostor.scene.model import Scene
from depthimpostor.oracles.truth import MIRROR_BACKING_ALBEDO, TruthTracer, shade

SIZE = (240, 160)
FLOOR = {"name": "floor", "shape": {"type": "plane", "size": [12.0, 12.0]},
         "material": {"type": "checker", "color_a": [0.8, 0.8, 0.8], "color_b": [0.4, 0.4, 0.4]}}
# A plane faces +Y; 90 degrees about X turns it to face +Z. The light travels towards +Z: it
# lights the mirror's back (and leaves its front, which only reflects, in the dark).
MIRROR = {"name": "mirror", "shape": {"type": "plane", "size": [3.0, 2.0]},
          "material": {"type": "mirror", "tint": [0.95, 0.95, 0.95]}, "position": [0.0, 1.1, -1.5],
          "rotation": [90.0, 0.0, 0.0]}
BOX = {"name": "box", "shape": {"type": "box", "size": [0.7, 0.7, 0.7]},
       "material": {"type": "diffuse", "color": [0.85, 0.15, 0.12]}, "position": [-0.6, 0.35, 0.2],
       "rotation": [0.0, 25.0, 0.0]}
SUN = {"type": "directional", "direction": [0.3, -1.0, 0.5]}
BEHIND = (0.8, 1.4, -5.5)
IN_FRONT = (0.8, 1.6, 4.5)
BACK_NORMAL = np.array([0.0, 0.0, -1.0])  # MIRROR's back, world space


def make_scene(objects: list[dict[str, Any]], eye: tuple[float, float, float], bounces: int = 1,
               lights: list[dict[str, Any]] | None = None) -> Scene:
    data = {"render": {"size": list(SIZE), "ambient": 0.25, "max_bounces": bounces},
            "camera": {"eye": list(eye), "target": [0.0, 1.0, -1.5]},
            "lights": lights or [SUN], "objects": objects}
    return parse_scene(data, "mirror backing test scene", Path("."))


def backing_color(scene: Scene, tint: float = 1.0) -> np.ndarray:
    """The numpy shading of MIRROR's backing (a directional light alone: the same everywhere)."""
    albedo = np.full((1, 3), MIRROR_BACKING_ALBEDO)
    return tint * shade(scene, albedo, np.zeros((1, 3)), BACK_NORMAL[None])[0]


def interior(mask: np.ndarray) -> np.ndarray:
    """The pixels of `mask` whose eight neighbours are in it too: away from silhouettes, where a
    pixel centre and the rasterizer's coverage may disagree."""
    inner = mask.copy()
    padded = np.pad(mask, 1)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            inner &= padded[1 + dy:1 + dy + mask.shape[0], 1 + dx:1 + dx + mask.shape[1]]
    return inner


def render_and_compare(renderer: Renderer) -> tuple[Comparison, ReflectionData]:
    """One frame against the truth, both free of NaN and Inf, and the frame's reflection data."""
    renderer.render()
    assert_finite(renderer.read_color_float())
    comparison = compare(renderer)
    assert_finite(comparison.truth)
    return comparison, renderer.read_reflection_data()


def test_a_mirror_seen_from_behind_shows_its_backing(ctx: moderngl.Context) -> None:
    scene = make_scene([FLOOR, MIRROR, BOX], BEHIND)
    with Renderer(ctx, scene, reflection_data=True, count_samples=True) as renderer:
        renderer.render()
        render = renderer.read_color_float()
        data = renderer.read_reflection_data()
        samples = renderer.read_sample_counts()
        camera, mirror = renderer.camera, renderer.world.mirrors[0]
    assert_finite(render)
    assert not data.mirror_mask.any(), "a mirror's back is no mirror pixel"
    assert (data.object_id == NO_OBJECT).all() and (data.mirror_id == NO_OBJECT).all()
    assert not samples.any(), "a backing pixel traces no reflected ray"
    # Where primary rays meet the mirror (Embree), from behind by construction of the view.
    rows, columns = np.mgrid[0:SIZE[1], 0:SIZE[0]] + 0.5
    directions = camera.ray_direction(columns.ravel(), rows.ravel())
    hits = TruthTracer(scene, [mirror], []).trace(np.broadcast_to(camera.C, directions.shape), directions)
    assert hits.backing[hits.hit].all()
    backing = interior(hits.backing.reshape(SIZE[1], SIZE[0]))
    assert backing.sum() > 0.15 * SIZE[0] * SIZE[1]
    expected = backing_color(scene)
    assert expected.min() > 0.25 * MIRROR_BACKING_ALBEDO, "the light reaches the back: more than ambient"
    # The truth shades the backing as this numpy shading, and the render agrees with both.
    np.testing.assert_allclose(hits.color[backing.ravel()], np.broadcast_to(expected, (int(backing.sum()), 3)), atol=1e-9)
    error = np.abs(render[backing] - expected).max()
    assert error < 2 / 255, f"backing off by {error:.4f} from {expected}"


def test_a_mirror_seen_from_the_front_still_reflects(ctx: moderngl.Context) -> None:
    with Renderer(ctx, make_scene([FLOOR, MIRROR, BOX], IN_FRONT), reflection_data=True) as renderer:
        comparison, data = render_and_compare(renderer)
        box = next(g.index for g in renderer.world.reflected_objects if g.object.name == "box")
    figures = comparison.figures
    assert figures.mirror_pixels > 0.1 * SIZE[0] * SIZE[1]
    assert (data.object_id[data.mirror_mask] == box).sum() > 200, "the box is seen in the mirror"
    assert figures.wrong_object_share < 0.01
    assert figures.color_rmse < 0.05, f"colour RMSE {figures.color_rmse:.4f}"


def test_a_mirror_shows_another_mirrors_back_as_its_backing(ctx: moderngl.Context) -> None:
    """Mirror B stands before MIRROR (A) with its back to it: at max_bounces = 2 A shows B's
    backing, drawn into A's depth image of B with the image's flipped winding accounted for."""
    small = {"name": "small", "shape": {"type": "plane", "size": [1.2, 1.2]},
             "material": {"type": "mirror", "tint": [0.9, 0.95, 1.0]}, "position": [1.2, 0.9, 1.0],
             "rotation": [90.0, 0.0, 0.0]}
    scene = make_scene([FLOOR, MIRROR, small, BOX], (-1.5, 1.5, 4.5), bounces=2)
    with Renderer(ctx, scene, reflection_data=True) as renderer:
        comparison, data = render_and_compare(renderer)
        ids = {g.object.name: g.index for g in renderer.world.mirrors}
        assert renderer.graph.impostors is not None and renderer.graph.impostors.bounces is not None
    figures = comparison.figures
    assert figures.wrong_object_share < 0.01, f"{100 * figures.wrong_object_share:.2f} % wrong object"
    assert figures.color_rmse < 0.07, f"colour RMSE {figures.color_rmse:.4f}"
    # A's pixels that see B: B's back, the backing grey times A's tint, in the render and the truth.
    sees_back = interior(data.mirror_mask & (data.mirror_id == ids["mirror"]) & (data.object_id == ids["small"]))
    assert sees_back.sum() > 100, "the big mirror shows the small one's back"
    expected = backing_color(scene, tint=0.95)
    truth_error = np.abs(comparison.truth[sees_back] - expected).max()
    assert truth_error < 1e-6, f"the truth's backing is off by {truth_error:.2e}"
    error = np.abs(comparison.render[sees_back] - expected).max()
    assert error < 3 / 255, f"the rendered backing is off by {error:.4f}"


def test_the_truth_of_a_shadowed_backing_seen_directly(ctx: moderngl.Context) -> None:
    """With shadows the direct view has a traced truth too: a planar mirror (which casts no
    shadow) is in it, its back shaded like the render's."""
    lamp = {"type": "point", "position": [1.0, 4.0, -4.5], "intensity": 0.9, "shadows": "hard"}
    scene = make_scene([FLOOR, MIRROR, BOX], BEHIND, lights=[lamp])
    with Renderer(ctx, scene, reflection_data=True) as renderer:
        comparison, data = render_and_compare(renderer)
    assert not data.mirror_mask.any()
    figures = comparison.figures
    assert figures.direct_pixels > 0.9 * SIZE[0] * SIZE[1], "the backing is measured, not left out"
    assert figures.direct_rmse < 0.012, f"direct RMSE {figures.direct_rmse:.4f}"

