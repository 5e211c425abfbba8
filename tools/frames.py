"""Record every shipped scene under every method and algorithm at a small size, and check later that a
refactoring changed no frame (issue 22: "frames must not change").

    python3 tools/frames.py record /tmp/frames     # before a step
    python3 tools/frames.py check /tmp/frames      # after it: the largest difference per frame

A scene that a method refuses (a SceneError: surrounds.toml for the baking methods, max_bounces > 1 for
the others) is recorded as refused, with its message, and must stay refused with the same message.
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from depthimpostor.constants import Algorithm, Method
from depthimpostor.methods.registry import METHODS
from depthimpostor.gpu.context import create_context
from depthimpostor.errors import SceneError
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene, load_scene

ROOT = Path(__file__).resolve().parent.parent
SIZE = (160, 90)
RESOLUTION = 64
#: Differences above this are reported as changes: llvmpipe is deterministic on one machine, so a
#: refactoring that changes no arithmetic gives 0; a reordering of float operations gives ~1e-7.
TOLERANCE = 1e-5


def configurations() -> Iterator[tuple[str, Scene | SceneError, Method, Algorithm]]:
    for path in sorted((ROOT / "scenes").glob("*.toml")) + sorted((ROOT / "scenes" / "hard").glob("*.toml")):
        name = str(path.relative_to(ROOT / "scenes"))
        try:
            scene: Scene | SceneError = load_scene(path).with_overrides(size=SIZE, impostor_resolution=RESOLUTION)
        except SceneError as error:  # a model file that is not here (the bunny without ../shared)
            scene = error
        for method in Method:
            algorithms = list(Algorithm) if METHODS[method].marches_depth_images else [Algorithm.OPTIMIZED]
            for algorithm in algorithms:
                yield name, scene, method, algorithm


def key(name: str, method: Method, algorithm: Algorithm) -> str:
    return f"{name.replace('/', '_')}-{method.name.lower()}-{algorithm.name.lower()}"


def refusal(error: SceneError) -> str:
    """A refusal's message without the folder of the checkout it came from (the scene's path is
    in it, and the folders a model file was looked for in), so that a recording made in one clone
    compares with a check in another."""
    return refusal_text(str(error))


def refusal_text(message: str) -> str:
    return re.sub(r"[^\s(]*/scenes\b", "scenes", message)


def render(ctx: object, scene: Scene | SceneError, method: Method, algorithm: Algorithm) -> np.ndarray | str:
    if isinstance(scene, SceneError):
        return refusal(scene)
    try:
        with Renderer(ctx, scene, algorithm, method=method) as renderer:  # type: ignore[arg-type]
            renderer.render()
            return renderer.read_color_float()
    except SceneError as error:
        return refusal(error)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("action", choices=("record", "check"))
    parser.add_argument("folder", type=Path)
    args = parser.parse_args()
    ctx = create_context()
    args.folder.mkdir(parents=True, exist_ok=True)
    changed = 0
    for name, scene, method, algorithm in configurations():
        frame = render(ctx, scene, method, algorithm)
        path = args.folder / (key(name, method, algorithm) + ".npz")
        if args.action == "record":
            np.savez_compressed(path, frame=np.asarray(frame) if not isinstance(frame, str) else np.array(frame))
            continue
        if not path.exists():  # a scene or method added since the recording: nothing to compare with
            print(f"new     {path.stem}: not in the recording", flush=True)
            continue
        before = np.load(path)["frame"]
        if isinstance(frame, str) or before.dtype.kind == "U":
            same = isinstance(frame, str) and before.dtype.kind == "U" and refusal_text(str(before)) == frame
            difference = "same refusal" if same else f"was {str(before)[:60]!r}, now {str(frame)[:60]!r}"
        else:
            largest = float(np.abs(frame - before).max()) if frame.shape == before.shape else float("inf")
            same = largest <= TOLERANCE
            difference = f"max difference {largest:.3g}"
        changed += not same
        print(f"{'ok     ' if same else 'CHANGED'} {path.stem}: {difference}", flush=True)
    if args.action == "check":
        print(f"{changed} frames changed")
    return 1 if changed else 0


if __name__ == "__main__":
    sys.exit(main())
