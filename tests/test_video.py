"""`depthimpostor render --video`: MP4 and GIF files read back (imageio) with the frames asked for,
of the size asked for, showing the scene, moving when the camera or the scene moves; the orbit's
geometry; bad arguments refused in one line (exit 2) before any file is made."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest

from conftest import PROJECT_ROOT, SCENES
from depthimpostor.interrupts import deferred_interrupts, raise_pending
from depthimpostor.renderer import Renderer
from depthimpostor.scene.model import Camera
from depthimpostor.video import (
    CameraPath, VideoSettings, gif_durations, orbit_view, view_at, write_video,
)
from test_cli import assert_one_line_error, run_in_process

SIZE = (64, 48)
#: 0.6 s at 10 frames/s.
FRAMES = 6


def read_video(path: Path) -> np.ndarray:
    """Every frame of the file, (frames, height, width, 3) uint8."""
    if path.suffix == ".gif":
        return np.asarray(iio.imread(path, index=None, mode="RGB"))
    return np.stack(list(iio.imiter(path, plugin="FFMPEG")))


def render_video(path: Path, capsys: pytest.CaptureFixture[str], scene: str = "default.toml",
                 *extra: str) -> tuple[np.ndarray, list[str]]:
    code, stdout, stderr = run_in_process(
        ["render", str(SCENES / scene), "--video", str(path), "--duration", "0.6", "--fps", "10",
         "--size", f"{SIZE[0]}x{SIZE[1]}", *extra], capsys)
    assert code == 0, stderr
    assert "Traceback" not in stderr
    return read_video(path), stdout.splitlines()


def frame_changes(frames: np.ndarray) -> list[float]:
    """Mean absolute difference (0 to 255) of each frame from the one before."""
    signed = frames.astype(np.float64)
    return [float(np.abs(signed[i + 1] - signed[i]).mean()) for i in range(len(frames) - 1)]


@pytest.mark.parametrize("suffix", [".mp4", ".gif"])
def test_an_orbit_of_a_still_scene(suffix: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / f"orbit{suffix}"
    frames, lines = render_video(out, capsys)
    assert lines[0] == str(out)
    assert f"{FRAMES} frames" in lines[1] and "camera orbit" in lines[1]
    assert frames.shape == (FRAMES, SIZE[1], SIZE[0], 3)
    assert all(frame.std() > 10.0 for frame in frames), "a frame is (nearly) one colour"
    # The camera turns 60 degrees a frame: every frame is another view.
    assert min(frame_changes(frames)) > 5.0, frame_changes(frames)
    assert [p.name for p in tmp_path.iterdir()] == [out.name], "a temporary file was left behind"


def test_the_video_frames_are_the_rendered_frames(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A fixed camera on a still scene: each frame is `render`'s PNG of that scene, within the
    GIF's palette (MP4's lossy colour would blur the comparison)."""
    out, png = tmp_path / "fixed.gif", tmp_path / "still.png"
    frames, _ = render_video(out, capsys, "default.toml", "--camera-path", "fixed")
    code, _, stderr = run_in_process(["render", str(SCENES / "default.toml"), "-o", str(png), "--frames", "1",
                                      "--size", f"{SIZE[0]}x{SIZE[1]}"], capsys)
    assert code == 0, stderr
    still = iio.imread(png).astype(np.float64)
    # Pillow writes a frame identical to the one before once, for their time together.
    assert 1 <= len(frames) <= FRAMES
    assert np.abs(frames[0].astype(np.float64) - still).mean() < 3.0


