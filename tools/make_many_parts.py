"""Write a glTF 2.0 file (.glb) of many parts for the scene-size benchmark (issue 32, "Scenes of any
size"): N nodes (default 1,000) of a few shared, textured meshes, standing on a textured floor in
front of a wall mirror, with a camera and a light, all from procedural data (nothing downloaded):

    python3 tools/make_many_parts.py /tmp/parts_1000.glb                 # 1,000 parts, seed 0
    python3 tools/make_many_parts.py /tmp/parts_5000.glb --count 5000 --seed 3
    python3 -m depthimpostor bench /tmp/parts_1000.glb --methods depth --frames 10 -o /tmp/bench

What a large authored file has, on purpose: meshes shared by many nodes ("crate", "barrel", "ball",
"ring"), a few materials (three textured, two plain), a mesh of two materials (the barrel's wood
side and metal ends: two objects per barrel node), nested transforms (the parts are the children of
"Row" nodes, each turned and moved; some parts scaled), and a name on every node, mesh and
material, so that a refusal or report names them (Scene.object_label). The same count and seed
write the same bytes. The output is not committed: write it where the benchmark reads it.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from depthimpostor import meshes, textured_meshes

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))
from gltf_files import GltfWriter, quaternion  # noqa: E402

TEXTURE_SIZE = 64  # texels a side: small files, and textures that still show a wrong UV
SPACING = 0.6  # between neighbouring parts, in metres: a part is at most 0.4 across
PER_ROW = 25  # parts per "Row" node


def _rgba(rgb: np.ndarray) -> np.ndarray:
    return np.concatenate([np.clip(rgb, 0, 255), np.full(rgb.shape[:2] + (1,), 255.0)], axis=-1).astype(np.uint8)


def planks() -> np.ndarray:
    """Warm stripes along u with dark seams: wood."""
    v, u = np.mgrid[0:TEXTURE_SIZE, 0:TEXTURE_SIZE] / TEXTURE_SIZE
    tone = 0.8 + 0.2 * np.sin(2 * np.pi * (v * 12 + 0.3 * np.sin(2 * np.pi * u)))
    rgb = np.stack([150 * tone, 95 * tone, 55 * tone], axis=-1)
    rgb[(v * 4 % 1.0) < 0.06] = (60, 38, 22)
    return _rgba(rgb)


def checker_arrow() -> np.ndarray:
    """A yellow and red checker with a white arrow pointing to the image's top: a turned or
    mirrored mapping shows."""
    v, u = np.mgrid[0:TEXTURE_SIZE, 0:TEXTURE_SIZE] / TEXTURE_SIZE
    rgb = np.where((((np.floor(u * 4) + np.floor(v * 4)) % 2) == 0)[..., None], (230, 190, 40), (190, 40, 40))
    rgb = rgb.astype(np.float64)
    stem = (np.abs(u - 0.5) < 0.08) & (v > 0.4) & (v < 0.85)
    head = (v > 0.15) & (v <= 0.4) & (np.abs(u - 0.5) < (v - 0.15) * 1.2)
    rgb[stem | head] = (250, 250, 250)
    return _rgba(rgb)


def stripes() -> np.ndarray:
    """Blue and white bands across v, with a green band across u: a ball's latitude and longitude."""
    v, u = np.mgrid[0:TEXTURE_SIZE, 0:TEXTURE_SIZE] / TEXTURE_SIZE
    rgb = np.where(((np.floor(v * 8) % 2) == 0)[..., None], (40, 80, 200), (235, 235, 235)).astype(np.float64)
    rgb[np.abs(u - 0.25) < 0.04] = (40, 170, 70)
    return _rgba(rgb)


def tiles() -> np.ndarray:
    """Grey floor tiles with light grout."""
    v, u = np.mgrid[0:TEXTURE_SIZE, 0:TEXTURE_SIZE] / TEXTURE_SIZE
    rgb = np.where(((np.floor(v * 2) + np.floor(u * 2)) % 2 == 0)[..., None], (120, 120, 125), (160, 160, 150))
    rgb = rgb.astype(np.float64)
    rgb[((u * 2 % 1.0) < 0.04) | ((v * 2 % 1.0) < 0.04)] = (225, 220, 210)
    return _rgba(rgb)


def _primitive(w: GltfWriter, mesh: meshes.Mesh, material: int, faces: np.ndarray | None = None) -> dict[str, object]:
    indices = mesh.indices if faces is None else faces
    return w.primitive(mesh.positions, indices, mesh.normals, mesh.uvs, material=material)


def _rectangle(width: float, depth: float, repeats: float) -> tuple[np.ndarray, ...]:
    """A width x depth rectangle in XZ facing +Y, its UVs running the image `repeats` times."""
    x, z = width / 2, depth / 2
    positions = np.array([[-x, 0, -z], [x, 0, -z], [x, 0, z], [-x, 0, z]], np.float32)
    uvs = np.array([[0, 0], [repeats, 0], [repeats, repeats], [0, repeats]], np.float32)
    return positions, np.array([[0, 2, 1], [0, 3, 2]]), np.tile((0.0, 1.0, 0.0), (4, 1)), uvs


