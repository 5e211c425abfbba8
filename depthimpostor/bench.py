"""The accuracy/time benchmark: for every scene, method (and, for depth images, intersection
algorithm) and resolution, what a frame costs and how far it is from the truth.

Per configuration two renderers are made. The timed one is the renderer `render` uses (no extra
outputs): its bakes and frames are timed with `time.perf_counter()` around `ctx.finish()` (GL time
queries under-report on software rasterizers; they are recorded beside, for real drivers), and
the mirror pass apart (a `ctx.finish()` before it): the part of the frame the methods differ in. The
measuring one adds the reflection outputs and the sample-counting variant, which exist only for
this: one frame of it gives the error figures against the truth and the samples each reflected
ray read. The truth depends only on the rays, which every method computes alike, so it is traced
once per scene and reused.

Frames are timed in rounds, every configuration of a scene once per round, in an order that
rotates from round to round: a machine that slows down for a while slows every one alike.
"""

from __future__ import annotations

import csv
import datetime
import io
import math
import os
import platform
import statistics
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass, fields
from functools import partial
from pathlib import Path

import moderngl
import numpy as np

from .oracles.compare import TruthFrame, compare
from .constants import Algorithm, Method
from .gpu.context import describe
from .errors import GpuLimitError
from .gpu.limits import check_fits, context_limits, planned_bytes
from .outputs import Outputs
from .peers import Peer, PeerRow, make_peers, mirror_rmse, peers_markdown
from .methods.planar import all_flat_mirrors
from .methods.registry import METHODS
from .plan import plan_render
from .renderer import Renderer
from .scene import Scene

#: Methods whose cost and accuracy depend on the image resolution; the triangle methods get one
#: row per scene, measured with the first resolution's group.
RESOLUTION_METHODS = frozenset(method for method, spec in METHODS.items() if spec.bakes_images)


@dataclass(frozen=True)
class Technique:
    """A method, and for depth images the intersection algorithm (the other methods have none)."""

    method: Method
    algorithm: Algorithm = Algorithm.OPTIMIZED

    @property
    def algorithm_name(self) -> str:
        return self.algorithm.name.lower() if METHODS[self.method].marches_depth_images else "-"


@dataclass(frozen=True)
class BenchSettings:
    methods: tuple[Method, ...]
    algorithms: tuple[Algorithm, ...]  # for the depth-image method
    resolutions: tuple[int | str, ...]  # sides in texels, or "auto" (resolution.py)
    size: tuple[int, int]
    frames: int  # timed frames per configuration
    warmup: int  # untimed frames before them
    bakes: int  # timed re-bakes per configuration (after an untimed first bake)
    peers: bool = False  # time Mitsuba 3 and the no-reflection renderer in the same rounds (peers.py)


@dataclass(frozen=True)
class BenchRow:
    """One scene, method (algorithm) and resolution (0 for the methods that have none)."""

    scene: str
    method: str
    algorithm: str  # the depth-image intersection; "-" for the other methods
    resolution: int | str  # "auto": each image sized from the pixels it covers
    stand_in: str
    frame_ms_median: float
    frame_ms_p10: float
    frame_ms_p90: float
    mirror_pass_ms_median: float  # the mirror pass alone
    gl_time_query_ms: float  # median of the frame's eye passes (no bake); under-reports on llvmpipe
    gl_mirror_pass_ms: float  # median of the mirror pass, by a GL time query; under-reports on llvmpipe
    bake_ms_median: float  # 0 for the methods that bake nothing
    memory_mib: float
    samples_per_ray_mean: float
    samples_per_ray_max: float
    mirror_pixels: int
    wrong_object_percent: float
    wrong_surface_percent: float  # of the mirror pixels that show an object (oracles/compare.py)
    retraced_percent: float  # of the mirror pixels: the hybrid method's rays traced against the triangles
    color_rmse: float
    psnr_db: float
    geometric_error_median_percent: float
    geometric_error_p95_percent: float



def rotated_medians(timers: dict[str, Callable[[], float]], rounds: int, warmup: int = 1) -> dict[str, float]:
    """The median milliseconds of each timer (returning seconds), taken in rounds that rotate the
    order of the timers, after `warmup` rounds: a load on the machine that comes and goes weighs
    on all of them alike (the tools' comparisons of variants; `bench` rotates its renderers so)."""
    names = list(timers)
    times: dict[str, list[float]] = {name: [] for name in names}
    for round_index in range(warmup + rounds):
        for offset in range(len(names)):
            name = names[(round_index + offset) % len(names)]
            seconds = timers[name]()
            if round_index >= warmup:
                times[name].append(1000.0 * seconds)
    return {name: statistics.median(values) for name, values in times.items()}

