"""A glTF 2.0 file (.gltf or .glb) read into what the scene needs: its JSON, checked, the world
matrix of every node of its scene, and each triangle primitive's arrays, decoded by gltf_data.py.

Everything is read here from the JSON, which is plain data, and the buffers (gltf_data.py): the
extensions KHR_lights_punctual, KHR_materials_transmission, KHR_materials_ior and
KHR_materials_emissive_strength
(`ignored_features` names those used but not read), the exact material factors, the primitive
modes, the node tree. (trimesh decoded the geometry once; it dropped sparse substitutions and
texture errors, decoded every texture again, read every accessor and node before a count could be
checked, and placed a camera by its own node's matrix alone.) A hostile file is refused before it
costs time or memory: the JSON's size in objects before it is parsed, every accessor's count and
place before a byte is decoded (`primitive_size`), and the scene's sum of them (gltf.py).

Every problem is a SceneError naming the file and the JSON path: `x.glb: nodes[2].matrix: ...`.
"""

from __future__ import annotations

import json
import re
import struct
import sys
import urllib.parse
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from depthimpostor.constants import MAX_COORDINATE
from depthimpostor.errors import SceneError
from depthimpostor.meshes import Mesh
from depthimpostor.scene.fields import At, Reader, leaves_folder, numbers, read_file_bytes, show
from depthimpostor.scene.gltf_data import GltfData, Layout
from depthimpostor.scene.tangents import generated_tangents

GLTF_SUFFIXES = (".glb", ".gltf")
#: The extensions read here. A file may require (`extensionsRequired`) these alone: any other
#: required one changes what the file means in a way this reader would get wrong (Draco, quantized
#: or basisu data would be misread), so the file is refused, naming it. Any other it merely uses is
#: drawn as if absent, and `ignored_features` names it.
SUPPORTED_REQUIRED = ("KHR_lights_punctual", "KHR_materials_transmission", "KHR_materials_ior",
                      "KHR_materials_emissive_strength", "KHR_texture_transform", "EXT_texture_webp")

# Primitive modes (glTF 2.0, 3.7.2.1): the triangles read, and what has no surface.
TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN = 4, 5, 6
NOT_SURFACES = {0: "points", 1: "lines", 2: "a line loop", 3: "a line strip"}

_GLB_MAGIC, _GLB_JSON = b"glTF", 0x4E4F534A

#: The most JSON objects and values a glTF file's JSON may hold, counted in its bytes (every `{`,
#: every `,`; within strings too, so an upper bound) before it is parsed: Python's JSON reader
#: takes about 3 s and 300 MB for a million small objects (a million nodes). A real file keeps its
#: data in buffers: its JSON holds thousands of objects, rarely a hundred thousand.
MAX_JSON_OBJECTS, MAX_JSON_VALUES = 2**18, 2**22


def read_json(path: Path, source: str) -> dict[str, Any]:
    """The file's JSON: the whole of a .gltf, the first chunk of a .glb."""
    data = read_file_bytes(path, source, "a glTF file")
    if path.suffix.lower() == ".glb":
        if len(data) < 20 or data[:4] != _GLB_MAGIC:
            raise SceneError(source, "", f'expected a binary glTF file (starting with "glTF"), got {show(data[:4])}')
        length, kind = struct.unpack_from("<II", data, 12)
        if kind != _GLB_JSON or 20 + length > len(data):
            raise SceneError(source, "", "expected a binary glTF file whose first chunk is its JSON, got a "
                                         "damaged or truncated file")
        data = data[20:20 + length]
    for what, count, most in (("objects", data.count(b"{"), MAX_JSON_OBJECTS), ("values", data.count(b","), MAX_JSON_VALUES)):
        if count > most:
            raise SceneError(source, "", f"expected glTF JSON of at most {most:,} {what} (nodes, accessors, ...: its "
                                         f"data belongs in buffers), got about {count:,}")
    try:
        header = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        raise SceneError(source, "", f"expected glTF JSON, got a file that is not JSON: {err}") from err
    except RecursionError:
        raise SceneError(source, "", "expected glTF JSON, got arrays or objects nested too deep to read "
                                     f"(over {sys.getrecursionlimit()} levels)") from None
    if not isinstance(header, dict):
        raise SceneError(source, "", f"expected glTF JSON (an object at the top), got {show(header)}")
    return header


