"""The frames of a renderer with a bake budget (issue 32; BakedImages.bake_budget), one by one until
every image its rays enter is baked: each frame's images still waiting, its draw time and its
bake's, and then the same renderer's settled frames beside the ray tracer's, on tools/scene_size.py's
scene. What a viewer's first seconds look like on a scene whose images take long to bake.

    python3 tools/bake_budget_frames.py --objects 1000 --size 640x360
    python3 tools/bake_budget_frames.py --objects 1000 --bake-budget 1000000
"""

from __future__ import annotations

import argparse
import statistics

from depthimpostor.constants import Method
from depthimpostor.gpu.context import create_context
from depthimpostor.renderer import Renderer


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--objects", type=int, default=1000)
    parser.add_argument("--method", default="hybrid")
    parser.add_argument("--size", default="640x360")
    parser.add_argument("--resolution", type=int, default=128)
    parser.add_argument("--bake-budget", default="interactive", help="an integer, or interactive: the viewer's")
    parser.add_argument("--settled", type=int, default=5, help="frames timed once every image is in")
    parser.add_argument("--max-frames", type=int, default=400)
    args = parser.parse_args()
    from scene_size import family_scene  # beside this file
    from startup_time import bake_budget_of

    width, height = (int(v) for v in args.size.split("x"))
    scene = family_scene(args.objects).with_overrides(size=(width, height), impostor_resolution=args.resolution)
    ctx = create_context()
    budget = bake_budget_of(args.bake_budget)
    with Renderer(ctx, scene, method=Method.from_option(args.method), bake_budget=budget) as renderer:
        baked = renderer.graph.baked_images
        if baked is None:
            parser.error(f"--method {args.method} bakes no images")
        print(f"{args.objects} objects, {args.size}, --method {args.method}, bake budget {budget} triangles a frame")
        print("frame  waiting  draw ms  bake ms")
        for frame in range(args.max_frames):
            bakes_before = len(renderer.stats.bake_seconds)
            renderer.render()
            ctx.finish()
            bake = renderer.stats.bake_seconds[-1] if len(renderer.stats.bake_seconds) > bakes_before else 0.0
            print(f"{frame:5d} {baked.deferred:8d} {1000 * renderer.stats.draw_seconds[-1]:8.0f} {1000 * bake:8.0f}")
            if not baked.needs_bake:
                break
        settled = []
        for _ in range(args.settled):
            renderer.render()
            ctx.finish()
            settled.append(renderer.stats.draw_seconds[-1])
    with Renderer(ctx, scene, method=Method.RAYTRACE) as traced:
        traced.render()  # its first frame uploads and compiles
        ctx.finish()
        for _ in range(args.settled):
            traced.render()
            ctx.finish()
        traced_seconds = traced.stats.draw_seconds[-args.settled:]
    with open("/proc/loadavg", encoding="ascii") as load:
        loads = " ".join(load.read().split()[:3])
    print(f"settled: {1000 * statistics.median(settled):.0f} ms a frame; --method raytrace "
          f"{1000 * statistics.median(traced_seconds):.0f} ms (medians of {args.settled}; load {loads})")


if __name__ == "__main__":
    main()
