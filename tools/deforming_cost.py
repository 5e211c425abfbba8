"""What each method pays per frame for geometry that deforms (issue 33, item 4): a skinned tube
before a wall mirror (tests/gltf_files.py's bending_scene, at several tessellations), played one
frame after another as `render --video` plays it, each frame at a new time.

Per method, tube and path (`gpu`: the renderer's, skinning and morphing in deform.comp and the BVH
refitted by compute passes; `cpu`: the same frames with both on the CPU, GpuDeform.enabled off),
the medians over the frames of:

- deform: the CPU skinning of the tube's mesh at the new time (numpy: scene/gltf_deform.py), which
  every method pays the same on either path (World.at calls it once per time: the world's bounds,
  the images' cameras and the truth read the mesh);
- upload: the deformed vertices written over the old ones in the mesh arena (GpuMeshes.replace;
  on the GPU path only what deform.comp cannot make is uploaded);
- skin: the GPU path's skinning and morphing into the arena (GpuDeform.follow: the joint matrices
  and weights uploaded, deform.comp dispatched), timed up to a ctx.finish();
- refit: the triangle methods' bottom-level BVH refitted (TrianglePass._refit): on the CPU, its node
  and triangle textures then uploaded whole; on the GPU, the compute passes and the roots read
  back; 0 for the methods without a BVH;
- set_time: all that the renderer does when the time changes (the three above, the world at the
  new time, the images' cameras fitted again);
- bake: the next frame's re-bakes (the depth images, cube maps, billboards that show the tube:
  RenderStats.bake_seconds); 0 for the methods that bake nothing;
- frame: the eye's passes of that frame (RenderStats.draw_seconds), which a still scene pays too.

A second table sets the refit beside what a CPU rebuild of the same bottom level would cost
(bvh.refit_triangle_forest against build_triangle_forest on the tube's triangles at t = 1).

    python3 tools/deforming_cost.py [--frames 12] [--size 960x540] [--model x.glb ...] [-o results/llvmpipe/deforming.md]

`--model` adds a glTF file of one's own (BrainStem.glb, say), scaled to 1.8 units tall and stood
before the mirror of scenes/planar_mirror.toml (`model_scene`).

Times are wall-clock around ctx.finish() (render_graph.py), on whatever GL the context gets.
"""

from __future__ import annotations

import argparse
import datetime
import statistics
import sys
import tempfile
import time
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))
from gltf_files import bending_scene  # noqa: E402

from depthimpostor.constants import Method  # noqa: E402
from depthimpostor.errors import SceneWarning  # noqa: E402
from depthimpostor.gpu.context import create_context, describe  # noqa: E402
from depthimpostor.gpu.deform import GpuDeform  # noqa: E402
from depthimpostor.gpu.meshes import GpuMeshes  # noqa: E402
from depthimpostor.methods.bvh import build_triangle_forest, refit_triangle_forest  # noqa: E402
from depthimpostor.methods.triangles import TrianglePass  # noqa: E402
from depthimpostor.renderer import Renderer  # noqa: E402
from depthimpostor.scene import load_scene  # noqa: E402
from depthimpostor.scene.gltf import read_gltf  # noqa: E402
from depthimpostor.scene.gltf_deform import PartMotion  # noqa: E402

#: Tubes (rings, sides): the tests' 80-triangle column, then about 8k and 66k triangles.
TUBES = ((8, 4), (64, 64), (256, 128))
METHODS = (Method.DEPTH, Method.CUBEMAP, Method.BILLBOARD, Method.RAYTRACE, Method.HYBRID, Method.PLANAR)
COLUMNS = ("deform", "upload", "skin", "refit", "set_time", "bake", "frame")
#: The columns timed per call (a frame's calls summed).
CALLS = ("deform", "upload", "skin", "refit")


@contextmanager
def timed(owner: Any, name: str, into: list[float], finish: Callable[[], None] | None = None) -> Iterator[None]:
    """Wrap owner.name so that each call's wall-clock seconds (up to `finish()`, given) go into `into`."""
    original: Callable[..., Any] = getattr(owner, name)

    def wrapper(*args: Any, **kwargs: Any) -> Any:
        start = time.perf_counter()
        try:
            return original(*args, **kwargs)
        finally:
            if finish is not None:
                finish()
            into.append(time.perf_counter() - start)

    setattr(owner, name, wrapper)
    try:
        yield
    finally:
        setattr(owner, name, original)


