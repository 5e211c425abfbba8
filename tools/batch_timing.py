"""What batch workers gain (results/llvmpipe/batch.md): a video rendered serially and on 1 and 2 Ray
workers, and a dataset batch killed half-way and resumed.

    python tools/batch_timing.py video --frames 120 --size 320x180 --rounds 2
    python tools/batch_timing.py resume dataset/jobs.toml --kill-after 80

`video`: Ray is started once (its start-up timed apart); then, `rounds` times in turn, the serial
video (one Renderer, frames in order, as `render --video`), and the same frames on 1 and on 2 workers
(the pool's start-up, each worker's context and renderer, the frames out of order and the video
assembled in order), each video's frames checked identical to the serial one's.
`resume`: `depthimpostor batch` as a user runs it (its own local Ray), killed with SIGKILL once the
manifest lists `--kill-after` frames, then run again to the end; the manifest is then checked: every
frame listed, none drawn twice, every file in place.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from depthimpostor.batch.jobs import Frame, load_batch, video_views  # noqa: E402
from depthimpostor.batch.run import RayPool, in_order  # noqa: E402
from depthimpostor.constants import Algorithm, Method  # noqa: E402
from depthimpostor.gpu.context import create_context, describe  # noqa: E402
from depthimpostor.renderer import Renderer  # noqa: E402
from depthimpostor.scene import load_scene  # noqa: E402
from depthimpostor.video import CameraPath, VideoSettings, render_frames, write_video  # noqa: E402


def _serial(scene_path: Path, size: tuple[int, int], settings: VideoSettings, output: Path) -> tuple[float, list[np.ndarray]]:
    started = time.perf_counter()
    ctx = create_context()
    scene = load_scene(scene_path).with_overrides(size=size)
    frames: list[np.ndarray] = []
    with Renderer(ctx, scene, Algorithm.OPTIMIZED, method=Method.DEPTH) as renderer:
        def kept() -> object:
            for frame in render_frames(renderer, settings):
                frames.append(frame)
                yield frame
        write_video(output, kept(), settings.fps)  # type: ignore[arg-type]
    ctx.release()
    return time.perf_counter() - started, frames


def _on_workers(workers: int, scene_path: Path, size: tuple[int, int], settings: VideoSettings,
                output: Path) -> tuple[float, float, list[np.ndarray]]:
    frames = [Frame(output.name, k, str(scene_path.resolve()), "depth", "optimized", (("size", size),), t, camera, (), None)
              for k, (t, camera) in enumerate(video_views(settings))]
    started = time.perf_counter()
    drawn: list[np.ndarray] = []
    with RayPool(workers) as pool:
        ready = time.perf_counter()

        def kept() -> object:
            for frame in in_order(pool.records(frames), len(frames)):
                drawn.append(frame)
                yield frame
        write_video(output, kept(), settings.fps)  # type: ignore[arg-type]
    return time.perf_counter() - started, ready - started, drawn


def video(args: argparse.Namespace) -> None:
    import ray

    width, height = (int(v) for v in args.size.split("x"))
    settings = VideoSettings(args.frames / args.fps, args.fps, CameraPath.ORBIT)
    folder = Path(args.folder)
    folder.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    ray.init(num_cpus=2 * max(args.workers), include_dashboard=False, logging_level="ERROR")
    print(f"Ray start-up (ray.init, local): {time.perf_counter() - started:.1f} s")
    ctx = create_context()
    print(f"GL: {describe(ctx)}; {os.cpu_count()} logical CPUs; {args.frames} frames of {args.size}, scene {args.scene}")
    ctx.release()
    reference: list[np.ndarray] | None = None
    for round_ in range(args.rounds):
        seconds, frames = _serial(Path(args.scene), (width, height), settings, folder / "serial.mp4")
        reference = reference or frames
        print(f"round {round_ + 1}: serial {seconds:.1f} s ({args.frames / seconds:.2f} frames/s)")
        for workers in args.workers:
            total, setup, drawn = _on_workers(workers, Path(args.scene), (width, height), settings,
                                              folder / f"workers{workers}.mp4")
            same = len(drawn) == len(reference) and all(np.array_equal(a, b) for a, b in zip(drawn, reference, strict=True))
            same_file = (folder / f"workers{workers}.mp4").read_bytes() == (folder / "serial.mp4").read_bytes()
            print(f"round {round_ + 1}: {workers} worker(s) {total:.1f} s, of which the pool's start {setup:.1f} s "
                  f"({args.frames / total:.2f} frames/s; {args.frames / (total - setup):.2f} after the start); "
                  f"frames identical to serial: {same}; MP4 bytes identical: {same_file}")
    ray.shutdown()


def _records(manifest: Path) -> list[dict[str, object]]:
    if not manifest.is_file():
        return []
    lines = []
    for line in manifest.read_text().splitlines():
        try:
            lines.append(json.loads(line))
        except json.JSONDecodeError:
            lines.append({"status": "cut"})
    return lines


def resume(args: argparse.Namespace) -> None:
    batch = load_batch(Path(args.jobs))
    manifest = batch.manifest
    command = [sys.executable, "-m", "depthimpostor", "batch", str(args.jobs), "--workers", str(args.workers)]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    started = time.perf_counter()
    process = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                               start_new_session=True)
    while len(_records(manifest)) < args.kill_after and process.poll() is None:
        time.sleep(0.2)
    os.killpg(process.pid, signal.SIGKILL)  # the batch and the local Ray it started, as a lost machine would
    process.wait()
    first = time.perf_counter() - started
    before = _records(manifest)
    complete = sum(all(p.is_file() for p in f.outputs) for f in batch.frames)
    print(f"first run killed after {first:.1f} s: {len(before)} manifest lines, {complete} of {len(batch.frames)} "
          f"frames complete on disk")
    started = time.perf_counter()
    result = subprocess.run(command, env=env, capture_output=True, text=True, check=False)
    second = time.perf_counter() - started
    print(f"second run: {second:.1f} s, exit {result.returncode}: {result.stdout.strip()}")
    records = _records(manifest)
    outputs: dict[str, list[str]] = {}
    for record in records:
        listed = record.get("outputs")
        if isinstance(listed, list) and listed:
            outputs.setdefault(str(listed[0]), []).append(str(record["status"]))
    missing = [f for f in batch.frames if not all(p.is_file() for p in f.outputs)]
    twice = {name: statuses for name, statuses in outputs.items() if statuses.count("rendered") > 1}
    found = sum(statuses == ["found"] for statuses in outputs.values())
    print(f"manifest: {len(records)} lines for {len(outputs)} of {len(batch.frames)} frames; drawn twice: {len(twice)}; "
          f"files missing: {len(missing)}; listed as found (written before the kill, its line lost): {found}; "
          f"lines cut short by the kill: {sum(r.get('status') == 'cut' for r in records)}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    commands = parser.add_subparsers(dest="command", required=True)
    shown = commands.add_parser("video")
    shown.add_argument("--scene", default=str(ROOT / "scenes" / "default.toml"))
    shown.add_argument("--frames", type=int, default=120)
    shown.add_argument("--fps", type=float, default=30.0)
    shown.add_argument("--size", default="320x180")
    shown.add_argument("--workers", type=lambda t: [int(v) for v in t.split(",")], default=[1, 2])
    shown.add_argument("--rounds", type=int, default=2)
    shown.add_argument("--folder", default="/tmp/batch_timing")
    resumed = commands.add_parser("resume")
    resumed.add_argument("jobs")
    resumed.add_argument("--kill-after", type=int, default=80)
    resumed.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    video(args) if args.command == "video" else resume(args)


if __name__ == "__main__":
    main()
