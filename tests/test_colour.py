"""The colour pipeline: linear float frames, sRGB-encoded 8-bit output through exposure and tone
mapping (depthimpostor/colour.py, shaders/lib/display.glsl), float output, and compare measuring
in linear space whatever the display settings."""

from __future__ import annotations

import json
from pathlib import Path

import moderngl
import numpy as np
import pytest
from PIL import Image

from conftest import SCENES
from depthimpostor.cli import main
from depthimpostor.colour import TONE_MAPPINGS, display_encode, encode_srgb, tone_map
from depthimpostor.gpu.context import bind_default_framebuffer
from depthimpostor.hdr import read_hdr
from depthimpostor.oracles.compare import colour_error
from depthimpostor.passes.present import PresentPass
from depthimpostor.scene.model import RenderSettings
from depthimpostor.gpu.shaders import ProgramCache


def srgb_decode(encoded: np.ndarray) -> np.ndarray:
    """IEC 61966-2-1's decoding, written independently of the encoder under test."""
    return np.where(encoded <= 0.04045, encoded / 12.92, ((encoded + 0.055) / 1.055) ** 2.4)


def test_linear_half_grey_is_written_as_188() -> None:
    assert display_encode(np.array([0.5]))[0] == 188
    assert display_encode(np.array([0.0, 1.0, 0.2158605, 2.0, -1.0, np.nan])).tolist() == [0, 255, 128, 255, 0, 0]


def test_srgb_encoding_is_the_standard_curve() -> None:
    linear = np.concatenate([np.linspace(0.0, 0.01, 1001), np.linspace(0.01, 1.0, 1001)])
    encoded = encode_srgb(linear)
    np.testing.assert_allclose(srgb_decode(encoded), linear, rtol=1e-12, atol=1e-15)
    assert (np.diff(encoded) >= 0).all()
    # The two segments meet (to the standard's rounding of its constants) at the limit.
    assert encode_srgb(np.array([0.0031308]))[0] == pytest.approx(0.04045, abs=1e-6)


@pytest.mark.parametrize(("mapping", "x", "expected"), [
    ("none", 0.5, 0.5), ("none", 3.0, 1.0),
    ("aces", 1.0, (2.51 + 0.03) / (2.43 + 0.59 + 0.14)),  # Narkowicz 2015 at 1
    ("aces", 0.18, 0.18 * (2.51 * 0.18 + 0.03) / (0.18 * (2.43 * 0.18 + 0.59) + 0.14)),
    ("aces", 1e9, 1.0), ("reinhard", 1.0, 0.5), ("reinhard", 3.0, 0.75),
])
def test_tone_curves(mapping: str, x: float, expected: float) -> None:
    assert tone_map(np.array([x]), mapping)[0] == pytest.approx(min(expected, 1.0), rel=1e-12)


def test_exposure_is_in_stops() -> None:
    np.testing.assert_allclose(tone_map(np.array([0.1, 0.2]), "none", exposure=2.0), [0.4, 0.8])
    np.testing.assert_allclose(tone_map(np.array([1.0]), "reinhard", exposure=-1.0), [1.0 / 3.0])


@pytest.mark.parametrize("mapping", TONE_MAPPINGS)
@pytest.mark.parametrize("exposure", [0.0, 1.5])
def test_the_gpu_display_transform_is_the_numpy_one(ctx: moderngl.Context, mapping: str, exposure: float) -> None:
    """The viewer's and the embedding's shader (lib/display.glsl) against colour.py: within one level."""
    width, height = 256, 4
    linear = np.stack([np.broadcast_to(np.geomspace(1e-4, 16.0, width), (height, width))] * 3, axis=2)
    linear = np.concatenate([linear, np.ones((height, width, 1))], axis=2).astype(np.float32)
    frame = ctx.texture((width, height), 4, linear.tobytes(), dtype="f4")
    target = ctx.texture((width, height), 4)
    framebuffer = ctx.framebuffer([target])
    programs = ProgramCache(ctx)
    present = PresentPass(ctx, programs, encode=True, flip=False)
    try:
        framebuffer.use()
        present.draw(frame, display=RenderSettings(tone_mapping=mapping, exposure=exposure))
        shown = np.frombuffer(framebuffer.read(components=3), np.uint8).reshape(height, width, 3)
    finally:
        bind_default_framebuffer(ctx)
        for item in (present, programs, framebuffer, target, frame):
            item.release()
    expected = display_encode(linear[..., :3], mapping, exposure)
    assert np.abs(shown.astype(int) - expected).max() <= 1


CONSTANT_SKY = """
[render]
size = [32, 18]
[camera]
eye = [0.0, 0.0, 0.0]
target = [0.0, 0.0, -1.0]
[environment]
type = "constant"
color = [0.5, 0.5, 0.5]
[[objects]]
name = "behind"
shape = { type = "sphere", radius = 0.1 }
position = [0.0, 0.0, 5.0]
"""


