"""The `depthimpostor` command line."""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import os
import signal
import statistics
import sys
import threading
import time as time_module
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, TypeVar

import moderngl

from .aov import AOVS, aov_path, compute_aovs, needs_reflection_data, parse_aovs, write_aovs
from .constants import Algorithm, Method
from .gpu.context import create_context, describe
from .errors import DepthImpostorError, SceneError, SceneWarning
from .interrupts import Terminated, deferred_interrupts, raise_pending
from .oracles.compare import Comparison, Figures, TruthFrame, compare, format_table, markdown_table, side_by_side, write_report
from .colour import TONE_MAPPINGS
from .outputs import (
    Outputs, check_file, check_folder, is_float_image, is_stdout, write_image,
)
from .gpu.limits import check_fits, limit_memory, parse_memory
from .methods.registry import METHODS
from .plan import RenderPlan, plan_render
from .render_graph import RenderStats
from .renderer import Renderer
from .resources import default_scene_path
from .scene import Scene, load_scene
from .scene.fields import SIZE, Reader
from .scene.model import AUTO_RESOLUTION, EXPOSURE, IMPOSTOR_RESOLUTION, SAMPLES

if TYPE_CHECKING:
    from .bench import BenchSettings
    from .video import VideoSettings

T = TypeVar("T")


def _size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(part) for part in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT such as 960x540, got {text!r}") from None
    return width, height


def _integer_at_least(least: int) -> Callable[[str], int]:
    """An argparse type: an integer >= `least` (argparse names the option in its message)."""
    expected = "a positive integer" if least == 1 else f"an integer >= {least}"

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}") from None
        if value < least:
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text}")
        return value
    return parse


_positive, _non_negative = _integer_at_least(1), _integer_at_least(0)


def _checked(reader: Reader[T], parse: Callable[[str], object]) -> Callable[[str], T]:
    """An argparse type: `parse`d text checked as strictly as a scene file's value (`reader`), so that
    a bad value is refused before any work, by argparse, naming the option it was given to."""
    def check(text: str) -> T:
        value = reader.parse(parse(text))
        if value is None:
            raise argparse.ArgumentTypeError(f"expected {reader.expected}, got {text}")
        return value
    return check


def _finite(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text}")
    return value


def _integer(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None


def _positive_float(text: str) -> float:
    value = _finite(text)
    if value <= 0.0:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text}")
    return value


def _resolution(text: str) -> int | str:
    """--impostor-res: an integer, or "auto" (checked, with the file's rules, by with_overrides)."""
    if text == AUTO_RESOLUTION:
        return text
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'expected an integer or "{AUTO_RESOLUTION}", got {text!r}') from None


def _load(args: argparse.Namespace) -> Scene:
    scene = load_scene(args.scene or default_scene_path())
    return scene.with_overrides(size=args.size, impostor_resolution=args.impostor_res,
                                simplified_triangles=args.simplified_triangles,
                                tone_mapping=getattr(args, "tone_mapping", None), exposure=getattr(args, "exposure", None),
                                samples=args.samples)


def _stand_in(renderer: Renderer) -> str:
    """What the reflected objects were found through, and what it cost to prepare."""
    stand_in = renderer.graph.stand_in
    if stand_in is None:
        return "no mirror"
    algorithm = f"{renderer.algorithm.name.lower()} algorithm, " if METHODS[renderer.method].marches_depth_images else ""
    bake = f", bake {1000 * sum(renderer.stats.bake_seconds):.1f} ms" if renderer.graph.baked_images is not None else ""
    return f"{renderer.method.option}: {algorithm}{_kept(renderer)}{bake}"


