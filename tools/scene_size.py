"""The benchmark of scene size (issue 32, item 3): the same two mirrors among 1, 10, 100 and 1,000
small checkered objects, the count the only thing that changes (the first N of one seeded list of
places, so every scene holds the smaller ones' objects), every method, and per count: frame,
mirror pass, bake, memory, images a reflected ray visits, and the error against the truth.

    python3 tools/scene_size.py -o results/llvmpipe/scene_size                 # 960x540, 256^2
    python3 tools/scene_size.py --counts 1,10 --methods depth --size 320x180   # a quick look

Times come from `depthimpostor bench`'s rounds (bench.run_bench: perf_counter around ctx.finish,
every method of one count timed in the same rotating rounds); errors from its measuring renderer
against the truth. "Images per ray" is counted here, on the CPU, from the depth-image method's
image records: the images whose hit bound a mirror pixel's reflected ray enters no later than
where it hits (lib/reflected_scene.glsl visits them nearest first and stops at the first
entered beyond its nearest hit), averaged over the mirror pixels. The depth method's mirror
pass is fitted as a * objects^k from 10 to 1,000 objects (the issue asks k <= 0.3).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from depthimpostor.bench import BenchRow, BenchSettings, machine_lines, run_bench
from depthimpostor.constants import Algorithm, Method
from depthimpostor.errors import DepthImpostorError
from depthimpostor.gpu.context import create_context
from depthimpostor.methods.registry import METHODS
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene
from depthimpostor.scene.loader import parse_scene

if sys.version_info >= (3, 11):
    import tomllib
else:  # tomllib joined the standard library in 3.11; tomli is the same parser (pyproject declares it)
    import tomli as tomllib

HEAD = """
[render]
size = [960, 540]
impostor_resolution = 256
ambient = 0.25

[camera]
eye = [0.0, 3.2, 8.5]
target = [0.0, 0.9, 0.0]
fov_y = 45.0

[[lights]]
type = "directional"
direction = [-0.4, -1.0, -0.3]

[[objects]]
name = "floor"
shape = { type = "plane", size = [30.0, 30.0] }
material = { type = "checker", color_a = [0.8, 0.8, 0.8], color_b = [0.35, 0.35, 0.35], scale = 1.0 }

[[objects]]
name = "mirror left"
shape = { type = "sphere", radius = 1.0 }
material = { type = "mirror", tint = [0.95, 0.95, 0.95] }
position = [-1.4, 1.0, 0.0]

[[objects]]
name = "mirror right"
shape = { type = "sphere", radius = 0.8 }
material = { type = "mirror", tint = [0.95, 0.95, 0.95] }
position = [1.5, 0.8, -0.6]
"""
MIRRORS = ((np.array([-1.4, 1.0, 0.0]), 1.0), (np.array([1.5, 0.8, -0.6]), 0.8))
#: Every object's size: small (a few pixels to a few dozen in the mirrors), the count alone grows.
OBJECT_RADIUS = 0.12
SEED = 32


def places(count: int) -> np.ndarray:
    """The first `count` of one seeded list of object centres: in a box about the mirrors, none
    within 0.3 of a mirror's surface."""
    rng = np.random.default_rng(SEED)
    kept: list[np.ndarray] = []
    while len(kept) < count:
        point = rng.uniform((-5.0, OBJECT_RADIUS, -5.0), (5.0, 2.6, 4.0))
        if all(np.linalg.norm(point - centre) > radius + OBJECT_RADIUS + 0.3 for centre, radius in MIRRORS):
            kept.append(point)
    return np.array(kept).reshape(-1, 3)


def scene_text(count: int) -> str:
    """The family's scene of `count` objects: spheres and boxes in turn, each checkered in a colour
    of its own (a ray answered by the wrong image shows the wrong colour and object)."""
    text = HEAD
    for i, (x, y, z) in enumerate(places(count)):
        shape = (f'{{ type = "sphere", radius = {OBJECT_RADIUS} }}' if i % 2 == 0
                 else f'{{ type = "box", size = [{1.4 * OBJECT_RADIUS}, {1.4 * OBJECT_RADIUS}, {1.4 * OBJECT_RADIUS}] }}')
        hue = (i * 0.618034) % 1.0
        colour = [0.5 + 0.45 * math.cos(2.0 * math.pi * (hue + k / 3.0)) for k in range(3)]
        text += (f'\n[[objects]]\nname = "object {i}"\nshape = {shape}\n'
                 f'material = {{ type = "checker", color_a = [{colour[0]:.3f}, {colour[1]:.3f}, {colour[2]:.3f}], '
                 f"color_b = [0.08, 0.08, 0.08], scale = 0.06 }}\nposition = [{x:.4f}, {y:.4f}, {z:.4f}]\n"
                 f"rotation = [0.0, {(37.0 * i) % 360:.1f}, 0.0]\n")
    return text