def measure(ctx: Any, path: Path, method: Method, frames: int, size: tuple[int, int], gpu: bool) -> dict[str, float]:
    """Median milliseconds of each column over `frames` frames at new times (after two untimed),
    on the GPU path (`gpu`) or the CPU's."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SceneWarning)
        scene = load_scene(path).with_overrides(size=size)
    spent: dict[str, list[float]] = {name: [] for name in COLUMNS}
    with Renderer(ctx, scene, method=method) as renderer, \
            timed(PartMotion, "mesh_at", spent["deform"]), timed(GpuMeshes, "replace", spent["upload"]), \
            timed(GpuDeform, "follow", spent["skin"], ctx.finish), timed(TrianglePass, "_refit", spent["refit"]):
        renderer.graph.deform.enabled = gpu
        calls: dict[str, list[float]] = {name: spent[name] for name in CALLS}
        per_frame: dict[str, list[float]] = {name: [] for name in calls}
        for frame in range(frames + 2):
            if frame == 2:  # the first frames are cold (programs, first bakes): not counted
                for values in (*spent.values(), *per_frame.values()):
                    values.clear()
                baked, drawn = len(renderer.stats.bake_seconds), len(renderer.stats.draw_seconds)
            made = {name: len(values) for name, values in calls.items()}
            start = time.perf_counter()
            renderer.set_time(frame / 30.0)  # a 30 frames/s video through the bend and back
            spent["set_time"].append(time.perf_counter() - start)
            renderer.render()
            for name, values in calls.items():  # a frame's calls summed: a model of many parts makes many
                if len(values) > made[name]:
                    per_frame[name].append(sum(values[made[name]:]))
        spent.update(per_frame)
        spent["bake"] = renderer.stats.bake_seconds[baked:]
        spent["frame"] = renderer.stats.draw_seconds[drawn:]
        triangles = sum(len(g.local_mesh.indices) for g in renderer.world.geometry if g.object.deforms)
        if gpu and not renderer.graph.deform.dispatches:
            raise SystemExit(f"{path.name}: nothing was deformed on the GPU (GL 4.3? PartMotion.gpu_refusal?)")
    medians = {name: 1000.0 * statistics.median(values) if values else 0.0 for name, values in spent.items()}
    medians["bakes"] = len(spent["bake"])
    medians["triangles"] = triangles
    return medians


def refit_against_rebuild(path: Path, repeats: int = 5) -> tuple[int, float, float]:
    """The tube's triangles, and the median ms of refitting its bottom level (built at t = 0) to
    t = 1, and of building it anew there."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SceneWarning)
        scene = load_scene(path)
    motion = next(o.motion for o in scene.objects if o.deforms and o.motion is not None)
    rest, bent = motion.mesh_at(0.0), motion.mesh_at(1.0)
    bvh = build_triangle_forest(rest.positions[rest.indices], [len(rest.indices)])
    triangles = bent.positions[bent.indices]
    times: dict[str, list[float]] = {"refit": [], "build": []}
    for _ in range(repeats):
        for name, run in (("refit", lambda: refit_triangle_forest(bvh, triangles)),
                          ("build", lambda: build_triangle_forest(triangles, [len(triangles)]))):
            start = time.perf_counter()
            run()
            times[name].append(1000.0 * (time.perf_counter() - start))
    return len(triangles), statistics.median(times["refit"]), statistics.median(times["build"])


def model_scene(model: Path, folder: Path) -> Path:
    """A TOML scene of `model` (scaled to 1.8 units tall, its foot at the origin) before
    scenes/planar_mirror.toml's mirror, under its floor, camera and light."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SceneWarning)
        lower, upper = np.min([p.mesh.positions.min(axis=0) for p in read_gltf(model, str(model)).parts], axis=0), \
            np.max([p.mesh.positions.max(axis=0) for p in read_gltf(model, str(model)).parts], axis=0)
    scale = 1.8 / float(upper[1] - lower[1])
    centre = 0.5 * (lower + upper)
    position = [-scale * float(centre[0]), -scale * float(lower[1]), -scale * float(centre[2])]
    base = (ROOT / "scenes" / "planar_mirror.toml").read_text(encoding="utf-8")
    scene = base[:base.index('[[objects]]\nname = "red_box"')]
    scene += (f'[[objects]]\nname = "model"\nshape = {{ type = "gltf", path = "{model.resolve()}" }}\n'
              f"scale = [{scale}, {scale}, {scale}]\nposition = {position}\n")
    path = folder / f"{model.stem}.toml"
    path.write_text(scene, encoding="utf-8")
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=12)
    parser.add_argument("--size", default="960x540")
    parser.add_argument("--model", type=Path, action="append", default=[], help="a glTF file to add (repeatable)")
    parser.add_argument("-o", "--output", type=Path)
    args = parser.parse_args()
    size = tuple(int(v) for v in args.size.split("x"))
    ctx = create_context()
    lines = [f"tools/deforming_cost.py, {datetime.date.today().isoformat()}, {describe(ctx)}, {args.size}, "
             f"median of {args.frames} frames after 2, each at a new time (ms)", "",
             "| deforming triangles | method | path | deform | upload | skin | refit | set_time | bake (frames that baked) "
             "| frame |", "|---:|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    with tempfile.TemporaryDirectory() as folder:
        scenes = [bending_scene(Path(folder) / f"tube_{rings}x{sides}.glb", rings, sides) for rings, sides in TUBES]
        for path in scenes + [model_scene(model, Path(folder)) for model in args.model]:
            for method in METHODS:
                for gpu in (False, True):  # interleaved: the machine's load drifts
                    m = measure(ctx, path, method, args.frames, (size[0], size[1]), gpu)
                    name = path.stem if path.suffix == ".toml" else "tube"
                    line = (f"| {name} {m['triangles']:,.0f} | {method.option} | {'gpu' if gpu else 'cpu'} | "
                            f"{m['deform']:.2f} | {m['upload']:.2f} | {m['skin']:.2f} | {m['refit']:.2f} | "
                            f"{m['set_time']:.2f} | {m['bake']:.2f} ({m['bakes']:.0f}) | {m['frame']:.2f} |")
                    lines.append(line)
                    print(line, flush=True)
        lines += ["", "The bottom level alone, refitted or built anew on the CPU (median of 5, ms):", "",
                  "| tube triangles | refit | build |", "|---:|---:|---:|"]
        for rings, sides in TUBES:
            triangles, refit, build = refit_against_rebuild(Path(folder) / f"tube_{rings}x{sides}.glb")
            lines.append(f"| {triangles:,} | {refit:.2f} | {build:.2f} |")
            print(lines[-1], flush=True)
    text = "\n".join(lines) + "\n"
    if args.output:
        args.output.write_text(text, encoding="utf-8")
    else:
        print(text)


if __name__ == "__main__":
    main()