def _render(args: argparse.Namespace) -> int:
    if args.video is not None:
        return _render_video(args)
    for option, value in (("--duration", args.duration), ("--camera-path", args.camera_path)):
        if value is not None:
            raise SceneError("command line", option, "expected only with --video")
    output = check_file(Path(args.output or DEFAULT_RENDER), "-o", float_image=True)
    linear = is_float_image(output)  # .exr, .hdr: the frame's linear float colour, for post-processing
    aovs = parse_aovs(args.aov) if args.aov else ()
    if aovs:
        if is_stdout(output):
            raise SceneError("command line", "--aov", "expected an -o file to write the AOVs beside, got standard output")
        check_file(aov_path(output), "--aov", image=False)
    scene = _load(args)
    ctx = _context(args)
    renderer_name = describe(ctx)
    algorithm = Algorithm[args.algorithm.upper()]
    method = Method.from_option(args.method)
    try:
        with Renderer(ctx, scene, algorithm, method=method, reflection_data=needs_reflection_data(aovs)) as renderer:
            for frame in range((args.frames or DEFAULT_FRAMES) + 1):  # the first frame bakes and warms up
                renderer.set_time(args.time + frame / args.fps)
                stats = renderer.render()
            image = renderer.read_color_float() if linear else renderer.read_color()
            channels = compute_aovs(renderer, aovs)[0] if aovs else {}
            colour = renderer.read_color_float() if aovs else None
            stand_in = _stand_in(renderer)
            plan = renderer.plan
    finally:
        ctx.release()
    timed = stats.draw_seconds[1:]
    report = sys.stderr if is_stdout(output) else sys.stdout  # `-o /dev/stdout`: the image alone there
    with Outputs() as out:  # the colour and its AOVs in place together
        written = [out.float_image(output, image) if linear else out.image(output, image)]
        if colour is not None:
            written.append(write_aovs(out, aov_path(output), colour, channels))
    print("\n".join(map(str, written)), file=report)
    # The first frame is a cold one (caches, lazily made programs and buffers): a time only with --frames.
    timing = (f"frame {1000 * statistics.median(timed):.1f} ms (median of {len(timed)})" if timed
              else f"first frame {1000 * stats.draw_seconds[0]:.1f} ms (cold; --frames N times N more)")
    print(f"{timing}, {stand_in}, {scene.render.size[0]}x{scene.render.size[1]} on {renderer_name}", file=report)
    if args.stats:
        print(format_stats(stats, plan, args.time, args.fps), file=report)
    return 0


def _render_video(args: argparse.Namespace) -> int:
    """`render --video`: every frame of --duration at --fps into a video, with a progress bar."""
    from .video import CameraPath, VideoSettings, check_video_file, check_video_settings, render_video

    for option, given in (("-o", args.output is not None), ("--frames", args.frames is not None)):
        if given:
            raise SceneError("command line", option, "expected no value with --video (the video's frames are "
                             "--duration x --fps from --time)")
    if args.aov:
        raise SceneError("command line", "--aov", "expected without --video (a video holds colour alone: "
                         "`depthimpostor batch` writes each frame's AOVs, docs/batch.md)")
    output = check_video_file(Path(args.video))
    if args.duration is None:
        raise SceneError("command line", "--duration", "expected with --video: the video's length in seconds")
    scene = _load(args)
    path = CameraPath(args.camera_path) if args.camera_path else CameraPath.default_for(scene)
    settings = VideoSettings(args.duration, args.fps, path, args.time)
    check_video_settings(settings, scene.render.size, output)
    if args.workers is not None or args.address is not None:
        return _render_video_on_workers(args, scene, output, settings)
    ctx = _context(args)
    renderer_name = describe(ctx)
    try:
        with Renderer(ctx, scene, Algorithm[args.algorithm.upper()], method=Method.from_option(args.method)) as renderer:
            print(render_video(renderer, output, settings), flush=True)
            stats, stand_in, plan = renderer.stats, _stand_in(renderer), renderer.plan
    finally:
        ctx.release()
    print(f"{settings.frames} frames, {settings.duration:g} s at {settings.fps:g} frames/s, camera {path.value}, "
          f"frame {1000 * statistics.median(stats.draw_seconds):.1f} ms (median), {stand_in}, "
          f"{scene.render.size[0]}x{scene.render.size[1]} on {renderer_name}")
    if args.stats:
        print(format_stats(stats, plan, args.time, args.fps))
    return 0


def _scene_overrides(args: argparse.Namespace) -> tuple[tuple[str, object], ...]:
    """What _load overrides in the scene, as a batch frame carries it to its worker."""
    return (("size", args.size), ("impostor_resolution", args.impostor_res),
            ("simplified_triangles", args.simplified_triangles), ("tone_mapping", getattr(args, "tone_mapping", None)),
            ("exposure", getattr(args, "exposure", None)), ("samples", args.samples))


