"""One command for a GPU (issue 35, item 4): on whatever GL driver it finds, every shipped scene under
every method (and depth-image algorithm) the registry accepts for it, measured against the truth as
`compare` does and held against the figures committed from llvmpipe; then the benchmark set at
1920x1080 and the four GPU criteria, into results/<renderer>/gpu_results/.

    python3 tools/gpu_results.py                 # the whole run: under 8 minutes on a GPU
    python3 tools/gpu_results.py --quick         # CI, on llvmpipe: a few scenes, a small bench (~1-2 min)
    python3 tools/gpu_results.py --check-only -o results/llvmpipe/gpu_results   # the reference, on llvmpipe

The device machine's preparation and its one command: docs/gpu.md.

1. The check. Every scenes/*.toml at CHECK_SIZE, images at CHECK_RESOLUTION, every method and, for the
   methods that march depth images, every algorithm: one frame with the reflection outputs, compared
   with the truth (traced once per scene, on the CPU). A frame must be finite (no NaN or Inf in its
   linear colour), a method that refuses the scene must refuse it here too (and one that rendered it,
   render it), and each figure must lie within TOLERANCES of the reference's (REFERENCE, made by
   this tool on llvmpipe). A GPU computes in other float precision than llvmpipe (fused multiply-adds,
   its own transcendentals) and rasterizes with other sub-pixel precision: a silhouette pixel or a
   grazing ray may land on the other side, so the tolerances allow what that moves and no more; a
   broken shader, a wrong binding or a driver's miscompile moves a figure by far more. What the
   driver said compiling each program (warnings too: gpu/compile_logs.py) is kept in
   shader_logs.txt.
   The frames of the configurations that failed are kept (failed_frames/, float16 linear colour).
2. The benchmark (`depthimpostor bench`'s rounds): BENCH_SCENES at BENCH_SIZE, every method, the
   optimized and hierarchical marches, BENCH_RESOLUTIONS; bench.csv, bench.md and the plots.
3. The criteria, from the benchmark's rows (criteria.md): the depth method's mirror pass at 1080p on
   the bunny (target under 2 ms), the hierarchical march against the linear (optimized) one with
   1024² images (target 5 times faster), the hybrid's mirror pass against the depth method's (target at
   most 1.25 times) and against the ray tracer's (target: cheaper). On a GPU the mirror pass's GL time
   query is the figure judged (its own clock, without the wait for ctx.finish()); on a software
   renderer, whose time queries under-report, the wall-clock time around ctx.finish(). Both are shown.

Exit status 0 when every check passed, 1 when one failed (the benchmark and criteria run anyway: a
GPU's minutes are few), 2 when nothing could be measured.
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing
import os
import re
import sys
import tempfile
import time
from collections.abc import Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # the checkout's package, installed or not (the device machine's is not)

import numpy as np  # noqa: E402

from depthimpostor.bench import BenchRow, BenchSettings, check_bench, machine_lines, run_bench, write_results  # noqa: E402
from depthimpostor.constants import Algorithm, Method  # noqa: E402
from depthimpostor.errors import SceneError  # noqa: E402
from depthimpostor.gpu.compile_logs import program_logs  # noqa: E402
from depthimpostor.gpu.context import create_context, describe  # noqa: E402
from depthimpostor.methods.registry import METHODS  # noqa: E402
from depthimpostor.oracles.compare import TruthFrame, compare  # noqa: E402
from depthimpostor.renderer import Renderer  # noqa: E402
from depthimpostor.scene import Scene, load_scene  # noqa: E402

SCENES = ROOT / "scenes"
CHECK_SIZE, CHECK_RESOLUTION = (256, 144), 128
#: The reference the check holds a run against: this tool's check, run on llvmpipe.
REFERENCE = ROOT / "results" / "llvmpipe" / "gpu_results" / "check.json"
#: --quick's scenes: a textured one, flat and curved mirrors with glass, and the many-object one, so
#: that every method and both kinds of mirror are checked in CI.
QUICK_SCENES = ("textured_near_mirror.toml", "planar_mirror.toml", "glass_and_mirrors.toml")

BENCH_SCENES = ("bunny.toml", "lecture_8x9.toml", "textured_near_mirror.toml", "images_per_mirror/boxes_64.toml")
BENCH_SIZE = (1920, 1080)
#: The scenes' own image size (256), and 1024 for the hierarchical march's criterion.
BENCH_RESOLUTIONS: tuple[int | str, ...] = (256, 1024)
BENCH_ALGORITHMS = (Algorithm.OPTIMIZED, Algorithm.HIERARCHICAL)
QUICK_BENCH_SCENES = ("bunny.toml",)
QUICK_BENCH_SIZE = (320, 180)
QUICK_BENCH_RESOLUTIONS: tuple[int | str, ...] = (64,)


@dataclass(frozen=True)
class Tolerance:
    """How far a figure may lie from the reference's: `absolute` plus `relative` times the reference."""

    absolute: float
    relative: float = 0.0
    why: str = ""

    def allows(self, reference: float, value: float) -> bool:
        return abs(value - reference) <= self.absolute + self.relative * abs(reference)


