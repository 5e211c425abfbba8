"""What the file fuzzer (tests/test_fuzz_files.py) mutates, and the worker that runs each case.

Seeds are small valid files built here: a glTF scene (a textured box with its own normals, a
mirror quad, a triangle strip, a sparse accessor, a light, a camera and a node tree), written as a
.glb, as a .gltf beside its .bin and .png, or as a .gltf of data URIs; and a TOML scene whose floor
is an image texture (PNG, JPEG, BMP or GIF) under an equirect sky (Radiance .hdr or OpenEXR .exr).
Mutations are what a hostile or broken file does: a JSON value replaced by another kind or a
boundary number, a key or element removed or repeated, bytes flipped, a file cut short, an image
header's size fields (PNG's IHDR, JPEG's SOF0, BMP's and GIF's, Radiance's resolution line,
OpenEXR's dataWindow) set to what a hypothesis draws.
"""

from __future__ import annotations

import base64
import copy
import io
import json
import os
import selectors
import struct
import subprocess
import sys
import tempfile
import zlib
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image

from depthimpostor.hdr import write_hdr
from gltf_files import GltfWriter, quaternion

PROJECT_ROOT = Path(__file__).resolve().parents[1]

#: Values a mutation puts in place of a JSON value: other kinds, and numbers at the edges of what
#: counts, indices, offsets and strides may be.
HOSTILE_VALUES: tuple[Any, ...] = (
    None, True, False, "", "x", "data:,", "../x.bin", "/etc/passwd", "file:///etc/passwd", "a" * 300, [], {}, [4],
    {"a": 1}, [[[[[]]]]], [0] * 20, -1, -5, 0, 1, 2, 3, 4, 6, 7, 252, 253, 1000, 65535, 2**24, 2**31 - 1, 2**32,
    2**53, 2**64, -(2**63), 10**100, 0.5, -0.0, 1e-300, 1e308, -1e308, float("nan"), float("inf"), float("-inf"),
)


# --- seeds ------------------------------------------------------------------------------------------------


def checker_png(size: int = 8) -> bytes:
    cells = (np.indices((size, size)).sum(axis=0) % 2).astype(np.uint8)
    pixels = np.stack([cells * 200 + 30, cells * 90 + 60, 255 - cells * 200], axis=-1)
    buffer = io.BytesIO()
    Image.fromarray(pixels.astype(np.uint8)).save(buffer, format="PNG")
    return buffer.getvalue()


def gltf_seed() -> GltfWriter:
    """A valid scene that uses most of what the reader reads."""
    w = GltfWriter()
    wood = w.material("Wood", (0.8, 0.7, 0.6))
    w.json["materials"][wood]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": w.image_texture(checker_png())}
    box = w.box(0.5, material=wood, normals=True)
    box["attributes"]["TEXCOORD_0"] = w.accessor(np.tile([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]], (8, 1))[:8], "VEC2")
    chrome = w.material("Chrome", metallic=1.0, roughness=0.0)
    quad = w.primitive([[-1, 0, -1], [1, 0, -1], [-1, 2, -1], [1, 2, -1]], [0, 1, 2, 3], material=chrome, mode=5)
    moved = w.sparse([[0, 0, 0], [0.3, 0, 0], [0, 0.3, 0]], [1], [[0.4, 0.0, 0.0]], "VEC3")
    child = w.node(root=False, name="Child", mesh=w.mesh({"attributes": {"POSITION": moved}}, name="tri"),
                   translation=[0.5, 0.2, 0.0])
    w.node(name="Box", mesh=w.mesh(box, name="box"), translation=[0.0, 0.5, 1.0], rotation=quaternion((0, 1, 0), 30),
           scale=[1.0, 1.2, 1.0], children=[child])
    w.node(name="Mirror", mesh=w.mesh(quad, name="mirror"))
    w.json["cameras"] = [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.05}}]
    w.node(name="Camera", camera=0, translation=[0.0, 1.0, 4.0])
    w.node(name="Sun", extensions={"KHR_lights_punctual": {"light": w.light(type="directional", intensity=2.0)}},
           rotation=quaternion((1, 0, 0), -60))
    return w


