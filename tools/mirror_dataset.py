"""A small mirror-segmentation dataset, end to end (docs/batch.md).

    python tools/mirror_dataset.py make dataset --seed 7 --scenes 20 --views 10 --size 160x120
    depthimpostor batch dataset/jobs.toml             # every frame, its AOVs, a manifest; resumable
    python tools/mirror_dataset.py sheet dataset docs/batch_samples.png --count 4

`make` writes random scenes from the seed (a checker floor; a mirror sphere, a standing planar mirror
or both; three to six diffuse objects of random shapes, colours, checkers and textures around them;
a random light) and a batch file of random cameras that see the mirrors. Each frame is a colour
PNG and an EXR of AOVs beside it: the mirror mask is `reflector_id >= 0`, and the per-pixel
`reflected_object_id` (what the depth images found), `truth_reflected_object_id` (what the exact
reflected ray hits), `object_id`, `depth` and `error` come with it (aov.py). `sheet` lays out a
few frames as picture, mirror mask and reflected objects (the truth's), for the docs.
"""

from __future__ import annotations

import argparse
import colorsys
import math
import random
import shutil
import sys
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from depthimpostor.aov import read_aovs  # noqa: E402

SHAPES = ("box", "sphere", "cylinder", "torus", "torus_knot")
AOVS = ["depth", "object_id", "reflector_id", "reflected_object_id", "truth_reflected_object_id", "error"]
TEXTURE = ROOT / "scenes" / "textures" / "checker_f.png"


def _vector(values: list[float] | tuple[float, ...]) -> str:
    return "[" + ", ".join(f"{v:.4g}" for v in values) + "]"


def _colour(rng: random.Random) -> list[float]:
    return list(colorsys.hsv_to_rgb(rng.random(), rng.uniform(0.4, 0.9), rng.uniform(0.5, 0.95)))


def _shape(rng: random.Random, kind: str) -> tuple[str, float]:
    """A shape's TOML and the height of its centre above the floor (each stands on it)."""
    s = rng.uniform(0.25, 0.45)
    if kind == "box":
        return f'{{ type = "box", size = {_vector([2 * s, 2 * s * rng.uniform(0.7, 1.6), 2 * s])} }}', s * 1.6
    if kind == "sphere":
        return f'{{ type = "sphere", radius = {s:.3g} }}', s
    if kind == "cylinder":
        height = rng.uniform(0.6, 1.4)
        return f'{{ type = "cylinder", radius = {s * 0.8:.3g}, height = {height:.3g} }}', height / 2
    if kind == "torus":
        return f'{{ type = "torus", major = {s:.3g}, minor = {s * 0.35:.3g} }}', s * 1.4
    return f'{{ type = "torus_knot", p = 2, q = 3, radius = {s:.3g}, tube = {s * 0.25:.3g} }}', s * 1.7


def _material(rng: random.Random, kind: str) -> str:
    roll = rng.random()
    if roll < 0.25 and kind != "torus_knot":  # textured content: where a depth image shows the wrong part
        return f'{{ type = "diffuse", color = {_vector(_colour(rng))}, texture = "{TEXTURE.as_posix()}" }}'
    if roll < 0.45:
        return (f'{{ type = "checker", color_a = {_vector(_colour(rng))}, color_b = {_vector(_colour(rng))}, '
                f'scale = {rng.uniform(0.15, 0.4):.3g} }}')
    return f'{{ type = "diffuse", color = {_vector(_colour(rng))} }}'


def scene_text(rng: random.Random) -> tuple[str, list[tuple[float, float, float]]]:
    """A random scene's TOML, and the mirrors' centres (the cameras look at them)."""
    kind = rng.choice(["sphere", "plane", "both"])
    light = [rng.uniform(-0.8, 0.8), -1.0, rng.uniform(-0.8, 0.8)]
    lines = ["[render]", "impostor_resolution = 256", "ambient = 0.3", "",
             "[environment]", 'type = "gradient"', f"zenith = {_vector(_colour(rng))}", "horizon = [0.9, 0.9, 0.92]",
             "ground = [0.3, 0.28, 0.25]", "", "[[lights]]", 'type = "directional"', f"direction = {_vector(light)}", "",
             "[[objects]]", 'name = "floor"', 'shape = { type = "plane", size = [20.0, 20.0] }',
             f'material = {{ type = "checker", color_a = {_vector(_colour(rng))}, color_b = [0.3, 0.3, 0.3], scale = 1.0 }}']
    mirrors: list[tuple[float, float, float]] = []
    if kind in ("sphere", "both"):
        radius = rng.uniform(0.7, 1.1)
        centre = (0.0 if kind == "sphere" else 1.2, radius, 0.0)
        mirrors.append(centre)
        lines += ["", "[[objects]]", 'name = "mirror_sphere"', f'shape = {{ type = "sphere", radius = {radius:.3g} }}',
                  'material = { type = "mirror", tint = [0.95, 0.95, 0.95] }', f"position = {_vector(centre)}"]
    if kind in ("plane", "both"):
        centre = (-0.8 if kind == "both" else 0.0, 1.3, -1.6)
        mirrors.append(centre)
        lines += ["", "[[objects]]", 'name = "mirror_plane"',
                  f'shape = {{ type = "plane", size = [{rng.uniform(2.5, 4.5):.3g}, 2.4] }}',
                  'material = { type = "mirror", tint = [0.95, 0.95, 0.95] }', f"position = {_vector(centre)}",
                  "rotation = [90.0, 0.0, 0.0]"]
    placed: list[tuple[float, float]] = []
    for k in range(rng.randint(3, 6)):
        kind_k = rng.choice(SHAPES)
        shape, height = _shape(rng, kind_k)
        for _ in range(100):  # a free place in front of the mirrors, off them and the others
            x, z = rng.uniform(-2.8, 2.8), rng.uniform(-0.9, 2.6)
            clear = all(math.hypot(x - m[0], z - m[2]) > m[1] + 0.9 for m in mirrors if m[2] == 0.0)
            if clear and all(math.hypot(x - px, z - pz) > 1.0 for px, pz in placed):
                break
        placed.append((x, z))
        lines += ["", "[[objects]]", f'name = "{kind_k}_{k}"', f"shape = {shape}", f"material = {_material(rng, kind_k)}",
                  f"position = {_vector([x, height, z])}", f"rotation = {_vector([0.0, rng.uniform(0, 360), 0.0])}"]
    return "\n".join(lines) + "\n", mirrors


