"""Makes reference.npz beside it: test meshes and the tangents mikktspace.c gives them, for
tests/test_mikktspace.py. Run by hand, never by the tests (they need no compiler):

    gcc -O2 -o /tmp/reference tests/data/mikktspace/reference.c MikkTSpace/mikktspace.c -lm
    PYTHONPATH=$PWD python3 tests/data/mikktspace/make_reference.py /tmp/reference

(mikktspace.c and .h from github.com/mmikk/MikkTSpace at 3e895b49d05e, beside reference.c when it
is compiled.) Each mesh `name` is stored as name/positions, name/normals, name/uvs (float32, what
mikktspace.c reads), name/faces (int32) and name/tangents (float32 (F, 3, 4), mikktspace.c's
tangent and sign per triangle corner, its sign as it gives it: not yet glTF's).
"""

from __future__ import annotations

import struct
import subprocess
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]


def _normals(positions: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals, unit."""
    normals = np.zeros_like(positions)
    cross = np.cross(positions[faces[:, 1]] - positions[faces[:, 0]], positions[faces[:, 2]] - positions[faces[:, 0]])
    for k in range(3):
        np.add.at(normals, faces[:, k], cross)
    return normals / np.linalg.norm(normals, axis=1, keepdims=True)


def sphere(rings: int = 12, segments: int = 16) -> tuple[np.ndarray, ...]:
    """A UV sphere: a seam of doubled vertices at u = 0 and 1, a vertex per segment at each pole."""
    theta, phi = np.meshgrid(np.linspace(0.0, np.pi, rings + 1), np.linspace(0.0, 2.0 * np.pi, segments + 1), indexing="ij")
    positions = np.stack([np.sin(theta) * np.cos(phi), np.cos(theta), -np.sin(theta) * np.sin(phi)], -1).reshape(-1, 3)
    uvs = np.stack([phi / (2.0 * np.pi), theta / np.pi], -1).reshape(-1, 2)
    faces = []
    for r in range(rings):
        for s in range(segments):
            a, b = r * (segments + 1) + s, r * (segments + 1) + s + 1
            if r > 0:
                faces.append((a, a + segments + 1, b))
            if r < rings - 1:
                faces.append((b, a + segments + 1, b + segments + 1))
    return positions, positions / np.linalg.norm(positions, axis=1, keepdims=True), np.array(faces), uvs


def grid(columns: int, rows: int) -> tuple[np.ndarray, ...]:
    """A wavy square of (columns x rows) quads, two triangles each, UVs its x and y over [0, 1]."""
    x, y = np.meshgrid(np.linspace(-1.0, 1.0, columns + 1), np.linspace(-1.0, 1.0, rows + 1))
    positions = np.stack([x, y, 0.2 * np.sin(2.0 * x) * np.cos(y)], -1).reshape(-1, 3)
    faces = []
    for j in range(rows):
        for i in range(columns):
            a = j * (columns + 1) + i
            faces += [(a, a + 1, a + columns + 2), (a, a + columns + 2, a + columns + 1)]
    faces_array = np.array(faces)
    return positions, _normals(positions, faces_array), faces_array, (positions[:, :2] + 1.0) / 2.0


def meshes() -> dict[str, tuple[np.ndarray, ...]]:
    made = {"sphere": sphere()}
    # UVs mirrored about the middle column, whose vertices both halves share (a mirror seam).
    positions, normals, faces, uvs = grid(8, 6)
    uvs[:, 0] = np.where(uvs[:, 0] > 0.5, 1.0 - uvs[:, 0], uvs[:, 0])
    made["mirrored"] = positions, normals, faces, uvs
    # UVs flipped at random and collapsed to one point at 30% of the vertices, the triangles
    # shuffled: triangles of no UV area (GROUP_WITH_ANY) whose orientation the first group to
    # reach them decides, and groups split by opposed tangents.
    rng = np.random.default_rng(218)
    positions, normals, faces, uvs = grid(10, 8)
    uvs = uvs * np.where(rng.random((len(uvs), 1)) < 0.5, 1.0, -1.0)
    uvs[rng.random(len(uvs)) < 0.3] = 0.25
    made["collapsed"] = positions, normals, faces[rng.permutation(len(faces))], uvs
    # Degenerate triangles: a row of vertices moved onto the next (two equal positions) and a few
    # triangles of no UV area.
    positions, normals, faces, uvs = grid(6, 5)
    positions[14:17] = positions[21:24]
    uvs[[3, 30]] = uvs[[4, 31]]
    made["degenerate"] = positions, normals, faces, uvs
    # Three triangles on one edge besides the square's two (a non-manifold fin).
    positions, normals, faces, uvs = grid(4, 3)
    a, b, top = faces[0, 0], faces[0, 1], len(positions)
    made["nonmanifold"] = (np.r_[positions, [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]], np.r_[normals, [[1.0, 0.0, 0.0]] * 2],
                           np.r_[faces, [[b, a, top], [a, b, top + 1], [b, a, top + 1]]],
                           np.r_[uvs, [[0.3, 0.2], [0.6, 0.9]]])
    made["clearcoat"] = _clearcoat()
    return made


def _clearcoat() -> tuple[np.ndarray, ...]:
    """tests/data/gltf/ClearCoatTest's meshes[9] (normal-mapped, no TANGENT), normals made unit as
    the loader makes them."""
    from depthimpostor.scene.gltf import _decoded  # noqa: PLC0415 (a tool's reach into the loader)
    from depthimpostor.scene.gltf_data import GltfData  # noqa: PLC0415
    from depthimpostor.scene.gltf_file import read_json, scene_nodes  # noqa: PLC0415
    path = ROOT / "tests" / "data" / "gltf" / "ClearCoatTest" / "ClearCoatTest.gltf"
    header = read_json(path, path.name)
    primitive = _decoded(GltfData(path, header, path.name), scene_nodes(header, path.name))[9, 0]
    assert primitive.normals is not None and primitive.uvs is not None
    normals = primitive.normals / np.linalg.norm(primitive.normals, axis=1, keepdims=True)
    return primitive.positions, normals, primitive.faces, primitive.uvs


def reference(tool: str, positions: np.ndarray, normals: np.ndarray, faces: np.ndarray, uvs: np.ndarray) -> np.ndarray:
    data = struct.pack("<ii", len(positions), len(faces)) + b"".join(
        np.ascontiguousarray(a, np.float32).tobytes() for a in (positions, normals, uvs)) + np.ascontiguousarray(faces, np.int32).tobytes()
    out = subprocess.run([tool], input=data, capture_output=True, check=True).stdout
    return np.frombuffer(out, np.float32).reshape(len(faces), 3, 4)


def main() -> None:
    stored = {}
    for name, (positions, normals, faces, uvs) in meshes().items():
        stored.update({f"{name}/positions": positions.astype(np.float32), f"{name}/normals": normals.astype(np.float32),
                       f"{name}/uvs": uvs.astype(np.float32), f"{name}/faces": faces.astype(np.int32),
                       f"{name}/tangents": reference(sys.argv[1], positions, normals, faces, uvs)})
    np.savez_compressed(HERE / "reference.npz", **stored)


if __name__ == "__main__":
    main()
