"""Small glTF files built in the tests (nothing downloaded): a writer of the JSON and one binary
buffer, enough for node trees, materials with their extensions, cameras, lights and textures."""

from __future__ import annotations

import io
import math
import json
import struct
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from PIL import Image

FLOAT, UNSIGNED_INT = 5126, 5125


class GltfWriter:
    def __init__(self) -> None:
        self.json: dict[str, Any] = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": []}],
                                     "nodes": [], "meshes": [], "accessors": [], "bufferViews": []}
        self.blob = bytearray()

    def _append(self, key: str, value: dict[str, Any]) -> int:
        self.json.setdefault(key, []).append(value)
        return len(self.json[key]) - 1

    def view(self, data: bytes) -> int:
        self.blob += b"\0" * (-len(self.blob) % 4)
        start = len(self.blob)
        self.blob += data
        return self._append("bufferViews", {"buffer": 0, "byteOffset": start, "byteLength": len(data)})

    def accessor(self, array: np.ndarray, kind: str) -> int:
        data = np.ascontiguousarray(array, np.uint32 if kind == "SCALAR" else np.float32)
        accessor = {"bufferView": self.view(data.tobytes()), "componentType": UNSIGNED_INT if kind == "SCALAR" else FLOAT,
                    "count": len(data), "type": kind}
        if kind == "VEC3":
            accessor |= {"min": data.min(axis=0).tolist(), "max": data.max(axis=0).tolist()}
        return self._append("accessors", accessor)

    def primitive(self, positions: Any, indices: Any = None, normals: Any = None, uvs: Any = None,
                  material: int | None = None, mode: int | None = None) -> dict[str, Any]:
        primitive: dict[str, Any] = {"attributes": {"POSITION": self.accessor(np.asarray(positions), "VEC3")}}
        if indices is not None:
            primitive["indices"] = self.accessor(np.asarray(indices).ravel(), "SCALAR")
        if normals is not None:
            primitive["attributes"]["NORMAL"] = self.accessor(np.asarray(normals), "VEC3")
        if uvs is not None:
            primitive["attributes"]["TEXCOORD_0"] = self.accessor(np.asarray(uvs), "VEC2")
        if material is not None:
            primitive["material"] = material
        if mode is not None:
            primitive["mode"] = mode
        return primitive

    def box(self, size: float = 1.0, material: int | None = None, normals: bool = False) -> dict[str, Any]:
        """A closed box centred at the origin (flat normals from the loader unless `normals`)."""
        box = trimesh.creation.box(extents=(size, size, size))
        return self.primitive(box.vertices, box.faces, box.vertex_normals if normals else None, material=material)

    def mesh(self, *primitives: dict[str, Any], name: str | None = None) -> int:
        return self._append("meshes", {"primitives": list(primitives)} | ({"name": name} if name else {}))

    def node(self, root: bool = True, **fields: Any) -> int:
        i = self._append("nodes", fields)
        if root:
            self.json["scenes"][0]["nodes"].append(i)
        return i

    def material(self, name: str | None = None, color: Any = (1, 1, 1), metallic: float = 0.0,
                 roughness: float = 1.0, **fields: Any) -> int:
        pbr = {"baseColorFactor": [*color, 1.0], "metallicFactor": metallic, "roughnessFactor": roughness}
        return self._append("materials", {"pbrMetallicRoughness": pbr} | ({"name": name} if name else {}) | fields)

    def texture(self, rgba: np.ndarray) -> int:
        png = io.BytesIO()
        Image.fromarray(np.asarray(rgba, np.uint8)).save(png, format="PNG")
        return self.image_texture(png.getvalue())

    def image_texture(self, data: bytes, mime: str = "image/png", **fields: Any) -> int:
        """A texture of an image file's bytes, as written (any format, depth or damage)."""
        image = self._append("images", {"bufferView": self.view(data), "mimeType": mime})
        sampler = self._append("samplers", {"magFilter": 9729, "wrapS": 10497})
        return self._append("textures", {"source": image, "sampler": sampler} | fields)

    def sparse(self, base: Any, indices: Any, values: Any, kind: str, count: int = 0) -> int:
        """A sparse accessor (glTF 3.6.2.3), float (unsigned int for SCALAR: indices): `base` (zeros
        where None: no bufferView, `count` of them) with the elements at `indices` replaced by `values`."""
        scalar = kind == "SCALAR"
        values = np.ascontiguousarray(values, np.uint32 if scalar else np.float32).reshape(len(indices), -1)
        if base is not None:
            k = self.accessor(np.asarray(base).ravel() if scalar else np.asarray(base), kind)
        else:
            k = self._append("accessors", {"componentType": UNSIGNED_INT if scalar else FLOAT, "count": count, "type": kind})
        accessor = self.json["accessors"][k]
        accessor["sparse"] = {"count": len(indices),
                              "indices": {"bufferView": self.view(np.asarray(indices, np.uint16).tobytes()),
                                          "componentType": 5123},
                              "values": {"bufferView": self.view(values.tobytes())}}
        accessor.pop("min", None), accessor.pop("max", None)
        return k

    def raw_accessor(self, array: Any, kind: str, component: int = FLOAT) -> int:
        """An accessor of any element type (SCALAR, VEC4, MAT4...) and component type, as given."""
        dtype = {FLOAT: np.float32, UNSIGNED_INT: np.uint32, 5123: np.uint16, 5121: np.uint8}[component]
        data = np.ascontiguousarray(array, dtype)
        return self._append("accessors", {"bufferView": self.view(data.tobytes()), "componentType": component,
                                          "count": len(data), "type": kind})

    def animation(self, *channels: tuple[int, str, Any, Any, str]) -> int:
        """An animation of (node, path, keyframe times, values (rows; CUBICSPLINE: in-tangent, value,
        out-tangent rows a keyframe), interpolation) channels, a sampler each."""
        samplers, targets = [], []
        for s, (node, path, times, values, interpolation) in enumerate(channels):
            values = np.asarray(values, np.float32)
            kind = "SCALAR" if values.ndim == 1 else f"VEC{values.shape[1]}"
            samplers.append({"input": self.raw_accessor(np.asarray(times), "SCALAR"),
                             "output": self.raw_accessor(values, kind), "interpolation": interpolation})
            targets.append({"sampler": s, "target": {"node": node, "path": path}})
        return self._append("animations", {"samplers": samplers, "channels": targets})

    def light(self, **fields: Any) -> int:
        extensions = self.json.setdefault("extensions", {}).setdefault("KHR_lights_punctual", {"lights": []})
        extensions["lights"].append(fields)
        self.json.setdefault("extensionsUsed", []).append("KHR_lights_punctual")
        return len(extensions["lights"]) - 1

    def write(self, path: Path) -> Path:
        """A .glb (the buffer in its BIN chunk) or a .gltf with the buffer in `<stem>.bin` beside it."""
        blob = bytes(self.blob) + b"\0" * (-len(self.blob) % 4)
        if path.suffix == ".gltf":
            (path.parent / f"{path.stem}.bin").write_bytes(blob)
            path.write_text(json.dumps(self.json | {"buffers": [{"uri": f"{path.stem}.bin", "byteLength": len(blob)}]}))
            return path
        text = json.dumps(self.json | {"buffers": [{"byteLength": len(blob)}]}).encode()
        text += b" " * (-len(text) % 4)
        chunks = struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(blob), 0x004E4942) + blob
        path.write_bytes(struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks)
        return path


