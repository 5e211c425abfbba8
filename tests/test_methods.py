"""The methods a reflected ray can find objects with: depth images (the rest of the suite) and
the ray-traced triangles, which must agree with Embree's truth to within float noise."""

from __future__ import annotations

import json
from pathlib import Path

import moderngl
import numpy as np
import pytest
import trimesh

from conftest import SCENES, assert_finite
from depthimpostor.bvh import LEAF_TRIANGLES, build_bvh
from depthimpostor.cli import main
from depthimpostor.compare import compare
from depthimpostor.constants import Method
from depthimpostor.renderer import Renderer
from depthimpostor.scene import load_scene

# The hard scenes too: surrounds.toml, which the depth method must refuse (no frustum fits an
# object around the mirror's centre), is an ordinary scene to a ray tracer.
SCENE_FILES = sorted(SCENES.glob("*.toml")) + sorted((SCENES / "hard").glob("*.toml"))


def test_bvh_holds_every_triangle_once_inside_nested_boxes() -> None:
    mesh = trimesh.creation.icosphere(subdivisions=4)
    triangles = np.asarray(mesh.vertices)[np.asarray(mesh.faces)]
    bvh = build_bvh(triangles)
    leaves = np.nonzero(bvh.count)[0]
    assert sorted(bvh.order) == list(range(len(triangles)))
    assert bvh.count[leaves].sum() == len(triangles) and bvh.count.max() <= LEAF_TRIANGLES
    assert bvh.depth <= int(np.ceil(np.log2(len(triangles) / LEAF_TRIANGLES))) + 1
    ordered = triangles[bvh.order]
    for leaf in leaves:
        inside = ordered[bvh.first[leaf] : bvh.first[leaf] + bvh.count[leaf]].reshape(-1, 3)
        assert (inside >= bvh.lower[leaf] - 1e-6).all() and (inside <= bvh.upper[leaf] + 1e-6).all()
    for node in np.nonzero(bvh.count == 0)[0]:
        for child in (bvh.first[node], bvh.first[node] + 1):
            assert (bvh.lower[child] >= bvh.lower[node]).all() and (bvh.upper[child] <= bvh.upper[node]).all()


@pytest.mark.parametrize("path", SCENE_FILES, ids=lambda p: p.stem)
def test_raytrace_renders_every_scene_finite(ctx: moderngl.Context, path: Path) -> None:
    scene = load_scene(path).with_overrides(size=(128, 72))
    with Renderer(ctx, scene, method=Method.RAYTRACE) as renderer:
        renderer.render()
        image = renderer.read_color_float()
        assert renderer.impostors is None, "the ray-traced method bakes no depth image"
        assert renderer.stats.depth_images_baked == 0
    assert_finite(image)


@pytest.mark.parametrize("name", ["default", "bunny", "lecture_8x9", "grid_3x3"])
def test_raytrace_matches_the_embree_truth(ctx: moderngl.Context, name: str) -> None:
    scene = load_scene(SCENES / f"{name}.toml").with_overrides(size=(320, 180))
    with Renderer(ctx, scene, reflection_data=True, method=Method.RAYTRACE) as renderer:
        renderer.render()
        figures = compare(renderer).figures
    assert figures.mirror_pixels > 1000
    assert figures.wrong_object_share < 0.001
    assert figures.color_rmse < 1e-3
    if figures.geometric_pixels:
        assert figures.geometric_error_max < 1e-3  # a share of the object's radius


def test_method_switch_keeps_only_the_methods_resources(ctx: moderngl.Context) -> None:
    scene = load_scene(SCENES / "default.toml").with_overrides(size=(96, 54), impostor_resolution=64)
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        depth = renderer.read_color_float()
        renderer.set_method(Method.RAYTRACE)
        assert renderer.impostors is None and renderer.triangles is not None
        renderer.render()
        traced = renderer.read_color_float()
        renderer.set_method(Method.DEPTH)
        assert renderer.triangles is None and renderer.impostors is not None
        renderer.render()
        np.testing.assert_allclose(renderer.read_color_float(), depth, atol=1e-6)
        assert renderer.stats.depth_images_baked == 10
    with Renderer(ctx, scene, method=Method.RAYTRACE) as fresh:
        fresh.render()
        np.testing.assert_allclose(fresh.read_color_float(), traced, atol=1e-6)
        fragments = {fragment for _, fragment, _ in fresh.programs.variants}
        assert "back_depth.frag" not in fragments, "no baking program for a method that bakes nothing"


def test_compare_reports_the_method(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "report"
    assert main(["compare", str(SCENES / "default.toml"), "--size", "96x54", "--method", "raytrace", "-o", str(out)]) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["settings"]["method"] == "raytrace"
    assert "wrong object" in capsys.readouterr().out
