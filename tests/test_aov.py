"""Per-pixel outputs (`render --aov`, aov.py): the values of each AOV on the default scene, checked
against what the scene says (its objects' indices and colours) and against each other; the EXR
file's channel names; the command line's refusals."""

from __future__ import annotations

from pathlib import Path

import moderngl
import numpy as np
import pytest

from conftest import PROJECT_ROOT, SCENES
from depthimpostor.aov import AOVS, aov_path, compute_aovs, needs_reflection_data, read_aovs
from depthimpostor.cli import main
from depthimpostor.constants import Algorithm, Method
from depthimpostor.renderer import Renderer
from depthimpostor.scene import load_scene

SIZE = (96, 54)
ALL = tuple(AOVS)
MIRROR, RED_BOX = 1, 2  # scenes/default.toml's objects[1] and objects[2]


def _aovs(ctx: moderngl.Context, method: Method) -> dict[str, np.ndarray]:
    scene = load_scene(SCENES / "default.toml").with_overrides(size=SIZE)
    with Renderer(ctx, scene, Algorithm.OPTIMIZED, method=method, reflection_data=needs_reflection_data(ALL)) as renderer:
        renderer.render()
        return compute_aovs(renderer, ALL)[0]


@pytest.fixture(scope="module")
def depth_aovs(ctx: moderngl.Context) -> dict[str, np.ndarray]:
    return _aovs(ctx, Method.DEPTH)


def test_every_aov_is_finite_and_of_the_frame_size(depth_aovs: dict[str, np.ndarray]) -> None:
    assert list(depth_aovs) == list(ALL)
    for name, image in depth_aovs.items():
        assert image.shape[:2] == SIZE[::-1], name
        assert image.dtype == np.float32
        assert np.isfinite(image).all(), name


def test_ids_are_the_scenes_objects(depth_aovs: dict[str, np.ndarray]) -> None:
    objects = len(load_scene(SCENES / "default.toml").objects)
    for name in ("object_id", "reflector_id", "reflected_object_id", "truth_reflected_object_id"):
        ids = depth_aovs[name]
        assert np.array_equal(ids, np.rint(ids)), name
        assert set(np.unique(ids)) <= set(range(-1, objects)), name
    seen = set(np.unique(depth_aovs["object_id"]).astype(int))
    assert {-1, 0, MIRROR, RED_BOX} <= seen  # sky, floor, mirror sphere, red box all in view
    # The mirror mask is the mirror sphere, as the primary rays see it (silhouette pixels aside).
    mask = depth_aovs["reflector_id"] >= 0
    assert set(np.unique(depth_aovs["reflector_id"][mask])) == {MIRROR}
    assert ((depth_aovs["object_id"] == MIRROR) == mask).mean() > 0.99
    # Outside the mirror nothing is reflected.
    for name in ("reflected_object_id", "truth_reflected_object_id"):
        assert (depth_aovs[name][~mask] == -1).all()
    assert (depth_aovs["reflected_distance"][~mask] == 0).all()


def test_surfaces_depth_normal_albedo(depth_aovs: dict[str, np.ndarray]) -> None:
    hit = depth_aovs["object_id"] >= 0
    depth = depth_aovs["depth"]
    assert (depth[hit] > 0).all() and (depth[~hit] == 0).all()
    assert depth[hit].max() < 30.0  # the floor's far edge is 15 units from the eye
    normal = depth_aovs["normal"]
    lengths = np.linalg.norm(normal[hit], axis=1)
    np.testing.assert_allclose(lengths, 1.0, atol=1e-5)
    floor = depth_aovs["object_id"] == 0
    np.testing.assert_allclose(normal[floor], np.broadcast_to([0.0, 1.0, 0.0], normal[floor].shape), atol=1e-6)
    box = depth_aovs["albedo"][depth_aovs["object_id"] == RED_BOX]
    np.testing.assert_allclose(box, np.broadcast_to([0.85, 0.15, 0.12], box.shape), atol=1e-6)
    # The floor's checker: its two colours and no other.
    checker = np.unique(depth_aovs["albedo"][floor], axis=0)
    np.testing.assert_allclose(checker, [[0.35] * 3, [0.8] * 3], atol=1e-6)


def test_reflected_distance_where_an_object_is_reflected(depth_aovs: dict[str, np.ndarray]) -> None:
    found = depth_aovs["reflected_object_id"] >= 0
    assert found.sum() > 20
    assert (depth_aovs["reflected_distance"][found] > 0).all()
    assert (depth_aovs["reflected_distance"][~found] == 0).all()


def test_error_is_zero_where_the_method_is_the_truth(ctx: moderngl.Context) -> None:
    """Ray-traced triangles are the truth's own geometry: where both find the same object, the
    colours agree to float rounding; outside the mirror the render is the truth (no shadows)."""
    aovs = _aovs(ctx, Method.RAYTRACE)
    mask = aovs["reflector_id"] >= 0
    agree = mask & (aovs["reflected_object_id"] == aovs["truth_reflected_object_id"])
    assert agree.sum() > 0.95 * mask.sum()
    assert aovs["error"][agree].max() < 1e-5
    assert (aovs["error"][~mask] == 0).all()
    assert (aovs["uncertain"] == 0).all()


def test_the_depth_method_errs_somewhere(depth_aovs: dict[str, np.ndarray]) -> None:
    """The error channel measures: depth images are an approximation, off somewhere in the mirror."""
    mask = depth_aovs["reflector_id"] >= 0
    assert depth_aovs["error"][mask].max() > 0.01


def test_hybrid_flags_its_uncertain_pixels(ctx: moderngl.Context) -> None:
    aovs = _aovs(ctx, Method.HYBRID)
    flagged = aovs["uncertain"] > 0
    assert flagged.any()
    assert (aovs["reflector_id"][flagged] >= 0).all()  # only mirror pixels are re-traced


def test_render_writes_the_aov_file_beside_the_image(tmp_path: Path) -> None:
    output = tmp_path / "frame.png"
    assert main(["render", str(SCENES / "default.toml"), "--size", "64x36", "-o", str(output),
                 "--aov", "depth,object_id,normal,error"]) == 0
    assert output.is_file()
    channels = read_aovs(aov_path(output))
    assert set(channels) == {"R", "G", "B", "depth", "object_id", "normal.X", "normal.Y", "normal.Z", "error"}
    assert channels["depth"].shape == (36, 64)
    assert sorted(tmp_path.iterdir()) == [tmp_path / "frame.aov.exr", output]  # no temporary file left


def test_an_unknown_aov_is_refused_before_any_work(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    output = tmp_path / "frame.png"
    assert main(["render", "--size", "64x36", "-o", str(output), "--aov", "depth,colour"]) == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("depthimpostor: command line: --aov: expected AOVs among depth, normal") and "'colour'" in error
    assert "\n" not in error
    assert not output.exists()


def test_the_docs_table_names_every_aov_and_its_channels() -> None:
    text = (PROJECT_ROOT / "docs" / "batch.md").read_text()
    for name, aov in AOVS.items():
        row = f"| `{name}` | {', '.join(f'`{channel}`' for channel in aov.channels)} | {aov.source} |"
        assert row in text, row


def test_aovs_are_refused_beside_a_video(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["render", "--size", "32x18", "--video", str(tmp_path / "v.gif"), "--duration", "0.1",
                 "--aov", "depth"]) == 2
    assert capsys.readouterr().err.startswith("depthimpostor: command line: --aov: expected without --video")
    assert list(tmp_path.iterdir()) == []