def table(value: Any, at: At) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise at.error(f"expected a JSON object, got {show(value)}")
    return value


def items(header: Mapping[str, Any], key: str, source: str) -> list[Mapping[str, Any]]:
    """The array of objects at `key` (empty when absent)."""
    value = header.get(key, [])
    if not isinstance(value, list):
        raise At(source, key).error(f"expected an array, got {show(value)}")
    for i, item in enumerate(value):  # the place of an item is made for its message alone: lists are long
        if not isinstance(item, dict):
            table(item, At(source, key).index(i))
    return value


def index(value: Any, count: int, at: At) -> int:
    if not (isinstance(value, int) and not isinstance(value, bool) and 0 <= value < count):
        raise at.error(f"expected an index in [0, {count}), got {show(value)}")
    return value


def check_header(header: Mapping[str, Any], source: str, folder: Path) -> None:
    """The version, the required extensions and the files the JSON names."""
    version = str(table(header.get("asset", {}), At(source, "asset")).get("version", ""))
    if not version.startswith("2."):
        raise SceneError(source, "asset.version", f'expected glTF "2.0", got {show(version)}')
    required = header.get("extensionsRequired", [])
    unsupported = [name for name in required if name not in SUPPORTED_REQUIRED] if isinstance(required, list) else [required]
    if unsupported:
        raise SceneError(source, "extensionsRequired", f"expected only extensions this reader supports "
                         f"({', '.join(SUPPORTED_REQUIRED)}), got {', '.join(show(name) for name in unsupported)}")
    for key in ("buffers", "images"):
        for i, item in enumerate(items(header, key, source)):
            uri = item.get("uri")
            if isinstance(uri, str) and not uri.startswith("data:"):
                _check_uri(uri, folder, At(source, f"{key}[{i}].uri"))


#: A URI with a scheme (`file:`, `http:`...): glTF's other URIs are relative to the file.
_SCHEME = re.compile(r"[A-Za-z][A-Za-z0-9+.-]*:")


def _check_uri(uri: str, folder: Path, at: At) -> None:
    """A buffer's or image's URI: a relative path to a file in the glTF file's folder or below it,
    as a TOML scene's relative paths are (fields.leaves_folder: the one rule, scene_format.md's
    "Paths"). Not an absolute path or another scheme: a file from elsewhere must not read the
    reader's files."""
    path = urllib.parse.unquote(uri)
    if _SCHEME.match(uri) or path.startswith("/"):
        raise at.error(f"expected a data: URI or a path relative to the glTF file, got {show(uri)}")
    if leaves_folder(path):
        raise at.error(f"expected a file in the glTF file's folder or below it (in {folder}), got {show(uri)}, "
                       "which leaves it")
    try:
        found = (folder / path).is_file()
    except OSError as error:  # a name too long for the file system
        raise at.error(f"expected a file next to the glTF file, got {show(uri)}: {error.strerror or error}") from None
    if not found:
        raise at.error(f"expected a file next to the glTF file (in {folder}), got {show(uri)}: no such file")


def _extension_names(value: Any) -> Iterator[str]:
    """The name of every extension object anywhere in the JSON (files do not always list what they
    use in `extensionsUsed`), but in `extras`, which is the application's own data. (A stack, not
    recursion: the JSON may nest as deep as the JSON reader went.)"""
    stack = [value]
    while stack:  # JSON's objects are dicts (no slower Mapping checks: a file may hold 10^5 of them)
        item = stack.pop()
        if type(item) is dict:
            extensions = item.get("extensions")
            if type(extensions) is dict:
                yield from (name for name in extensions if isinstance(name, str))
            stack.extend(child for key, child in item.items() if key != "extras" and type(child) in (dict, list))
        elif type(item) is list:
            stack.extend(child for child in item if type(child) in (dict, list))