def _render_video_on_workers(args: argparse.Namespace, scene: Scene, output: Path, settings: VideoSettings) -> int:
    """`render --video --workers N`: the video's frames drawn by batch workers, out of order, and
    put into the video in order: the same frames as one renderer draws them one after another."""
    from .batch.jobs import Frame, video_views
    from .batch.run import in_order, open_pool
    from tqdm import tqdm

    from .video import write_video

    if args.stats:
        raise SceneError("command line", "--stats", "expected without --workers (each worker has its own renderer)")
    # What a Renderer would refuse (a method that refuses the scene), refused here before any worker starts.
    plan_render(scene, Method.from_option(args.method), Algorithm[args.algorithm.upper()])
    source = str(Path(args.scene or default_scene_path()).resolve())
    frames = [Frame(output.name, k, source, args.method, args.algorithm, _scene_overrides(args), time, camera, (), None)
              for k, (time, camera) in enumerate(video_views(settings))]
    started = time_module.perf_counter()
    with open_pool(args.workers, args.address, args.backend, args.max_memory) as pool:
        shown = tqdm(in_order(pool.records(frames), len(frames)), total=len(frames), unit="frame", desc=output.name)
        with shown:
            print(write_video(output, shown, settings.fps), flush=True)
        where = pool.description
    seconds = time_module.perf_counter() - started
    print(f"{settings.frames} frames, {settings.duration:g} s at {settings.fps:g} frames/s, camera "
          f"{settings.camera_path.value}, {seconds:.1f} s on {where}, {scene.render.size[0]}x{scene.render.size[1]}")
    return 0


def _batch(args: argparse.Namespace) -> int:
    """`depthimpostor batch jobs.toml`: every frame of every job, on Ray workers (docs/batch.md)."""
    from .batch.jobs import load_batch
    from .batch.run import open_pool, run_batch

    batch = load_batch(args.jobs)
    manifest = args.manifest or batch.manifest
    with open_pool(args.workers, args.address, args.backend, args.max_memory) as pool:
        summary = run_batch(batch.frames, pool, manifest)
        where = pool.description
    print(f"{summary.frames} frames: {summary.rendered} rendered, {summary.found} complete before, "
          f"{len(summary.failed)} failed, in {summary.seconds:.1f} s on {where}; manifest {manifest}")
    for job, (count, error) in summary.failed_jobs().items():
        print(f"depthimpostor: batch: job {job}: {count} frame{'s' if count > 1 else ''} failed: {error}",
              file=sys.stderr)
    return 1 if summary.failed else 0


_WORKERS_HELP = {
    "render": "--video: draw the frames on this many batch workers (Ray processes), out of order, assembled in order",
    "batch": "worker processes (Ray actors), one per core by default (one per GPU on a cluster with GPUs)",
    "bench": ("run the configurations on this many batch workers (Ray processes), each timed alone on its worker "
              "while the others run theirs: timings from concurrent workers share the machine (not the rounds of "
              "the serial bench), so they measure the throughput of a sweep; accuracy figures are the serial "
              "bench's exactly (docs/batch.md)"),
}


def _workers_arguments(command: argparse.ArgumentParser, name: str) -> None:
    command.add_argument("--workers", type=_non_negative, help=f"{_WORKERS_HELP[name]}; 0: in this process, without Ray")
    command.add_argument("--address", help="join the Ray cluster at this address (ray://host:10001, or auto) "
                                           "instead of starting a local Ray (docs/batch.md)")


def format_stats(stats: RenderStats, plan: RenderPlan, start: float, fps: float) -> str:
    """The work the frames did, beside what the plan said they would do."""
    end = start + (stats.frames - 1) / fps
    lines = [f"work over {stats.frames} frames (scene time {start:g} to {end:g} s at {fps:g} frames/s):"]
    runs = ", ".join(f"{planned.stage.value} {stats.passes[planned.stage.value]}" for planned in plan.passes)
    lines.append(f"  passes run (frames): {runs}"
                 + (f" ({plan.samples} sub-pixel frames per frame: {stats.sub_frames} in all)" if plan.samples > 1 else ""))
    unplanned = sorted(set(stats.passes) - {planned.stage.value for planned in plan.passes})
    if unplanned:
        lines.append(f"  passes run that the plan lacks: {', '.join(unplanned)}")
    planned_images = {image.label for image in plan.images}
    once = sorted(label for label, count in stats.images_baked.items() if count == 1)
    again = {label: count for label, count in sorted(stats.images_baked.items()) if count > 1}
    lines.append(f"  images baked: {stats.depth_images_baked} bakes of the {len(planned_images)} planned images: "
                 f"{len(once)} baked once, {len(again)} more than once"
                 + "".join(f"\n    {label}: {count} times" for label, count in again.items()))
    never = sorted(planned_images - set(stats.images_baked))
    if never:
        lines.append(f"  planned images never baked: {', '.join(never)}")
    lines.append(f"  shadow maps baked: {stats.shadow_maps_baked}, glass interiors made: {stats.interiors_made}, "
                 + (f"eye images made: {stats.eye_images_made}, " if stats.eye_images_made else "")
                 + f"draw calls: {stats.draw_calls}")
    return "\n".join(lines)


