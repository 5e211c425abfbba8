"""Outputs: a destination that cannot be written is refused before any work, in one line; every
file is written whole or not at all (depthimpostor/outputs.py); a closed stdout ends quietly."""

from __future__ import annotations

import errno
import io
import os
import resource
import signal
import subprocess
import sys
from pathlib import Path
from typing import IO

import numpy as np
import pytest
from PIL import Image

from conftest import PROJECT_ROOT, SCENES
from depthimpostor import cli, outputs
from depthimpostor.cli import BROKEN_PIPE_EXIT, main
from depthimpostor.outputs import Outputs, write_image


def refused_at_once(args: list[str], capsys: pytest.CaptureFixture[str], *fragments: str) -> str:
    """Exit 2 with one line naming the option, nothing on stdout, and no work done: neither a scene
    read nor a GL context made (a refusal after them would raise here, not exit 2)."""

    def work(*_: object, **__: object) -> None:
        raise AssertionError("refused only after the work")

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(cli, "_load", work)
        patch.setattr(cli, "create_context", work)
        code = main(args)
    captured = capsys.readouterr()
    assert code == 2, captured.err
    assert captured.out == ""
    [line] = captured.err.splitlines()
    for fragment in fragments:
        assert fragment in line
    return line


def test_bad_destinations_are_refused_before_any_work(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    refused_at_once(["render", "-o", str(tmp_path / "out.xyz")], capsys, "-o", "out.xyz", "expected an image file name")
    refused_at_once(["render", "-o", str(tmp_path)], capsys, "expected a file name, got an existing folder")
    refused_at_once(["render", "-o", "/proc/x.png"], capsys, "-o /proc/x.png: cannot write in /proc")
    refused_at_once(["truth", "-o", str(tmp_path / "truth.txt")], capsys, "expected an image file name")
    existing = tmp_path / "existing_file"
    existing.write_text("keep me")
    refused_at_once(["compare", "-o", str(existing)], capsys, "expected a folder", "got an existing file")
    assert existing.read_text() == "keep me"
    refused_at_once(["bench", "-o", "/proc/b", "--resolutions", "64"], capsys, "-o /proc/b: cannot write in /proc/b")
    assert not list(tmp_path.glob(".*.tmp"))


def test_the_viewer_checks_its_outputs_before_the_window_opens(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    """In this process (cli.main, what `python -m depthimpostor view` runs; a process each cost a
    start-up): with no display a window that opened first would end in exit 3, not the refusal."""
    monkeypatch.delenv("DISPLAY", raising=False)  # no window could open anyway
    monkeypatch.chdir(tmp_path)
    for option, value in (("--screenshot", str(tmp_path)), ("--window-screenshot", "shot.xyz"),
                          ("--report", "/proc/report.json")):
        code = main(["view", option, value])
        stderr = capsys.readouterr().err
        assert code == 2, stderr
        assert stderr.startswith(f"depthimpostor: {option} ") and len(stderr.splitlines()) == 1


def png_bytes(color: tuple[int, int, int], size: tuple[int, int]) -> bytes:
    buffer = io.BytesIO()
    Image.new("RGB", size, color).save(buffer, format="PNG")
    return buffer.getvalue()


def test_two_writers_to_one_path_leave_one_whole_file(tmp_path: Path) -> None:
    """The reproduction: a second render wrote the same path while the first was writing, and
    the file was the one PNG with 85 bytes of the other after IEND. Here the second write happens
    in the middle of the first: the file is then exactly one of the two images."""
    path = tmp_path / "render.png"
    noisy = np.random.default_rng(1).integers(0, 255, (64, 64, 3), dtype=np.uint8)  # the larger PNG
    flat = np.zeros((8, 8, 3), np.uint8)

    def interrupted(file: IO[bytes]) -> None:
        Image.fromarray(noisy).save(file, format="PNG")
        write_image(path, flat)  # the other writer, done while this one is half way

    with Outputs() as out:
        out.write(path, interrupted)
    data = path.read_bytes()
    assert data.endswith(b"IEND\xaeB`\x82"), "nothing after IEND"
    assert np.array_equal(np.asarray(Image.open(path)), noisy)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["render.png"]


def test_a_full_disk_leaves_no_half_report(monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    """The disk fills at the report's third file: none of its files appear, nor any temporary."""
    calls = []

    def fsync(fd: int) -> None:
        calls.append(fd)
        if len(calls) == 3:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(outputs.os, "fsync", fsync)
    report = tmp_path / "report"
    code = main(["compare", "--size", "96x54", "--impostor-res", "32", "-o", str(report)])
    captured = capsys.readouterr()
    assert code == 2
    [line] = captured.err.splitlines()
    assert line.startswith("depthimpostor: cannot write ") and line.endswith("No space left on device")
    assert list(report.iterdir()) == []


def _file_size_limit(limit: int) -> None:
    """A child's writes over `limit` bytes fail with EFBIG, as a full disk fails them with ENOSPC."""
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # fail the write instead of killing the process


def test_a_failed_write_keeps_the_old_file_whole(tmp_path: Path) -> None:
    """A real process whose write fails (a file-size limit) exits 2 in one line; the file it was
    replacing is as it was, and no temporary is left."""
    out = tmp_path / "render.png"
    old = png_bytes((10, 20, 30), (4, 4))
    out.write_bytes(old)
    env = {**os.environ, "PYTHONPATH": str(PROJECT_ROOT), "MESA_SHADER_CACHE_DISABLE": "true"}
    done = subprocess.run([sys.executable, "-m", "depthimpostor", "render", str(SCENES / "default.toml"),
                           "--size", "160x90", "--frames", "1", "-o", str(out)], env=env, capture_output=True,
                          text=True, timeout=120, preexec_fn=lambda: _file_size_limit(4096))
    assert done.returncode == 2, done.stderr
    assert done.stderr.startswith(f"depthimpostor: cannot write {out}: File too large")
    assert out.read_bytes() == old
    assert sorted(p.name for p in tmp_path.iterdir()) == ["render.png"]


def test_a_closed_stdout_ends_quietly(tmp_path: Path) -> None:
    """`render ... | head`: the reader leaves before the output; no traceback, the shell's status."""
    env = {**os.environ, "PYTHONPATH": str(PROJECT_ROOT)}
    read_end, write_end = os.pipe()
    os.close(read_end)  # the reader has gone before anything is printed
    done = subprocess.run([sys.executable, "-m", "depthimpostor", "render", "--size", "64x36", "--frames", "1",
                           "--stats", "-o", str(tmp_path / "out.png")], stdout=write_end, stderr=subprocess.PIPE,
                          env=env, text=True, timeout=120)
    os.close(write_end)
    assert done.returncode == BROKEN_PIPE_EXIT == 141
    assert done.stderr == ""
    assert (tmp_path / "out.png").is_file()


@pytest.mark.parametrize("suffix", sorted(outputs.IMAGE_FORMATS))
def test_every_image_format_taken_is_written_and_read_back(tmp_path: Path, suffix: str) -> None:
    """Each extension `-o` takes gives a file of that format holding the frame (lossy ones close)."""
    y, x = np.mgrid[0:36, 0:64]
    frame = np.stack([x * 4, y * 7, (x + y) * 2], axis=-1).astype(np.uint8)  # smooth: JPEG and WebP stay close
    path = write_image(tmp_path / f"frame{suffix}", frame)
    with Image.open(path) as written:
        assert written.format == outputs.IMAGE_FORMATS[suffix]
        pixels = np.asarray(written.convert("RGB")).astype(int)
    lossy = outputs.IMAGE_FORMATS[suffix] in ("JPEG", "WEBP")
    assert pixels.shape == frame.shape and np.abs(pixels - frame).max() <= (24 if lossy else 0)


@pytest.mark.parametrize("suffix", [".blp", ".bufr", ".grib", ".h5", ".hdf", ".emf", ".wmf", ".msp", ".palm", ".xbm",
                                    ".pfm", ".pbm", ".pgm"])
def test_formats_pillow_registers_but_that_are_not_written_are_refused(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], suffix: str) -> None:
    """Pillow lists these as formats it saves, but fails on an RGB frame after the rendering
    (.blp, .bufr, ...) or writes a binary PPM whatever the name says (.pfm, .pbm, .pgm)."""
    refused_at_once(["render", "-o", str(tmp_path / f"x{suffix}")], capsys, f"x{suffix}: expected an image file name",
                    ".png, .jpg", f"got '{suffix}'")
    assert list(tmp_path.iterdir()) == []


def test_a_link_into_a_missing_folder_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A dangling link's folder is not made (it was: outside the folder, where the link pointed)."""
    link = tmp_path / "link.png"
    link.symlink_to(tmp_path / "elsewhere" / "dir" / "x.png")
    refused_at_once(["render", "-o", str(link)], capsys, "link.png: a symbolic link to", "whose folder does not exist")
    assert not (tmp_path / "elsewhere").exists()
    # A link into an existing folder writes the file it names; the link stays a link.
    (tmp_path / "elsewhere").mkdir()
    link.unlink()
    link.symlink_to(tmp_path / "elsewhere" / "x.png")
    write_image(link, np.zeros((2, 2, 3), np.uint8))
    assert link.is_symlink() and (tmp_path / "elsewhere" / "x.png").is_file()


def test_a_name_too_long_is_refused_and_a_long_one_is_written(tmp_path: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    line = refused_at_once(["render", "-o", str(tmp_path / ("a" * 300 + ".png"))], capsys, "File name too long")
    assert len(line) < 200, "the name is shortened in the message"
    # 255 bytes, the most a folder holds: its temporary's name (a hidden, random one beside it) fits too.
    longest = tmp_path / ("b" * 251 + ".png")
    write_image(longest, np.zeros((2, 2, 3), np.uint8))
    assert sorted(p.name for p in tmp_path.iterdir()) == [longest.name]


def test_an_image_into_a_pipe_on_stdout_is_the_image_alone(tmp_path: Path) -> None:
    """`render -o /dev/stdout | ...`: the PNG straight into the pipe (it failed after rendering:
    /dev/stdout resolved to /proc/.../pipe:[...]); what the command says goes to stderr."""
    env = {**os.environ, "PYTHONPATH": str(PROJECT_ROOT)}
    done = subprocess.run([sys.executable, "-m", "depthimpostor", "render", "--size", "64x36", "--impostor-res", "32",
                           "-o", "/dev/stdout"], capture_output=True, env=env, timeout=120, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    with Image.open(io.BytesIO(done.stdout)) as image:
        assert image.format == "PNG" and image.size == (64, 36)
    assert done.stderr.decode().startswith("/dev/stdout\n")
    assert list(tmp_path.iterdir()) == []
