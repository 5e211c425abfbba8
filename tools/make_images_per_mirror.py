"""Writes scenes/images_per_mirror/: one mirror sphere among N boxes (N = 1, 4, 16, 64), in two
families (FAMILIES), the bench's measure of how the mirror pass grows with the depth images a
mirror holds (issue 24: "a mirror with 64 images should cost little more than one with a few").

    python3 tools/make_images_per_mirror.py
    python3 -m depthimpostor bench scenes/images_per_mirror/*.toml --methods depth --algorithms optimized \\
        --resolutions 256 -o /tmp/images_per_mirror

A family's boxes are the first N places of one sequence where a box fits (so that the boxes
family's scenes hold the smaller ones' boxes). They stand all round the mirror (the mirror shows what is behind the camera in its middle),
but nowhere they would hide part of it from the camera: the mirror pixels, the work, would
shrink as N grows.
"""

from __future__ import annotations

import colorsys
import math
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
FOLDER = ROOT / "scenes" / "images_per_mirror"
COUNTS = (1, 4, 16, 64)
MIRROR_RADIUS = 0.6
MIRROR_CENTRE = (0.0, 0.8, 0.0)
EYE = (0.0, 1.5, 4.5)
BOX = 0.3  # side of the boxes family's boxes
#: boxes_NN: N boxes of side 0.3 spread all round the mirror, as the issue asks (the mirror shows more
#: of them as N grows, and more of its rays have an image to march); wall_NN: a wall at the mirror's
#: left of N cubes in a square grid, whose sides shrink as 1/sqrt(N): the mirror shows the same wall
#: whatever N, and what grows is the number of images alone.
FAMILIES = {"boxes": "{count} boxes of side 0.3", "wall": "a wall of {count} cubes"}
WALL = (-1.8, 3.6)  # the wall's face (x) and side: z in [-1.8, 1.8], y in [0, 3.6]
HEADER = f"""# One mirror sphere among {{what}}: the bench's measure of the mirror pass against the
# depth images per mirror (written by tools/make_images_per_mirror.py; do not edit by hand).

[render]
size = [960, 540]
impostor_resolution = 256
ambient = 0.25

[camera]
eye = [{EYE[0]}, {EYE[1]}, {EYE[2]}]
target = [0.0, 0.8, 0.0]
fov_y = 45.0

[environment]
type = "gradient"
zenith = [0.35, 0.55, 0.9]
horizon = [0.9, 0.9, 0.95]
ground = [0.3, 0.28, 0.25]

[[lights]]
type = "directional"
direction = [-0.4, -1.0, -0.3]

[[objects]]
name = "floor"
shape = {{{{ type = "plane", size = [20.0, 20.0] }}}}
material = {{{{ type = "checker", color_a = [0.8, 0.8, 0.8], color_b = [0.35, 0.35, 0.35], scale = 1.0 }}}}

[[objects]]
name = "mirror"
shape = {{{{ type = "sphere", radius = {MIRROR_RADIUS} }}}}
material = {{{{ type = "mirror", tint = [0.95, 0.95, 0.95] }}}}
position = [{MIRROR_CENTRE[0]}, {MIRROR_CENTRE[1]}, {MIRROR_CENTRE[2]}]
"""


def fraction(k: int, step: float) -> float:
    """The k-th point of an additive recurrence (a low-discrepancy sequence in [0, 1))."""
    return (0.5 + k * step) % 1.0


def hides_mirror(position: np.ndarray, side: float) -> bool:
    """Could a box there stand between the camera and the mirror (its sphere overlaps the cone of
    sight lines to the mirror, nearer than the mirror's centre)?"""
    to_mirror, to_box = np.subtract(MIRROR_CENTRE, EYE), position - EYE
    if np.linalg.norm(to_box) > np.linalg.norm(to_mirror):
        return False
    cosine = float(to_box @ to_mirror / (np.linalg.norm(to_box) * np.linalg.norm(to_mirror)))
    apart = math.acos(min(1.0, cosine))
    mirror_angle = math.asin(MIRROR_RADIUS / np.linalg.norm(to_mirror))
    box_angle = math.asin(min(1.0, side * math.sqrt(3.0) / 2.0 / np.linalg.norm(to_box)))
    return apart < mirror_angle + box_angle + math.radians(2.0)


def box_positions(count: int, side: float) -> list[np.ndarray]:
    """The first `count` places of the sequence (all round the mirror, 0.1 to 1.3 beyond where a
    box of `side` would touch it, on the floor to 1.75 above it) where a box hides no part of the
    mirror and overlaps no other box."""
    placed: list[np.ndarray] = []
    k = 0
    while len(placed) < count:
        azimuth = 2.0 * math.pi * fraction(k, 0.6180339887)
        distance = MIRROR_RADIUS + side * math.sqrt(3.0) / 2.0 + 0.1 + 1.2 * fraction(k, 0.7548776662)
        height = side / 2.0 + 1.75 * fraction(k, 0.5698402910)
        position = np.array([MIRROR_CENTRE[0] + distance * math.sin(azimuth), height,
                             MIRROR_CENTRE[2] + distance * math.cos(azimuth)])
        k += 1
        if hides_mirror(position, side) or any(np.linalg.norm(position - other) < 2.0 * side for other in placed):
            continue
        placed.append(position)
    return placed


def box(k: int, position: np.ndarray, side: float, yaw: float) -> str:
    red, green, blue = colorsys.hsv_to_rgb(fraction(k, 0.381966), 0.75, 0.85)
    x, y, z = position
    return (f'\n[[objects]]\nname = "box_{k}"\nshape = {{ type = "box", size = [{side}, {side}, {side}] }}\n'
            f'material = {{ type = "diffuse", color = [{red:.3f}, {green:.3f}, {blue:.3f}] }}\n'
            f"position = [{x:.4f}, {y:.4f}, {z:.4f}]\nrotation = [0.0, {yaw:.1f}, 0.0]\n")


def wall_positions(count: int) -> tuple[list[np.ndarray], float]:
    """The cubes of a square wall (face at x = WALL[0], WALL[1] a side, on the floor), and their side."""
    across = math.isqrt(count)
    side = WALL[1] / across
    return [np.array([WALL[0] - side / 2.0, side * (row + 0.5), -WALL[1] / 2.0 + side * (column + 0.5)])
            for row in range(across) for column in range(across)], side


def main() -> None:
    FOLDER.mkdir(exist_ok=True)
    for family, what in FAMILIES.items():
        for count in COUNTS:
            positions, side = wall_positions(count) if family == "wall" else (box_positions(count, BOX), BOX)
            # The spread boxes turned this way and that; the wall's cubes square to it.
            boxes = "".join(box(k, position, side, 0.0 if family == "wall" else 37.0 * k % 90)
                            for k, position in enumerate(positions))
            path = FOLDER / f"{family}_{count:02d}.toml"
            path.write_text(HEADER.format(what=what.format(count=count)) + boxes, encoding="utf-8")
            print(path.relative_to(ROOT))


if __name__ == "__main__":
    main()
