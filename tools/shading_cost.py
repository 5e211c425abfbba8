"""What the floor costs (issue 24, item 3): a scene's analytic planes drawn alone by the diffuse
pass, and the scene's mirror pass with and without its planes, each with the shaders' light and
plane loops bounded by constants of the program (LIGHT_COUNT, PLANE_COUNT: the variants the passes
make) and by uniforms (the shaders' fallback without them: what they ran before). On llvmpipe a
loop bounded by a uniform costs several times the same loop with a constant bound, which the
compiler unrolls (lib/shading.glsl).

    python3 tools/shading_cost.py [scene.toml] [--frames 9]

Medians of timed frames, taken in rounds that rotate over the variants (as bench does).
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from collections.abc import Callable
from pathlib import Path

import moderngl

from depthimpostor.bench import rotated_medians
from depthimpostor.eye import clear_depth, eye_depth
from depthimpostor.gpu.context import create_context, describe
from depthimpostor.gpu.uniforms import write
from depthimpostor.oracles.truth import MIRROR_BACKING_ALBEDO
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene, load_scene

ROOT = Path(__file__).resolve().parent.parent
#: The defines that make the loops' bounds constants; without them the shaders loop to a uniform.
CONSTANT_BOUNDS = ("LIGHT_COUNT", "PLANE_COUNT")


def floor_timer(renderer: Renderer, program: moderngl.Program) -> Callable[[], float]:
    """Seconds to draw the scene's analytic planes alone with `program`, after a clear."""
    ctx, planes = renderer.ctx, renderer.world.analytic_planes
    view_projection = renderer.camera.view_projection

    def run() -> float:
        renderer.targets.color_framebuffer.use()
        renderer.targets.framebuffer.clear(0.0, 0.0, 0.0, 0.0, depth=clear_depth(ctx))
        ctx.finish()
        start = time.perf_counter()
        with eye_depth(ctx):
            for plane in planes:
                write(program, "u_material_index", renderer.scene.material_index(plane.object.material))
                renderer.graph.meshes.draw(program, plane, view_projection)
        ctx.finish()
        return time.perf_counter() - start
    return run


def mirror_timer(renderer: Renderer, program: moderngl.Program) -> Callable[[], float]:
    """Seconds of the mirror pass of one frame drawn with `program` as the mirrors' shader."""
    assert renderer.graph.reflector_pass is not None
    reflector_pass = renderer.graph.reflector_pass

    def run() -> float:
        kept = reflector_pass.programs[False]
        reflector_pass.programs[False] = program
        try:
            renderer.render()
        finally:
            reflector_pass.programs[False] = kept
        return renderer.stats.mirror_seconds[-1]
    return run


def variants(renderer: Renderer, planes_kept: bool) -> dict[str, Callable[[], float]]:
    """The floor and mirror timers of one renderer, with constant and with uniform bounds."""
    assert renderer.graph.diffuse is not None and renderer.graph.reflector_pass is not None
    timers: dict[str, Callable[[], float]] = {}
    mirror_program = renderer.graph.reflector_pass.programs[False]
    assert mirror_program is not None
    for bounds in ("constant", "uniform"):
        diffuse, mirror = renderer.graph.diffuse.program, mirror_program
        if bounds == "uniform":
            diffuse = renderer.programs.without_defines(diffuse, CONSTANT_BOUNDS)
            mirror = renderer.programs.without_defines(mirror, CONSTANT_BOUNDS)
            write(mirror, "u_backing_albedo", MIRROR_BACKING_ALBEDO)
        if planes_kept:
            timers[f"planes alone, diffuse pass, {bounds} bounds"] = floor_timer(renderer, diffuse)
            timers[f"mirror pass, {bounds} bounds"] = mirror_timer(renderer, mirror)
        else:
            timers[f"mirror pass without the planes, {bounds} bounds"] = mirror_timer(renderer, mirror)
    return timers


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", nargs="?", type=Path, default=ROOT / "scenes" / "default.toml")
    parser.add_argument("--frames", type=int, default=9)
    args = parser.parse_args()
    ctx = create_context()
    print(describe(ctx))
    scene: Scene = load_scene(args.scene)
    no_planes = dataclasses.replace(scene, objects=tuple(o for i, o in enumerate(scene.objects)
                                                         if i not in scene.analytic_plane_indices))
    with Renderer(ctx, scene, time_mirror_pass=True) as renderer, \
            Renderer(ctx, no_planes, time_mirror_pass=True) as bare:
        renderer.render()
        bare.render()
        timers = {**variants(renderer, True), **variants(bare, False)}
        medians = rotated_medians(timers, args.frames, warmup=2)
    print(f"{scene.source} at {scene.render.size[0]}x{scene.render.size[1]}, median of {args.frames} frames:")
    for name, median in medians.items():
        print(f"  {name:58s} {median:7.2f} ms")


if __name__ == "__main__":
    main()
