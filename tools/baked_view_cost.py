"""What baking a reflected surface's view-dependent shading from the mirror's centre costs (issue 33,
item 2: "or say, with a figure, what baking it costs in error").

The baking methods' images (depth, hybrid's answers before they are made exact, billboards, cube
maps) shade a glTF metallic-roughness surface when they are baked, as seen from the image's
camera: the mirror's centre (methods/atlas.mirror_centre). The reflected ray sees it from the
mirror point it leaves, so the specular part (the GGX highlights, the sky's prefiltered
reflection, the Fresnel mix) differs by the angle between those two views. The traced methods
(`raytrace`, `hybrid`'s exact hits) shade for the ray itself.

To tell that error apart from the stand-in's geometry, the truth is traced twice for the same rays:
as always (each hit seen along its ray), and with every reflected metallic-roughness hit shaded as
seen from its mirror's centre (`trace_truth(..., viewed_from_centres=True)`: the images' view,
with the exact geometry). Per scene, over the mirror pixels:

- the two truths against each other: what baking from the centre costs whatever the stand-in
  (colour RMSE, and the share of the pixels showing an object whose colour moves by more than
  compare.WRONG_SURFACE_COLOR_ERROR, the wrong-surface threshold);
- each method against either truth: its wrong-surface share and RMSE against the truth, and what
  they would be if baking from the centre were right (the geometry's share).

    PYTHONPATH=$PWD python3 tools/baked_view_cost.py scenes/showcase.toml scenes/blend_near_mirror.toml \\
        scenes/hdr_sky.toml --metals --methods depth,billboard,cubemap,raytrace -o results/llvmpipe/baked_view_cost.md

`--metals`: the scenes whose reflected objects are not metallic-roughness already are measured
a second time with those objects made so, alternately polished gold and glossy plastic (their
textures kept), and a point light added for highlights: the case where baking from the centre
shows (a highlight's place depends on the view; a diffuse surface's shading does not).
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
from pathlib import Path

import moderngl
import numpy as np

from depthimpostor.constants import Method
from depthimpostor.gpu.context import create_context
from depthimpostor.oracles.compare import WRONG_SURFACE_COLOR_ERROR, Comparison, colour_error, compare, trace_truth
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene, load_scene
from depthimpostor.scene.model import DiffuseMaterial, Light, MetallicRoughnessMaterial, PlaneShape

GOLD = MetallicRoughnessMaterial((1.0, 0.77, 0.34), None, metallic=1.0, roughness=0.2)
PLASTIC = MetallicRoughnessMaterial((0.2, 0.5, 0.9), None, metallic=0.0, roughness=0.15)


def with_metals(scene: Scene) -> Scene | None:
    """The scene with its diffuse reflected objects made gold and plastic by turns (a diffuse
    texture kept as the base colour's), and a point light above the camera; None when it has none."""
    objects, changed = [], 0
    for obj in scene.objects:
        if not obj.is_reflector and isinstance(obj.material, DiffuseMaterial) and not isinstance(obj.shape, PlaneShape):
            chosen = GOLD if changed % 2 == 0 else PLASTIC
            obj = dataclasses.replace(obj, material=dataclasses.replace(chosen, texture=obj.material.texture))
            changed += 1
        objects.append(obj)
    if not changed:
        return None
    eye = scene.camera.eye
    light = Light("point", position=(eye[0], eye[1] + 2.0, eye[2]), intensity=1.5)
    return dataclasses.replace(scene, objects=tuple(objects), lights=(*scene.lights, light))

ROOT = Path(__file__).resolve().parent.parent


def measure(ctx: moderngl.Context, name: str, scene: Scene, methods: list[Method]) -> list[str]:
    """The markdown rows of one scene: the two truths against each other, then each method."""
    rows: list[str] = []
    truth = centred = None
    for method in methods:
        with Renderer(ctx, scene, method=method, reflection_data=True) as renderer:
            renderer.render()
            against_ray = compare(renderer, truth)
            truth = against_ray.truth_frame
            if centred is None:
                centred = trace_truth(renderer, renderer.read_reflection_data(), viewed_from_centres=True)
                reflected = [g.index for g in renderer.world.reflected_objects]
                rows.append(_truths_row(name, against_ray, centred.color, reflected))
            against_centre = compare(renderer, centred)
            rows.append(f"| {name} | `{method.option}` | {_share(against_ray)} | {_share(against_centre)} | "
                        f"{against_ray.figures.color_rmse:.4f} | {against_centre.figures.color_rmse:.4f} |")
    return rows


def _share(comparison: Comparison) -> str:
    return f"{100 * comparison.figures.wrong_surface_share:.2f} %"


def _truths_row(name: str, comparison: Comparison, centred_color: np.ndarray, reflected: list[int]) -> str:
    """The truth seen along the rays against the truth seen from the mirrors' centres, over the
    mirror pixels, and over those that show a reflected object (`reflected`: their ids; as
    compare counts the wrong surface)."""
    mask = comparison.mirror_mask
    error = colour_error(centred_color, comparison.truth)
    rmse = float(np.sqrt((error[mask] ** 2).mean())) if mask.any() else 0.0
    shows_object = mask & np.isin(comparison.truth_frame.object_id, reflected)
    moved = shows_object & (np.abs(error).max(axis=2) > WRONG_SURFACE_COLOR_ERROR)
    share = moved.sum() / max(int(shows_object.sum()), 1)
    return (f"| {name} | the truth seen from the centres | {100 * share:.2f} % of {int(shows_object.sum()):,} | – | "
            f"{rmse:.4f} | – |")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", type=Path, nargs="+")
    parser.add_argument("--methods", default="depth,billboard,raytrace")
    parser.add_argument("--size", default="960x540")
    parser.add_argument("--metals", action="store_true", help="each scene again with its objects gold and plastic")
    parser.add_argument("-o", "--output", type=Path, help="write the table here (markdown), else print it")
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    methods = [Method.from_option(name) for name in args.methods.split(",")]
    lines = [
        "| scene | against | wrong surface, against the truth | ... against the truth seen from the centres | "
        "colour RMSE, against the truth | ... against the truth seen from the centres |",
        "|---|---|---:|---:|---:|---:|",
    ]
    ctx = create_context()
    for path in args.scenes:
        # One sample a pixel: the figures compare one set of rays (an anti-aliased frame's truth is
        # traced per sub-frame, which this tool does not need to tell the two views apart).
        scene = load_scene(path).with_overrides(size=(width, height), samples=1)
        lines += measure(ctx, path.name, scene, methods)
        metals = with_metals(scene) if args.metals else None
        if metals is not None:
            lines += measure(ctx, f"{path.name}, gold and plastic", metals, methods)
    table = "\n".join(lines)
    if args.output is None:
        print(table)
        return 0
    stamp = datetime.date.today().isoformat()
    args.output.write_text(
        "# What baking view-dependent shading from the mirror's centre costs (tools/baked_view_cost.py)\n\n"
        f"{stamp}, {width}x{height}, one sample a pixel; the command: `python3 tools/baked_view_cost.py "
        f"{' '.join(str(p) for p in args.scenes)}{' --metals' * args.metals} --methods {args.methods} --size {args.size}`.\n\n"
        f"{table}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