def _plan(args: argparse.Namespace) -> int:
    """The plan; then, as `render` would, a refusal of what this GL cannot hold (exit 2)."""
    scene = _load(args)
    plan = plan_render(scene, Method.from_option(args.method), Algorithm[args.algorithm.upper()])
    print(json.dumps(plan.to_json(), indent=2) if args.json else plan.format(), flush=True)
    ctx = _context(args)
    try:
        check_fits(ctx, scene, plan)
    finally:
        ctx.release()
    return 0


def _context(args: argparse.Namespace) -> moderngl.Context:
    """A headless context, its memory budget `--max-memory` where given."""
    ctx = create_context(args.backend)
    limit_memory(ctx, args.max_memory)
    return ctx


def _kept(renderer: Renderer) -> str:
    """What the method kept to draw the frame, and its memory."""
    stand_in = renderer.graph.stand_in
    return f"{stand_in.describe()}, {stand_in.bytes / 2**20:.2f} MiB" if stand_in is not None else "no mirror"


def _compare_frame(
    ctx: moderngl.Context, scene: Scene, args: argparse.Namespace, method: Method, truth: TruthFrame | None = None
) -> tuple[Comparison, str]:
    """One frame of `method` compared with the truth (`truth` when it was traced for the same
    rays), and what the method kept to draw it."""
    algorithm = Algorithm[getattr(args, "algorithm", "optimized").upper()]
    with Renderer(ctx, scene, algorithm, reflection_data=True, method=method) as renderer:
        time = getattr(args, "time", 0.0)
        if time:  # an animated scene at --time: the truth follows the renderer's world there
            renderer.set_time(time)
        renderer.render()
        return compare(renderer, truth), _kept(renderer)


def _truth(args: argparse.Namespace) -> int:
    output = check_file(Path(args.output), "-o")
    ctx = _context(args)
    try:
        comparison, _ = _compare_frame(ctx, _load(args), args, Method.RAYTRACE)
    finally:
        ctx.release()
    written = write_image(output, comparison.image(comparison.truth))
    print(written, file=sys.stderr if is_stdout(output) else sys.stdout)
    return 0


def _compare(args: argparse.Namespace) -> int:
    """One method: its report in the output folder. `--method all`: every method's report in a
    sub-folder, and the side-by-side sheet and table of all of them."""
    output = check_folder(Path(args.output), "-o")
    scene = _load(args)
    methods = list(Method) if args.method == ALL_METHODS else [Method.from_option(args.method)]
    rows: dict[str, tuple[str, Figures]] = {}
    refused: dict[str, str] = {}  # `all`: the methods that refuse the scene (planar: curved mirrors), and why
    comparisons: dict[str, Comparison] = {}
    written: list[Path] = []
    tables: list[str] = []
    # Every method's report, and the sheet of all of them, go in place together once all are
    # written: a failure (a full disk, a method refused) leaves no half report.
    out = Outputs()
    ctx = _context(args)
    try:
        for method in methods:
            # Every method computes the same rays: the truth is traced once and reused.
            truth = next(iter(comparisons.values())).truth_frame if comparisons else None
            try:
                comparison, kept = _compare_frame(ctx, scene, args, method, truth)
            except SceneError as error:
                if len(methods) == 1:
                    raise
                refused[method.option] = error.detail
                continue
            settings = {
                "scene": scene.source,
                "size": list(scene.render.size),
                "impostor_resolution": scene.render.impostor_resolution,
                "simplified_triangles": scene.render.simplified_triangles,
                "samples": scene.render.samples,
                "algorithm": args.algorithm,
                "method": method.option,
                "stand_in": kept,
                "time": args.time,
            }
            written += write_report(comparison, output / method.option if len(methods) > 1 else output, settings,
                                    out)
            tables.append(format_table(comparison.figures))
            rows[method.option], comparisons[method.option] = (kept, comparison.figures), comparison
        if len(methods) > 1:
            written.append(out.image(output / "methods.png", side_by_side(comparisons)))
            written.append(out.text(output / "methods.md", markdown_table(rows, refused)))
        out.commit()
    finally:
        out.discard()
        ctx.release()
    for path in written:
        print(path)
    print("\n".join(tables))
    if len(methods) > 1:
        print(markdown_table(rows, refused), end="")
    return 0