#: Each checked figure's tolerance, and what the margin is for.
TOLERANCES = {
    "mirror_pixels": Tolerance(8, 0.01, "the mirror's silhouette pixels, rasterized with another sub-pixel precision"),
    "wrong_object_percent": Tolerance(1.0, 0.0, "percentage points: rays grazing an object's edge"),
    "wrong_surface_percent": Tolerance(2.0, 0.05, "percentage points: samples at a colour edge of a texture"),
    "retraced_percent": Tolerance(2.0, 0.05, "percentage points: the hybrid's uncertain rays at a depth edge"),
    "color_rmse": Tolerance(0.01, 0.1, "linear colour: filtering and float precision"),
    "direct_rmse": Tolerance(0.01, 0.1, "linear colour outside the mirrors: shadow-map depth precision"),
    "glass_rmse": Tolerance(0.01, 0.1, "linear colour of glass pixels"),
    "geometric_error_median_percent": Tolerance(0.5, 0.2, "percent of the object's radius: depth precision"),
}
#: Criteria targets: the depth method's mirror pass (ms), the hierarchical march's speed-up, the
#: hybrid's mirror pass against the depth method's (at most this ratio).
TARGET_MIRROR_MS, TARGET_HIERARCHICAL_SPEEDUP, TARGET_HYBRID_RATIO = 2.0, 5.0, 1.25


def renderer_slug(gl_renderer: str) -> str:
    """A folder name for a GL_RENDERER string: its name before the first "/" or " (", in lower case
    with dashes ("NVIDIA H100 80GB HBM3/PCIe/SSE2" -> nvidia-h100-80gb-hbm3, "llvmpipe (LLVM 15...)"
    -> llvmpipe)."""
    name = re.split(r"/| \(", gl_renderer, maxsplit=1)[0]
    return re.sub(r"[^a-z0-9]+", "-", name.lower()).strip("-") or "unknown-renderer"


def is_software(gl_renderer: str) -> bool:
    """Mesa's software rasterizers, whose GL time queries under-report."""
    return any(name in gl_renderer.lower() for name in ("llvmpipe", "softpipe", "swrast", "lavapipe"))


# ------------------------------------------------------------------------------------- check
def check_configurations(scene_names: Sequence[str] | None) -> Iterator[tuple[str, Scene | SceneError, Method,
                                                                              Algorithm]]:
    """Every scene (of `scene_names`, or every scenes/*.toml) x method x algorithm."""
    paths = sorted(SCENES.glob("*.toml")) if scene_names is None else [SCENES / name for name in scene_names]
    for path in paths:
        try:
            scene: Scene | SceneError = load_scene(path).with_overrides(size=CHECK_SIZE,
                                                                        impostor_resolution=CHECK_RESOLUTION)
        except SceneError as error:
            scene = error
        for method in Method:
            for algorithm in (list(Algorithm) if METHODS[method].marches_depth_images else [Algorithm.OPTIMIZED]):
                yield path.name, scene, method, algorithm


def check_key(scene: str, method: Method, algorithm: Algorithm) -> str:
    return f"{scene} {method.option} {algorithm.name.lower() if METHODS[method].marches_depth_images else '-'}"


def frame_file(frames: Path, key: str) -> Path:
    """Where a configuration's frame is kept: its key with the spaces and ".toml" taken out."""
    return frames / (key.replace(".toml", "").replace(" ", "_") + ".npy")