def write_gltf(json_data: dict[str, Any], blob: bytes, image: bytes, folder: Path, container: str) -> Path:
    """The scene as a .glb (its image in a buffer view, as the seed has it), a .gltf beside x.bin
    and wood.png, or a .gltf of data URIs."""
    data = json.loads(json.dumps(json_data))  # a copy
    if container == "glb":
        text = json.dumps(data).encode() if "buffers" in data else json.dumps(data | {"buffers": [{"byteLength": len(blob)}]}).encode()
        text += b" " * (-len(text) % 4)
        blob += b"\0" * (-len(blob) % 4)
        chunks = struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(blob), 0x004E4942) + blob
        path = folder / "x.glb"
        path.write_bytes(struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks)
        return path
    if container == "gltf":
        (folder / "x.bin").write_bytes(blob)
        (folder / "wood.png").write_bytes(image)
        buffer: dict[str, Any] = {"uri": "x.bin", "byteLength": len(blob)}
        image_entry: dict[str, Any] = {"uri": "wood.png"}
    else:
        buffer = {"uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode(), "byteLength": len(blob)}
        image_entry = {"uri": "data:image/png;base64," + base64.b64encode(image).decode()}
    data.setdefault("buffers", [buffer])
    if isinstance(data.get("images"), list) and data["images"] and isinstance(data["images"][0], dict) \
            and "bufferView" in data["images"][0]:
        data["images"][0] = image_entry
    path = folder / "x.gltf"
    path.write_text(json.dumps(data))
    return path


def locations(value: Any, path: tuple[Any, ...] = ()) -> Iterator[tuple[Any, ...]]:
    """The path of every value in a JSON document (keys and indices), depth first."""
    if isinstance(value, dict):
        for key, item in value.items():
            yield path + (key,)
            yield from locations(item, path + (key,))
    elif isinstance(value, list):
        for k, item in enumerate(value):
            yield path + (k,)
            yield from locations(item, path + (k,))


def _parent(document: Any, path: tuple[Any, ...]) -> tuple[Any, Any] | None:
    """The container holding `path`'s value and its key, where the path still leads somewhere."""
    node = document
    for key in path[:-1]:
        if isinstance(node, dict) and key in node or isinstance(node, list) and isinstance(key, int) and key < len(node):
            node = node[key]
        else:
            return None
    last = path[-1]
    if isinstance(node, dict) and last in node or isinstance(node, list) and isinstance(last, int) and last < len(node):
        return node, last
    return None


def mutate_json(document: Any, op: tuple[Any, ...]) -> None:
    """One mutation, in place: ("set", path, value), ("nudge", path, delta), ("delete", path),
    ("repeat", path); a path a former mutation removed is left alone."""
    found = _parent(document, op[1])
    if found is None:
        return
    node, key = found
    if op[0] == "set":
        node[key] = copy.deepcopy(op[2])  # the strategy's own list or object stays as it is
    elif op[0] == "nudge" and isinstance(node[key], (int, float)) and not isinstance(node[key], bool):
        node[key] = type(node[key])(node[key] * op[2]) if isinstance(op[2], float) else node[key] + op[2]
    elif op[0] == "delete":
        del node[key]
    elif op[0] == "repeat" and isinstance(node, list):
        node.insert(key, json.loads(json.dumps(node[key])))


def mutate_bytes(data: bytes, op: tuple[Any, ...]) -> bytes:
    """("flip", offset, byte) or ("cut", offset), the offset taken modulo the length."""
    if not data:
        return data
    offset = op[1] % len(data)
    if op[0] == "flip":
        return data[:offset] + bytes([op[2] % 256]) + data[offset + 1:]
    return data[:offset]


# --- image seeds and their size fields ----------------------------------------------------------------------


def _png_chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


def with_png_header(png: bytes, width: int, height: int, depth: int, colour: int, crc: bool) -> bytes:
    """The PNG with its IHDR's width, height, bit depth and colour type replaced (its CRC made
    right, or left as it was)."""
    body = struct.pack(">II", width % 2**32, height % 2**32) + bytes([depth % 256, colour % 256]) + png[26:29]
    chunk = _png_chunk(b"IHDR", body) if crc else png[8:16] + body + png[29:33]
    return png[:8] + chunk + png[33:]


def texture_seed(kind: str) -> bytes:
    """An 8x8 checker as PNG, JPEG, BMP or GIF."""
    if kind == "png":
        return checker_png()
    buffer = io.BytesIO()
    Image.open(io.BytesIO(checker_png())).convert("RGB").save(buffer, format=kind.upper())
    return buffer.getvalue()


def with_size_fields(data: bytes, kind: str, width: int, height: int) -> bytes:
    """A JPEG's, BMP's or GIF's header with its width and height replaced (where its format keeps them)."""
    if kind == "bmp":
        return data[:18] + struct.pack("<ii", _int32(width), _int32(height)) + data[26:]
    if kind == "gif":
        return data[:6] + struct.pack("<HH", width % 2**16, height % 2**16) + data[10:]
    start = data.find(b"\xff\xc0")  # JPEG's SOF0: length (2), precision (1), height (2), width (2)
    if start < 0:
        return data
    return data[:start + 5] + struct.pack(">HH", height % 2**16, width % 2**16) + data[start + 9:]


def sky_seed(kind: str, folder: Path) -> bytes:
    sky = np.linspace(0.2, 2.0, 8 * 4 * 3, dtype=np.float32).reshape(4, 8, 3)
    path = folder / f"seed.{kind}"
    with open(path, "wb") as file:
        write_hdr(file, sky, f".{kind}")
    return path.read_bytes()


def with_sky_size(data: bytes, kind: str, box: tuple[int, int, int, int]) -> bytes:
    """A Radiance file's resolution line, or an OpenEXR file's dataWindow, replaced."""
    if kind == "hdr":
        start = data.index(b"\n\n") + 2
        end = data.index(b"\n", start)
        axes = (b"-Y", b"+X") if box[0] % 2 == 0 else (b"+X", b"-Y")
        line = b"%s %d %s %d" % (axes[0], box[1], axes[1], box[2])
        return data[:start] + line + data[end:]
    at = data.index(b"dataWindow\0box2i\0") + len(b"dataWindow\0box2i\0") + 4
    return data[:at] + struct.pack("<4i", *(_int32(v) for v in box)) + data[at + 16:]


def _int32(value: int) -> int:
    return max(-(2**31), min(2**31 - 1, value))


TEXTURED_SCENE = """[camera]
eye = [0.0, 1.0, 3.0]
target = [0.0, 0.3, 0.0]

[environment]
type = "equirect"
path = "sky.{sky}"

[[lights]]
type = "directional"
direction = [-0.3, -1.0, -0.4]

[[objects]]
name = "floor"
shape = {{ type = "plane", size = [4.0, 4.0] }}
material = {{ type = "diffuse", texture = {{ path = "floor.{texture}", scale = [2.0, 2.0] }} }}

[[objects]]
name = "mirror"
shape = {{ type = "plane", size = [1.5, 1.0] }}
material = {{ type = "mirror" }}
position = [0.0, 0.5, -1.0]
rotation = [90.0, 0.0, 0.0]

[[objects]]
name = "ball"
shape = {{ type = "sphere", radius = 0.3 }}
material = {{ type = "diffuse", color = [0.8, 0.3, 0.2] }}
position = [0.0, 0.3, 0.5]
"""


# --- the worker -------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Result:
    outcome: str  # "rendered", "refused", "bug", or "hang" (no answer in time: the worker is restarted)
    message: str
    growth: int  # the worker's peak resident bytes while it ran the case, over what it held before
    stray: int  # bytes written to its file descriptors 1 and 2 besides the answer


class Worker:
    """tests/fuzz_worker.py, run apart: `run` sends it a scene path and waits for its answer."""

    #: Its data segment's cap: far past any budget (MAX_DECODED_BYTES is 2 GiB), so that only a
    #: runaway allocation meets it.
    DATA_LIMIT = 4 * 2**30

    def __init__(self) -> None:
        self.log = tempfile.TemporaryFile()  # noqa: SIM115 (the worker's stderr, as long as it runs)
        self.process: subprocess.Popen[str] | None = None

    def _start(self) -> subprocess.Popen[str]:
        env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(PROJECT_ROOT), str(PROJECT_ROOT / "tests")]))
        return subprocess.Popen([sys.executable, str(PROJECT_ROOT / "tests" / "fuzz_worker.py"), str(self.DATA_LIMIT)],
                                stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self.log, text=True, env=env)

    def run(self, path: Path, timeout: float) -> Result:
        if self.process is None:
            self.process = self._start()
        assert self.process.stdin is not None and self.process.stdout is not None
        self.process.stdin.write(f"{path}\n")
        self.process.stdin.flush()
        with selectors.DefaultSelector() as selector:
            selector.register(self.process.stdout, selectors.EVENT_READ)
            ready = selector.select(timeout)
        line = self.process.stdout.readline() if ready else ""
        if not line:
            self.close()
            return Result("hang", f"no answer within {timeout:g} s (or the worker died)", 0, 0)
        answer = json.loads(line)
        return Result(answer["outcome"], answer["message"], answer["growth"], answer["stray"])

    def close(self) -> None:
        if self.process is not None:
            self.process.kill()
            self.process.wait()
            self.process = None

    def release(self) -> None:
        self.close()
        self.log.close()
