"""How long a Renderer takes to make, and to switch algorithm, on a scene (issue 22's figures):
the median of a few runs, each in a fresh renderer of a fresh scene object on one context, with the shader programs
compiled (the cache is per renderer) and without (a second renderer on the same context shares
nothing but the context). Besides: the median of Renderer() and its first frame together (what a
user waits for), and of the CPU time the process spent on them (llvmpipe's threads included: on a
machine shared with other work, less disturbed by it than the wall time).

    python3 tools/startup_time.py scenes/lecture_8x9.toml --size 320x180 --resolution 128
    python3 tools/startup_time.py --objects 1000 --method raytrace   # tools/scene_size.py's scene of 1,000
    python3 tools/startup_time.py --objects 1000 --method depth --resolution auto
    python3 tools/startup_time.py --objects 1000 --method hybrid --bake-budget interactive   # as the viewer starts

`--bake-budget`: the triangles a frame's bake may draw where the method answers the rays of the
images not baked yet otherwise (the hybrid traces them; Renderer's bake_budget): `interactive` is
the viewer's (constants.INTERACTIVE_BAKE_BUDGET). Without it a frame waits for every image it
enters, as the CLI's renders do.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from depthimpostor.constants import INTERACTIVE_BAKE_BUDGET, Algorithm, Method
from depthimpostor.gpu.context import create_context
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene, load_scene


def bake_budget_of(option: str | None) -> int | None:
    """--bake-budget's triangles: an integer, `interactive` (the viewer's), or None (not given)."""
    if option is None:
        return None
    return INTERACTIVE_BAKE_BUDGET if option == "interactive" else int(option)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", type=Path, nargs="?", help="a scene file, or --objects")
    parser.add_argument("--objects", type=int, help="tools/scene_size.py's scene of that many objects around two mirrors")
    parser.add_argument("--method", default="depth")
    parser.add_argument("--size", default="320x180")
    parser.add_argument("--resolution", default="128", help="the images' side, or auto (sized by what the view asks)")
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--bake-budget", help="triangles a frame's bake may draw (an integer, or interactive: the viewer's)")
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    if (args.scene is None) == (args.objects is None):
        parser.error("give a scene file or --objects, not both")
    resolution = args.resolution if args.resolution == "auto" else int(args.resolution)
    if args.objects is not None:
        from scene_size import family_scene  # beside this file

        name = f"{args.objects} objects"
    else:
        name = str(args.scene)

    def fresh_scene() -> Scene:
        """The scene as a user's start has it: a new object each run, so that what a Scene keeps
        once worked out (its cached properties, the shading defines kept by scene) is paid by every
        run, as a start pays it, and not by the first alone."""
        written = family_scene(args.objects) if args.objects is not None else load_scene(args.scene)
        return written.with_overrides(size=(width, height), impostor_resolution=resolution)

    method = Method.from_option(args.method)
    budget = bake_budget_of(args.bake_budget)
    ctx = create_context()
    made, switched, first_frame, started, cpu = [], [], [], [], []
    for _ in range(args.runs):
        scene = fresh_scene()
        start, start_cpu = time.perf_counter(), time.process_time()
        renderer = Renderer(ctx, scene, method=method, bake_budget=budget)
        ctx.finish()
        made.append(time.perf_counter() - start)
        renderer.render()
        ctx.finish()
        started.append(time.perf_counter() - start)
        first_frame.append(started[-1] - made[-1])
        cpu.append(time.process_time() - start_cpu)
        start = time.perf_counter()
        renderer.set_algorithm(Algorithm.BASIC)
        ctx.finish()
        switched.append(time.perf_counter() - start)
        renderer.release()
    with open("/proc/loadavg", encoding="ascii") as load:
        loads = " ".join(load.read().split()[:3])
    budgeted = "" if budget is None else f", bake budget {budget:,} triangles a frame"
    print(f"{name}, --method {method.option}, resolution {args.resolution}{budgeted} (load {loads}): Renderer() {1000 * statistics.median(made):.0f} ms, first frame (bakes, compiles) "
          f"{1000 * statistics.median(first_frame):.0f} ms, set_algorithm {1000 * statistics.median(switched):.0f} ms "
          f"(medians of {args.runs}); Renderer() + first frame {1000 * statistics.median(started):.0f} ms "
          f"(the process's first renderer: {1000 * started[0]:.0f} ms), "
          f"{1000 * statistics.median(cpu):.0f} ms of this process's CPU time (all its threads: llvmpipe's too)")


if __name__ == "__main__":
    main()