#: The UV sets a texture may read (TEXCOORD_0 and TEXCOORD_1): a texture info's texCoord past them
#: is listed as ignored and reads TEXCOORD_0.
UV_SETS = 2


def _material_features(material: Mapping[str, Any]) -> Iterator[str]:
    """The core material properties a material uses that are not drawn (scene_format.md says what
    is): a texture on a UV set past TEXCOORD_1 (alphaMode MASK and BLEND are drawn)."""
    pbr = material.get("pbrMetallicRoughness", {})
    pbr = pbr if isinstance(pbr, Mapping) else {}
    infos = [("baseColorTexture", pbr.get("baseColorTexture")), ("metallicRoughnessTexture", pbr.get("metallicRoughnessTexture")),
             ("normalTexture", material.get("normalTexture")), ("occlusionTexture", material.get("occlusionTexture")),
             ("emissiveTexture", material.get("emissiveTexture"))]
    for key, info in infos:
        if not isinstance(info, Mapping):
            continue
        if not _read_set(info.get("texCoord", 0)):
            yield f"{key}.texCoord {info.get('texCoord')} (TEXCOORD_0 and TEXCOORD_1 are read)"
        extensions = info.get("extensions")
        transform = extensions.get("KHR_texture_transform") if isinstance(extensions, Mapping) else None
        if isinstance(transform, Mapping) and not _read_set(transform.get("texCoord", 0)):
            yield f"{key}.KHR_texture_transform.texCoord {transform.get('texCoord')} (TEXCOORD_0 and TEXCOORD_1 are read)"


def _read_set(value: Any) -> bool:
    """Is a texCoord one of the UV sets read (a whole number below UV_SETS)?"""
    return isinstance(value, int) and not isinstance(value, bool) and 0 <= value < UV_SETS


def texture_set(info: Mapping[str, Any]) -> int:
    """The UV set a texture info reads: KHR_texture_transform's texCoord where it gives one (the
    extension's overrides the info's), else the info's; 0 for one not read (listed as ignored)."""
    extensions = info.get("extensions")
    transform = extensions.get("KHR_texture_transform") if isinstance(extensions, Mapping) else None
    value = transform["texCoord"] if isinstance(transform, Mapping) and "texCoord" in transform else info.get("texCoord", 0)
    return value if _read_set(value) else 0


def ignored_features(header: Mapping[str, Any]) -> tuple[str, ...]:
    """What the file uses that this loader does not implement, each named once, in a stable order:
    the extensions it uses but SUPPORTED_REQUIRED lacks (sorted), then the core features read past
    (material properties, the animations after the first). Such a file is drawn as
    if they were absent; `plan` lists them and loading warns once."""
    used = header.get("extensionsUsed", [])
    extensions = {name for name in used if isinstance(name, str)} if isinstance(used, list) else set()
    extensions |= set(_extension_names(header))
    features: dict[str, None] = {}  # ordered, each once
    materials = header.get("materials", [])
    for material in materials if isinstance(materials, list) else []:
        if isinstance(material, Mapping):
            features |= dict.fromkeys(_material_features(material))
    animations = header.get("animations", [])
    if isinstance(animations, list) and len(animations) > 1:  # gltf_animation.py plays the first alone
        features[f"{len(animations) - 1} animation(s) after the first (only animations[0] plays)"] = None
    return tuple(sorted(extensions - set(SUPPORTED_REQUIRED))) + tuple(features)


_PLACEMENT = ("matrix", "translation", "rotation", "scale")