def _list_of(kind: Callable[[str], T]) -> Callable[[str], list[T]]:
    def parse(text: str) -> list[T]:
        parts = [part.strip() for part in text.split(",") if part.strip()]
        if not parts:
            raise argparse.ArgumentTypeError(f"expected a comma-separated list, got {text!r}")
        try:
            return [kind(part) for part in parts]
        except (ValueError, argparse.ArgumentTypeError) as error:
            where = f" (in the list {text!r})" if len(parts) > 1 else ""
            raise argparse.ArgumentTypeError(f"{error}{where}") from None
    return parse


def _bench(args: argparse.Namespace) -> int:
    from tqdm import tqdm  # the progress bar is the benchmark's alone

    from .bench import BenchSettings, check_bench, machine_lines, run_bench, total_configurations, write_results
    from .peers import PeerRow

    scenes = [load_scene(path) for path in args.scenes] or [load_scene(default_scene_path())]
    scenes = [scene.with_overrides(samples=args.samples) for scene in scenes]
    if ALL_METHODS in args.methods:
        methods = tuple(Method)
    else:
        unknown = [name for name in args.methods if name not in {m.option for m in Method}]
        if unknown:
            raise SceneError("command line", "--methods", f"expected methods among {[m.option for m in Method]} "
                             f"or all, got {unknown}")
        methods = tuple(Method.from_option(name) for name in args.methods)
    output = check_folder(Path(args.output), "-o")
    size = args.size or scenes[0].render.size
    unknown = [name for name in args.algorithms if name not in {a.name.lower() for a in Algorithm}]
    if unknown:
        raise SceneError("command line", "--algorithms", f"expected algorithms among "
                         f"{[a.name.lower() for a in Algorithm]}, got {unknown}")
    algorithms = tuple(Algorithm[name.upper()] for name in dict.fromkeys(args.algorithms))
    settings = BenchSettings(methods, algorithms, tuple(args.resolutions), size, args.frames, args.warmup, args.bakes,
                             peers=args.peers)
    if args.peers and importlib.util.find_spec("mitsuba") is None:
        raise SceneError("command line", "--peers", 'expected Mitsuba 3 installed (pip install -e ".[peers]", or '
                         "pip install mitsuba)")
    if args.workers is not None or args.address is not None:
        return _bench_on_workers(args, scenes, settings, output)
    peer_rows: list[PeerRow] = []
    ctx = _context(args)
    try:
        check_bench(ctx, scenes, settings)  # before any work
        header = machine_lines(ctx, settings, scenes)
        print("\n".join(header), flush=True)
        with tqdm(total=total_configurations(scenes, settings), unit="configuration") as progress:
            rows = run_bench(ctx, scenes, settings, progress, peer_rows)
    finally:
        ctx.release()
    for path in write_results(rows, output, header, peer_rows):
        print(path)
    return 0


def _bench_on_workers(args: argparse.Namespace, scenes: list[Scene], settings: BenchSettings, output: Path) -> int:
    """`bench --workers N`: each configuration a task of the batch workers (batch/bench_tasks.py),
    the rows written as the serial bench writes them; the header names the workers."""
    from tqdm import tqdm

    from .batch.bench_tasks import bench_tasks, run_bench_on_pool
    from .batch.run import open_pool
    from .bench import write_results

    if args.peers:
        raise SceneError("command line", "--peers", "expected without --workers (the peers are timed in the same "
                         "rounds as a scene's configurations, in one process)")
    count = len(bench_tasks(scenes, settings, args.samples))  # a method that refuses a scene: refused before Ray
    with open_pool(args.workers, args.address, args.backend, args.max_memory) as pool, \
            tqdm(total=count, unit="configuration", desc=pool.description) as progress:
        result = run_bench_on_pool(pool, scenes, settings, args.samples, progress)
    print("\n".join(result.header), flush=True)
    for path in write_results(result.rows, output, result.header):
        print(path)
    return 0


