"""Issue 24's figures of an interactive frame, each a ratio taken within one interleaved run (the
renderers draw in turn, so that the machine's load weighs on both alike):

- the default scene's depth-method frame over the same scene's with its mirror made diffuse;
- on the bunny at 256^2, the raytrace method's mirror pass over the depth method's;
- the lecture's 8 x 9 scene's bake at 1024^2, in frames of that scene.

The first two come with a bound measured in the same run: the mirror pass with no reflected object
at all (OBJECTS_LEFT_OUT: the ray set-up, the analytic planes and the sky alone), about the least
any stand-in this reflector pass reads can cost here (approximately: a ray that would meet an
object meets the floor or the sky instead, and is shaded so). The default frame with it over the
diffuse frame is about the lowest ratio such a stand-in could reach on this machine; the raytrace
method's mirror pass over it, about the highest against ray tracing. (tools/bake_cost.py bounds
the bake likewise.)

    python3 tools/interactive_frame.py -o results/llvmpipe/interactive_frame.md

Times are wall-clock medians around ctx.finish() (render_graph.py), like `depthimpostor bench`'s.
"""

from __future__ import annotations

import argparse
import dataclasses
import platform
import statistics
from pathlib import Path

import moderngl

from depthimpostor.constants import Algorithm, Method
from depthimpostor.gpu.context import create_context
from depthimpostor.gpu.uniforms import write
from depthimpostor.oracles.truth import MIRROR_BACKING_ALBEDO
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene, load_scene
from depthimpostor.scene.model import DiffuseMaterial

ROOT = Path(__file__).resolve().parent.parent
SIZE = (960, 540)


def interleaved(renderers: list[Renderer], frames: int, warmup: int = 2) -> list[list[float]]:
    """Each renderer's frame times (draw, not bake), drawing in turn."""
    for _ in range(warmup):
        for renderer in renderers:
            renderer.render()
    starts = [len(r.stats.draw_seconds) for r in renderers]
    for _ in range(frames):
        for renderer in renderers:
            renderer.render()
    return [r.stats.draw_seconds[start:] for r, start in zip(renderers, starts, strict=True)]


def mirror_made_diffuse(scene: Scene) -> Scene:
    objects = tuple(dataclasses.replace(o, material=DiffuseMaterial()) if o.is_reflector else o for o in scene.objects)
    return dataclasses.replace(scene, objects=objects)


def median_ms(values: list[float]) -> float:
    return 1000 * statistics.median(values)


def objects_left_out(renderer: Renderer) -> Renderer:
    """`renderer` with its mirrors drawn by the OBJECTS_LEFT_OUT variant of their program: the
    mirror pass without any stand-in (lib/reflected_scene.glsl), about the least any method's costs."""
    reflector_pass = renderer.graph.reflector_pass
    mirrors = reflector_pass.programs[False] if reflector_pass is not None else None
    assert reflector_pass is not None and mirrors is not None
    program = renderer.programs.with_defines(mirrors, {"OBJECTS_LEFT_OUT": 1})
    write(program, "u_backing_albedo", MIRROR_BACKING_ALBEDO)
    reflector_pass.programs[False] = program
    return renderer


def default_against_diffuse(ctx: moderngl.Context, frames: int) -> list[str]:
    scene = load_scene(ROOT / "scenes" / "default.toml").with_overrides(size=SIZE)
    with Renderer(ctx, scene) as mirror, Renderer(ctx, mirror_made_diffuse(scene)) as diffuse, \
            Renderer(ctx, scene) as bound:
        bound.render()
        with_mirror, without, least = interleaved([mirror, diffuse, objects_left_out(bound)], frames)
    a, b, c = median_ms(with_mirror), median_ms(without), median_ms(least)
    return [f"| default scene, 960x540, depth method ({scene.render.impostor_resolution}) over the mirror made "
            f"diffuse | {a:.1f} ms / {b:.1f} ms | {a / b:.2f} |",
            f"| the same, the mirror pass without any reflected object (about the least any stand-in costs) over the "
            f"mirror made diffuse | {c:.1f} ms / {b:.1f} ms | {c / b:.2f} |"]


def bunny_raytrace_against_depth(ctx: moderngl.Context, frames: int) -> list[str]:
    scene = load_scene(ROOT / "scenes" / "bunny.toml").with_overrides(size=SIZE, impostor_resolution=256)
    def make(method: Method) -> Renderer:
        return Renderer(ctx, scene, Algorithm.OPTIMIZED, method=method, time_mirror_pass=True)

    with make(Method.DEPTH) as depth, make(Method.RAYTRACE) as traced, make(Method.DEPTH) as bound:
        renderers = [depth, traced, bound]
        for renderer in renderers:
            renderer.render()
        objects_left_out(bound)
        first = [len(r.stats.mirror_seconds) for r in renderers]
        interleaved(renderers, frames, warmup=1)
        a, b, c = (median_ms(r.stats.mirror_seconds[start + 1:]) for r, start in zip(renderers, first, strict=True))
    return [f"| bunny, 960x540, 256^2: raytrace's mirror pass over the depth method's | {b:.1f} ms / {a:.1f} ms | {b / a:.2f} |",
            f"| the same, raytrace's mirror pass over the mirror pass without any reflected object (a bound for every "
            f"stand-in) | {b:.1f} ms / {c:.1f} ms | {b / c:.2f} |"]


def lecture_bake_in_frames(ctx: moderngl.Context, frames: int) -> list[str]:
    scene = load_scene(ROOT / "scenes" / "lecture_8x9.toml").with_overrides(size=SIZE, impostor_resolution=1024)
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        bakes_before = len(renderer.stats.bake_seconds)
        frame_times: list[float] = []
        for _ in range(max(1, frames // 4)):
            renderer.bake_again()
            renderer.render()
            for _ in range(3):
                renderer.render()
                frame_times.append(renderer.stats.draw_seconds[-1])
        bake = median_ms(renderer.stats.bake_seconds[bakes_before:])
        frame = median_ms(frame_times)
    return [f"| lecture 8x9, 960x540: the bake at 1024^2 (72 images) over a frame | {bake:.0f} ms / {frame:.1f} ms | {bake / frame:.1f} |"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", type=Path)
    parser.add_argument("--frames", type=int, default=20)
    args = parser.parse_args()
    ctx = create_context()
    info = ctx.info
    lines = [f"GL: {info['GL_RENDERER']} ({info['GL_VERSION']}); {platform.processor() or platform.machine()}", "",
             "| figure | times | ratio |", "|---|---:|---:|"]
    for figure in (default_against_diffuse, bunny_raytrace_against_depth, lecture_bake_in_frames):
        rows = figure(ctx, args.frames)
        lines += rows
        print("\n".join(rows), flush=True)
    text = "\n".join(lines) + "\n"
    if args.output is not None:
        args.output.write_text(text)
    else:
        print(text)


if __name__ == "__main__":
    main()
