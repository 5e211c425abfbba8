"""Where a renderer's start-up goes (issue 32: start a scene of 1,000 objects in under 2 s): the
wall and CPU time of each phase of `Renderer()` and of its first frame, each phase closed by
`ctx.finish()` so that llvmpipe's queued work is counted where it was asked for. Phases: the
plan (images planned, camera fits), the passes made (atlas, buffers, records; the BVH's textures
apart), programs compiled (ProgramCache.get, as it is called), and in the first frame the atlas's
rows made for the images baked, the bake's layers (visible surface, back layer, where second runs
begin), the rest of the frame (the eye's passes and mirror pass).
Without the finishes a phase's GPU work would land in the next; with them the sum is a little
more than startup_time.py's figure.

    python3 tools/startup_phases.py --objects 1000 --method depth
    python3 tools/startup_phases.py --objects 1000 --method hybrid --bake-budget interactive   # as the viewer starts
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import moderngl

from depthimpostor import renderer as renderer_module
from depthimpostor.constants import Method
from depthimpostor.gpu import shaders
from depthimpostor.gpu.context import create_context
from depthimpostor.methods import atlas, baked_images, triangles
from depthimpostor.renderer import Renderer
from depthimpostor import render_graph

WALL: dict[str, float] = defaultdict(float)
CPU: dict[str, float] = defaultdict(float)
_OPEN: list[str] = []  # phases open now: an inner phase's time is taken out of the outer's


@contextmanager
def phase(ctx: moderngl.Context, name: str) -> Iterator[None]:
    ctx.finish()
    start, start_cpu = time.perf_counter(), time.process_time()
    _OPEN.append(name)
    try:
        yield
    finally:
        ctx.finish()
        _OPEN.pop()
        wall, cpu = time.perf_counter() - start, time.process_time() - start_cpu
        WALL[name] += wall
        CPU[name] += cpu
        if _OPEN:  # time counted in the inner phase only
            WALL[_OPEN[-1]] -= wall
            CPU[_OPEN[-1]] -= cpu


def timed(ctx: moderngl.Context, owner: Any, attribute: str, name: str) -> None:
    original: Callable[..., Any] = getattr(owner, attribute)

    def wrapper(*args: Any, **kwargs: Any) -> Any:
        with phase(ctx, name):
            return original(*args, **kwargs)

    setattr(owner, attribute, wrapper)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--objects", type=int, default=1000)
    parser.add_argument("--method", default="depth")
    parser.add_argument("--size", default="320x180")
    parser.add_argument("--resolution", default="128")
    parser.add_argument("--bake-budget", help="triangles a frame's bake may draw (an integer, or interactive: the viewer's)")
    args = parser.parse_args()
    from scene_size import family_scene  # beside this file
    from startup_time import bake_budget_of

    budget = bake_budget_of(args.bake_budget)

    width, height = (int(v) for v in args.size.split("x"))
    resolution = args.resolution if args.resolution == "auto" else int(args.resolution)
    scene = family_scene(args.objects).with_overrides(size=(width, height), impostor_resolution=resolution)
    ctx = create_context()
    timed(ctx, renderer_module, "plan_render", "plan (images planned, cameras fitted)")
    timed(ctx, shaders.ProgramCache, "get", "programs (compiled on first use)")
    timed(ctx, render_graph.RenderGraph, "build", "passes made (atlas, buffers, records)")
    timed(ctx, triangles.TrianglePass, "__init__", "passes made: the BVH's textures (traced methods, hybrid)")
    timed(ctx, atlas.ImpostorAtlas, "grow", "bake: the atlas's rows made")
    timed(ctx, baked_images.BakedImages, "drawn", "bake: levels of detail chosen")
    timed(ctx, baked_images.BakedImages, "_bake_surfaces", "bake: visible surfaces")
    timed(ctx, baked_images.BakedImages, "_bake_back_layers", "bake: back layers")
    timed(ctx, baked_images.BakedImages, "_bake_beyond", "bake: second runs")
    start, start_cpu = time.perf_counter(), time.process_time()
    with phase(ctx, "Renderer(): the rest"):
        renderer = Renderer(ctx, scene, method=Method.from_option(args.method), bake_budget=budget)
    with phase(ctx, "first frame: the rest (eye's passes, mirror pass, bake's other work)"):
        renderer.render()
    wall, cpu = time.perf_counter() - start, time.process_time() - start_cpu
    with open("/proc/loadavg", encoding="ascii") as load:
        loads = load.read().split()[:3]
    budgeted = "" if budget is None else f", bake budget {budget:,} triangles a frame"
    print(f"{args.objects} objects, --method {args.method}, {args.size}, resolution {args.resolution}{budgeted}: "
          f"{wall:.2f} s wall, {cpu:.2f} s CPU (load {' '.join(loads)})")
    for name in WALL:
        print(f"  {name:70s} {WALL[name]:6.2f} s wall {CPU[name]:6.2f} s CPU")
    renderer.release()


if __name__ == "__main__":
    main()