def family_scene(count: int) -> Scene:
    return parse_scene(tomllib.loads(scene_text(count)), f"scene_size_{count}.toml", Path.cwd())


def images_per_ray(renderer: Renderer) -> float:
    """The mean count, over the mirror pixels, of the depth images whose hit bound the reflected
    ray enters no later than its hit (all it enters where it hits nothing): what the mirror shader
    visits (see the module's docstring)."""
    data = renderer.read_reflection_data()
    baked = renderer.graph.baked_images
    if baked is None or not data.mirror_mask.any():
        return 0.0
    total, rays = 0, 0
    for mirror_index, images in baked.images_by_reflector.items():
        pixels = data.mirror_mask & (data.mirror_id == mirror_index)
        if not pixels.any() or not images:
            continue
        origins, directions = data.origin[pixels], data.direction[pixels]
        hits = np.where(data.object_id[pixels] >= 0,
                        np.linalg.norm(data.hit_position[pixels] - origins, axis=1), np.inf)
        records = baked.image_records(images)
        spheres = np.stack([record["hit_bound"] for record in records[: len(images)]]).astype(np.float64)
        for first in range(0, len(origins), 4096):
            o, d, t_hit = origins[first:first + 4096], directions[first:first + 4096], hits[first:first + 4096]
            to_centre = spheres[None, :, :3] - o[:, None, :]
            along = np.einsum("rij,rj->ri", to_centre, d)
            miss_squared = np.einsum("rij,rij->ri", to_centre, to_centre) - along**2
            radius_squared = spheres[None, :, 3] ** 2
            entered = miss_squared <= radius_squared
            entry = along - np.sqrt(np.maximum(radius_squared - miss_squared, 0.0))
            exit_ = along + np.sqrt(np.maximum(radius_squared - miss_squared, 0.0))
            visited = entered & (exit_ >= 0.0) & (np.maximum(entry, 0.0) <= t_hit[:, None])
            total += int(visited.sum())
        rays += len(origins)
    return total / max(rays, 1)


def interleaved_mirror_pass(ctx: object, counts: list[int], method: Method, size: tuple[int, int], resolution: int,
                            rounds: int) -> dict[int, float]:
    """The mirror pass's median (ms) per count, with one renderer per count alive at once and each
    round drawing every count in turn: on a machine whose load drifts (other jobs on shared cores),
    the drift falls on every count alike, which one count after another does not give."""
    renderers = []
    try:
        for count in counts:
            scene = family_scene(count).with_overrides(size=size, impostor_resolution=resolution)
            renderer = Renderer(ctx, scene, method=method, time_mirror_pass=True)  # type: ignore[arg-type]
            renderer.render()  # bakes, compiles: not timed
            renderers.append(renderer)
        for _ in range(rounds):
            for renderer in renderers:
                renderer.render()
        return {count: 1000.0 * float(np.median(renderer.stats.mirror_seconds[1:]))
                for count, renderer in zip(counts, renderers, strict=True)}
    finally:
        for renderer in renderers:
            renderer.release()


def exponent(counts: list[int], values: list[float]) -> float:
    """k of the least-squares fit values = a * counts^k (log-log)."""
    return float(np.polyfit(np.log(counts), np.log(values), 1)[0])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--counts", default="1,10,100,1000")
    parser.add_argument("--methods", default="all", help="comma-separated, or all")
    parser.add_argument("--size", default="960x540")
    parser.add_argument("--resolution", type=int, default=256)
    parser.add_argument("--frames", type=int, default=5)
    parser.add_argument("-o", "--output", type=Path, default=None)
    parser.add_argument("--interleaved", type=int, default=0, metavar="ROUNDS",
                        help="also time the depth method's mirror pass from 10 objects up with every count's renderer "
                             "alive and ROUNDS rounds rotating across them (the figure the exponent is fitted to)")
    args = parser.parse_args()
    counts = [int(c) for c in args.counts.split(",")]
    methods = tuple(METHODS) if args.methods == "all" else tuple(Method.from_option(m) for m in args.methods.split(","))
    width, height = (int(v) for v in args.size.split("x"))
    settings = BenchSettings(methods=methods, algorithms=(Algorithm.OPTIMIZED,), resolutions=(args.resolution,),
                             size=(width, height), frames=args.frames, warmup=1, bakes=2)
    ctx = create_context()
    rows: list[tuple[int, BenchRow | str, float]] = []
    for count in counts:
        scene = family_scene(count)
        for method in methods:
            one = BenchSettings(**{**settings.__dict__, "methods": (method,)})
            try:
                [row] = run_bench(ctx, [scene], one)
            except (DepthImpostorError, ValueError) as error:
                print(f"{count} objects, {method.option}: refused: {error}", file=sys.stderr)
                rows.append((count, str(error).splitlines()[0], 0.0))
                continue
            visits = 0.0
            if METHODS[method].marches_depth_images:
                variant = scene.with_overrides(size=(width, height), impostor_resolution=args.resolution)
                with Renderer(ctx, variant, method=method, reflection_data=True) as renderer:
                    renderer.render()
                    visits = images_per_ray(renderer)
            rows.append((count, row, visits))
            print(f"{count:>5} objects {method.option:<17} frame {row.frame_ms_median:8.1f} ms  mirror pass "
                  f"{row.mirror_pass_ms_median:8.1f} ms  bake {row.bake_ms_median:8.1f} ms  {row.memory_mib:7.1f} MiB  "
                  f"images/ray {visits:5.2f}  wrong object {row.wrong_object_percent:5.2f} %  wrong surface "
                  f"{row.wrong_surface_percent:5.2f} %  RMSE {row.color_rmse:.4f}", flush=True)
    interleaved: dict[int, float] = {}
    if args.interleaved:
        interleaved = interleaved_mirror_pass(ctx, [c for c in counts if c >= 10], Method.DEPTH, (width, height),
                                              args.resolution, args.interleaved)
        print("interleaved depth mirror pass (ms):", {c: round(v, 1) for c, v in interleaved.items()}, flush=True)
    report = _report(ctx, settings, counts, rows, interleaved)
    print(report)
    if args.output is not None:
        args.output.mkdir(parents=True, exist_ok=True)
        (args.output / "scene_size.md").write_text(report)
        _plot(rows, args.output / "scene_size.png")
    return 0