def measure_frame(ctx: object, scene: Scene, method: Method, algorithm: Algorithm, truth: TruthFrame | None,
                  logs: dict[str, str], frame: Path | None = None) -> tuple[dict[str, float | int | bool], TruthFrame]:
    """One frame's figures against the truth (traced now unless `truth` was traced for its rays),
    and the driver's words on each program it compiled, into `logs`; its linear colour (float16,
    row 0 at the bottom) saved to `frame`, where given."""
    with Renderer(ctx, scene, algorithm, reflection_data=True, method=method) as renderer:  # type: ignore[arg-type]
        renderer.render()
        colour = renderer.read_color_float()
        if frame is not None:
            np.save(frame, colour.astype(np.float16))
        comparison = compare(renderer, truth)
        for (stages, defines), program in renderer.programs.compiled():
            name = " + ".join(stages) + "".join(f" {k}={v}" for k, v in defines)
            if name not in logs:
                try:
                    logs[name] = program_logs(ctx, program)  # type: ignore[arg-type]
                except LookupError as error:
                    logs[name] = f"(not readable: {error})"
    f = comparison.figures
    figures: dict[str, float | int | bool] = {
        "finite": bool(np.isfinite(colour).all()),
        "mirror_pixels": f.mirror_pixels,
        "wrong_object_percent": 100.0 * f.wrong_object_share,
        "wrong_surface_percent": 100.0 * f.wrong_surface_share,
        "retraced_percent": 100.0 * f.retraced_share,
        "color_rmse": f.color_rmse,
        "direct_rmse": f.direct_rmse,
        "glass_rmse": f.glass_rmse,
        "geometric_error_median_percent": 100.0 * f.geometric_error_median,
    }
    return figures, comparison.truth_frame


def check_scene(ctx: object, name: str, scene: Scene | SceneError, configurations: Sequence[tuple[Method, Algorithm]],
                logs: dict[str, str], frames: Path | None = None) -> dict[str, object]:
    """One scene's configurations (its truth traced once, for the first, and shared): key -> the
    frame's figures, or {"refused": message} where the scene or the method refused."""
    results: dict[str, object] = {}
    truth: TruthFrame | None = None
    for method, algorithm in configurations:
        key = check_key(name, method, algorithm)
        if isinstance(scene, SceneError):
            results[key] = {"refused": _portable(str(scene))}
            continue
        try:
            figures, truth = measure_frame(ctx, scene, method, algorithm, truth, logs,
                                           None if frames is None else frame_file(frames, key))
        except SceneError as error:
            results[key] = {"refused": _portable(str(error))}
            continue
        results[key] = figures
        print(f"  {key}: " + ", ".join(f"{k} {_short(v)}" for k, v in figures.items()), flush=True)
    return results


_WORKER_CONTEXT: object = None


def _check_scene_in_worker(name: str, scene: Scene | SceneError, configurations: Sequence[tuple[Method, Algorithm]],
                           frames: Path | None) -> tuple[dict[str, object], dict[str, str]]:
    """check_scene in a worker process, on the worker's own context (made once per process)."""
    global _WORKER_CONTEXT
    if _WORKER_CONTEXT is None:
        _WORKER_CONTEXT = create_context()
    logs: dict[str, str] = {}
    return check_scene(_WORKER_CONTEXT, name, scene, configurations, logs, frames), logs


def run_check(ctx: object, scene_names: Sequence[str] | None, logs: dict[str, str], jobs: int = 1,
              frames: Path | None = None) -> dict[str, object]:
    """Every configuration's figures (check_scene's), in check_configurations' order. With `jobs` > 1
    the scenes are checked in that many processes at once, each with its own context: most of a
    configuration's time is the CPU's (loading, baking, building the BVH, tracing the truth), and
    the device machine has 16 cores for its few minutes (one process took 478 s for the 210
    configurations on an H100's host; the benchmark then had no time left)."""
    by_scene: dict[str, tuple[Scene | SceneError, list[tuple[Method, Algorithm]]]] = {}
    for name, scene, method, algorithm in check_configurations(scene_names):
        by_scene.setdefault(name, (scene, []))[1].append((method, algorithm))
    results: dict[str, object] = {}
    if jobs <= 1 or len(by_scene) <= 1:
        for name, (scene, configurations) in by_scene.items():
            results.update(check_scene(ctx, name, scene, configurations, logs, frames))
        return results
    # Spawned, not forked: a forked child would share the parent's EGL display and GL state.
    with ProcessPoolExecutor(max_workers=jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
        futures = [pool.submit(_check_scene_in_worker, name, scene, configurations, frames)
                   for name, (scene, configurations) in by_scene.items()]
        for future in futures:  # in the scenes' order, whichever finishes first
            scene_results, scene_logs = future.result()
            results.update(scene_results)
            for program, text in scene_logs.items():
                logs.setdefault(program, text)
    return results


def _shown(path: Path) -> Path:
    """`path` relative to the working directory where it lies under it (the bench's header names it)."""
    return path.relative_to(Path.cwd()) if path.is_relative_to(Path.cwd()) else path


def _portable(message: str) -> str:
    """A refusal's message without the folder of the checkout it came from."""
    return re.sub(r"[^\s(\"']*/scenes\b", "scenes", message)


def _short(value: object) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)


