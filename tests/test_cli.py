"""The `depthimpostor render` command: renders the default and a bundled scene to PNG, and turns bad
input into one `depthimpostor: ...` line on stderr and exit status 2, never a traceback.

Most runs call `cli.main` in-process; the same commands also run once as `python -m depthimpostor`,
which is what a user types and the only way to see that nothing but the message reaches stderr.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from conftest import PROJECT_ROOT, SCENES
from depthimpostor.cli import main
from depthimpostor.scene import load_scene

BAD_COLOUR_SCENE = """\
# One diffuse sphere whose colour is a name instead of three numbers.
[camera]
eye = [0.0, 1.0, 4.0]
target = [0.0, 0.0, 0.0]

[[objects]]
name = "ball"
shape = { type = "sphere", radius = 1.0 }
material = { type = "diffuse", color = "red" }
"""


def run_in_process(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    try:
        code = main(args)
    except SystemExit as exit_:  # argparse exits on a malformed argument
        code = exit_.code
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def run_subprocess(args: list[str]) -> tuple[int, str, str]:
    env = {key: value for key, value in os.environ.items() if key != "DEPTHIMPOSTOR_GL_BACKEND"}
    env["PYTHONPATH"] = str(PROJECT_ROOT)
    done = subprocess.run([sys.executable, "-m", "depthimpostor", *args], cwd=PROJECT_ROOT, env=env,
                          capture_output=True, text=True, timeout=120)
    return done.returncode, done.stdout, done.stderr


def run(mode: str, args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    return run_subprocess(args) if mode == "subprocess" else run_in_process(args, capsys)


def assert_rendered(out: Path, stdout: str, size: tuple[int, int]) -> str:
    """The path on the first line, the timing line after it, and a PNG of `size` that shows something.
    Returns the timing line."""
    lines = stdout.splitlines()
    assert len(lines) == 2, stdout
    assert lines[0] == str(out)
    assert "frame" in lines[1] and "ms" in lines[1]
    assert f"{size[0]}x{size[1]}" in lines[1]
    with Image.open(out) as image:
        assert image.format == "PNG"
        assert image.size == size
        pixels = np.asarray(image.convert("RGB"), dtype=np.float64)
    assert pixels.std() > 10.0, "the image is (nearly) a flat colour"
    assert len(np.unique(pixels.reshape(-1, 3), axis=0)) > 20
    return lines[1]


# --- renders ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("mode", ["in_process", "subprocess"])
def test_render_without_a_scene_renders_the_default_scene(
    mode: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "nested" / "default.png"  # the output folder is created
    code, stdout, stderr = run(mode, ["render", "-o", str(out), "--size", "160x90"], capsys)
    assert code == 0, stderr
    assert stderr == ""
    timing = assert_rendered(out, stdout, (160, 90))
    assert "optimized" in timing and "256x256" in timing  # the default algorithm and the scene's resolution


def test_render_planar_mirror_with_the_basic_algorithm(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "planar.png"
    args = ["render", str(SCENES / "planar_mirror.toml"), "--algorithm", "basic", "--impostor-res", "32",
            "--size", "96x54", "-o", str(out)]
    code, stdout, stderr = run_in_process(args, capsys)
    assert code == 0, stderr
    timing = assert_rendered(out, stdout, (96, 54))
    assert "basic" in timing and "32x32" in timing


# --- bad input ---------------------------------------------------------------------------------------


def assert_one_line_error(code: int, stdout: str, stderr: str, *fragments: str) -> str:
    assert code == 2, (code, stderr)
    assert stdout == ""
    assert "Traceback" not in stderr
    lines = stderr.splitlines()
    assert len(lines) == 1, stderr
    assert lines[0].startswith("depthimpostor: ")
    for fragment in fragments:
        assert fragment in lines[0]
    return lines[0]


def write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize("mode", ["in_process", "subprocess"])
def test_bad_colour_names_the_file_and_the_field(mode: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene = write(tmp_path / "bad_colour.toml", BAD_COLOUR_SCENE)
    # The colour is the only thing wrong with the file.
    load_scene(write(tmp_path / "fixed.toml", BAD_COLOUR_SCENE.replace('"red"', "[1.0, 0.0, 0.0]")))
    out = tmp_path / "never.png"
    code, stdout, stderr = run(mode, ["render", str(scene), "-o", str(out)], capsys)
    line = assert_one_line_error(code, stdout, stderr, f"{scene}: objects[0].material.color: ", '"red"')
    assert "expected 3 numbers" in line
    assert not out.exists()


@pytest.mark.parametrize("mode", ["in_process", "subprocess"])
def test_missing_scene_file(mode: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "no_such_scene.toml"
    code, stdout, stderr = run(mode, ["render", str(missing), "-o", str(tmp_path / "never.png")], capsys)
    assert_one_line_error(code, stdout, stderr, str(missing), "no such file")


@pytest.mark.parametrize("mode", ["in_process", "subprocess"])
def test_zero_size_override_is_rejected_by_scene_validation(
    mode: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "never.png"
    code, stdout, stderr = run(mode, ["render", "--size", "0x10", "-o", str(out)], capsys)
    line = assert_one_line_error(code, stdout, stderr, "command line: --size: ")
    assert "[0, 10]" in line
    assert not out.exists()


@pytest.mark.parametrize("size", ["abc", "10x", "1x2x3"])
def test_malformed_size_is_an_argparse_error(size: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, stdout, stderr = run_in_process(["render", "--size", size, "-o", str(tmp_path / "never.png")], capsys)
    assert code == 2
    assert stdout == "" and "Traceback" not in stderr
    last = stderr.splitlines()[-1]
    assert last.startswith("depthimpostor render: error: argument --size: ")
    assert repr(size) in last and "WIDTHxHEIGHT" in last


def test_malformed_size_from_the_shell(tmp_path: Path) -> None:
    code, stdout, stderr = run_subprocess(["render", "--size", "abc", "-o", str(tmp_path / "never.png")])
    assert code == 2
    assert stdout == "" and "Traceback" not in stderr
    assert stderr.splitlines()[0].startswith("usage: depthimpostor render")
    assert "argument --size: expected WIDTHxHEIGHT such as 960x540, got 'abc'" in stderr