def quaternion(axis: tuple[float, float, float], degrees: float) -> list[float]:
    """glTF's XYZW rotation quaternion."""
    half = np.radians(degrees) / 2.0
    return [*(np.sin(half) * np.asarray(axis, float) / np.linalg.norm(axis)).tolist(), float(np.cos(half))]


def skinned_column(w: GltfWriter, material: int, translation: tuple[float, float, float] = (0.0, 0.0, 0.0),
                   keys: tuple[float, ...] = (0.0, 60.0, 0.0), interpolation: str = "LINEAR", rings: int = 8,
                   sides: int = 4) -> int:
    """A column 2 high along +Y (a square 0.4 wide, or with more `sides` a tube as wide; `rings`
    bands; file normals), skinned to two bones: the root joint at its foot (the node `translation`)
    and a child joint 1 above it, which the file's animation turns about Z through `keys` degrees
    at t = 0, 1, 2... The vertices below y = 0.5 follow the root, those above 1.5 the child, those
    between a blend (wide enough that no triangle folds over at 60 degrees). Returns the root."""
    heights = np.linspace(0.0, 2.0, rings + 1)
    angles = np.radians(225.0) + 2.0 * np.pi * np.arange(sides) / sides  # sides = 4: the square's corners
    around = np.hypot(0.2, 0.2) * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    positions = np.array([[x, y, z] for y in heights for x, z in around])
    normals = np.array([[x, 0.0, z] for _ in heights for x, z in around]) / np.hypot(0.2, 0.2)
    n, top = sides, sides * rings
    faces = [[n * r + k, n * r + n + (k + 1) % n, n * r + (k + 1) % n] for r in range(rings) for k in range(n)]
    faces += [[n * r + k, n * r + n + k, n * r + n + (k + 1) % n] for r in range(rings) for k in range(n)]
    faces += [[0, k, k + 1] for k in range(1, n - 1)] + [[top, top + k + 1, top + k] for k in range(1, n - 1)]  # the ends
    upper = np.clip(positions[:, 1] - 0.5, 0.0, 1.0)
    primitive = w.primitive(positions, np.array(faces), normals, material=material)
    primitive["attributes"]["JOINTS_0"] = w.raw_accessor(np.tile([0, 1, 0, 0], (len(positions), 1)), "VEC4", 5123)
    primitive["attributes"]["WEIGHTS_0"] = w.raw_accessor(
        np.stack([1.0 - upper, upper, 0.0 * upper, 0.0 * upper], axis=1), "VEC4")
    root = w.node(name="Root", translation=list(translation))
    bend = w.node(root=False, name="Bend", translation=[0.0, 1.0, 0.0])
    w.json["nodes"][root]["children"] = [bend]
    # Inverse bind matrices: the joints' world matrices at bind time, inverted (column-major).
    binds = np.stack([np.eye(4), np.eye(4)])
    binds[0, :3, 3] = -np.asarray(translation)
    binds[1, :3, 3] = -np.asarray(translation) - (0.0, 1.0, 0.0)
    w.json["skins"] = [{"joints": [root, bend], "inverseBindMatrices": w.raw_accessor(
        binds.transpose(0, 2, 1).reshape(-1, 16), "MAT4")}]
    w.node(name="Column", mesh=w.mesh(primitive), skin=0)
    w.animation((bend, "rotation", [float(t) for t in range(len(keys))], [quaternion((0, 0, 1), a) for a in keys],
                 interpolation))
    return root


