"""Write the default scene without its mirror plus a grid of 10,000 small objects (issue 24, item 5:
"10,000 objects cost about what their visible triangles cost"), for `depthimpostor bench`:

    python3 tools/many_objects.py spheres /tmp/many_spheres.toml   # spheres of radius 0.02
    python3 tools/many_objects.py boxes /tmp/many_boxes.toml       # boxes of 0.04 (12 triangles each)
    python3 -m depthimpostor bench /tmp/many_spheres.toml --methods depth --frames 10 -o /tmp/bench

The objects stand on the floor in a 100 x 100 grid in front of and around where the mirror was,
every one a diffuse colour of a small palette (so that materials repeat, as in real scenes).
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from depthimpostor.resources import default_scene_path

PALETTE = ((0.85, 0.15, 0.12), (0.15, 0.7, 0.25), (0.15, 0.3, 0.85), (0.95, 0.8, 0.15), (0.6, 0.6, 0.6))
SHAPES = {"spheres": ('{ type = "sphere", radius = 0.02 }', 0.02),
          "boxes": ('{ type = "box", size = [0.04, 0.04, 0.04] }', 0.02)}


def without_mirror(text: str) -> str:
    """The default scene's text less its [[objects]] block whose material is a mirror."""
    blocks = re.split(r"(?m)^(?=\[\[objects\]\])", text)
    return "".join(block for block in blocks if 'type = "mirror"' not in block)


def scene_text(kind: str, count: int) -> str:
    shape, half_height = SHAPES[kind]
    side = round(count ** 0.5)
    lines = [without_mirror(default_scene_path().read_text()).rstrip(), ""]
    for i in range(side):
        for j in range(count // side):
            x, z = -3.0 + 6.0 * i / max(side - 1, 1), -3.0 + 5.0 * j / max(side - 1, 1)
            color = PALETTE[(i + j) % len(PALETTE)]
            lines += ["[[objects]]", f'name = "{kind}_{i}_{j}"', f"shape = {shape}",
                      f'material = {{ type = "diffuse", color = [{color[0]}, {color[1]}, {color[2]}] }}',
                      f"position = [{x:.4f}, {half_height}, {z:.4f}]", ""]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("kind", choices=sorted(SHAPES))
    parser.add_argument("output", type=Path)
    parser.add_argument("--count", type=int, default=10_000)
    args = parser.parse_args()
    args.output.write_text(scene_text(args.kind, args.count))
    print(f"{args.output}: the default scene without its mirror, and {args.count} {args.kind}")


if __name__ == "__main__":
    main()