def test_an_animated_scene_keeps_its_camera_and_moves(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "carousel.mp4"
    frames, lines = render_video(out, capsys, "carousel.toml")
    assert "camera fixed" in lines[1]
    assert frames.shape == (FRAMES, SIZE[1], SIZE[0], 3)
    changes = frame_changes(frames)
    # The box and the torus move (and their reflections with them); the rest stays.
    assert all(0.05 < change < 5.0 for change in changes), changes


def test_the_orbit_turns_about_the_up_axis_keeping_distance_and_height() -> None:
    view = Camera(eye=(0.6, 2.2, 6.5), target=(0.0, 0.8, 0.0))
    eye, target = np.array(view.eye), np.array(view.target)
    for turn in (0.125, 0.25, 0.5, 0.75):
        turned = orbit_view(view, turn)
        moved = np.array(turned.eye)
        assert turned.target == view.target and turned.up == view.up and turned.fov_y == view.fov_y
        assert moved[1] == pytest.approx(eye[1])
        assert np.linalg.norm(moved - target) == pytest.approx(np.linalg.norm(eye - target))
        before, after = (eye - target)[[0, 2]], (moved - target)[[0, 2]]
        angle = np.degrees(np.arccos(np.dot(before, after) / np.linalg.norm(before) / np.linalg.norm(after)))
        assert angle == pytest.approx(min(360 * turn, 360 - 360 * turn), abs=1e-6)
    assert np.allclose(orbit_view(view, 1.0).eye, view.eye)
    settings = VideoSettings(duration=2.0, fps=4.0, camera_path=CameraPath.ORBIT)
    assert settings.frames == 8
    assert view_at(view, settings, 2) == orbit_view(view, 0.25)
    assert view_at(view, VideoSettings(2.0, 4.0, CameraPath.FIXED), 2) == view


def test_gif_frame_times_keep_the_frame_rate() -> None:
    assert gif_durations(4, 10.0) == [100] * 4
    thirty = gif_durations(30, 30.0)
    assert set(thirty) == {30, 40} and sum(thirty) == 1000


@pytest.mark.parametrize(("arguments", "fragments"), [
    (["--video", "{out}.avi", "--duration", "1"], ["--video", ".mp4 or .gif", "'.avi'"]),
    (["--video", "{out}.mp4"], ["--duration: expected with --video"]),
    (["--video", "{out}.mp4", "--duration", "0.01"], ["--duration: expected at least one frame"]),
    (["--video", "{out}.mp4", "--duration", "1", "--size", "65x48"], ["--size", "even", "65x48"]),
    (["--video", "{out}.gif", "--duration", "1", "-o", "{out}.png"], ["-o: expected no value with --video"]),
    (["--duration", "1", "-o", "{out}.png"], ["--duration: expected only with --video"]),
    (["--video", "{tmp}", "--duration", "1"], ["--video", "expected a video file name"]),
    # A billion frames (they were all rendered, a GIF's held in a list): refused at once.
    (["--video", "{out}.gif", "--duration", "1", "--fps", "1e9"],
     ["--duration: expected at most 100,000 frames: 1 s at 1e+09 frames/s is 1e+09 frames"]),
    (["--video", "{out}.mp4", "--duration", "1e9"], ["--duration: expected at most 100,000 frames"]),
    (["--video", "{out}.mp4", "--duration", "1e308", "--fps", "1e308"], ["is inf frames"]),
    (["--video", "{out}.mp4", "--duration", "3334", "--fps", "30"], ["is 100,020 frames"]),
    # A GIF frame shows for at most 655.35 s (an OverflowError after the rendering).
    (["--video", "{out}.gif", "--duration", "1e5", "--fps", "0.00152590"], ["got 0.0015259"]),
    (["--video", "{out}.gif", "--duration", "1000", "--fps", "0.001"],
     ["--fps: expected at least 0.00152591 frames/s for a GIF (a GIF frame shows for at most 655.35 s), got 0.001"]),
])
def test_bad_video_arguments_are_one_line(arguments: list[str], fragments: list[str], tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "never"
    args = [a.format(out=out, tmp=tmp_path) for a in arguments]
    code, stdout, stderr = run_in_process(["render", "--size", "64x48", *args], capsys)
    assert_one_line_error(code, stdout, stderr, *fragments)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(("option", "value"), [("--duration", "-1"), ("--fps", "0"), ("--duration", "nan")])
def test_malformed_numbers_are_argparse_errors(option: str, value: str, tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    args = ["render", "--video", str(tmp_path / "never.mp4"), "--duration", "1", option, value]
    code, stdout, stderr = run_in_process(args, capsys)
    assert code == 2 and stdout == "" and "Traceback" not in stderr
    assert stderr.splitlines()[-1].startswith(f"depthimpostor render: error: argument {option}: expected a ")
    assert list(tmp_path.iterdir()) == []


def test_a_failure_while_drawing_leaves_no_file(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """The third frame fails: one line, exit 2, and neither the video nor its temporary file."""
    from depthimpostor.errors import GpuLimitError
    from depthimpostor.renderer import Renderer

    drawn = Renderer.render
    frames = iter(range(100))

    def render(self: Renderer, *args: object, **kwargs: object) -> object:
        if next(frames) == 2:
            raise GpuLimitError("out of memory on the third frame (a test)")
        return drawn(self, *args, **kwargs)

    monkeypatch.setattr(Renderer, "render", render)
    for suffix in (".mp4", ".gif"):
        frames = iter(range(100))
        out = tmp_path / f"never{suffix}"
        code, stdout, stderr = run_in_process(["render", "--video", str(out), "--duration", "0.6", "--fps", "10",
                                               "--size", "64x48"], capsys)
        # The progress bar stays where it stopped (2 of 6 frames), the error on a line of its own.
        bar, error = stderr.rstrip("\n").rsplit("\n", 1)
        assert "2/6" in bar and "Traceback" not in bar
        assert_one_line_error(code, stdout, error, "out of memory on the third frame")
        assert list(tmp_path.iterdir()) == []


def test_ffmpeg_is_done_when_a_frame_fails(tmp_path: Path) -> None:
    """The error reaches the caller only once ffmpeg has exited: otherwise it could open the
    temporary file after Outputs removed it, and leave a stray file (seen under load)."""
    from depthimpostor.video import write_video

    def frames() -> Iterator[np.ndarray]:
        for i in range(2):
            yield np.full((SIZE[1], SIZE[0], 3), 40 * i, np.uint8)
        raise RuntimeError("a frame that could not be drawn")

    def ffmpeg_children() -> list[str]:
        children = Path(f"/proc/{os.getpid()}/task/{os.getpid()}/children").read_text().split()
        names = []
        for child in children:
            with contextlib.suppress(FileNotFoundError):  # gone between the two reads
                names.append(Path(f"/proc/{child}/comm").read_text().strip())
        return [name for name in names if "ffmpeg" in name]

    with pytest.raises(RuntimeError, match="could not be drawn") as failed:
        write_video(tmp_path / "never.mp4", frames(), 10.0)
    assert failed.traceback  # the failure, and whatever it holds, still alive here
    assert ffmpeg_children() == []
    assert list(tmp_path.iterdir()) == []


def test_a_gif_is_written_as_its_frames_come(tmp_path: Path) -> None:
    """The GIF's frames are not held until the end (they were, in a list: a billion frames ran the
    memory out): the file grows while they are drawn (in a temporary beside it)."""
    out = tmp_path / "v.gif"
    rng = np.random.default_rng(3)
    sizes = []

    def frames() -> Iterator[np.ndarray]:
        for _ in range(5):
            sizes.append(sum(p.stat().st_size for p in tmp_path.iterdir()))  # before each frame is drawn
            yield (rng.random((SIZE[1], SIZE[0], 3)) * 255).astype(np.uint8)

    write_video(out, frames(), 10.0)
    # A frame is written once the next shows it is not the same (then it would be written once, longer).
    assert sizes[0] == sizes[1] == 0 and 0 < sizes[2] < sizes[3] < sizes[4], sizes
    assert read_video(out).shape == (5, SIZE[1], SIZE[0], 3)
    assert [p.name for p in tmp_path.iterdir()] == ["v.gif"]


def test_a_still_gif_writes_a_repeated_frame_once() -> None:
    from PIL import Image

    from depthimpostor.video import _write_gif

    frame = np.zeros((4, 6, 3), np.uint8)
    frame[1:3, 2:4] = (200, 40, 10)
    moved = np.roll(frame, 1, axis=1)
    path = Path(os.environ.get("TMPDIR", "/tmp")) / f"still-{os.getpid()}.gif"
    try:
        _write_gif(path, [frame, frame, frame, moved], 10.0)
        with Image.open(path) as gif:
            times = []
            for index in range(gif.n_frames):
                gif.seek(index)
                times.append(gif.info["duration"])
        assert times == [300, 100]
        assert np.array_equal(read_video(path), np.stack([frame, moved]))
    finally:
        path.unlink(missing_ok=True)


def _sigint_by_default() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.parametrize(("suffix", "sent", "status"), [(".gif", signal.SIGINT, 130), (".mp4", signal.SIGINT, 130),
                                                         (".gif", signal.SIGTERM, 143)])
def test_an_interrupted_video_ends_quietly_and_leaves_no_file(tmp_path: Path, suffix: str, sent: int,
                                                              status: int) -> None:
    """Ctrl-C (or `kill`) while the frames are drawn: the shell's status, no traceback (it was a
    KeyboardInterrupt's), neither the video nor its temporary."""
    env = {**os.environ, "PYTHONPATH": str(PROJECT_ROOT)}
    out = tmp_path / f"v{suffix}"
    # As a terminal's foreground job: SIGINT at its default disposition. A suite started in the
    # background of a script (`nohup ... &`) hands its children SIGINT ignored, which Python
    # honours (no KeyboardInterrupt handler), as it should: the test is of Ctrl-C, not of that.
    process = subprocess.Popen([sys.executable, "-m", "depthimpostor", "render", "--video", str(out), "--duration",
                                "1000", "--fps", "30", "--size", "32x24", "--impostor-res", "32"], env=env,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               preexec_fn=_sigint_by_default)
    try:
        deadline = time.monotonic() + 120
        while not any(p.stat().st_size > 0 for p in tmp_path.glob(f".v{suffix}.*")):  # frames are being written
            assert process.poll() is None and time.monotonic() < deadline, process.communicate()
            time.sleep(0.1)
        process.send_signal(sent)
        stdout, stderr = process.communicate(timeout=60)
    finally:
        process.kill()
    assert process.returncode == status, stderr
    assert stdout == "" and "Traceback" not in stderr and "Error" not in stderr
    assert list(tmp_path.iterdir()) == []


class _InterruptedCleanup:
    """An object whose finalizer is where a Ctrl-C lands (as one did in a generator context
    manager's `finally`, closed by the garbage collector)."""

    def __del__(self) -> None:
        raise KeyboardInterrupt


def test_a_ctrl_c_that_lands_in_a_finalizer_is_not_lost(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """Python cannot raise an exception from a finalizer: it printed "Exception ignored in ..."
    with a traceback and rendered on (a 1,000-second video to its end). Now the interrupt is
    kept, silently, and raised at the video's next frame: exit 130 quietly, no file."""
    drawn = []
    render = Renderer.render

    def render_and_interrupt_in_a_finalizer(self: Renderer) -> None:
        render(self)
        drawn.append(1)
        if len(drawn) == 3:
            _InterruptedCleanup()  # made and let go at once: its __del__ runs here

    monkeypatch.setattr(Renderer, "render", render_and_interrupt_in_a_finalizer)
    out = tmp_path / "v.gif"
    code, stdout, stderr = run_in_process(["render", "--video", str(out), "--duration", "100", "--fps", "10",
                                           "--size", "32x24", "--impostor-res", "32"], capsys)
    assert code == 130 and stdout == ""
    assert "Traceback" not in stderr and "Exception ignored" not in stderr, stderr
    assert len(drawn) == 3
    assert list(tmp_path.iterdir()) == []
    with deferred_interrupts():  # and outside a video, at the next safe point
        _InterruptedCleanup()
        with pytest.raises(KeyboardInterrupt):
            raise_pending()
        raise_pending()  # raised once