def bending_scene(path: Path, rings: int = 8, sides: int = 4) -> Path:
    """A wall mirror, the skinned column (skinned_column's `rings` and `sides`) before it, bending
    60 degrees at t = 1, a red box, and a camera looking at the mirror from the side (the column's
    reflection clear of the column)."""
    w = GltfWriter()
    chrome = w.material("Chrome", (0.95, 0.95, 0.95), metallic=1.0, roughness=0.0)
    w.node(name="Mirror", mesh=w.mesh(w.primitive([[-2, 0, -1.2], [2, 0, -1.2], [2, 0, 1.2], [-2, 0, 1.2]],
                                                  [[0, 2, 1], [0, 3, 2]], [[0, 1, 0]] * 4, material=chrome)),
           translation=[0.0, 1.2, -1.2], rotation=quaternion((1, 0, 0), 90))
    skinned_column(w, w.material("Blue", (0.2, 0.5, 0.9)), translation=(0.3, 0.0, -0.3), rings=rings, sides=sides)
    w.node(name="Red", mesh=w.mesh(w.box(0.5, w.material("Red", (0.8, 0.1, 0.1)), normals=True)),
           translation=[-1.0, 0.25, 0.3])
    w.json["cameras"] = [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.05}}]
    half_y, half_x = math.radians(25) / 2, math.radians(-12) / 2  # turned left about Y, then tipped down about X
    yaw, pitch = np.array([0, math.sin(half_y), 0, math.cos(half_y)]), np.array([math.sin(half_x), 0, 0, math.cos(half_x)])
    rotation = [yaw[3] * pitch[0], yaw[1] * pitch[3], -yaw[1] * pitch[0], yaw[3] * pitch[3]]  # yaw * pitch (x y z w)
    w.node(camera=0, translation=[2.4, 1.6, 3.6], rotation=rotation)
    # Behind the column and to its right: its side the mirror shows is lit.
    w.node(extensions={"KHR_lights_punctual": {"light": w.light(type="point", intensity=20.0)}}, translation=[1.5, 2.5, -0.9])
    return w.write(path)