def node_matrix(node: Mapping[str, Any], at: At) -> np.ndarray:
    """A node's local matrix: its `matrix` (column-major), or T @ R @ S from its TRS properties."""
    if "matrix" in node:
        matrix = np.array(at.key("matrix").read(node["matrix"], numbers(16)), dtype=np.float64).reshape(4, 4).T
        if not np.allclose(matrix[3], (0.0, 0.0, 0.0, 1.0)):
            raise at.key("matrix").error(f"expected an affine matrix (last row 0, 0, 0, 1), got {matrix[3].tolist()}")
        return matrix
    translation = at.key("translation").read(node.get("translation", [0, 0, 0]), numbers(3))
    quaternion = np.array(at.key("rotation").read(node.get("rotation", [0, 0, 0, 1]), numbers(4, nonzero=True)))
    x, y, z, w = quaternion / np.linalg.norm(quaternion)  # glTF's order; unit length, within rounding
    # R = I + 2w [v]x + 2 [v]x^2 for the unit quaternion (v, w), v = (x, y, z).
    cross = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    matrix = np.eye(4)
    matrix[:3, :3] = (np.eye(3) + 2.0 * w * cross + 2.0 * cross @ cross) @ np.diag(at.key("scale").read(
        node.get("scale", [1, 1, 1]), numbers(3)))
    matrix[:3, 3] = translation
    return matrix


def scene_nodes(header: Mapping[str, Any], source: str) -> list[tuple[int, np.ndarray]]:
    """Every node of the file's scene (`scene`, or the first) with its world matrix, depth first in
    the order the file lists them: parents before children, each child as parent @ local. (Walked
    once per file: it is as long as the file's node list, which may be long.)"""
    nodes, scenes = items(header, "nodes", source), items(header, "scenes", source)
    if not scenes:
        return []
    chosen = index(header.get("scene", 0), len(scenes), At(source, "scene"))
    roots = scenes[chosen].get("nodes", [])
    at = At(source, f"scenes[{chosen}].nodes")
    if not isinstance(roots, list):
        raise at.error(f"expected an array of node indices, got {show(roots)}")
    stack = [(index(root, len(nodes), at.index(i)), np.eye(4)) for i, root in enumerate(roots)][::-1]
    seen: set[int] = set()
    walked = []
    while stack:
        i, parent = stack.pop()
        if i in seen:
            raise SceneError(source, f"nodes[{i}]", "expected a node tree (each node with one parent, no cycles), "
                                                    "got a node reached twice")
        seen.add(i)
        # A node with no transform is the identity: its children keep its parent's matrix (and a
        # chain of 10^5 such nodes costs no matrix product, nor an At, a node).
        local = None if nodes[i].keys().isdisjoint(_PLACEMENT) else node_matrix(nodes[i], At(source, f"nodes[{i}]"))
        world = parent if local is None else parent @ local
        if local is not None and not np.isfinite(world).all():
            raise SceneError(source, f"nodes[{i}]", "expected finite transforms, got a world matrix that overflows")
        walked.append((i, world))
        children = nodes[i].get("children", [])
        if not isinstance(children, list):
            raise SceneError(source, f"nodes[{i}].children", f"expected an array of node indices, got {show(children)}")
        for k in range(len(children) - 1, -1, -1):
            child = children[k]
            if not (type(child) is int and 0 <= child < len(nodes)):  # its place made for the message alone
                index(child, len(nodes), At(source, f"nodes[{i}].children").index(k))
            stack.append((child, world))
    return walked


@dataclass(frozen=True, eq=False)
class Primitive:
    """One triangle primitive's arrays, in its mesh's local space."""

    positions: np.ndarray  # (N, 3)
    faces: np.ndarray  # (M, 3)
    normals: np.ndarray | None  # (N, 3) from the file's NORMAL, or None (glTF then asks for flat normals)
    uvs: np.ndarray | None  # (N, 2) TEXCOORD_0 in glTF's convention (v down from the image's top)
    tangents: np.ndarray | None = None  # (N, 4) TANGENT: xyz and the bitangent's sign w
    colors: np.ndarray | None = None  # (N, 4) COLOR_0, linear RGBA (alpha 1 where the file gives RGB)
    uvs1: np.ndarray | None = None  # (N, 2) TEXCOORD_1