def _view(args: argparse.Namespace) -> int:
    from .viewer import ViewerOptions, run_viewer  # glfw is loaded for the window alone
    from .viewer.keys import parse_key_script

    for option, path in (("--screenshot", args.screenshot), ("--window-screenshot", args.window_screenshot),
                         ("--report", args.report)):
        if path is not None:
            check_file(path, option, image=option != "--report")
    options = ViewerOptions(
        scene=_load(args),
        algorithm=Algorithm[args.algorithm.upper()],
        method=Method.from_option(args.method),
        frames=args.frames,
        keys=tuple(parse_key_script(args.keys or "")),
        screenshot=args.screenshot,
        window_screenshot=args.window_screenshot,
        report=args.report,
        shaders=args.shaders,
        max_memory=args.max_memory,
        panel=not args.no_panel,
    )
    return run_viewer(options)


def _scene_arguments(command: argparse.ArgumentParser, headless: bool = True, display: bool = True) -> None:
    command.add_argument("scene", nargs="?", help="scene file (TOML, or a .glb/.gltf glTF file); the built-in default scene if omitted")
    command.add_argument("--size", type=_size, help="output size WxH, overriding the scene's render.size")
    command.add_argument("--impostor-res", type=_resolution,
                         help="resolution of depth images, cube-map faces and billboards, or auto (each image "
                              "sized so that a sample covers about one reflected pixel), overriding the scene's")
    command.add_argument("--simplified-triangles", type=int,
                         help="--method simplified: triangles per reflected object at most, overriding the scene's")
    if display:
        command.add_argument("--tone-mapping", choices=TONE_MAPPINGS,
                             help="how the 8-bit image compresses linear colour into [0, 1], overriding the scene's "
                                  "render.tone_mapping: none (clamp), aces (Narkowicz 2015), reinhard (docs/colour.md)")
        command.add_argument("--exposure", type=_checked(EXPOSURE, _finite),
                             help="stops the linear colour is scaled by (2^exposure) before tone mapping and sRGB "
                                  "encoding, overriding the scene's render.exposure")
    _samples_argument(command)
    _max_memory_argument(command)
    if not headless:
        return
    _backend_argument(command)


def _samples_argument(command: argparse.ArgumentParser) -> None:
    command.add_argument("--samples", type=_checked(SAMPLES, _integer),
                         help="anti-aliasing: frames drawn per pixel at jittered sub-pixel positions and averaged "
                              "(1, 4 or 8), overriding the scene's render.samples (docs/colour.md)")