def _camera(rng: random.Random, mirrors: list[tuple[float, float, float]]) -> str:
    target = rng.choice(mirrors)
    angle = math.radians(rng.uniform(-65, 65))  # in front of the mirrors (a plane reflects towards +Z)
    distance = rng.uniform(4.0, 6.5)
    eye = (target[0] + distance * math.sin(angle), rng.uniform(0.8, 3.0), target[2] + distance * math.cos(angle))
    look = (target[0] + rng.uniform(-0.4, 0.4), target[1] * rng.uniform(0.6, 1.0), target[2])
    return f"{{ eye = {_vector(eye)}, target = {_vector(look)}, fov_y = {rng.uniform(40, 55):.3g} }}"


def make(folder: Path, seed: int, scenes: int, views: int, size: tuple[int, int]) -> Path:
    rng = random.Random(seed)
    (folder / "scenes").mkdir(parents=True, exist_ok=True)
    jobs = [f"# {scenes} random scenes x {views} cameras from seed {seed} (tools/mirror_dataset.py)",
            'manifest = "manifest.jsonl"', "", "[defaults]", f"size = [{size[0]}, {size[1]}]",
            f"aov = {AOVS!r}".replace("'", '"'), 'output = "images/{job}/{frame:02d}.png"']
    for index in range(scenes):
        text, mirrors = scene_text(rng)
        name = f"scene_{index:03d}"
        (folder / "scenes" / f"{name}.toml").write_text(text)
        cameras = ",\n    ".join(_camera(rng, mirrors) for _ in range(views))
        jobs += ["", "[[jobs]]", f'name = "{name}"', f'scene = "scenes/{name}.toml"', f"cameras = [\n    {cameras},\n]"]
    path = folder / "jobs.toml"
    path.write_text("\n".join(jobs) + "\n")
    return path


def _palette(ids: np.ndarray) -> np.ndarray:
    """Object ids as colours (the environment and nothing: black)."""
    rng = np.random.default_rng(3)
    colours = (rng.uniform(0.25, 1.0, (256, 3)) * 255).astype(np.uint8)
    image = colours[np.clip(ids.astype(np.int64), 0, 255)]
    image[ids < 0] = 0
    return image


def sheet(folder: Path, output: Path, count: int) -> Path:
    """`count` frames (spread over the dataset) as rows of picture, mirror mask, truth's reflected objects."""
    frames = sorted((folder / "images").rglob("*.png"))
    chosen = [frames[k * len(frames) // count] for k in range(count)]
    rows = []
    for path in chosen:
        aovs = read_aovs(path.with_name(path.stem + ".aov.exr"))
        mask = aovs["reflector_id"] >= 0
        picture = np.asarray(Image.open(path).convert("RGB"))
        rows.append(np.concatenate([picture, np.repeat((mask * 255).astype(np.uint8)[..., None], 3, axis=2),
                                    _palette(np.where(mask, aovs["truth_reflected_object_id"], -1))], axis=1))
    picture = Image.fromarray(np.concatenate(rows, axis=0))
    draw = ImageDraw.Draw(picture)
    width = rows[0].shape[1] // 3
    for k, label in enumerate(["colour", "mirror mask", "reflected object (truth)"]):
        box = draw.textbbox((k * width + 4, 2), label)
        draw.rectangle((box[0] - 2, box[1] - 1, box[2] + 2, box[3] + 1), fill=(0, 0, 0))
        draw.text((k * width + 4, 2), label, fill=(255, 255, 255))
    output.parent.mkdir(parents=True, exist_ok=True)
    picture.save(output, optimize=True)
    return output


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    commands = parser.add_subparsers(dest="command", required=True)
    made = commands.add_parser("make", help="random scenes and the batch file of their cameras")
    made.add_argument("folder", type=Path)
    made.add_argument("--seed", type=int, default=7)
    made.add_argument("--scenes", type=int, default=20)
    made.add_argument("--views", type=int, default=10)
    made.add_argument("--size", default="160x120")
    made.add_argument("--clean", action="store_true", help="remove the folder's images and manifest first")
    shown = commands.add_parser("sheet", help="a picture of a few frames: colour, mask, reflected objects")
    shown.add_argument("folder", type=Path)
    shown.add_argument("output", type=Path)
    shown.add_argument("--count", type=int, default=4)
    args = parser.parse_args()
    if args.command == "make":
        if args.clean:
            shutil.rmtree(args.folder / "images", ignore_errors=True)
            (args.folder / "manifest.jsonl").unlink(missing_ok=True)
        width, height = (int(v) for v in args.size.split("x"))
        print(make(args.folder, args.seed, args.scenes, args.views, (width, height)))
    else:
        print(sheet(args.folder, args.output, args.count))


if __name__ == "__main__":
    main()