def judge(results: dict[str, object], reference: dict[str, object]) -> tuple[list[str], list[str], int]:
    """(failures, configurations not in the reference, configurations compared). A failure names
    the configuration, the figure, both values and the tolerance."""
    failures, unknown, compared = [], [], 0
    for key, figures in results.items():
        assert isinstance(figures, dict)
        if "finite" in figures and not figures["finite"]:
            failures.append(f"{key}: the frame holds NaN or Inf")
        expected = reference.get(key)
        if expected is None:
            unknown.append(key)
            continue
        assert isinstance(expected, dict)
        compared += 1
        if ("refused" in figures) != ("refused" in expected):
            failures.append(f"{key}: {'refused' if 'refused' in figures else 'rendered'} here, "
                            f"{'refused' if 'refused' in expected else 'rendered'} in the reference"
                            + (f" ({figures.get('refused') or expected.get('refused')})"))
            continue
        for figure, tolerance in TOLERANCES.items():
            if figure in expected and figure in figures:
                value, wanted = float(figures[figure]), float(expected[figure])
                if not math.isfinite(value) or not tolerance.allows(wanted, value):
                    failures.append(f"{key}: {figure} {value:.4g}, reference {wanted:.4g} "
                                    f"(tolerance {tolerance.absolute:g} + {tolerance.relative:g} x reference)")
    return failures, unknown, compared


def keep_failed_frames(frames: Path, results: dict[str, object], failures: Sequence[str]) -> None:
    """Keep the frames of the configurations that failed, to be set beside llvmpipe's (the same
    configuration rendered there); drop the others, and the folder where none failed."""
    failed = {key for key in results if any(failure.startswith(f"{key}: ") for failure in failures)}
    for key in results:
        if key not in failed:
            frame_file(frames, key).unlink(missing_ok=True)
    if not any(frames.iterdir()):
        frames.rmdir()


