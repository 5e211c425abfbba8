"""Anti-aliasing (`render.samples`, `--samples`): a frame drawn at jittered sub-pixel positions and
averaged, the truth traced at the same positions (renderer.py, oracles/compare.py; docs/colour.md).

The scene is black boxes against a white sky, one seen directly and one only in a planar mirror,
so that one sample per pixel gives exactly 0 or 1 and N samples give multiples of 1/N: the
intermediate values are the edge's coverage ("MSAA edge smoothness" in issue 23).
"""

from __future__ import annotations

import moderngl
import numpy as np
import pytest

from conftest import SCENES, assert_finite, scene_from_toml
from depthimpostor.cli import main
from depthimpostor.oracles.compare import compare
from depthimpostor.constants import SAMPLE_OFFSETS, Method
from depthimpostor.errors import SceneError
from depthimpostor.graph import Pass
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene, load_scene

EDGES = """\
[render]
size = [96, 64]
ambient = 0.0
{samples}

[camera]
eye = [0.0, 0.0, 5.0]
target = [0.0, 0.0, 0.0]
fov_y = 40.0

[environment]
type = "constant"
color = [1.0, 1.0, 1.0]

# Seen directly, left of the mirror: its silhouette against the sky.
[[objects]]
name = "box"
shape = {{ type = "box", size = [1.0, 1.0, 1.0] }}
material = {{ type = "diffuse", color = [0.0, 0.0, 0.0] }}
position = [-1.0, 0.0, 0.0]
rotation = [0.0, 0.0, 20.0]

[[objects]]
name = "mirror"
shape = {{ type = "plane", size = [2.0, 2.5] }}
material = {{ type = "mirror", tint = [1.0, 1.0, 1.0] }}
position = [1.1, 0.0, -1.0]
rotation = [90.0, 0.0, 0.0]

# Behind the eye: seen only in the mirror.
[[objects]]
name = "behind"
shape = {{ type = "box", size = [1.6, 1.6, 1.6] }}
material = {{ type = "diffuse", color = [0.0, 0.0, 0.0] }}
position = [1.1, 0.0, 7.0]
rotation = [0.0, 0.0, 25.0]
"""


def edges(samples: int | None) -> Scene:
    return scene_from_toml(EDGES.format(samples="" if samples is None else f"samples = {samples}"))


def frame(ctx: moderngl.Context, scene: Scene, method: Method = Method.RAYTRACE) -> tuple[np.ndarray, np.ndarray]:
    """The frame's red channel (linear), and the pixels every sub-frame saw the mirror in."""
    with Renderer(ctx, scene, reflection_data=True, method=method) as renderer:
        renderer.render()
        color = renderer.read_color_float()
        masks = [sub.reflection.mirror_mask for sub in renderer.sub_frames() if sub.reflection is not None]
    assert_finite(color)
    return color[..., 0], np.logical_and.reduce(masks)


def intermediate(values: np.ndarray) -> np.ndarray:
    return (values > 1e-4) & (values < 1.0 - 1e-4)


def test_one_sample_is_todays_frame(ctx: moderngl.Context) -> None:
    """samples = 1 is the default and draws one ray through each pixel's centre: hard edges."""
    default, mask = frame(ctx, edges(None))
    one, _ = frame(ctx, edges(1))
    assert np.array_equal(default, one)
    assert mask.any() and not intermediate(default).any()
    assert set(np.unique(default)) == {0.0, 1.0}


@pytest.mark.parametrize("samples", [4, 8])
def test_edges_get_the_coverage_of_their_pixels(ctx: moderngl.Context, samples: int) -> None:
    values, mask = frame(ctx, edges(samples))
    direct, reflected = intermediate(values) & ~mask, intermediate(values) & mask
    # Both silhouettes, the one seen directly and the one in the mirror, are smoothed...
    assert direct.sum() > 20 and reflected.sum() > 10, (direct.sum(), reflected.sum())
    # ...by coverage: each value is a share of the N samples (0 and 1 blended, nothing else).
    levels = values * samples
    assert np.allclose(levels, np.rint(levels), atol=1e-4)
    # The patterns put no two samples in a row or a column: a slanted edge shows every level.
    assert len(np.unique(np.rint(levels))) == samples + 1


