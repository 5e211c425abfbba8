"""What a bake costs (issue 24, item 4): a scene's full bake (every image stale, as `bake_again`
makes it) with the programs the renderer makes, against the same bake with programs made without
the specializations that spare work in the bake's fragments: NO_CHECKER (no object baked has a
checker material) and DIRECTIONAL_LIGHTS (no point light: the surface's position is not read).
Then what bounds the bake on this machine: the same images drawn with a trivial fragment shader
(colour and depth alone), and with no colour at all.

    python3 tools/bake_cost.py [scene.toml] [--resolution 1024] [--rounds 5]

Medians of bakes taken in rounds that rotate over the variants (as bench does), wall-clock around
ctx.finish(); the machine's load weighs on all variants alike.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import moderngl
import numpy as np

from depthimpostor.bench import rotated_medians
from depthimpostor.gpu.context import create_context, describe
from depthimpostor.gpu.gl_state import RasterState, raster_state
from depthimpostor.geometry import ObjectGeometry, mesh_for_shape
from depthimpostor.methods.atlas import BACK_FACES, DepthImage
from depthimpostor.methods.baked_images import BakedImages
from depthimpostor.renderer import Renderer
from depthimpostor.scene import load_scene
from depthimpostor.scene.model import BoxShape, SceneObject

ROOT = Path(__file__).resolve().parent.parent
SPECIALIZATIONS = ("NO_CHECKER", "DIRECTIONAL_LIGHTS")

TRIVIAL_VERTEX = """#version 330 core
in vec3 in_position;
uniform mat4 u_model;
uniform mat4 u_view_projection;
void main() { gl_Position = u_view_projection * u_model * vec4(in_position, 1.0); }
"""
TRIVIAL_FRAGMENT = """#version 330 core
layout(location = 0) out vec4 out_color;
layout(location = 1) out vec2 out_depth_and_object;
void main() { out_color = vec4(1.0); out_depth_and_object = vec2(gl_FragCoord.z); }
"""


def bake_timer(baked: BakedImages, dropped: tuple[str, ...] = (), rested: bool = False) -> Callable[[], float]:
    """Seconds of a full bake, its surface and back-layer passes drawing with their programs made
    without the defines `dropped`; `rested`: after the depth buffer was let go (BakedImages.rest,
    as after a frame that baked nothing), so that the bake makes it again."""
    passes = [p for p in (baked.diffuse, baked.back_layer) if p is not None]

    def run() -> float:
        kept = [p.defines for p in passes]
        for diffuse_pass in passes:
            diffuse_pass.defines = {k: v for k, v in diffuse_pass.defines.items() if k not in dropped}
        try:
            baked.bake_again()
            if rested:
                baked.rest()  # after bake_again, which makes the buffer: the bake makes it again
            baked.ctx.finish()
            start = time.perf_counter()
            baked.bake()
            baked.ctx.finish()
            return time.perf_counter() - start
        finally:
            for diffuse_pass, defines in zip(passes, kept, strict=True):
                diffuse_pass.defines = defines
    return run


def drawing_timer(baked: BakedImages, program: moderngl.Program,
                  drawn: Callable[[DepthImage], Sequence[ObjectGeometry]], colour: bool = True,
                  cleared: bool = True) -> Callable[[], float]:
    """Seconds to draw `drawn(image)` into every image's tile with `program`, twice as the bake
    does (nothing culled, then front faces culled for the back layer), each time after a whole
    clear (unless not `cleared`), colour written (unless not `colour`): the images' own objects
    give what rasterizing the bake's fragments costs without its shading; a small box in every
    image, what its draw calls cost apart from what they draw."""
    atlas = baked.atlas

    def run() -> float:
        atlas.bake_buffer()
        framebuffer = atlas.framebuffer
        baked.ctx.finish()
        start = time.perf_counter()
        framebuffer.use()
        framebuffer.color_mask = atlas.masks(*[(colour,) * 4] * len(atlas.textures))
        for state in (RasterState(), BACK_FACES):
            if cleared:
                framebuffer.viewport = (0, 0, *atlas.size)
                framebuffer.clear(1.0, 1.0, 1.0, 0.0, depth=1.0)
            with raster_state(baked.ctx, state):
                for image in baked.depth_images:
                    framebuffer.viewport = image.tile
                    for target in drawn(image):
                        baked.meshes.draw(program, target, image.camera.view_projection)
        baked.ctx.finish()
        framebuffer.color_mask = atlas.masks(*[(True,) * 4] * len(atlas.textures))
        return time.perf_counter() - start
    return run


def covered_texels(baked: BakedImages) -> int:
    """Texels of the atlas's images that show a surface (colour alpha > 0) after a bake."""
    baked.bake_again()
    baked.bake()
    alpha = np.frombuffer(baked.atlas.color.read(), np.uint8)[3::4]
    return int(np.count_nonzero(alpha))


def shown(image: DepthImage) -> Sequence[ObjectGeometry]:
    return image.targets


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", nargs="?", type=Path, default=ROOT / "scenes" / "lecture_8x9.toml")
    parser.add_argument("--resolution", type=int, default=1024)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    ctx = create_context()
    print(describe(ctx))
    scene = load_scene(args.scene).with_overrides(impostor_resolution=args.resolution)
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        baked = renderer.graph.baked_images
        if baked is None or baked.back_layer is None:
            raise SystemExit(f"{args.scene}: the depth-image method bakes no images here")
        trivial = ctx.program(vertex_shader=TRIVIAL_VERTEX, fragment_shader=TRIVIAL_FRAGMENT)
        small_box = BoxShape((0.1, 0.1, 0.1))
        box = ObjectGeometry(0, SceneObject(name="box", shape=small_box), mesh_for_shape(small_box))
        covered = covered_texels(baked)
        slots = sum(image.camera.width * image.camera.height for image in baked.depth_images)
        frame_times = []
        for _ in range(3):
            renderer.render()
            frame_times.append(renderer.stats.draw_seconds[-1])
        timers = {
            "bake, the renderer's programs": bake_timer(baked),
            "bake, after a frame that baked nothing (depth buffer made again)": bake_timer(baked, rested=True),
            f"bake, without {' and '.join(SPECIALIZATIONS)}": bake_timer(baked, SPECIALIZATIONS),
            "the same fragments, a trivial shader": drawing_timer(baked, trivial, shown),
            "the same fragments, depth alone": drawing_timer(baked, trivial, shown, colour=False),
            "the bake's draw calls, each drawing a 12-triangle box": drawing_timer(baked, trivial, lambda _: [box],
                                                                                    cleared=False),
        }
        medians = rotated_medians(timers, args.rounds)
        frame = 1000.0 * statistics.median(frame_times)
    print(f"{scene.source}: {len(baked.depth_images)} images at {args.resolution}^2, median of {args.rounds} rounds; "
          f"a frame at {scene.render.size[0]}x{scene.render.size[1]}: {frame:.1f} ms; "
          f"{covered / 1e6:.1f} million of the images' {slots / 1e6:.1f} million texels show a surface")
    for name, median in medians.items():
        print(f"  {name:58s} {median:8.1f} ms  ({median / frame:5.1f} frames)")


if __name__ == "__main__":
    main()