def machine_lines(ctx: moderngl.Context, settings: BenchSettings, scenes: Sequence[Scene]) -> list[str]:
    """What the figures were measured on and with: the first lines of every output."""
    return header_lines(describe(ctx), settings, scenes)


def header_lines(gl: str, settings: BenchSettings, scenes: Sequence[Scene]) -> list[str]:
    """machine_lines for the GL named `gl` (bench --workers: the workers' GL, as they report it)."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text(encoding="utf-8").splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return [
        f"depthimpostor bench, {datetime.date.today().isoformat()}",
        f"GL: {gl}",
        f"machine: {cpu}, {os.cpu_count()} logical CPUs, {platform.system()} {platform.release()}, "
        f"Python {platform.python_version()}",
        f"scenes: {', '.join(scene.source for scene in scenes)}",
        f"settings: size {settings.size[0]}x{settings.size[1]}, resolutions {list(settings.resolutions)}, "
        f"methods {[m.option for m in settings.methods]}, depth-image algorithms "
        f"{[a.name.lower() for a in settings.algorithms]}, {settings.warmup} warm-up + {settings.frames} timed "
        f"frames, {settings.bakes} timed bakes",
        # render.samples: a frame's time is its sub-frames'; colour figures are on averaged colours.
        f"anti-aliasing: {', '.join(f'{scene.source} {scene.render.samples}' for scene in scenes)} samples per pixel",
    ]


def _percentile(values: Sequence[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else math.nan


@contextmanager
def _renderers(ctx: moderngl.Context, configured: Sequence[tuple[Scene, Technique]]) -> Iterator[list[Renderer]]:
    renderers: list[Renderer] = []
    try:
        for scene, technique in configured:
            renderers.append(Renderer(ctx, scene, technique.algorithm, method=technique.method, time_mirror_pass=True))
        yield renderers
    finally:
        for renderer in renderers:
            renderer.release()


def time_group(ctx: moderngl.Context, renderers: list[Renderer], settings: BenchSettings,
                peers: Sequence[Peer] = ()) -> list[dict[str, float]]:
    """Bake and frame times of renderers timed together: every round renders each once, starting
    one further along each time. The `peers` are drawn in the same rounds (their times are theirs)."""
    for renderer in renderers:
        renderer.render()  # the first bake: llvmpipe compiles shaders on first use
        for _ in range(settings.bakes if renderer.graph.baked_images is not None else 0):
            renderer.bake_again()
            renderer.render()
    first_timed = [len(renderer.stats.draw_seconds) + settings.warmup for renderer in renderers]
    for peer in peers:
        peer.render()  # untimed, as the renderers' first frame: Mitsuba compiles its kernels, we our shaders
    timed: list[Renderer | Peer] = [*renderers, *peers]
    for round_index in range(settings.warmup + settings.frames):
        for offset in range(len(timed)):
            timed[(round_index + offset) % len(timed)].render()
    timings = []
    for renderer, first in zip(renderers, first_timed, strict=True):
        frames = [1000.0 * seconds for seconds in renderer.stats.draw_seconds[first:]]
        mirror_passes = [1000.0 * seconds for seconds in renderer.stats.mirror_seconds[first:]]
        # The GL time queries the render graph ran around the same frames (time_mirror_pass).
        gl_frames = [1000.0 * seconds for seconds in renderer.stats.gl_draw_seconds[first:]]
        gl_mirror_passes = [1000.0 * seconds for seconds in renderer.stats.gl_mirror_seconds[first:]]
        bakes = [1000.0 * seconds for seconds in renderer.stats.bake_seconds[1:]]
        timings.append({
            "frame_ms_median": statistics.median(frames),
            "frame_ms_p10": _percentile(frames, 10),
            "frame_ms_p90": _percentile(frames, 90),
            "mirror_pass_ms_median": statistics.median(mirror_passes),
            "gl_time_query_ms": statistics.median(gl_frames),
            "gl_mirror_pass_ms": statistics.median(gl_mirror_passes),
            "bake_ms_median": statistics.median(bakes) if bakes else 0.0,
        })
    return timings


def measure(
    ctx: moderngl.Context, scene: Scene, technique: Technique, truth: TruthFrame | None
) -> tuple[dict[str, float | int | str], TruthFrame]:
    """Error figures and samples per ray, from one frame of the measuring variant."""
    with Renderer(ctx, scene, technique.algorithm, reflection_data=True, method=technique.method,
                  count_samples=True) as renderer:
        renderer.render()
        comparison = compare(renderer, truth)
        figures = comparison.figures
        samples = renderer.read_sample_counts()[comparison.mirror_mask]
        stand_in = renderer.graph.stand_in
        measured: dict[str, float | int | str] = {
            "stand_in": stand_in.describe() if stand_in is not None else "no mirror",
            "memory_mib": stand_in.bytes / 2**20 if stand_in is not None else 0.0,
            "samples_per_ray_mean": float(samples.mean()) if len(samples) else 0.0,
            "samples_per_ray_max": float(samples.max()) if len(samples) else 0.0,
            "mirror_pixels": figures.mirror_pixels,
            "wrong_object_percent": 100.0 * figures.wrong_object_share,
            "wrong_surface_percent": 100.0 * figures.wrong_surface_share,
            "retraced_percent": 100.0 * figures.retraced_share,
            "color_rmse": figures.color_rmse,
            "psnr_db": figures.psnr_db,
            "geometric_error_median_percent": 100.0 * figures.geometric_error_median,
            "geometric_error_p95_percent": 100.0 * figures.geometric_error_p95,
        }
    return measured, comparison.truth_frame


def bench_configuration(ctx: moderngl.Context, variant: Scene, technique: Technique, settings: BenchSettings,
                        truth: TruthFrame | None) -> tuple[dict[str, float | int | str], TruthFrame]:
    """One configuration alone (`bench --workers`: a task of batch/bench_tasks.py): checked against
    the context's limits, timed as a group of one, then measured; its row's figures but the names,
    and the truth (for the scene's next configuration on this worker)."""
    check_fits(ctx, variant, plan_render(variant, technique.method, technique.algorithm, reflection_data=True,
                                         count_samples=True))
    check_fits(ctx, variant, plan_render(variant, technique.method, technique.algorithm))
    with _renderers(ctx, [(variant, technique)]) as renderers:
        (timing,) = time_group(ctx, renderers, settings)
    measured, truth = measure(ctx, variant, technique, truth)
    return {**measured, **timing}, truth


def techniques(settings: BenchSettings) -> list[Technique]:
    """Every method, the depth-image method once per algorithm."""
    return [
        Technique(method, algorithm)
        for method in settings.methods
        for algorithm in (settings.algorithms if METHODS[method].marches_depth_images else (Algorithm.OPTIMIZED,))
    ]


def configurations(settings: BenchSettings) -> list[tuple[int | str, list[Technique]]]:
    """The configurations of one scene, by resolution. The methods without a resolution are
    made with the first (resolution 0 in their rows)."""
    resolution_methods = [t for t in techniques(settings) if t.method in RESOLUTION_METHODS]
    others = [t for t in techniques(settings) if t.method not in RESOLUTION_METHODS]
    groups = [(resolution, list(resolution_methods)) for resolution in settings.resolutions if resolution_methods]
    if others:
        if groups:
            groups[0][1].extend(others)
        else:
            groups.append((settings.resolutions[0], others))
    return groups


def scene_configurations(scene: Scene, settings: BenchSettings) -> list[tuple[Scene, int | str, Technique]]:
    """Every configuration of one scene: the scene at its size and resolution, and the technique
    (but a method for flat mirrors alone, the planar one, in a scene with another reflector)."""
    flat = all_flat_mirrors(scene)
    return [
        (scene.with_overrides(size=settings.size, impostor_resolution=resolution), resolution, technique)
        for resolution, group in configurations(settings) for technique in group
        if flat or not METHODS[technique.method].flat_mirrors
    ]


def check_bench(ctx: moderngl.Context, scenes: Sequence[Scene], settings: BenchSettings) -> None:
    """Refuse, before any work, a benchmark this context cannot hold (GpuLimitError): each
    configuration with the measuring renderer's extra outputs, and each scene's configurations
    together, since they are timed side by side."""
    limits = context_limits(ctx)
    for scene in scenes:
        together = 0
        for variant, _, technique in scene_configurations(scene, settings):
            # The measuring renderer, with every extra output, must fit alone; the timed ones together.
            check_fits(ctx, variant, plan_render(variant, technique.method, technique.algorithm,
                                                 reflection_data=True, count_samples=True))
            together += planned_bytes(plan_render(variant, technique.method, technique.algorithm))
        if limits.memory is not None and together > limits.memory:
            raise GpuLimitError(
                f"{scene.source}: the {len(scene_configurations(scene, settings))} configurations timed together need "
                f"{together / 2**20:.0f} MiB, over the {limits.memory / 2**20:.0f} MiB of {limits.memory_source}; "
                "give fewer --resolutions or --methods, or raise --max-memory")


def run_bench(
    ctx: moderngl.Context, scenes: Sequence[Scene], settings: BenchSettings, progress: object | None = None,
    peer_rows: list[PeerRow] | None = None,
) -> list[BenchRow]:
    """Every scene x technique x resolution; `progress` is a tqdm bar (or anything with update()).
    With settings.peers, each peer's row of each scene is appended to `peer_rows`."""
    rows: list[BenchRow] = []
    for scene in scenes:
        name = Path(scene.source).stem
        configured = scene_configurations(scene, settings)
        # Every configuration of the scene is timed in the same rounds: a machine that slows down
        # for a few seconds (this one did, by a third, when resolutions were timed one after the
        # other) then slows every configuration alike. The cost is memory: every configuration's
        # images exist at once (about 4.4 GiB for the 8 x 9 scene at 64 to 1024).
        with _renderers(ctx, [(variant, technique) for variant, _, technique in configured]) as renderers, \
                _peers(ctx, configured[0][0], renderers[0], settings) as peers:
            timings = time_group(ctx, renderers, settings, peers)
            peer_timings = [_frame_times(peer.seconds[1 + settings.warmup:]) for peer in peers]
            peer_images = [peer.image() for peer in peers]
            peer_names = [(peer.name, getattr(peer, "variant", "")) for peer in peers]
        # Measured after all timing, as a precaution: the truth's ray tracer (Embree, on TBB
        # threads, which may spin a while after their work) should not share the cores with
        # frames being timed. (Not shown to matter: the slow groups seen while this was written
        # were machine noise, which the rotating rounds above absorb.)
        truth: TruthFrame | None = None
        for (variant, resolution, technique), timing in zip(configured, timings, strict=False):
            measured, truth = measure(ctx, variant, technique, truth)
            row_resolution = resolution if technique.method in RESOLUTION_METHODS else 0
            rows.append(BenchRow(scene=name, method=technique.method.option, algorithm=technique.algorithm_name,
                                 resolution=row_resolution, **measured, **timing))  # type: ignore[arg-type]
            if progress is not None:
                progress.update(1)  # type: ignore[attr-defined]
        if truth is not None and peer_rows is not None:
            peer_rows += [PeerRow(name, peer, variant, mirror_rmse(image, truth), **timing)
                          for (peer, variant), image, timing in zip(peer_names, peer_images, peer_timings, strict=True)]
    return rows


@contextmanager
def _peers(ctx: moderngl.Context, scene: Scene, renderer: Renderer, settings: BenchSettings) -> Iterator[list[Peer]]:
    """The peers of `scene` (as `renderer` sees it: its world and camera), where asked for."""
    peers = make_peers(ctx, scene, renderer.world, renderer.camera) if settings.peers else []
    try:
        yield peers
    finally:
        for peer in peers:
            peer.release()


def _frame_times(seconds: Sequence[float]) -> dict[str, float]:
    frames = [1000.0 * value for value in seconds]
    return {"frame_ms_median": statistics.median(frames), "frame_ms_p10": _percentile(frames, 10),
            "frame_ms_p90": _percentile(frames, 90)}


def total_configurations(scenes: Sequence[Scene], settings: BenchSettings) -> int:
    return sum(len(scene_configurations(scene, settings)) for scene in scenes)


# ---------------------------------------------------------------------------------- output
COLUMNS = [field.name for field in fields(BenchRow)]


def csv_text(rows: Sequence[BenchRow], header: Sequence[str]) -> str:
    """Comment lines (`# ...`) name the machine and settings; then one row per configuration."""
    text = io.StringIO(newline="")
    for line in header:
        text.write(f"# {line}\n")
    writer = csv.DictWriter(text, fieldnames=COLUMNS)
    writer.writeheader()
    for row in rows:
        writer.writerow(asdict(row))
    return text.getvalue()


def markdown(rows: Sequence[BenchRow], header: Sequence[str]) -> str:
    lines = [f"{line}  " for line in header] + [""]
    lines += [
        "| scene | method | resolution | frame ms (median, p10-p90) | mirror pass ms | bake ms | MiB "
        "| samples/ray mean / max | wrong object | wrong surface | re-traced | colour RMSE | geometric error median / p95 |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        lines.append(
            f"| {r.scene} | `{r.method}`{'' if r.algorithm == '-' else ' ' + r.algorithm} | {r.resolution or '-'} "
            f"| {r.frame_ms_median:.1f} ({r.frame_ms_p10:.1f}-{r.frame_ms_p90:.1f}) | {r.mirror_pass_ms_median:.1f} "
            f"| {r.bake_ms_median:.1f} | {r.memory_mib:.2f} | {r.samples_per_ray_mean:.1f} / "
            f"{r.samples_per_ray_max:.0f} | {r.wrong_object_percent:.2f} % | {r.wrong_surface_percent:.2f} % "
            f"| {r.retraced_percent:.2f} % | {r.color_rmse:.4f} | "
            f"{r.geometric_error_median_percent:.2f} % / {r.geometric_error_p95_percent:.1f} % |"
        )
    return "\n".join(lines) + "\n"


def _label(row: BenchRow) -> str:
    """A plot's name for a row's technique: `depth (hierarchical)`, `cubemap`."""
    return row.method + ("" if row.algorithm == "-" else f" ({row.algorithm})")


def plot(rows: Sequence[BenchRow], folder: Path, header: Sequence[str], out: Outputs) -> list[Path]:
    """Per scene: the accuracy/time frontier (colour RMSE against frame time, a curve per method,
    a point per resolution) and samples per ray against resolution."""
    import matplotlib

    matplotlib.use("Agg")  # files only: no display, whatever the environment says
    import matplotlib.pyplot as plt

    written = []
    for scene in dict.fromkeys(row.scene for row in rows):
        mine = [row for row in rows if row.scene == scene]
        labels = list(dict.fromkeys(_label(row) for row in mine))
        figure, axis = plt.subplots(figsize=(7.5, 5.0))
        for label in labels:
            points = sorted((row for row in mine if _label(row) == label and isinstance(row.resolution, int)),
                            key=lambda row: int(row.resolution))
            times = [row.frame_ms_median for row in points]
            errors = [max(row.color_rmse, 1e-6) for row in points]  # the exact method sits on the floor
            (line,) = axis.plot(times, errors, marker="o", label=label)
            # "auto" is one point beside its method's curve of fixed resolutions: on the frontier
            # when no fixed resolution is both faster and more accurate.
            for row in (row for row in mine if _label(row) == label and not isinstance(row.resolution, int)):
                axis.plot([row.frame_ms_median], [max(row.color_rmse, 1e-6)], marker="*", markersize=12,
                          color=line.get_color(), linestyle="none")
                points.append(row)
            for row in points:
                if row.resolution:
                    axis.annotate(str(row.resolution), (row.frame_ms_median, max(row.color_rmse, 1e-6)),
                                  textcoords="offset points", xytext=(4, 3), fontsize=7)
        axis.set(xscale="log", yscale="log", xlabel="frame time, ms (median)",
                 ylabel="colour RMSE in the mirrors (under 1e-6 drawn at 1e-6)",
                 title=f"{scene}: accuracy against frame time")
        axis.grid(True, which="both", alpha=0.3)
        axis.legend(fontsize=8)
        figure.text(0.01, 0.005, header[1], fontsize=6)
        path = folder / f"frontier-{scene}.png"
        figure.tight_layout(rect=(0, 0.03, 1, 1))
        written.append(out.write(path, partial(figure.savefig, format="png", dpi=110)))
        plt.close(figure)

        figure, axis = plt.subplots(figsize=(7.5, 5.0))
        for label in labels:
            points = sorted((row for row in mine if _label(row) == label and isinstance(row.resolution, int)
                             and row.resolution), key=lambda r: int(r.resolution))
            if points:
                (mean,) = axis.plot([row.resolution for row in points], [row.samples_per_ray_mean for row in points],
                                    marker="o", label=f"{label}, mean")
                axis.plot([row.resolution for row in points], [row.samples_per_ray_max for row in points],
                          marker=".", linestyle=":", color=mean.get_color(), label=f"{label}, max")
        axis.set(xscale="log", yscale="log", xlabel="image resolution (pixels a side)",
                 ylabel="samples read per reflected ray", title=f"{scene}: samples per ray")
        axis.grid(True, which="both", alpha=0.3)
        axis.legend(fontsize=8)
        path = folder / f"samples-{scene}.png"
        figure.tight_layout()
        written.append(out.write(path, partial(figure.savefig, format="png", dpi=110)))
        plt.close(figure)
    return written


def write_results(rows: Sequence[BenchRow], folder: Path, header: Sequence[str],
                  peer_rows: Sequence[PeerRow] = ()) -> list[Path]:
    """bench.csv, bench.md, the plots and (with peers) peers.md, put in place together once all are written."""
    with Outputs() as out:
        peers = [out.text(folder / "peers.md", peers_markdown(rows, peer_rows, header))] if peer_rows else []
        return [out.text(folder / "bench.csv", csv_text(rows, header)),
                out.text(folder / "bench.md", markdown(rows, header)), *plot(rows, folder, header, out), *peers]