def build(count: int, seed: int) -> GltfWriter:
    """The file: `count` part nodes under ceil(count / PER_ROW) "Row" nodes, a floor, a mirror,
    a camera and a light; placements drawn from `seed`."""
    rng = np.random.default_rng(seed)
    w = GltfWriter()
    wood = w.material("Wood", pbrMetallicRoughness={"baseColorTexture": {"index": w.texture(planks())},
                                                   "metallicFactor": 0.0, "roughnessFactor": 0.7})
    crate_m = w.material("Crate", pbrMetallicRoughness={"baseColorTexture": {"index": w.texture(checker_arrow())},
                                                       "metallicFactor": 0.0, "roughnessFactor": 0.6})
    ball_m = w.material("Beach ball", pbrMetallicRoughness={"baseColorTexture": {"index": w.texture(stripes())},
                                                           "metallicFactor": 0.0, "roughnessFactor": 0.5})
    metal = w.material("Dull metal", (0.55, 0.55, 0.6), metallic=0.6, roughness=0.5)
    paint = w.material("Green paint", (0.15, 0.6, 0.25))
    floor_m = w.material("Floor tiles", pbrMetallicRoughness={"baseColorTexture": {"index": w.texture(tiles())},
                                                             "metallicFactor": 0.0, "roughnessFactor": 0.8})
    mirror_m = w.material("Mirror", (0.95, 0.95, 0.95), metallic=1.0, roughness=0.0)

    crate = w.mesh(_primitive(w, meshes.box((0.3, 0.3, 0.3)), crate_m), name="crate")
    barrel_mesh = textured_meshes.cylinder(0.14, 0.36, 24)
    ends = np.abs(barrel_mesh.normals[barrel_mesh.indices, 1]).min(axis=1) > 0.5  # the caps' triangles
    barrel = w.mesh(_primitive(w, barrel_mesh, wood, barrel_mesh.indices[~ends]),
                    _primitive(w, barrel_mesh, metal, barrel_mesh.indices[ends]), name="barrel")
    ball = w.mesh(_primitive(w, textured_meshes.sphere(0.16, 24, 12), ball_m), name="ball")
    ring = w.mesh(_primitive(w, textured_meshes.torus(0.13, 0.045, 24, 8), paint), name="ring")
    kinds = (("Crate", crate, 0.15), ("Barrel", barrel, 0.18), ("Ball", ball, 0.16), ("Ring", ring, 0.045))

    rows = math.ceil(count / PER_ROW)
    width, depth = PER_ROW * SPACING, rows * SPACING
    for r in range(rows):
        # Each row turned a little about +Y (so that its children's world matrices are products)
        # and set back from the mirror, which stands at z = 0 facing +Z.
        turn = float(rng.uniform(-4.0, 4.0))
        children = []
        for k in range(min(PER_ROW, count - r * PER_ROW)):
            name, mesh, half_height = kinds[int(rng.integers(len(kinds)))]
            scale = float(rng.choice((1.0, 1.0, 1.0, 0.7, 1.3)))
            spin = quaternion((0, 1, 0), float(rng.uniform(0.0, 360.0)))
            x = (k - (PER_ROW - 1) / 2) * SPACING + float(rng.uniform(-0.1, 0.1))
            children.append(w.node(root=False, name=f"{name}.{r * PER_ROW + k:05d}", mesh=mesh, rotation=spin,
                                   translation=[x, half_height * scale, float(rng.uniform(-0.1, 0.1))],
                                   scale=[scale] * 3))
        w.node(name=f"Row {r:03d}", children=children, translation=[0.0, 0.0, 1.0 + (r + 0.5) * SPACING],
               rotation=quaternion((0, 1, 0), turn))

    p, f, n, uv = _rectangle(width + 4.0, depth + 6.0, (width + 4.0) / 2.0)
    w.node(name="Floor", mesh=w.mesh(w.primitive(p, f, n, uv, material=floor_m), name="floor"),
           translation=[0.0, 0.0, (depth + 2.0) / 2.0])
    p, f, n, _ = _rectangle(width, 2.0, 1.0)
    w.node(name="Mirror", mesh=w.mesh(w.primitive(p, f, n, material=mirror_m), name="mirror"),
           translation=[0.0, 1.05, 0.0], rotation=quaternion((1, 0, 0), 90))
    # The camera among the rows, far enough from the mirror to see all its width at 16:9 (a
    # horizontal half-angle of about 39 degrees), looking a little down: the rows between it and
    # the mirror are seen directly, and the mirror shows those behind it.
    camera = w._append("cameras", {"type": "perspective", "perspective": {"yfov": math.radians(50), "znear": 0.05}})
    w.node(name="Camera", camera=camera, translation=[0.0, 1.8, 0.65 * width + 1.0], rotation=quaternion((1, 0, 0), -5))
    sun = w.light(type="directional", color=[1.0, 0.95, 0.85], intensity=1.0)
    w.node(name="Sun", rotation=quaternion((1, -0.6, 0.3), -60), extensions={"KHR_lights_punctual": {"light": sun}})
    w.json["asset"]["generator"] = f"depthimpostor tools/make_many_parts.py --count {count} --seed {seed}"
    return w


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output", type=Path, help="the .glb file to write")
    parser.add_argument("--count", type=int, default=1000, help="part nodes (default 1000)")
    parser.add_argument("--seed", type=int, default=0, help="the placements' random seed (default 0)")
    args = parser.parse_args()
    if args.count < 1 or args.output.suffix.lower() != ".glb":
        parser.error("expected --count of at least 1 and an output path ending in .glb")
    path = build(args.count, args.seed).write(args.output)
    print(f"{path}: {args.count} parts in {math.ceil(args.count / PER_ROW)} rows ({path.stat().st_size // 1024} KiB)")


if __name__ == "__main__":
    main()
