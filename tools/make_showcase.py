"""Writes scenes/showcase.glb, the README's scene, from procedural data (nothing downloaded): a room
of a wood floor and two tiled walls (each one textured rectangle, which the loader places as an
exactly intersected plane), a standing mirror (metallic 1, roughness 0), a glass sphere
(KHR_materials_transmission with KHR_materials_ior), textured boxes, a torus, two
KHR_lights_punctual lights and a camera. scenes/showcase.toml adds the HDR sky seen over the walls.

    python3 tools/make_showcase.py

The glTF is written with the tests' small writer (tests/gltf_files.py), which the project already
trusts to produce what trimesh reads.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import trimesh

from depthimpostor import meshes

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))
from gltf_files import GltfWriter, quaternion  # noqa: E402

SIZE = 128  # texels a side: enough at 960x540 with the textures repeated, and a small file


def wood() -> np.ndarray:
    """Planks along u: warm stripes with a grain that wanders, dark seams between planks."""
    v, u = np.mgrid[0:SIZE, 0:SIZE] / SIZE
    plank = np.floor(v * 4)
    grain = 0.5 + 0.5 * np.sin(2 * np.pi * (v * 24 + 0.6 * np.sin(2 * np.pi * (u * 2 + plank * 0.37))))
    tone = 0.75 + 0.12 * ((plank * 0.61) % 1.0) + 0.13 * grain
    seam = (v * 4 % 1.0) < 0.04
    rgb = np.stack([150 * tone, 95 * tone, 55 * tone], axis=-1)
    rgb[seam] = (60, 38, 22)
    return _rgba(rgb)


def tiles() -> np.ndarray:
    """4x4 glazed tiles in two blue-greens with light grout."""
    v, u = np.mgrid[0:SIZE, 0:SIZE] / SIZE
    row, column = np.floor(v * 4), np.floor(u * 4)
    rgb = np.where(((row + column) % 2 == 0)[..., None], (70, 140, 150), (200, 215, 205)).astype(np.float64)
    grout = ((u * 4 % 1.0) < 0.05) | ((v * 4 % 1.0) < 0.05)
    rgb[grout] = (235, 230, 220)
    return _rgba(rgb)


def checker_arrow() -> np.ndarray:
    """A yellow and red checker with a white arrow pointing up (+v down the image's rows, so a
    turned or flipped texture shows)."""
    v, u = np.mgrid[0:SIZE, 0:SIZE] / SIZE
    rgb = np.where((((np.floor(u * 4) + np.floor(v * 4)) % 2) == 0)[..., None], (230, 190, 40), (190, 40, 40))
    rgb = rgb.astype(np.float64)
    stem = (np.abs(u - 0.5) < 0.08) & (v > 0.4) & (v < 0.85)
    head = (v > 0.15) & (v <= 0.4) & (np.abs(u - 0.5) < (v - 0.15) * 1.2)
    rgb[stem | head] = (250, 250, 250)
    return _rgba(rgb)


def _rgba(rgb: np.ndarray) -> np.ndarray:
    return np.concatenate([np.clip(rgb, 0, 255), np.full(rgb.shape[:2] + (1,), 255.0)], axis=-1).astype(np.uint8)


def rectangle(width: float, height: float, repeats: tuple[float, float]) -> tuple[np.ndarray, ...]:
    """A width x height rectangle in XY facing +Z, its UVs running the image `repeats` times
    (v down the image from the top edge, as glTF's UVs run)."""
    x, y = width / 2, height / 2
    positions = np.array([[-x, -y, 0], [x, -y, 0], [x, y, 0], [-x, y, 0]], np.float32)
    uvs = np.array([[0, repeats[1]], [repeats[0], repeats[1]], [repeats[0], 0], [0, 0]], np.float32)
    return positions, np.array([[0, 1, 2], [0, 2, 3]]), uvs


def build() -> GltfWriter:
    w = GltfWriter()
    floor_m = w.material("Wood floor", (1, 1, 1), pbrMetallicRoughness={
        "baseColorTexture": {"index": w.texture(wood())}, "metallicFactor": 0.0, "roughnessFactor": 0.8})
    wall_m = w.material("Tiles", (1, 1, 1), pbrMetallicRoughness={
        "baseColorTexture": {"index": w.texture(tiles())}, "metallicFactor": 0.0, "roughnessFactor": 0.5})
    crate_m = w.material("Crate", (1, 1, 1), pbrMetallicRoughness={
        "baseColorTexture": {"index": w.texture(checker_arrow())}, "metallicFactor": 0.0, "roughnessFactor": 0.6})
    mirror_m = w.material("Mirror", (0.95, 0.95, 0.95), metallic=1.0, roughness=0.0)
    glass_m = w.material("Glass", (0.9, 0.97, 1.0), metallic=0.0, roughness=0.0, extensions={
        "KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.5}})
    torus_m = w.material("Green", (0.15, 0.6, 0.25))
    w.json["extensionsUsed"] = ["KHR_materials_transmission", "KHR_materials_ior"]

    def place(name: str, mesh: int, translation: tuple[float, ...], rotation: list[float] | None = None) -> None:
        w.node(name=name, mesh=mesh, translation=list(translation),
               **({"rotation": rotation} if rotation is not None else {}))

    def rect_mesh(width: float, height: float, repeats: tuple[float, float], material: int) -> int:
        p, f, uv = rectangle(width, height, repeats)
        return w.mesh(w.primitive(p, f, np.tile((0.0, 0.0, 1.0), (4, 1)), uv, material=material))

    place("Floor", rect_mesh(8, 8, (4, 4), floor_m), (0, 0, 0), quaternion((1, 0, 0), -90))
    place("Back wall", rect_mesh(8, 1.6, (4, 0.8), wall_m), (0, 0.8, -4))
    place("Left wall", rect_mesh(8, 1.6, (4, 0.8), wall_m), (-4, 0.8, 0), quaternion((0, 1, 0), 90))
    place("Mirror", rect_mesh(1.8, 2.2, (1, 1), mirror_m), (1.5, 1.15, -1.5), quaternion((0, 1, 0), -38))
    cube = meshes.box((0.7, 0.7, 0.7))  # the project's box: each face its own four vertices and whole image
    crate = w.mesh(w.primitive(cube.positions, cube.indices, cube.normals, cube.uvs, material=crate_m))
    place("Crate", crate, (-0.6, 0.35, -0.9), quaternion((0, 1, 0), 30))
    place("Small crate", crate, (-1.6, 0.35, -2.6), quaternion((0, 1, 0), -15))
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.5)
    place("Glass ball", w.mesh(w.primitive(sphere.vertices, sphere.faces, sphere.vertex_normals, material=glass_m)),
          (0.2, 0.5, 0.5))
    torus = trimesh.creation.torus(0.4, 0.13, major_sections=48, minor_sections=16)
    place("Torus", w.mesh(w.primitive(torus.vertices, torus.faces, torus.vertex_normals, material=torus_m)),
          (-2.2, 0.53, -0.4), quaternion((1, 0, 0), 90))
    camera = w._append("cameras", {"type": "perspective", "perspective": {"yfov": np.radians(50), "znear": 0.05}})
    w.node(name="Camera", camera=camera, translation=[0.3, 1.9, 4.4], rotation=quaternion((1, 0, 0), -12))
    sun = w.light(type="directional", color=[1.0, 0.95, 0.85], intensity=1.0)
    lamp = w.light(type="point", color=[1.0, 0.85, 0.7], intensity=6.0)
    w.node(name="Sun", translation=[0, 5, 0], rotation=quaternion((1, -0.6, 0.3), -60),
           extensions={"KHR_lights_punctual": {"light": sun}})
    w.node(name="Lamp", translation=[-1.5, 2.2, 1.0], extensions={"KHR_lights_punctual": {"light": lamp}})
    return w


def main() -> None:
    path = build().write(ROOT / "scenes" / "showcase.glb")
    print(f"{path} ({path.stat().st_size // 1024} KiB)")


if __name__ == "__main__":
    main()