def check_markdown(results: dict[str, object], failures: Sequence[str], unknown: Sequence[str], compared: int,
                   header: Sequence[str]) -> str:
    lines = [f"{line}  " for line in header] + [
        "", f"Checked {len(results)} configurations at {CHECK_SIZE[0]}x{CHECK_SIZE[1]}, images {CHECK_RESOLUTION}; "
        f"{compared} compared with {REFERENCE.relative_to(ROOT)}: {len(failures)} failed, "
        f"{len(unknown)} not in the reference.", ""]
    lines += [f"- FAILED {failure}" for failure in failures]
    if compared:  # (the reference's own run compares with nothing)
        lines += [f"- not in the reference: {key}" for key in unknown]
    lines += ["", "| scene method algorithm | mirror px | wrong object % | wrong surface % | re-traced % | colour RMSE "
              "| direct RMSE | glass RMSE | geometric median % |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for key, figures in results.items():
        assert isinstance(figures, dict)
        if "refused" in figures:
            lines.append(f"| {key} | refused: {str(figures['refused'])[:90]} |||||||")
            continue
        lines.append(f"| {key} | {figures['mirror_pixels']} | " + " | ".join(
            f"{float(figures[name]):.{digits}f}" for name, digits in (
                ("wrong_object_percent", 2), ("wrong_surface_percent", 2), ("retraced_percent", 2), ("color_rmse", 4),
                ("direct_rmse", 4), ("glass_rmse", 4), ("geometric_error_median_percent", 2))) + " |")
    return "\n".join(lines) + "\n"


def logs_text(logs: dict[str, str], gl: str) -> str:
    said = {name: text for name, text in logs.items() if text}
    lines = [f"GL: {gl}", f"{len(logs)} programs compiled; the driver said something on {len(said)} of them.", ""]
    for name, text in sorted(said.items()):
        lines += [f"== {name}", text, ""]
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------------------------- criteria
def _row(rows: Sequence[BenchRow], scene: str, method: str, algorithm: str, resolution: int | str) -> BenchRow | None:
    for row in rows:
        if (row.scene, row.method, row.algorithm) == (scene, method, algorithm) and \
                row.resolution in (resolution, 0):
            return row
    return None


def criteria_markdown(rows: Sequence[BenchRow], gl: str, resolutions: Sequence[int | str],
                      size: tuple[int, int] = BENCH_SIZE) -> str:
    """The four GPU criteria, each with the figures it is judged on and its verdict."""
    software = is_software(gl)
    judged = "wall clock around ctx.finish() (software rasterizer: its GL time queries under-report)" if software \
        else "GL time query"

    def mirror(row: BenchRow) -> float:
        return row.mirror_pass_ms_median if software else row.gl_mirror_pass_ms

    def both(row: BenchRow | None) -> str:
        return "-" if row is None else f"{row.mirror_pass_ms_median:.3f} / {row.gl_mirror_pass_ms:.3f}"

    scenes = list(dict.fromkeys(row.scene for row in rows))
    low, high = resolutions[0], resolutions[-1]
    lines = [f"GL: {gl}  ", f"Mirror-pass times in ms as wall clock / GL time query; judged on the {judged}.", ""]

    lines += ["## 1. The depth method's mirror pass on the bunny (target under "
              f"{TARGET_MIRROR_MS:g} ms at 1920x1080; measured at {size[0]}x{size[1]})", "", "| algorithm | images | mirror pass ms | frame ms | verdict |",
              "|---|---:|---:|---:|---|"]
    for algorithm in ("optimized", "hierarchical"):
        for resolution in resolutions:
            row = _row(rows, "bunny", "depth", algorithm, resolution)
            if row is not None:
                met = "met" if mirror(row) < TARGET_MIRROR_MS else "not met"
                lines.append(f"| {algorithm} | {resolution} | {both(row)} | {row.frame_ms_median:.3f} | {met} |")

    lines += ["", f"## 2. Hierarchical against linear (optimized) march, images {high}² "
              f"(target {TARGET_HIERARCHICAL_SPEEDUP:g} times faster)", "",
              "| scene | linear mirror pass ms | hierarchical mirror pass ms | speed-up | verdict |", "|---|---:|---:|---:|---|"]
    for scene in scenes:
        linear, hierarchical = (_row(rows, scene, "depth", a, high) for a in ("optimized", "hierarchical"))
        if linear is not None and hierarchical is not None:
            speedup = mirror(linear) / max(mirror(hierarchical), 1e-9)
            met = "met" if speedup >= TARGET_HIERARCHICAL_SPEEDUP else "not met"
            lines.append(f"| {scene} | {both(linear)} | {both(hierarchical)} | {speedup:.2f} x | {met} |")

    lines += ["", f"## 3. and 4. The hybrid's mirror pass against the depth method's (target at most "
              f"{TARGET_HYBRID_RATIO:g} times) and the ray tracer's (target: cheaper), images {low}, optimized march", "",
              "| scene | depth ms | hybrid ms | raytrace ms | hybrid / depth | verdict | hybrid / raytrace | verdict |",
              "|---|---:|---:|---:|---:|---|---:|---|"]
    for scene in scenes:
        depth, hybrid = (_row(rows, scene, m, "optimized", low) for m in ("depth", "hybrid"))
        raytrace = _row(rows, scene, "raytrace", "-", low)
        if depth is None or hybrid is None or raytrace is None:
            continue
        to_depth = mirror(hybrid) / max(mirror(depth), 1e-9)
        to_raytrace = mirror(hybrid) / max(mirror(raytrace), 1e-9)
        lines.append(f"| {scene} | {both(depth)} | {both(hybrid)} | {both(raytrace)} | {to_depth:.2f} | "
                     f"{'met' if to_depth <= TARGET_HYBRID_RATIO else 'not met'} | {to_raytrace:.2f} | "
                     f"{'met' if to_raytrace < 1.0 else 'not met'} |")
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------------------------- main
def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help=f"CI: the check on {', '.join(QUICK_SCENES)}, the bench on {', '.join(QUICK_BENCH_SCENES)} "
                             f"at {QUICK_BENCH_SIZE[0]}x{QUICK_BENCH_SIZE[1]}; into a temporary folder unless -o")
    parser.add_argument("--check-only", action="store_true", help="the check alone (the reference: on llvmpipe)")
    parser.add_argument("-o", "--output", type=Path,
                        help="output folder (default: results/<renderer>/gpu_results, or a temporary one with --quick)")
    parser.add_argument("--reference", type=Path, default=REFERENCE, help=f"the check's reference (default {REFERENCE})")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1,
                        help="processes checking scenes at once, each with its own context (default: one per CPU)")
    parser.add_argument("--require-gpu", action="store_true",
                        help="stop at once (exit 3) on a software renderer: the device machine's run, whose "
                             "minutes a 1080p benchmark on llvmpipe would waste")
    args = parser.parse_args()
    started = time.perf_counter()
    ctx = create_context()
    gl_renderer, gl = str(ctx.info["GL_RENDERER"]), describe(ctx)
    if args.require_gpu and is_software(gl_renderer):
        print(f"GL: {gl}: a software renderer, not the GPU (--require-gpu); see docs/gpu.md", flush=True)
        return 3
    output = args.output or (Path(tempfile.mkdtemp(prefix="gpu_results-")) if args.quick
                             else ROOT / "results" / renderer_slug(gl_renderer) / "gpu_results")
    output.mkdir(parents=True, exist_ok=True)
    print(f"GL: {gl}\noutput: {output}", flush=True)

    logs: dict[str, str] = {}
    print("check: every scene x method x algorithm against the truth", flush=True)
    frames = output / "failed_frames"
    frames.mkdir(exist_ok=True)
    results = run_check(ctx, QUICK_SCENES if args.quick else None, logs, max(1, args.jobs), frames)
    reference = json.loads(args.reference.read_text(encoding="utf-8"))["results"] if args.reference.exists() else {}
    failures, unknown, compared = judge(results, reference)
    keep_failed_frames(frames, results, failures)
    header = [f"tools/gpu_results.py{' --quick' if args.quick else ''}, {time.strftime('%Y-%m-%d')}", f"GL: {gl}"]
    (output / "check.json").write_text(json.dumps({"gl": gl, "size": CHECK_SIZE, "resolution": CHECK_RESOLUTION,
                                                   "results": results}, indent=1) + "\n", encoding="utf-8")
    (output / "check.md").write_text(check_markdown(results, failures, unknown, compared, header), encoding="utf-8")
    (output / "shader_logs.txt").write_text(logs_text(logs, gl), encoding="utf-8")
    check_seconds = time.perf_counter() - started
    print(f"check: {len(results)} configurations, {compared} compared with the reference, {len(failures)} failed, "
          f"{len(unknown)} not in it ({check_seconds:.0f} s)", flush=True)
    for failure in failures:
        print(f"  FAILED {failure}", flush=True)

    if not args.check_only:
        names = QUICK_BENCH_SCENES if args.quick else BENCH_SCENES
        scenes = [load_scene(_shown(SCENES / name)) for name in names]
        resolutions = QUICK_BENCH_RESOLUTIONS if args.quick else BENCH_RESOLUTIONS
        settings = BenchSettings(tuple(Method), BENCH_ALGORITHMS, resolutions,
                                 QUICK_BENCH_SIZE if args.quick else BENCH_SIZE,
                                 frames=2 if args.quick else 10, warmup=1 if args.quick else 2, bakes=1 if args.quick else 2)
        check_bench(ctx, scenes, settings)
        bench_header = machine_lines(ctx, settings, scenes)
        print("bench: " + "; ".join(bench_header[3:5]), flush=True)
        rows: list[BenchRow] = []
        for scene in scenes:  # the bunny first; written after each scene, so that a run cut short keeps them
            scene_started = time.perf_counter()
            rows += run_bench(ctx, [scene], settings)
            write_results(rows, output, bench_header)
            criteria = criteria_markdown(rows, gl, resolutions, settings.size)
            (output / "criteria.md").write_text(criteria, encoding="utf-8")
            print(f"bench: {scene.source} in {time.perf_counter() - scene_started:.0f} s", flush=True)
        print(criteria, flush=True)
    total = time.perf_counter() - started
    print(f"done in {total:.0f} s (check {check_seconds:.0f} s); results in {output}", flush=True)
    ctx.release()
    if not results:
        return 2
    if compared == 0 and not args.check_only:
        print(f"FAILED: no configuration was compared with {args.reference}", flush=True)
        return 1
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
