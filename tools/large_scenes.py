"""The large scenes of issue 32's first done-when line, each beside two mirrors (a wall mirror and a
mirror sphere), compared against the truth with every method that accepts a sphere mirror:

- the parts file of tools/make_many_parts.py (1,000 textured nodes of four shared meshes, its own
  wall mirror), with a mirror sphere above its rows;
- 64 distinct image textures (tests/test_many_textures.py's 60 textured boxes, floor and walls),
  with a mirror sphere beside its wall mirror;
- a glTF model given with --engine (2CylinderEngine.glb of glTF-Sample-Models: 115 objects; not
  in the repository), scaled to fit between a wall mirror and a mirror sphere.

    python3 tools/large_scenes.py /tmp/large -o results/llvmpipe/large_scenes.md --engine 2CylinderEngine.glb

Writes the scene files into the folder, then one row per scene and method: `compare`'s figures
(wrong object, wrong surface, colour RMSE over the mirror pixels) and the frame it drew.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from PIL import Image

from depthimpostor.constants import Method
from depthimpostor.errors import DepthImpostorError
from depthimpostor.gpu.context import create_context
from depthimpostor.methods.registry import METHODS
from depthimpostor.oracles.compare import compare
from depthimpostor.renderer import Renderer
from depthimpostor.scene import load_scene
from depthimpostor.world import World

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tools"))
sys.path.insert(0, str(ROOT / "tests"))
from make_many_parts import build  # noqa: E402
from test_many_textures import sixty_four_textures  # type: ignore[import-not-found]  # noqa: E402

RENDER = """
[render]
size = [640, 360]
impostor_resolution = 128
ambient = 0.35
"""
LIGHT = """
[[lights]]
type = "directional"
direction = [-0.4, -1.0, -0.5]
"""


def mirror(name: str, shape: str, position: tuple[float, ...], rotation: tuple[float, ...] = (0.0, 0.0, 0.0)) -> str:
    return (f'\n[[objects]]\nname = "{name}"\nshape = {shape}\nmaterial = {{ type = "mirror" }}\n'
            f"position = {list(position)}\nrotation = {list(rotation)}\n")


def parts_scene(folder: Path) -> Path:
    """1,000 parts before their wall mirror (15 m wide, at z = 0), a mirror ball over the front rows."""
    build(1000, 0).write(folder / "parts_1000.glb")
    text = (RENDER + '\n[camera]\neye = [0.0, 1.8, 10.75]\ntarget = [0.0, 0.925, 0.75]\nfov_y = 50.0\n'
            + '\n[[objects]]\nname = "parts"\nshape = { type = "gltf", path = "parts_1000.glb" }\n'
            + mirror("mirror ball", '{ type = "sphere", radius = 0.6 }', (-2.5, 2.4, 3.0)))
    (folder / "parts_1000.toml").write_text(text, encoding="utf-8")
    return folder / "parts_1000.toml"


def textures_scene(folder: Path) -> Path:
    """The 64 textures' scene with a mirror ball over its boxes."""
    sixty_four_textures(folder)
    path = folder / "many.toml"
    text = path.read_text(encoding="utf-8")
    text += mirror("mirror ball", '{ type = "sphere", radius = 0.45 }', (1.6, 1.5, -1.2))
    path.write_text(text, encoding="utf-8")
    return path


def engine_scene(folder: Path, model: Path) -> Path:
    """The model scaled to 3 m across, standing on a floor between a wall mirror and a mirror ball."""
    world = World(load_scene(model))
    points = np.concatenate([g.world_mesh.positions for g in world.geometry])
    low, high = points.min(axis=0), points.max(axis=0)
    scale = 3.0 / float((high - low).max())
    centre = 0.5 * (low + high)
    offset = [-scale * float(centre[0]), -scale * float(low[1]), -scale * float(centre[2])]
    text = (RENDER + '\n[camera]\neye = [1.5, 2.4, 6.0]\ntarget = [0.0, 0.8, 0.0]\nfov_y = 50.0\n' + LIGHT
            + '\n[[objects]]\nname = "floor"\nshape = { type = "plane", size = [14.0, 14.0] }\n'
            + 'material = { type = "checker", color_a = [0.8, 0.8, 0.8], color_b = [0.3, 0.3, 0.3], scale = 0.5 }\n'
            + f'\n[[objects]]\nname = "engine"\nshape = {{ type = "gltf", path = "{model.resolve()}" }}\n'
            + f"position = {offset}\nscale = [{scale}, {scale}, {scale}]\n"
            + mirror("wall mirror", '{ type = "plane", size = [7.0, 3.0] }', (0.0, 1.5, -2.4), (90.0, 0.0, 0.0))
            + mirror("mirror ball", '{ type = "sphere", radius = 0.6 }', (2.4, 1.0, 0.6)))
    (folder / "engine.toml").write_text(text, encoding="utf-8")
    return folder / "engine.toml"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="where the scene files are written")
    parser.add_argument("-o", "--output", type=Path, help="the markdown table to write")
    parser.add_argument("--engine", type=Path, help="a glTF model to place between the mirrors (2CylinderEngine.glb)")
    parser.add_argument("--methods", default="all", help="comma-separated, or all")
    args = parser.parse_args()
    args.folder.mkdir(parents=True, exist_ok=True)
    scenes = [parts_scene(args.folder), textures_scene(args.folder)]
    if args.engine is not None:
        scenes.append(engine_scene(args.folder, args.engine))
    methods = tuple(METHODS) if args.methods == "all" else tuple(Method.from_option(m) for m in args.methods.split(","))
    ctx = create_context()
    lines = ["| scene | objects | method | wrong object % | wrong surface % | RMSE | mirror pixels |", "|---|---|---|---|---|---|---|"]
    for path in scenes:
        scene = load_scene(path)
        for method in methods:
            try:
                with Renderer(ctx, scene, method=method, reflection_data=True) as renderer:
                    renderer.render()
                    figures = compare(renderer).figures
                    Image.fromarray(renderer.read_color()).save(args.folder / f"{path.stem}-{method.option}.png")
            except DepthImpostorError as error:
                line = f"| {path.name} | {len(scene.objects)} | {method.option} | refused: {str(error).splitlines()[0]} | | | |"
            else:
                line = (f"| {path.name} | {len(scene.objects)} | {method.option} | {100 * figures.wrong_object_share:.2f} | "
                        f"{100 * figures.wrong_surface_share:.2f} | {figures.color_rmse:.4f} | {figures.mirror_pixels} |")
            print(line, flush=True)
            lines.append(line)
    if args.output is not None:
        args.output.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