def _memory(text: str) -> int:
    try:
        return parse_memory(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def _max_memory_argument(command: argparse.ArgumentParser) -> None:
    command.add_argument("--max-memory", type=_memory,
                         help="memory the frame and its images may take, such as 512M or 2G (a bare number is MiB; "
                              "default: the machine's available memory on a software renderer; none on a GPU)")


def _backend_argument(command: argparse.ArgumentParser) -> None:
    command.add_argument("--backend", choices=["auto", "egl", "osmesa"], default=None,
                         help="headless GL backend (default: auto, EGL then OSMesa)")


#: `render`'s image when no -o is given, and the frames it times after the first.
DEFAULT_RENDER, DEFAULT_FRAMES = "render.png", 0

#: `compare --method all`: every method, side by side.
ALL_METHODS = "all"


#: `--algorithm`'s help: what each intersection algorithm does (constants.Algorithm's).
ALGORITHM_HELP = {
    Algorithm.BASIC: "the lecture's linear march, unprojecting every step",
    Algorithm.OPTIMIZED: "the lecture's linear march in 2-D image space (the default)",
    Algorithm.HIERARCHICAL: "the optimized march's steps, spans that cannot hit skipped by a min/max pyramid",
    Algorithm.AUTO: "per image, whichever of optimized and hierarchical bench measured faster at its size",
}


def _method_arguments(command: argparse.ArgumentParser, every: bool = False) -> None:
    marching = ", ".join(spec.option for spec in METHODS.values() if spec.marches_depth_images)
    command.add_argument("--algorithm", choices=[a.name.lower() for a in Algorithm], default="optimized",
                         help=f"ray/depth-image intersection of the methods that march depth images ({marching}): "
                              + "; ".join(f"{a.name.lower()}: {ALGORITHM_HELP[a]}" for a in Algorithm))
    command.add_argument("--method", choices=[m.option for m in Method] + ([ALL_METHODS] if every else []),
                         default="depth",
                         help="how reflected objects are stood in for: "
                              + "; ".join(f"{spec.option}: {spec.label}" for spec in METHODS.values())
                              + ("; all: every one, side by side" if every else ""))


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="depthimpostor", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)
    render = commands.add_parser("render", help="render a scene headless to a PNG")
    _scene_arguments(render)
    render.add_argument("-o", "--output",
                        help=f"output image (default: {DEFAULT_RENDER}): 8-bit sRGB through the display transform, or "
                             "the linear float frame for .exr (32-bit float) and .hdr (Radiance RGBE)")
    _method_arguments(render)
    render.add_argument("--frames", type=_non_negative,
                        help=f"frames drawn and timed after the first (default {DEFAULT_FRAMES}: one frame, the picture)")
    render.add_argument("--time", type=_finite, default=0.0,
                        help="scene time of the first frame, in seconds, for animated scenes (default 0)")
    render.add_argument("--fps", type=_positive_float, default=30.0,
                        help="frames per second of scene time between frames (default 30); the PNG is the last "
                             "frame; with --video, the video's frame rate")
    render.add_argument("--video", type=Path,
                        help="write a video instead of an image: .mp4 (H.264) or .gif, --duration seconds at --fps "
                             "from --time, with a progress bar (docs/notebooks_and_videos.md)")
    render.add_argument("--duration", type=_positive_float,
                        help="--video: its length in seconds of scene time (frames: duration x fps, rounded)")
    render.add_argument("--camera-path", choices=["orbit", "fixed"],
                        help="--video: orbit (one turn of the scene camera about the world up axis through its "
                             "target, over the video) or fixed (the scene camera); default: fixed for a scene "
                             "that animates, orbit for a still one")
    render.add_argument("--aov", type=_list_of(str),
                        help="per-pixel outputs, comma-separated, written as named float channels of one OpenEXR "
                             f"file beside the image (frame.png -> frame.aov.exr): {', '.join(AOVS)} "
                             "(docs/batch.md says what each holds)")
    _workers_arguments(render, "render")
    render.add_argument("--stats", action="store_true",
                        help="print the work done (passes run, images baked, draw calls) beside the plan")
    render.set_defaults(run=_render)

    plan = commands.add_parser("plan", help="the passes, depth images and shader variants a scene calls for, and why")
    _scene_arguments(plan, display=False)
    _method_arguments(plan)
    plan.add_argument("--json", action="store_true", help="print the plan as JSON")
    plan.set_defaults(run=_plan)

    truth = commands.add_parser("truth", help="ray-trace the mirrors' reflections against the real triangles")
    _scene_arguments(truth)
    truth.add_argument("-o", "--output", default="truth.png", help="output PNG (default: truth.png)")
    truth.add_argument("--time", type=_finite, default=0.0,
                       help="scene time, in seconds, for animated scenes (default 0)")
    truth.set_defaults(run=_truth)

    comparison = commands.add_parser("compare", help="render and truth side by side, with error figures")
    _scene_arguments(comparison)
    comparison.add_argument("-o", "--output", default="report", help="output folder (default: report/)")
    comparison.add_argument("--time", type=_finite, default=0.0,
                            help="scene time, in seconds, for animated scenes (default 0)")
    _method_arguments(comparison, every=True)
    comparison.set_defaults(run=_compare)

    bench = commands.add_parser("bench", help="frame time, memory, samples per ray and error of every method")
    bench.add_argument("scenes", nargs="*", type=Path, help="scene files (TOML or glTF); the built-in default if none")
    bench.add_argument("--methods", type=_list_of(str), default=[ALL_METHODS],
                       help="comma-separated methods, or all (default)")
    bench.add_argument("--algorithms", type=_list_of(str), default=["optimized", "hierarchical"],
                       help="the depth-image method's intersection algorithms, comma-separated "
                            "(default: optimized,hierarchical)")
    bench.add_argument("--resolutions", type=_list_of(_checked(IMPOSTOR_RESOLUTION, _resolution)),
                       default=[64, 128, 256, 512, 1024],
                       help="image resolutions of the methods that bake images, auto among them if wanted "
                            "(default 64,128,256,512,1024)")
    bench.add_argument("--size", type=_checked(SIZE, _size), help="frame size WxH (default: the first scene's render.size)")
    bench.add_argument("--frames", type=_positive, default=10, help="timed frames per configuration (default 10)")
    bench.add_argument("--warmup", type=_non_negative, default=2, help="untimed frames before them (default 2)")
    bench.add_argument("--bakes", type=_positive, default=3, help="timed re-bakes per configuration (default 3)")
    bench.add_argument("--peers", action="store_true",
                       help="also time, in the same rounds, Mitsuba 3 (1 sample a pixel, exact mirrors; the "
                            "optional extra: pip install -e \".[peers]\") and this renderer with no reflections, "
                            "with their error against the same truth: peers.md (docs/methods_and_results.md)")
    bench.add_argument("-o", "--output", default="results", help="output folder (default: results/)")
    _samples_argument(bench)
    _backend_argument(bench)
    _max_memory_argument(bench)
    _workers_arguments(bench, "bench")
    bench.set_defaults(run=_bench)

    batch = commands.add_parser("batch", help="render the jobs of a batch file (TOML) on Ray workers, resumably "
                                              "(docs/batch.md)")
    batch.add_argument("jobs", type=Path, help="the batch file: [[jobs]] of scenes, cameras, times, methods, outputs")
    batch.add_argument("--manifest", type=Path,
                       help="the manifest (JSON lines, one per frame), overriding the batch file's")
    _workers_arguments(batch, "batch")
    _backend_argument(batch)
    _max_memory_argument(batch)
    batch.set_defaults(run=_batch)

    view = commands.add_parser("view", help="fly around a scene in a window (keys: H in the window)")
    _scene_arguments(view, headless=False)
    _method_arguments(view)
    view.add_argument("--frames", type=_positive, help="quit after this many frames")
    view.add_argument("--keys", help='scripted key presses, one per frame, e.g. "right*6 ] wait p escape"')
    view.add_argument("--screenshot", type=Path, help="save the last frame (without the overlay) here at exit")
    view.add_argument("--window-screenshot", type=Path, help="save the last frame as the window shows it")
    view.add_argument("--report", type=Path, help="write a JSON report of the session (frames, bakes, keys, GL errors)")
    view.add_argument("--shaders", type=Path, help="read the GLSL from this folder (edit a copy, reload with R)")
    view.add_argument("--no-panel", action="store_true", help="start with the panel of controls hidden (F2 shows it)")
    view.set_defaults(run=_view)
    return parser


