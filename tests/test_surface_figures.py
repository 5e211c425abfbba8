"""The figures that tell the right object from the right surface: over the mirror pixels whose
truth shows a reflected object, the share that show another object or another part of the right
one (a colour off by more than WRONG_SURFACE_COLOR_ERROR), and the hybrid method's re-traced rays.
Flat-coloured objects hide a wrong part of the right object; the checker scene shows it."""

from __future__ import annotations

import dataclasses
import json
from types import SimpleNamespace
from typing import cast

import moderngl
import numpy as np
import pytest

from conftest import SCENES, assert_finite
from depthimpostor.oracles.compare import (
    WRONG_SURFACE_COLOR_ERROR,
    Comparison,
    Figures,
    TruthFrame,
    compare,
    format_table,
    markdown_table,
)
from depthimpostor.constants import NO_OBJECT, Method
from depthimpostor.renderer import Renderer
from depthimpostor.targets import ReflectionData
from depthimpostor.scene import load_scene
from depthimpostor.scene.model import Camera, Environment, PlaneShape, RenderSettings, Scene, SceneObject, SphereShape

# Small, but the checker squares of the near objects still span several pixels each.
SIZE = (320, 180)
OBJECT = 1  # the synthetic case's one reflected object
FLOOR = 0  # an analytic plane: exact by construction, never an "object pixel"


def _synthetic() -> tuple[Renderer, TruthFrame]:
    """A 2 x 4 frame with 7 mirror pixels, each a case of the figures (truth -> render):
    row 0: object, exact | object, another checker square | object, off by half the threshold |
           object -> environment (wrong object);
    row 1: floor -> object (wrong, but not an object pixel) | environment, colour far off (not an
           object pixel either) | no mirror (re-traced flag set, to be ignored) | object, exact,
           re-traced."""
    shape = (2, 4)
    mask = np.ones(shape, bool)
    mask[1, 2] = False
    truth_object = np.array([[OBJECT, OBJECT, OBJECT, OBJECT], [FLOOR, NO_OBJECT, NO_OBJECT, OBJECT]])
    render_object = np.array([[OBJECT, OBJECT, OBJECT, NO_OBJECT], [OBJECT, NO_OBJECT, NO_OBJECT, OBJECT]])
    truth_color = np.full(shape + (3,), 0.5)
    render_color = truth_color.copy()
    render_color[0, 1] = [0.9, 0.2, 0.15]  # a red square where the truth has grey
    render_color[0, 2, 0] += 0.5 * WRONG_SURFACE_COLOR_ERROR
    render_color[1, 1] = [1.0, 1.0, 1.0]
    retraced = np.zeros(shape, bool)
    retraced[1, 2] = retraced[1, 3] = True
    direction = np.zeros(shape + (3,))
    direction[..., 2] = -1.0
    position = np.zeros(shape + (3,))
    data = ReflectionData(mask, np.where(mask, 5, NO_OBJECT), position, direction, np.where(mask, render_object, NO_OBJECT),
                          position, direction, retraced)
    truth = TruthFrame(mask, direction, np.where(mask[..., None], truth_color, 0.0),
                       np.where(mask, truth_object, NO_OBJECT), position)
    # compare() reads no GL when it is given a truth that fits: this stands in for the renderer.
    stand_in = SimpleNamespace(
        read_reflection_data=lambda: data, read_color_float=lambda: render_color,
        world=SimpleNamespace(glass=[], reflected_objects=[SimpleNamespace(index=OBJECT, bounding_sphere=(np.zeros(3), 1.0))]),
        # The display settings of the report's images, and the objects its worst pixels name.
        scene=Scene("synthetic", RenderSettings(), Camera(), Environment(), (),
                    (SceneObject("floor", PlaneShape((4.0, 4.0))), SceneObject("ball", SphereShape(1.0)))),
    )
    return cast(Renderer, stand_in), truth


def test_wrong_surface_counts_wrong_objects_and_wrong_colours_on_objects_alone() -> None:
    renderer, truth = _synthetic()
    figures = compare(renderer, truth).figures
    assert figures.mirror_pixels == 7
    assert figures.object_pixels == 5  # the floor and the environment are not reflected objects
    # Of the 5: the other checker square and the environment where the object is; not the pixel
    # off by half the threshold.
    assert figures.wrong_surface_share == pytest.approx(2 / 5)
    assert figures.wrong_object_share == pytest.approx(2 / 7)  # the floor pixel counts here, over all 7
    # The flag outside the mirrors is not counted.
    assert (figures.retraced_pixels, figures.retraced_share) == (1, pytest.approx(1 / 7))