@pytest.mark.parametrize(("flags", "value"), [
    ([], 188),  # sRGB of 0.5
    (["--exposure", "-1"], 137),  # sRGB of 0.25
    (["--tone-mapping", "reinhard"], 156),  # sRGB of 0.5 / 1.5
    (["--tone-mapping", "aces"], round(255 * float(encode_srgb(tone_map(np.array([0.5]), "aces"))[0]))),
])
def test_render_writes_srgb_pngs_through_the_display_settings(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], flags: list[str], value: int
) -> None:
    scene = tmp_path / "grey.toml"
    scene.write_text(CONSTANT_SKY)
    out = tmp_path / "grey.png"
    assert main(["render", str(scene), "-o", str(out), "--frames", "1", *flags]) == 0, capsys.readouterr().err
    pixels = np.asarray(Image.open(out).convert("RGB"))
    assert (pixels == value).all(), np.unique(pixels)


def test_scene_display_settings_apply_and_flags_override_them(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene = tmp_path / "grey.toml"
    scene.write_text(CONSTANT_SKY.replace("[render]", '[render]\ntone_mapping = "reinhard"\nexposure = 1.0'))
    out = tmp_path / "grey.png"
    assert main(["render", str(scene), "-o", str(out), "--frames", "1"]) == 0
    assert (np.asarray(Image.open(out).convert("RGB")) == 188).all()  # 1 / (1 + 1), encoded
    assert main(["render", str(scene), "-o", str(out), "--frames", "1", "--tone-mapping", "none"]) == 0
    assert (np.asarray(Image.open(out).convert("RGB")) == 255).all()  # 2^1 x 0.5, clamped


@pytest.mark.parametrize("suffix", [".exr", ".hdr"])
def test_float_output_is_the_linear_frame(tmp_path: Path, capsys: pytest.CaptureFixture[str], suffix: str) -> None:
    """-o frame.exr (or .hdr) holds the linear float frame: no exposure, tone mapping or encoding."""
    scene = tmp_path / "bright.toml"
    scene.write_text(CONSTANT_SKY.replace("[0.5, 0.5, 0.5]", "[0.5, 2.0, 7.25]"))
    out = tmp_path / f"frame{suffix}"
    code = main(["render", str(scene), "-o", str(out), "--frames", "1", "--tone-mapping", "aces", "--exposure", "3"])
    assert code == 0, capsys.readouterr().err
    frame = read_hdr(out)
    assert frame.shape == (18, 32, 3)
    np.testing.assert_allclose(frame.reshape(-1, 3), np.broadcast_to([0.5, 2.0, 7.25], (32 * 18, 3)),
                               rtol=0.0 if suffix == ".exr" else 1 / 128)


def test_an_output_format_nothing_writes_is_refused_before_rendering(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(["render", "-o", str(tmp_path / "frame.pfm2"), "--size", "32x18"])
    assert code == 2
    assert "expected an image file name" in capsys.readouterr().err


def test_compare_measures_in_linear_space_whatever_the_display(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The report says where colour errors are measured, and the figures do not move with exposure
    or tone mapping (which change only the report's pictures)."""
    reports = {}
    for name, flags in {"plain": [], "graded": ["--tone-mapping", "aces", "--exposure", "2"]}.items():
        folder = tmp_path / name
        args = ["compare", str(SCENES / "default.toml"), "--size", "96x54", "--impostor-res", "32", "-o", str(folder)]
        assert main(args + flags) == 0, capsys.readouterr().err
        reports[name] = json.loads((folder / "report.json").read_text())
        assert "colour RMSE (linear)" in capsys.readouterr().out
    assert reports["plain"]["colour_space"].startswith("linear")
    assert reports["plain"]["figures"] == reports["graded"]["figures"]
    plain, graded = (np.asarray(Image.open(tmp_path / name / "render.png")) for name in ("plain", "graded"))
    assert graded.mean() > plain.mean() + 10  # two stops brighter, even through ACES


def test_the_colour_error_is_relative_above_1_whichever_side_is_bright() -> None:
    """At most 1 on both sides: the plain difference; above, divided by the larger luminance, so a
    sun (50) shown where the truth sees a wall (0.5) counts about 1, as the wall shown where it
    sees the sun does (divided by the truth's alone, the first counted 49.5)."""
    sun, wall = np.full(3, 50.0), np.full(3, 0.5)
    assert np.allclose(colour_error(wall, np.full(3, 0.25)), 0.25)
    assert np.allclose(colour_error(sun, wall), 0.99) and np.allclose(colour_error(wall, sun), -0.99)
    assert np.allclose(colour_error(sun * 1.05, sun), 0.05 / 1.05)
