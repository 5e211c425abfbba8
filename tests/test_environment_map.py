"""Equirect HDR environments: the lookup's convention, the GPU against the truth's lookup (float
noise, unclamped), and the scene file's checks of the image."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import moderngl
import numpy as np
import pytest

from conftest import SCENES, assert_finite
from depthimpostor.oracles.compare import LUMINANCE_WEIGHTS, colour_error, compare
from depthimpostor.constants import Method
from depthimpostor.errors import SceneError
from depthimpostor.hdr import read_hdr, write_hdr
from depthimpostor.renderer import Renderer
from depthimpostor.scene import load_scene
from depthimpostor.scene.model import Environment
from depthimpostor.oracles.truth import environment, equirect_lookup

WIDTH, HEIGHT = 16, 8


def sky_file(folder: Path, image: np.ndarray, name: str = "sky.exr") -> Path:
    path = folder / name
    with open(path, "wb") as file:
        write_hdr(file, image, path.suffix)
    return path


def map_of(image: np.ndarray, intensity: float = 1.0, rotation: float = 0.0) -> Environment:
    return Environment("equirect", path=Path("sky.exr"), intensity=intensity, rotation=rotation,
                       image=image.astype(np.float32))


def direction(longitude: float, polar: float) -> np.ndarray:
    """The direction at `longitude` (from -Z toward +X) and `polar` (from the zenith)."""
    return np.array([[np.sin(polar) * np.sin(longitude), np.cos(polar), -np.sin(polar) * np.cos(longitude)]])


def test_texel_centres_give_their_texels_and_the_axes_fall_where_stated() -> None:
    """Column i and row j of the image are seen at the longitude and polar angle of the texel's
    centre; -Z is the image's middle, +X three quarters across, the zenith its top row."""
    image = np.arange(WIDTH * HEIGHT * 3, dtype=np.float32).reshape(HEIGHT, WIDTH, 3)
    env = map_of(image, intensity=2.0)
    for i, j in [(0, 0), (3, 2), (WIDTH - 1, HEIGHT - 1), (WIDTH // 2, HEIGHT // 2)]:
        d = direction(((i + 0.5) / WIDTH - 0.5) * 2 * np.pi, (j + 0.5) / HEIGHT * np.pi)
        np.testing.assert_allclose(equirect_lookup(env, d)[0], 2.0 * image[j, i], rtol=1e-9, atol=1e-9)
    # Halfway between two columns at the seam (longitude +-pi, behind +Z): the first and last columns' mean.
    seam = equirect_lookup(env, direction(np.pi, (2 + 0.5) / HEIGHT * np.pi))[0]
    np.testing.assert_allclose(seam, (image[2, 0] + image[2, WIDTH - 1]), rtol=1e-9)
    # Straight up: the top row, halfway between the two columns at longitude 0.
    np.testing.assert_allclose(equirect_lookup(env, np.array([[0.0, 1.0, 0.0]]))[0],
                               image[0, WIDTH // 2 - 1] + image[0, WIDTH // 2], rtol=1e-9)
    ramp = np.zeros((HEIGHT, WIDTH, 3), np.float32)
    ramp[..., 0] = np.arange(WIDTH)  # red grows across
    ahead, right = (equirect_lookup(map_of(ramp), np.array(v))[0, 0] for v in ([[0.0, 0.0, -1.0]], [[1.0, 0.0, 0.0]]))
    assert ahead == pytest.approx(WIDTH / 2 - 0.5) and right == pytest.approx(WIDTH * 3 / 4 - 0.5)


def test_rotation_turns_the_sky_counter_clockwise_about_up() -> None:
    """rotation = 90 turns the sky as a right-handed turn about +Y: what was toward +X is then toward -Z."""
    rng = np.random.default_rng(1)
    image = rng.random((HEIGHT, WIDTH, 3)).astype(np.float32)
    turned = map_of(image, rotation=90.0)
    for before, after in [([1.0, 0.2, 0.0], [0.0, 0.2, -1.0]), ([0.0, -0.5, -1.0], [-1.0, -0.5, 0.0])]:
        np.testing.assert_allclose(equirect_lookup(turned, np.array([after])),
                                   equirect_lookup(map_of(image), np.array([before])), atol=1e-12)


def sky_scene(folder: Path, image: np.ndarray, intensity: float, rotation: float) -> str:
    sky_file(folder, image)
    return f"""
[render]
size = [160, 90]
[camera]
eye = [0.0, 0.3, 3.0]
target = [0.0, 0.0, 0.0]
[environment]
type = "equirect"
path = "sky.exr"
intensity = {intensity}
rotation = {rotation}
[[objects]]
name = "ball"
shape = {{ type = "sphere", radius = 0.9 }}
material = {{ type = "mirror" }}
"""


@pytest.mark.parametrize("method", [Method.RAYTRACE, Method.DEPTH, Method.CUBEMAP])
def test_gpu_sky_is_the_truths_lookup_unclamped(ctx: moderngl.Context, tmp_path: Path, method: Method) -> None:
    """A mirror ball alone under a sky of values up to 8 (no texel alike, so that a wrong texel or
    weight shows): the background (the environment pass) and every mirror pixel (the mirror
    shader; every method's reflected rays see only the sky) are the truth's lookup of the same
    rays, to float32 noise, before any clamp."""
    rng = np.random.default_rng(7)
    image = (8.0 * rng.random((32, 64, 3))).astype(np.float32)
    path = tmp_path / "scene.toml"
    path.write_text(sky_scene(tmp_path, image, 1.7, 33.0))
    scene = load_scene(path)
    with Renderer(ctx, scene, reflection_data=True, method=method) as renderer:
        renderer.render()
        frame = renderer.read_color_float()
        data = renderer.read_reflection_data()
        camera = renderer.camera
    assert_finite(frame)
    mask = data.mirror_mask
    assert mask.mean() > 0.2 and (~mask).mean() > 0.2
    expected = environment(scene, data.direction[mask])
    assert expected.max() > 4.0  # far past what a clamp to [0, 1] would keep
    # float32 angles (the GPU's atan) place a texel position within ~3e-5 of a texel: an error of
    # that share of the largest step between neighbouring texels (8 x 1.7). A wrong texel, weight
    # or wrap is off by a whole step.
    noise = 1e-4 * 8.0 * 1.7
    np.testing.assert_allclose(frame[mask], expected, rtol=0, atol=noise)
    rows, columns = np.nonzero(~mask)
    rays = camera.ray_direction(columns + 0.5, rows + 0.5)
    np.testing.assert_allclose(frame[~mask], environment(scene, rays), rtol=0, atol=noise)


def test_hdr_sky_scene_raytrace_matches_the_truth(ctx: moderngl.Context) -> None:
    """The shipped HDR-sky scene: ray-traced mirrors against the Embree truth, at float noise."""
    scene = load_scene(SCENES / "hdr_sky.toml").with_overrides(size=(240, 135))
    assert scene.environment.is_map and scene.environment.image is not None
    assert scene.environment.image.max() > 10.0  # the sun
    with Renderer(ctx, scene, reflection_data=True, method=Method.RAYTRACE) as renderer:
        renderer.render()
        comparison = compare(renderer)
        figures = comparison.figures
        # The colour error is measured unclamped: a truth 5 % brighter everywhere (the sun's disc
        # included, where both pictures exceed 1 and clamping saw no difference) is off by 5 % of
        # the truth's luminance above 1, by 5 % of its value below.
        brighter = dataclasses.replace(comparison.truth_frame, color=comparison.truth_frame.color * 1.05)
        off = compare(renderer, truth=brighter)
    assert figures.mirror_pixels > 1000
    assert figures.wrong_object_share == 0.0
    assert figures.color_rmse < 1e-4
    truth = comparison.truth[comparison.mirror_mask]
    luminance = 1.05 * truth @ LUMINANCE_WEIGHTS  # the brighter truth's, which the error is measured against
    both_above_1 = (comparison.render[comparison.mirror_mask] > 1.0).all(axis=1) & (truth > 1.0).all(axis=1)
    assert both_above_1.sum() > 20  # the scene shows the sun's disc in its mirrors
    expected = (0.05 * truth / np.maximum(luminance, 1.0)[:, None]).max(axis=1)
    error = np.abs(colour_error(off.render, off.truth)[comparison.mirror_mask]).max(axis=1)
    np.testing.assert_allclose(error, expected, rtol=1e-3, atol=1e-4)
    assert error[both_above_1].min() > 0.02
    assert off.figures.color_rmse > 100 * figures.color_rmse


def test_radiance_and_exr_files_read_alike(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    image = (4.0 * rng.random((6, 10, 3))).astype(np.float32)
    exr, hdr = read_hdr(sky_file(tmp_path, image, "a.exr")), read_hdr(sky_file(tmp_path, image, "a.hdr"))
    np.testing.assert_array_equal(exr, image)  # 32-bit float, lossless
    # RGBE: 8-bit mantissas under the brightest channel's exponent (a step of at most 1/128 of it).
    assert (np.abs(hdr - image) <= image.max(axis=2, keepdims=True) / 128).all()
    assert exr.shape == hdr.shape == (6, 10, 3)


def bad(tmp_path: Path, environment: str) -> SceneError:
    path = tmp_path / "bad.toml"
    path.write_text(f'environment = {environment}\n[[objects]]\nname = "a"\nshape = {{ type = "sphere", radius = 1.0 }}\n')
    with pytest.raises(SceneError) as caught:
        load_scene(path)
    assert "\n" not in str(caught.value)
    return caught.value


@pytest.mark.parametrize(("environment", "path", "fragment"), [
    ('{ type = "equirect" }', "environment.path", "missing required field"),
    ('{ type = "equirect", path = "none.exr" }', "environment.path", 'expected an existing HDR image, got "none.exr"'),
    ('{ type = "equirect", path = "sky.png" }', "environment.path", "expected a path to a .hdr or .exr file"),
    ('{ type = "equirect", path = "text.hdr" }', "environment.path", "expected an HDR image"),
    ('{ type = "equirect", path = "broken.exr" }', "environment.path", "OpenEXR cannot decode"),
    ('{ type = "equirect", path = "broken.hdr" }', "environment.path", "OpenCV cannot decode"),
    ('{ type = "equirect", path = "nan.exr" }', "environment.path", "expected finite pixel values"),
    ('{ type = "equirect", path = "good.exr", intensity = -1 }', "environment.intensity", "expected a number >= 0"),
    ('{ type = "equirect", path = "good.exr", rotation = 720 }', "environment.rotation",
     "expected a number in [-360, 360]"),
    ('{ type = "equirect", path = "good.exr", color = [1, 1, 1] }', "environment", 'unknown field "color"'),
])
def test_bad_environment_maps_are_named(tmp_path: Path, environment: str, path: str, fragment: str) -> None:
    sky_file(tmp_path, np.ones((4, 8, 3), np.float32), "good.exr")
    (tmp_path / "text.hdr").write_text("not an image\n")
    (tmp_path / "broken.exr").write_bytes(b"\x76\x2f\x31\x01" + bytes(40))
    (tmp_path / "broken.hdr").write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 8\n\x01")
    nan = np.ones((4, 8, 3), np.float32)
    nan[1, 2, 0] = np.nan
    sky_file(tmp_path, nan, "nan.exr")
    error = bad(tmp_path, environment)
    assert error.path == path
    assert fragment in str(error), str(error)


def test_the_environment_map_is_compared_by_its_path(tmp_path: Path) -> None:
    """A scene holds the image, but compares (and re-plans) by the file that names it."""
    image = np.ones((4, 8, 3), np.float32)
    a, b = map_of(image), map_of(image * 2)
    assert a == b and dataclasses.replace(a, path=Path("other.exr")) != a