def _flat_normals(positions: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """One unit normal per face, (0, 1, 0) for a face of no area (any unit vector keeps NaN out)."""
    a, b, c = (positions[faces[:, k]] for k in range(3))
    normals = np.cross(b - a, c - a)
    lengths = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.where(lengths > 1e-30, normals / np.maximum(lengths, 1e-300), (0.0, 1.0, 0.0))


#: A vertex normal shorter than this (zero in the file, or cancelled by a morph target) has no
#: direction to normalize: local_mesh gives it +Y instead of 0/0 (and deform.comp does the same).
MIN_NORMAL_LENGTH = 1e-13


def local_mesh(group: list[Primitive], tangent_set: int | None = None) -> Mesh:
    """The primitives of one node and material as one mesh, in the node's space. A primitive with
    the file's normals keeps them (and its shared vertices); one without gets flat normals, as the
    glTF specification asks, each triangle with its own three vertices (and the file's tangents,
    which the specification then says to ignore, are generated). `tangent_set` (the UV set its
    material's normal map reads; None: no normal map) asks for tangents: the file's where it gives
    them, else generated (scene/tangents.py: MikkTSpace, which splits a vertex whose corners get
    different tangents, every attribute copied, the faces re-indexed). TEXCOORD_1 and COLOR_0
    where any primitive has them (the others: zeros, and white)."""
    positions, normals, uvs, faces, start = [], [], [], [], 0
    extras: dict[str, list[np.ndarray]] = {"tangents": [], "colors": [], "uvs1": []}
    any_uvs = any(p.uvs is not None for p in group)
    wanted = {"tangents": tangent_set is not None, "colors": any(p.colors is not None for p in group),
              "uvs1": any(p.uvs1 is not None for p in group)}
    for p in group:
        if p.normals is not None:
            lengths = np.linalg.norm(p.normals, axis=1, keepdims=True)
            corners = np.arange(len(p.positions))
            normal = np.where(lengths > MIN_NORMAL_LENGTH, p.normals / np.maximum(lengths, 1e-300), (0.0, 1.0, 0.0))
            face = p.faces
        else:
            corners = p.faces.ravel()
            normal = np.repeat(_flat_normals(p.positions, p.faces), 3, axis=0)
            face = np.arange(len(corners)).reshape(-1, 3)
        if tangent_set is not None:
            tangents, kept, face = _tangents(p, corners, normal, face, tangent_set)
            corners, normal = corners[kept], normal[kept]  # MikkTSpace may split vertices
            extras["tangents"].append(tangents)
        positions.append(p.positions[corners])
        normals.append(normal)
        uvs.append(p.uvs[corners] if p.uvs is not None else np.zeros((len(corners), 2)))
        faces.append(face + start)
        if wanted["colors"]:
            extras["colors"].append(p.colors[corners] if p.colors is not None else np.ones((len(corners), 4)))
        if wanted["uvs1"]:
            extras["uvs1"].append(p.uvs1[corners] if p.uvs1 is not None else np.zeros((len(corners), 2)))
        start += len(corners)
    return Mesh(np.concatenate(positions), np.concatenate(normals), np.concatenate(faces),
                np.concatenate(uvs) if any_uvs else None,
                **{name: np.concatenate(values) for name, values in extras.items() if wanted[name]})


def _tangents(p: Primitive, corners: np.ndarray, normals: np.ndarray, faces: np.ndarray,
              uv_set: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A primitive's tangents at `corners` (faces indexing them), the corners they are on and the
    faces indexing those: the file's (with its normals: glTF ignores them beside flat normals),
    else MikkTSpace's from the UV set the normal map reads (scene/tangents.py), which may split a
    vertex in several (zero UVs where the primitive has not that set: the map then reads one
    texel, and the tangents are arbitrary)."""
    if p.tangents is not None and p.normals is not None:
        return p.tangents[corners], np.arange(len(corners)), faces
    uvs = p.uvs1 if uv_set == 1 else p.uvs
    chosen = uvs[corners] if uvs is not None else np.zeros((len(corners), 2))
    made = generated_tangents(p.positions[corners], normals, faces, chosen)
    return made.tangents, made.vertices, made.faces


def primitive_modes(header: Mapping[str, Any], source: str) -> Iterator[tuple[int, int, Mapping[str, Any], int]]:
    """(mesh, primitive, its JSON, its mode) for every primitive of every mesh, in file order."""
    for m, mesh in enumerate(items(header, "meshes", source)):
        primitives = mesh.get("primitives", [])
        if not isinstance(primitives, list):
            raise SceneError(source, f"meshes[{m}].primitives", f"expected an array, got {show(primitives)}")
        for p, value in enumerate(primitives):
            at = At(source, f"meshes[{m}].primitives[{p}]")
            primitive = table(value, at)
            mode = primitive.get("mode", TRIANGLES)
            if not (isinstance(mode, int) and not isinstance(mode, bool) and 0 <= mode <= TRIANGLE_FAN):
                raise at.key("mode").error(f"expected a primitive mode 0 to 6, got {show(mode)}")
            yield m, p, primitive, mode


#: The vertex attributes read, and their components: glTF requires these widths (3.7.2.1; COLOR_0
#: is RGB or RGBA).
ATTRIBUTES: dict[str, tuple[int, ...]] = {"POSITION": (3,), "NORMAL": (3,), "TEXCOORD_0": (2,), "TEXCOORD_1": (2,),
                                          "TANGENT": (4,), "COLOR_0": (3, 4)}
#: The component types glTF allows where an attribute is not float (3.7.2.1): normalized unsigned
#: bytes or shorts (signed ones for tangents are KHR_mesh_quantization's, which is not read).
NORMALIZED_ATTRIBUTES = ("TEXCOORD_0", "TEXCOORD_1", "COLOR_0")


@dataclass(frozen=True)
class PrimitiveSize:
    """What decoding a triangle primitive makes, from its accessors' counts alone."""

    triangles: int
    decoded_bytes: int  # its accessors as float64 / int64 arrays


def primitive_size(data: GltfData, primitive: Mapping[str, Any], mode: int, at: At) -> PrimitiveSize:
    """A triangle primitive's (TRIANGLES or TRIANGLE_STRIP) counts, every accessor it reads checked
    (type, count, place in its buffer) and nothing decoded: what a file claims is summed before
    any array is made."""
    attributes = table(primitive.get("attributes", {}), at.key("attributes"))
    if "POSITION" not in attributes:
        raise at.key("attributes").error("expected a POSITION attribute, got none")
    layouts: dict[str, Layout] = {}
    for name, widths in ATTRIBUTES.items():
        if name not in attributes:
            continue
        layout = data.layout(attributes[name], at.key("attributes").key(name))
        if layout.width not in widths:
            raise at.key("attributes").key(name).error(f"expected an accessor of {' or '.join(f'VEC{w}' for w in widths)}, "
                                                       f"got one of {layout.width} components")
        if name in NORMALIZED_ATTRIBUTES and layout.dtype.kind != "f" and not (
                layout.normalized and layout.dtype.kind == "u" and layout.dtype.itemsize <= 2):
            raise at.key("attributes").key(name).error(f"expected floats, or normalized unsigned bytes or shorts, got "
                                                       f"{'normalized ' if layout.normalized else ''}{layout.dtype.name}")
        if name == "TANGENT" and layout.dtype.kind != "f":
            raise at.key("attributes").key(name).error(f"expected floats, got {layout.dtype.name}")
        if name != "POSITION" and layout.count != layouts["POSITION"].count:
            raise at.key("attributes").key(name).error(f"expected {layouts['POSITION'].count} elements, as POSITION "
                                                       f"has, got {layout.count}")
        layouts[name] = layout
    corners, corners_at = layouts["POSITION"].count, at.key("attributes").key("POSITION")
    if "indices" in primitive:
        corners_at = at.key("indices")
        indices = data.layout(primitive["indices"], corners_at)
        if indices.width != 1 or indices.dtype.kind != "u":
            raise corners_at.error("expected an accessor of SCALAR unsigned integers (5121, 5123 or 5125), got one of "
                                   f"{indices.width} component(s) of {indices.dtype.name}")
        corners = indices.count
    if mode == TRIANGLES and corners % 3:
        raise corners_at.error(f"expected a count divisible by 3 (the corners of triangles), got {corners}")
    triangles = corners // 3 if mode == TRIANGLES else max(corners - 2, 0)
    return PrimitiveSize(triangles, sum(layout.decoded_bytes for layout in layouts.values()) + 8 * corners)


def decode_primitive(data: GltfData, primitive: Mapping[str, Any], mode: int, at: At) -> Primitive:
    """A triangle primitive's arrays (primitive_size checked its accessors): sparse substitutions
    made, normalized integers scaled (gltf_data.py), strips turned into triangles."""
    attributes = primitive["attributes"]
    positions = data.accessor(attributes["POSITION"]).astype(np.float64)
    normals, uvs, uvs1, tangents, colors = (data.accessor(attributes[name]).astype(np.float64) if name in attributes
                                            else None for name in ("NORMAL", "TEXCOORD_0", "TEXCOORD_1", "TANGENT", "COLOR_0"))
    if colors is not None and colors.shape[1] == 3:
        colors = np.c_[colors, np.ones(len(colors))]
    corners = data.accessor(primitive["indices"]).ravel() if "indices" in primitive \
        else np.arange(len(positions), dtype=np.int64)
    faces = corners.reshape(-1, 3) if mode == TRIANGLES else _strip_faces(corners)
    if faces.size and int(faces.max()) >= len(positions):
        raise at.key("indices").error(f"expected vertex indices below the POSITION count {len(positions)}, got "
                                      f"{int(faces.max())}")
    if not np.abs(positions).max(initial=0.0) <= MAX_COORDINATE:  # also NaN
        raise at.key("attributes").key("POSITION").error(
            f"expected vertex coordinates of magnitude at most {MAX_COORDINATE:g} (float32 geometry squares "
            f"distances), got {float(np.abs(positions).max()):g}")
    for name, values in (("TEXCOORD_0", uvs), ("TEXCOORD_1", uvs1), ("TANGENT", tangents), ("COLOR_0", colors)):
        if values is not None and not np.isfinite(values).all():
            what = "texture coordinates" if name.startswith("TEXCOORD") else "values"
            raise at.key("attributes").key(name).error(f"expected finite {what}, got NaN or infinity")
    if tangents is not None:
        tangents = _unit_tangents(tangents)
    return Primitive(positions, np.asarray(faces, np.int64), normals, uvs, tangents, colors, uvs1)


def _unit_tangents(tangents: np.ndarray) -> np.ndarray:
    """A file's tangents at unit length, their sign w +-1 (glTF asks for both; a zero tangent stays
    zero: the normal map then reads the normal's own direction there)."""
    lengths = np.linalg.norm(tangents[:, :3], axis=1, keepdims=True)
    along = np.where(lengths > 1e-13, tangents[:, :3] / np.maximum(lengths, 1e-300), 0.0)
    return np.c_[along, np.where(tangents[:, 3] < 0.0, -1.0, 1.0)]


def _strip_faces(corners: np.ndarray) -> np.ndarray:
    """A triangle strip's triangles (glTF 3.7.2.1): (c0, c1, c2), then (c3, c2, c1)... each second
    one turned so that all wind alike (written (c[i+2], c[i+1], c[i]), as trimesh writes them)."""
    faces = np.stack([corners[:-2], corners[1:-1], corners[2:]], axis=1) if len(corners) >= 3 \
        else np.zeros((0, 3), np.int64)
    faces[1::2] = faces[1::2, ::-1]
    return faces


def number_at(value: Mapping[str, Any], key: str, default: float, reader: Reader[float], at: At) -> float:
    """An optional number of a JSON object, read as strictly as a scene file's."""
    return at.key(key).read(value[key], reader) if key in value else default


def extension(value: Mapping[str, Any], name: str, at: At) -> Mapping[str, Any] | None:
    """The object's extension `name`, or None."""
    if "extensions" not in value:
        return None
    extensions = table(value["extensions"], at.key("extensions"))
    return table(extensions[name], at.key("extensions").key(name)) if name in extensions else None