#: The exit status of a command whose standard output was closed early (`render ... | head`): the
#: shell's for a process ended by SIGPIPE, as `yes | head` gives.
BROKEN_PIPE_EXIT = 128 + 13
#: Ctrl-C (SIGINT) and `kill` (SIGTERM) end a command quietly, with the shell's status for them;
#: what was being written is taken away on the way out (outputs.py: no temporary file is left).
INTERRUPTED_EXIT = 128 + signal.SIGINT
TERMINATED_EXIT = 128 + signal.SIGTERM


def _terminate(signum: int, frame: FrameType | None) -> None:
    raise Terminated


_python_format_warning = warnings.formatwarning


def _format_warning(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                    line: str | None = None) -> str:
    """Our warnings (a texture drawn as its mean colour, ...) as one line, like our errors; other
    packages' as Python writes them."""
    if issubclass(category, SceneWarning):
        return f"depthimpostor: warning: {message}\n"
    return _python_format_warning(message, category, filename, lineno, line)


def main(argv: Sequence[str] | None = None) -> int:
    warnings.formatwarning = _format_warning
    args = build_parser().parse_args(argv)
    # Signals are handled in the main thread only (a test may call main from another).
    own_signals = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _terminate) if own_signals else None
    try:
        if not own_signals:  # the signals, and so the interrupts, are the main thread's
            return int(args.run(args))
        with deferred_interrupts():  # an interrupt that lands in a finalizer is raised, not lost
            status: int = args.run(args)
            raise_pending()
            return status
    except KeyboardInterrupt:
        print(file=sys.stderr)  # after a progress bar, or the terminal's ^C
        return INTERRUPTED_EXIT
    except Terminated:
        return TERMINATED_EXIT
    except DepthImpostorError as error:
        print(f"depthimpostor: {error}", file=sys.stderr)
        return error.exit_code
    except BrokenPipeError:
        # The reader went away (`| head`): nothing more to say, and nowhere to say it. Python
        # flushes stdout again at exit; pointing it at /dev/null keeps that from failing too.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
        return BROKEN_PIPE_EXIT
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)