def _report(ctx: object, settings: BenchSettings, counts: list[int], rows: list[tuple[int, BenchRow | str, float]],
            interleaved: dict[int, float]) -> str:
    lines = ["# Scene size: 1 to 1,000 reflected objects around two mirrors (tools/scene_size.py)", ""]
    lines += [f"{line}  " for line in machine_lines(ctx, settings, [family_scene(1)])]  # type: ignore[arg-type]
    lines += ["", "| objects | method | frame ms | mirror pass ms | bake ms | memory MiB | images / ray | wrong object % | "
              "wrong surface % | RMSE |", "|---|---|---|---|---|---|---|---|---|---|"]
    for count, row, visits in rows:
        if isinstance(row, str):
            lines.append(f"| {count} | | refused: {row} | | | | | | | |")
            continue
        lines.append(f"| {count} | {row.method} | {row.frame_ms_median:.1f} | {row.mirror_pass_ms_median:.1f} | "
                     f"{row.bake_ms_median:.1f} | {row.memory_mib:.1f} | {visits:.2f} | {row.wrong_object_percent:.2f} | "
                     f"{row.wrong_surface_percent:.2f} | {row.color_rmse:.4f} |")
    depth = {count: row for count, row, _ in rows if not isinstance(row, str) and row.method == "depth" and count >= 10}
    if len(depth) >= 2:
        ks = sorted(depth)
        k = exponent(ks, [depth[c].mirror_pass_ms_median for c in ks])
        lines += ["", f"The depth method's mirror pass grows as objects^{k:.2f} from {ks[0]} to {ks[-1]} objects "
                  "(least squares in log-log)."]
    if len(interleaved) >= 2:
        ks = sorted(interleaved)
        k = exponent(ks, [interleaved[c] for c in ks])
        figures = ", ".join(f"{c}: {interleaved[c]:.1f} ms" for c in ks)
        lines += ["", f"Interleaved (every count's renderer alive, rounds rotating across counts, so that a drift in "
                  f"the machine's load falls on all alike): the depth method's mirror pass {figures}; "
                  f"objects^{k:.2f} from {ks[0]} to {ks[-1]}."]
    return "\n".join(lines) + "\n"


def _plot(rows: list[tuple[int, BenchRow | str, float]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, (time_axis, error_axis) = plt.subplots(1, 2, figsize=(11, 4))
    for method in dict.fromkeys(row.method for _, row, _ in rows if not isinstance(row, str)):
        points = sorted((count, row) for count, row, _ in rows if not isinstance(row, str) and row.method == method)
        counts = [count for count, _ in points]
        time_axis.plot(counts, [row.mirror_pass_ms_median for _, row in points], "o-", label=method)
        error_axis.plot(counts, [row.color_rmse for _, row in points], "o-", label=method)
    for axis, label in ((time_axis, "mirror pass (ms)"), (error_axis, "colour RMSE against the truth")):
        axis.set_xscale("log")
        axis.set_yscale("log")
        axis.set_xlabel("reflected objects")
        axis.set_ylabel(label)
        axis.grid(True, which="both", alpha=0.3)
    time_axis.legend(fontsize=7)
    figure.tight_layout()
    figure.savefig(path, dpi=110)


if __name__ == "__main__":
    sys.exit(main())
