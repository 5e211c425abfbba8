"""README's methods table, with what each method costs beside what it gets wrong, made from a
`bench` run (issue 35: "the front page answers which method, at what cost").

    python3 -m depthimpostor bench scenes/textured_near_mirror.toml scenes/lecture_8x9.toml --methods all \\
        --algorithms optimized --resolutions 256 --size 960x540 --frames 5 --warmup 1 --bakes 1 \\
        -o results/llvmpipe/front_page
    python3 tools/front_page.py results/llvmpipe/front_page/bench.csv    # rewrites README's table

The table sits between README's METHODS_BEGIN and METHODS_END markers; one row per method of the
registry (tests/test_front_page.py holds the two lists equal), each scene's frame, mirror pass,
bake, memory, wrong object and wrong surface.
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
BEGIN, END = "<!-- METHODS_BEGIN (tools/front_page.py writes this table) -->", "<!-- METHODS_END -->"

#: What stands in for the reflected objects, per method (the registry's options).
WHAT = {
    "depth": "one depth image per mirror and object, marched per pixel (the lecture's method)",
    "cubemap": "a cube map from the mirror's centre, looked up by direction",
    "cubemap-parallax": "the cube map, corrected against a proxy box",
    "billboard": "one textured quad per mirror and object",
    "simplified": "500 triangles an object, ray-traced",
    "raytrace": "the real triangles, ray-traced through a two-level BVH on the GPU",
    "hybrid": "the depth images, and the real triangles for the rays the images cannot answer",
    "planar": "the scene rendered once more through each flat mirror's plane (flat mirrors only)",
    "ssr": "the frame itself, marched in screen space (what it cannot see, it cannot show)",
}


def read_rows(path: Path) -> tuple[list[str], list[dict[str, str]]]:
    """The csv's comment lines (machine, date, settings) and its rows."""
    lines = path.read_text(encoding="utf-8").splitlines()
    header = [line[2:] for line in lines if line.startswith("# ")]
    rows = list(csv.DictReader(line for line in lines if not line.startswith("#")))
    return header, rows


def table(header: list[str], rows: list[dict[str, str]], source: str) -> str:
    scenes = list(dict.fromkeys(row["scene"] for row in rows))
    methods = list(WHAT)  # the registry's order
    by_key = {(row["scene"], row["method"]): row for row in rows}
    head = "| `--method` | what stands in for the reflected objects | " + " | ".join(
        f"{scene}: frame / mirror pass / bake ms, MiB | {scene}: wrong object / surface" for scene in scenes) + " |"
    lines = [head, "|---|---|" + "---:|---:|" * len(scenes)]
    for method in methods:
        cells = []
        for scene in scenes:
            row = by_key.get((scene, method))
            if row is None:  # refused by the scene (planar: flat mirrors only), or not run
                cells += ["-", "-"]
                continue
            cells.append(f"{float(row['frame_ms_median']):.0f} / {float(row['mirror_pass_ms_median']):.0f} / "
                         f"{float(row['bake_ms_median']):.0f}, {float(row['memory_mib']):.1f}")
            cells.append(f"{float(row['wrong_object_percent']):.2f} % / {float(row['wrong_surface_percent']):.2f} %")
        lines.append(f"| `{method}` | {WHAT.get(method, '')} | " + " | ".join(cells) + " |")
    said = "; ".join(line for line in header if line.startswith(("depthimpostor bench", "GL:", "settings:")))
    lines += ["", f"From `{source}` ({said})."]
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("csv", type=Path, help="a bench.csv")
    parser.add_argument("--readme", type=Path, default=README)
    args = parser.parse_args()
    header, rows = read_rows(args.csv)
    text = args.readme.read_text(encoding="utf-8")
    if BEGIN not in text or END not in text:
        print(f"{args.readme}: expected the markers {BEGIN} and {END}", file=sys.stderr)
        return 2
    resolved = args.csv.resolve()
    source = resolved.relative_to(ROOT) if resolved.is_relative_to(ROOT) else resolved
    start, end = text.index(BEGIN) + len(BEGIN), text.index(END)
    args.readme.write_text(text[:start] + "\n" + table(header, rows, str(source)) + "\n" + text[end:], encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