def test_the_truth_is_traced_at_the_same_sub_pixel_positions(ctx: moderngl.Context) -> None:
    """The exact method against the truth, anti-aliased: float noise, though the mirror's edge
    pixels are blends; the truth is blended the same way, one trace per sub-frame."""
    with Renderer(ctx, edges(4), reflection_data=True, method=Method.RAYTRACE) as renderer:
        renderer.render()
        result = compare(renderer)
        assert len(result.truth_frame.sub_frames) == 4
        # A second method's comparison of the same rays reuses the traced truth.
        assert compare(renderer, result.truth_frame).truth_frame.sub_frames == result.truth_frame.sub_frames
    assert result.figures.samples == 4
    assert result.figures.color_rmse < 1e-4 and result.figures.wrong_object_share == 0.0
    truth = result.truth[..., 0]
    assert intermediate(truth)[result.mirror_mask].sum() > 10
    # The truth of the pixel centres alone is another picture: the positions matter.
    with Renderer(ctx, edges(1), reflection_data=True, method=Method.RAYTRACE) as renderer:
        renderer.render()
        centres = compare(renderer).truth[..., 0]
    assert np.abs(centres - truth)[result.mirror_mask].max() > 0.2


def test_plan_and_stats_count_the_sub_frames(ctx: moderngl.Context) -> None:
    """The eye's passes run once per sample; the bakes once a frame, as without anti-aliasing."""
    baked = {}
    for samples in (1, 8):
        with Renderer(ctx, edges(samples), method=Method.DEPTH) as renderer:
            assert renderer.plan.samples == samples
            assert (f"anti-aliasing: {samples} samples" in renderer.plan.format()) == (samples > 1)
            assert renderer.plan.to_json()["samples"] == samples
            for _ in range(2):
                stats = renderer.render()
            assert stats.frames == 2 and stats.sub_frames == 2 * samples
            assert len(stats.draw_seconds) == 2
            assert stats.passes[Pass.REFLECTORS.value] == 2 * samples
            assert stats.passes[Pass.STAND_IN.value] == 1
            baked[samples] = stats.depth_images_baked
    assert baked[8] == baked[1] > 0


def test_sample_offsets_are_inside_the_pixel_and_cover_it_evenly() -> None:
    for samples, offsets in SAMPLE_OFFSETS.items():
        assert len(offsets) == samples
        array = np.array(offsets)
        assert np.all(np.abs(array) < 0.5)
        assert np.allclose(array.mean(axis=0), 0.0)  # no shift of the image as a whole
        assert len(set(array[:, 0])) == samples and len(set(array[:, 1])) == samples


@pytest.mark.parametrize("value", [3, 0, 16, True])
def test_bad_sample_counts_are_refused_in_the_file(value: object) -> None:
    text = EDGES.format(samples=f"samples = {str(value).lower()}")
    with pytest.raises(SceneError, match=r"render\.samples: expected one of: 1, 4, 8"):
        scene_from_toml(text)


@pytest.mark.parametrize("value", ["3", "0", "16", "four"])
def test_bad_sample_counts_are_refused_on_the_command_line(value: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_:
        main(["render", "--samples", value, "-o", "unused.png"])
    assert exit_.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert "--samples" in lines[-1] and ("expected one of: 1, 4, 8" in lines[-1] or "integer" in lines[-1])


def test_glass_interiors_are_made_once_a_frame(ctx: moderngl.Context) -> None:
    """A jitter keeps the eye and the pixel's size, all a glass interior depends on."""
    # Small images (the scene's 256^2 baked for two bounces took seconds): interiors do not depend on them.
    scene = load_scene(SCENES / "glass_and_mirrors.toml").with_overrides(size=(64, 48), samples=8, impostor_resolution=32)
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        renderer.render()
        assert_finite(renderer.read_color_float())
        glass = len(renderer.world.glass)
        assert glass and renderer.stats.interiors_made == glass
        assert renderer.stats.passes[Pass.REFLECTORS.value] == 16
