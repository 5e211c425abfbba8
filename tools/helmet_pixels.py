"""Why `hybrid` differs from the truth at a few mirror pixels of a public model (issue 33:
results/llvmpipe/public_models.md): for each mirror pixel whose colour is off by more than 1e-3 of
the truth's luminance where `raytrace` is not, the hybrid's hit (retraced or made exact) and the
model's triangles along the reflected ray, nearest first, with their ray parameter and facing, and
which triangle the mirror's centre sees there. DamagedHelmet had two such pixels until the hybrid
traced a ray whose exact hit its image's own triangles hide from the image's eye
(lib/reflected_scene.glsl's hidden_from_eye); it lists none now.

    PYTHONPATH=$PWD python3 tools/helmet_pixels.py /tmp/pm/large/DamagedHelmet.glb
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from public_models import mirror_scene  # noqa: E402

from depthimpostor.constants import Method  # noqa: E402
from depthimpostor.gpu.context import create_context  # noqa: E402
from depthimpostor.oracles.compare import colour_error, compare  # noqa: E402
from depthimpostor.renderer import Renderer  # noqa: E402

#: Relative colour error (compare's) above which a pixel is listed.
OFF = 1e-3


def along(triangles: np.ndarray, origin: np.ndarray, direction: np.ndarray) -> list[tuple[int, float, bool]]:
    """Every triangle (rows of 3 corners) the ray meets, nearest first: (index, t, facing the ray)."""
    e1, e2 = triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]
    p = np.cross(direction, e2)
    det = (e1 * p).sum(axis=1)
    inverse = 1.0 / np.where(det == 0.0, np.inf, det)
    s = origin - triangles[:, 0]
    u = (s * p).sum(axis=1) * inverse
    q = np.cross(s, e1)
    v = (q @ direction) * inverse
    t = (e2 * q).sum(axis=1) * inverse
    met = np.flatnonzero((u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0))
    facing = np.cross(e1, e2) @ direction < 0.0
    return [(int(k), float(t[k]), bool(facing[k])) for k in met[np.argsort(t[met])]]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model", type=Path)
    args = parser.parse_args()
    ctx = create_context()
    scene = mirror_scene(args.model)
    results, data = {}, None
    truth = None
    for method in (Method.RAYTRACE, Method.HYBRID):
        with Renderer(ctx, scene, method=method, reflection_data=True) as renderer:
            renderer.render()
            results[method] = compare(renderer, truth)
            truth = results[method].truth_frame
            if method == Method.HYBRID:
                data = renderer.read_reflection_data()
                model = [g for g in renderer.world.reflected_objects if g.object.name.startswith("model")]
                mirrors = {g.index: g for g in renderer.world.reflectors}
    assert data is not None
    off = {m: np.abs(colour_error(r.render, r.truth)).max(axis=2) > OFF for m, r in results.items()}
    pixels = np.argwhere(off[Method.HYBRID] & ~off[Method.RAYTRACE] & data.mirror_mask)
    triangles = np.concatenate([g.world_mesh.positions[g.world_mesh.indices] for g in model])
    for y, x in pixels:
        origin, direction = data.origin[y, x].astype(float), data.direction[y, x].astype(float)
        hybrid, exact = results[Method.HYBRID].render[y, x], results[Method.HYBRID].truth[y, x]
        t = float(np.linalg.norm(data.hit_position[y, x] - origin))
        print(f"pixel ({y}, {x}) in {mirrors[int(data.mirror_id[y, x])].object.name!r}: hybrid {hybrid.round(4)}, "
              f"truth {exact.round(4)}, retraced {bool(data.retraced[y, x])}, hybrid's hit at t = {t:.5f}")
        met = along(triangles, origin, direction)
        for k, tk, facing in met[:4]:
            print(f"    triangle {k}: t = {tk:.5f}, {'facing the ray' if facing else 'met from behind'}")
        if met:
            point = origin + direction * met[0][1]
            centre = mirrors[int(data.mirror_id[y, x])].bounding_sphere[0]
            to = point - centre
            seen = along(triangles, centre, to / np.linalg.norm(to))
            print(f"    from the mirror's centre toward triangle {met[0][0]}'s point: triangle {seen[0][0]} is seen")
    return 0


if __name__ == "__main__":
    sys.exit(main())
