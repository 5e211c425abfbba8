"""What an equirect sky's image-based lighting costs (ibl.py), once per sky: the GPU prefilter of
its specular levels (passes/environment.py's prefilter: IBL_LEVELS draws of IBL_SAMPLES filtered
reads a texel), the numpy projection of its irradiance onto nine spherical-harmonic terms, and
what a frame pays after (the eye's passes with and without ENVIRONMENT_LIGHTING: the scene
with its metallic-roughness sky lighting, and the same scene whose metals take the constant ambient).

    python3 tools/prefilter_cost.py [--scene scenes/showcase.toml] [--runs 5]

The median of `--runs` prefilters (each timed around ctx.finish()) is what ibl.PREFILTER_SECONDS
records for `plan`. Times are wall-clock, on whatever GL the context gets.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import time
from pathlib import Path

import numpy as np

from depthimpostor.gpu.context import create_context, describe
from depthimpostor.ibl import _SH_CACHE, irradiance_sh9, prefilter_reads, uses_environment_lighting
from depthimpostor.renderer import Renderer
from depthimpostor.scene import load_scene
from depthimpostor.scene.model import Environment

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", type=Path, default=ROOT / "scenes" / "showcase.toml")
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--frames", type=int, default=5)
    args = parser.parse_args()
    ctx = create_context()
    scene = load_scene(args.scene)
    if not uses_environment_lighting(scene):
        raise SystemExit(f"{args.scene}: no equirect sky lights a metallic-roughness material here")
    image = scene.environment.image
    assert image is not None
    print(f"{args.scene.name}: a {image.shape[1]}x{image.shape[0]} sky; {describe(ctx)}")
    projections = []
    for _ in range(args.runs):
        _SH_CACHE.clear()
        start = time.perf_counter()
        irradiance_sh9(image)
        projections.append(time.perf_counter() - start)
    print(f"irradiance (nine terms, numpy): {statistics.median(projections) * 1e3:.1f} ms (median of {args.runs})")
    frames: dict[str, float] = {}
    # The same scene with the gradient's colours in place of the image: the constant ambient.
    plain = dataclasses.replace(scene, environment=Environment())
    for label, drawn in (("sky lighting", scene), ("gradient sky, constant ambient", plain)):
        with Renderer(ctx, drawn) as renderer:
            renderer.render()  # compiles, bakes and prefilters
            if label == "sky lighting":
                prefilters = []
                for _ in range(args.runs):
                    ctx.finish()
                    start = time.perf_counter()
                    renderer.graph.environment.prefilter()
                    ctx.finish()
                    prefilters.append(time.perf_counter() - start)
                print(f"prefilter (GPU, {prefilter_reads() / 1e6:.1f} M filtered reads): "
                      f"{statistics.median(prefilters) * 1e3:.0f} ms (median of {args.runs}: "
                      f"{', '.join(f'{t * 1e3:.0f}' for t in prefilters)})")
            renderer.stats.draw_seconds.clear()
            for _ in range(args.frames):
                renderer.render()
            frames[label] = float(np.median(renderer.stats.draw_seconds))
    print("frame (the eye's passes, median of {}): {}".format(
        args.frames, ", ".join(f"{label} {seconds * 1e3:.0f} ms" for label, seconds in frames.items())))


if __name__ == "__main__":
    main()
