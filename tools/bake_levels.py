"""What the bakes' levels of detail (lod.py, "Baked images") and the culled back faces of their
surface pass change: each scene with each baking method, its images baked as this branch bakes
them and again as main did (full meshes, every back face drawn; --against: undo one of the two),
both compared with the truth (traced once), and the largest difference between the two frames.

    python3 tools/bake_levels.py --counts 10,100,1000 scenes/lecture_8x9.toml -o results/llvmpipe/bake_levels.md

Scenes: tools/scene_size.py's family at --counts (small checkered spheres and boxes around two
mirror spheres) and any scene files given.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from depthimpostor import lod
from depthimpostor.constants import Method
from depthimpostor.errors import DepthImpostorError
from depthimpostor.gpu.context import create_context
from depthimpostor.oracles.compare import Comparison, TruthFrame, compare
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene, load_scene

sys.path.insert(0, str(Path(__file__).resolve().parent))
from scene_size import family_scene  # noqa: E402

METHODS = (Method.DEPTH, Method.BILLBOARD, Method.CUBEMAP, Method.CUBEMAP_PARALLAX, Method.HYBRID)


def both(renderer: Renderer, truth: TruthFrame | None, against: str) -> tuple[Comparison, Comparison, int, int]:
    """The comparisons of the frame baked as this branch bakes and as `against` says (main's: full
    meshes, every back face drawn; "levels": full meshes; "culling": every back face drawn), and
    the triangles each bake drew."""
    baked = renderer.graph.baked_images
    assert baked is not None
    images = [image for image in baked.depth_images if not image.level]
    renderer.render()
    levels = compare(renderer, truth)
    coarse = sum(len(item.local_mesh.indices) for drawn in baked.drawn(images) for item in drawn)
    if against in ("main", "levels"):
        baked.detail = None  # every object at its full mesh
    if against in ("main", "culling"):
        baked.culls_back_faces = False  # every back face drawn in the surface pass
    renderer.bake_again()
    renderer.render()
    full = compare(renderer, levels.truth_frame)
    return levels, full, coarse, sum(len(item.local_mesh.indices) for drawn in baked.drawn(images) for item in drawn)


def row(name: str, method: Method, levels: Comparison, full: Comparison, coarse: int, triangles: int) -> str:
    difference = np.abs(levels.render - full.render).max(axis=-1)
    mirror = levels.mirror_mask
    a, b = full.figures, levels.figures
    return (f"| {name} | {method.option} | {triangles:,} -> {coarse:,} | {difference.max():.3f} | "
            f"{100 * (difference[mirror] > 0.1).mean() if mirror.any() else 0.0:.3f} | "
            f"{100 * a.wrong_object_share:.3f} -> {100 * b.wrong_object_share:.3f} | "
            f"{100 * a.wrong_surface_share:.3f} -> {100 * b.wrong_surface_share:.3f} | "
            f"{a.color_rmse:.4f} -> {b.color_rmse:.4f} |")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", type=Path, nargs="*")
    parser.add_argument("--counts", default="10,100,1000", help="tools/scene_size.py's scenes ('' for none)")
    parser.add_argument("--size", default="640x360")
    parser.add_argument("--resolution", type=int, default=128)
    parser.add_argument("--methods", default=",".join(m.option for m in METHODS))
    parser.add_argument("--fraction", type=float, default=lod.LOD_TEXEL_ERROR,
                        help="the texels of chordal error a level may make (lod.LOD_TEXEL_ERROR)")
    parser.add_argument("--against", choices=("main", "levels", "culling"), default="main",
                        help="what the second frame undoes: both changes (main's bakes), the levels, the culling")
    parser.add_argument("-o", "--output", type=Path)
    args = parser.parse_args()
    lod.LOD_TEXEL_ERROR = args.fraction  # read by lod.image_levels at each bake
    methods = [Method.from_option(m) for m in args.methods.split(",")]
    width, height = (int(v) for v in args.size.split("x"))
    named: list[tuple[str, Scene]] = [(f"{int(c)} objects", family_scene(int(c))) for c in args.counts.split(",") if c]
    named += [(str(path), load_scene(path)) for path in args.scenes]
    ctx = create_context()
    lines = [f"{width}x{height}, images of {args.resolution}^2, levels within {args.fraction} texels; each pair is {args.against} -> this branch; `difference` is "
             "the largest of any pixel's channels between the two frames, `changed` the share of mirror pixels whose "
             "difference passes 0.1.", "",
             "| scene | method | bake triangles | difference | changed % | wrong object % | wrong surface % | RMSE |",
             "|---|---|---:|---:|---:|---|---|---|"]
    print("\n".join(lines), flush=True)
    for name, written in named:
        scene = written.with_overrides(size=(width, height), impostor_resolution=args.resolution)
        truth: TruthFrame | None = None
        for method in methods:
            try:
                with Renderer(ctx, scene, method=method, reflection_data=True) as renderer:
                    levels, full, coarse, triangles = both(renderer, truth, args.against)
            except DepthImpostorError as error:
                line = f"| {name} | {method.option} | refused: {str(error).splitlines()[0]} | | | | | |"
            else:
                truth = levels.truth_frame
                line = row(name, method, levels, full, coarse, triangles)
            print(line, flush=True)
            lines.append(line)
    if args.output is not None:
        args.output.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
