"""Glossy mirrors against the GGX truth (issue 25, item 3): each scene's mirrors set to each
roughness in turn (Scene.with_roughness), rendered by the depth-image and cube-map methods and
compared with the Embree truth that averages GGX_SAMPLES importance-sampled rays per pixel
(oracles/ggx.py). Writes results/llvmpipe/glossy.md (the table) and docs/glossy.png (the picture).

    PYTHONPATH=$PWD DEPTHIMPOSTOR_MODEL_PATH=/work/shared/data/models python3 tools/glossy_table.py

The frames are smaller than the scenes' own (SIZE): the truth traces 64 rays per mirror pixel on
the CPU. A scene whose model file is missing (the bunny without the shared models) is left out,
and the table says so.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from PIL import Image

from depthimpostor.constants import Method
from depthimpostor.errors import SceneError
from depthimpostor.gpu.context import create_context
from depthimpostor.oracles.compare import Comparison, compare, side_by_side
from depthimpostor.oracles.ggx import GGX_SAMPLES
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene, load_scene

ROOT = Path(__file__).resolve().parent.parent
SCENES = ("default.toml", "bunny.toml")
ROUGHNESSES = (0.0, 0.05, 0.15, 0.3)
#: The methods compared; `raytrace` (one exact ray, its floor and sky prefiltered by the cone, its
#: objects sharp) shows what a method that does not prefilter the objects gets.
METHODS = (Method.DEPTH, Method.CUBEMAP, Method.CUBEMAP_PARALLAX, Method.SSR, Method.RAYTRACE)
SIZE = (480, 270)
#: The roughness of the picture (docs/glossy.png).
PICTURE_ROUGHNESS = 0.15


def comparisons(ctx: object, scene: Scene) -> dict[Method, Comparison]:
    """Every method's comparison of `scene` with the truth (traced once: the same rays)."""
    results: dict[Method, Comparison] = {}
    truth = None
    for method in METHODS:
        with Renderer(ctx, scene, method=method, reflection_data=True) as renderer:  # type: ignore[arg-type]
            renderer.render()
            results[method] = compare(renderer, truth)
            truth = results[method].truth_frame
    return results


def table(name: str, rows: list[tuple[float, dict[Method, Comparison]]]) -> list[str]:
    heads = " | ".join(f"`{m.option}` RMSE" for m in METHODS)
    lines = [f"### {name}", "", f"| roughness | {heads} | most accurate of depth, cube maps and SSR |",
             "|---:|" + "---:|" * (len(METHODS) + 1)]
    for roughness, results in rows:
        errors = {m: results[m].figures.color_rmse for m in METHODS}
        best = min(METHODS[:4], key=lambda m: errors[m])
        cells = " | ".join(f"{errors[m]:.4f}" for m in METHODS)
        lines.append(f"| {roughness:.2f} | {cells} | `{best.option}` |")
    return lines + [""]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "llvmpipe" / "glossy.md")
    parser.add_argument("--picture", type=Path, default=ROOT / "docs" / "glossy.png")
    args = parser.parse_args()
    ctx = create_context()
    lines = ["# Glossy mirrors against the GGX truth", "",
             f"Written by `tools/glossy_table.py`: each scene's mirrors set to each roughness, frames of "
             f"{SIZE[0]}x{SIZE[1]} at the scene's impostor resolution, colour RMSE (linear, over the mirror "
             f"pixels) against the Embree truth averaging {GGX_SAMPLES} GGX rays per pixel "
             "(oracles/ggx.py). `raytrace` traces one exact ray, with the floor and sky prefiltered by the "
             "cone and its objects sharp. `ssr` reads the frame's colour copy prefiltered over the cone's "
             "footprint (its mips), and misses what the eye does not see.", ""]
    pictures = []
    for scene_name in SCENES:
        try:
            base = load_scene(ROOT / "scenes" / scene_name).with_overrides(size=SIZE)
        except SceneError as error:
            lines += [f"### {scene_name}", "", f"left out: {error}", ""]
            continue
        rows = []
        for roughness in ROUGHNESSES:
            results = comparisons(ctx, base.with_roughness(roughness))
            rows.append((roughness, results))
            print(scene_name, roughness, {m.option: round(c.figures.color_rmse, 4) for m, c in results.items()},
                  flush=True)
            if roughness == PICTURE_ROUGHNESS:
                pictures.append(side_by_side({m.option: results[m] for m in METHODS[:2]}))
        lines += table(scene_name, rows)
    args.out.write_text("\n".join(lines))
    if pictures:
        width = max(p.shape[1] for p in pictures)
        sheet = np.full((sum(p.shape[0] for p in pictures), width, 3), 255, np.uint8)
        top = 0
        for picture in pictures:
            sheet[top:top + picture.shape[0], :picture.shape[1]] = picture
            top += picture.shape[0]
        Image.fromarray(sheet).save(args.picture)
    print(f"wrote {args.out}" + (f" and {args.picture}" if pictures else ""))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
