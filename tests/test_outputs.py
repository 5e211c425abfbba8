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
import time
from pathlib import Path
from typing import IO

import numpy as np
import pytest
from PIL import Image

from conftest import PROJECT_ROOT, SCENES
from depthimpostor import outputs
from depthimpostor.cli import BROKEN_PIPE_EXIT, main
from depthimpostor.outputs import Outputs, write_image


def refused_at_once(args: list[str], capsys: pytest.CaptureFixture[str], *fragments: str) -> str:
    """Exit 2 with one line naming the option, nothing on stdout (no work was done), quickly."""
    start = time.perf_counter()
    code = main(args)
    captured = capsys.readouterr()
    assert code == 2, captured.err
    assert captured.out == ""
    [line] = captured.err.splitlines()
    for fragment in fragments:
        assert fragment in line
    assert time.perf_counter() - start < 5.0, "refused only after the work"
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


def test_the_viewer_checks_its_outputs_before_the_window_opens(tmp_path: Path) -> None:
    env = {key: value for key, value in os.environ.items() if key != "DISPLAY"}  # no window could open anyway
    env["PYTHONPATH"] = str(PROJECT_ROOT)
    for option, value in (("--screenshot", str(tmp_path)), ("--window-screenshot", "shot.xyz"),
                          ("--report", "/proc/report.json")):
        done = subprocess.run([sys.executable, "-m", "depthimpostor", "view", option, value], cwd=tmp_path, env=env,
                              capture_output=True, text=True, timeout=60)
        assert done.returncode == 2, done.stderr
        assert done.stderr.startswith(f"depthimpostor: {option} ") and len(done.stderr.splitlines()) == 1


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