def test_the_tables_and_the_report_show_the_new_figures() -> None:
    renderer, truth = _synthetic()
    figures = compare(renderer, truth).figures
    table = format_table(figures)
    assert "wrong surface" in table and "40.00 % of the 5 mirror pixels that show an object" in table
    assert "re-traced rays" in table
    assert "re-traced rays" not in format_table(dataclasses.replace(figures, retraced_pixels=0, retraced_share=0.0))
    header, _, row = markdown_table({"hybrid": ("depth images", figures)}).splitlines()
    columns = [cell.strip() for cell in header.split("|")]
    assert columns.index("wrong surface") == columns.index("wrong object") + 1
    assert row.split("|")[columns.index("wrong surface")].strip() == "40.00 %"
    report = json.loads(json.dumps(dataclasses.asdict(figures)))
    assert report["object_pixels"] == 5 and report["retraced_pixels"] == 1


def test_old_callers_get_no_surface_figures() -> None:
    """Figures made before these figures existed still build, with nothing measured."""
    figures = Figures(mirror_pixels=10, color_rmse=0.1, psnr_db=20.0, wrong_object_share=0.0, geometric_pixels=0,
                      geometric_error_median=0.0, geometric_error_p95=0.0, geometric_error_max=0.0)
    assert (figures.object_pixels, figures.wrong_surface_share, figures.retraced_pixels) == (0, 0.0, 0)


def _checker(ctx: moderngl.Context, method: Method, truth: TruthFrame | None = None) -> tuple[Comparison, np.ndarray]:
    """The checker scene by `method`, and the wrong objects over the pixels that show an object."""
    scene = load_scene(SCENES / "checker_near_mirror.toml").with_overrides(size=SIZE)
    with Renderer(ctx, scene, reflection_data=True, method=method) as renderer:
        renderer.render()
        assert_finite(renderer.read_color_float())
        comparison = compare(renderer, truth)
        data = renderer.read_reflection_data()
        reflected = [g.index for g in renderer.world.reflected_objects]
    truth_object = comparison.truth_frame.object_id
    objects = data.mirror_mask & np.isin(truth_object, reflected)
    assert int(objects.sum()) == comparison.figures.object_pixels
    return comparison, (data.object_id != truth_object)[objects]


@pytest.fixture(scope="module")
def checker(ctx: moderngl.Context) -> dict[Method, tuple[Comparison, np.ndarray]]:
    """The depth and ray-traced methods on the checker scene (one truth traced for both)."""
    depth = _checker(ctx, Method.DEPTH)
    return {Method.DEPTH: depth, Method.RAYTRACE: _checker(ctx, Method.RAYTRACE, depth[0].truth_frame)}


def test_checkers_show_wrong_surfaces_that_wrong_objects_miss(checker: dict[Method, tuple[Comparison, np.ndarray]]) -> None:
    """Depth images from the mirror's centre show sides of the near objects it does not see: the
    right object, the wrong squares."""
    comparison, wrong_object = checker[Method.DEPTH]
    figures = comparison.figures
    # The objects fill a small part of the mirror (1,430 of its 19,762 pixels): enough squares.
    assert figures.object_pixels > 500
    assert figures.wrong_surface_share > wrong_object.mean(), (
        f"wrong surface {100 * figures.wrong_surface_share:.2f} %, wrong object {100 * wrong_object.mean():.2f} %")


def test_ray_tracing_shows_the_right_surfaces(checker: dict[Method, tuple[Comparison, np.ndarray]]) -> None:
    """The real triangles: only float noise at checker edges, and shading differences well under
    the threshold, remain."""
    figures = checker[Method.RAYTRACE][0].figures
    assert figures.object_pixels == checker[Method.DEPTH][0].figures.object_pixels  # the same rays, the same truth
    assert figures.wrong_surface_share < 0.01, f"{100 * figures.wrong_surface_share:.2f} % wrong surface"


@pytest.mark.parametrize("method", [Method.DEPTH, Method.RAYTRACE])
def test_only_the_hybrid_method_retraces(checker: dict[Method, tuple[Comparison, np.ndarray]], method: Method) -> None:
    figures = checker[method][0].figures
    assert (figures.retraced_pixels, figures.retraced_share) == (0, 0.0)
    assert "re-traced rays" not in format_table(figures)
