"""A glTF 2.0 file (.gltf or .glb) read into what the scene needs: its JSON, checked, the world
matrix of every node of its scene, and each triangle primitive's arrays, decoded by trimesh.

trimesh decodes the binary data (accessors, triangle strips, data URIs, external buffers), but
for what it reads wrongly: sparse accessors, whose substitutions it drops, and images, whose
errors it swallows, are read by gltf_data.py. What trimesh drops is read from the JSON, which is
plain data: the extensions KHR_lights_punctual, KHR_materials_transmission, KHR_materials_ior and
KHR_materials_emissive_strength
(`ignored_features` names those used but not read), the exact material factors (trimesh rounds baseColorFactor to 8 bits), the primitive modes, and the node
tree. The node tree's matrices are taken here too, because trimesh 5's scene graph leaves out the
children of a node that holds a camera and places a camera by its own node's matrix alone.

Every problem is a SceneError naming the file and the JSON path: `x.glb: nodes[2].matrix: ...`.
"""

from __future__ import annotations

import json
import struct
import urllib.parse
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from depthimpostor.constants import MAX_COORDINATE
from depthimpostor.errors import SceneError
from depthimpostor.meshes import Mesh
from depthimpostor.scene.fields import At, Reader, numbers, read_file_bytes, show
from depthimpostor.scene.gltf_data import GltfData

GLTF_SUFFIXES = (".glb", ".gltf")
#: The extensions read here. A file may require (`extensionsRequired`) these alone: any other
#: required one changes what the file means in a way this reader would get wrong (Draco, quantized
#: or basisu data would be misread), so the file is refused, naming it. Any other it merely uses is
#: drawn as if absent, and `ignored_features` names it.
SUPPORTED_REQUIRED = ("KHR_lights_punctual", "KHR_materials_transmission", "KHR_materials_ior",
                      "KHR_materials_emissive_strength", "KHR_texture_transform", "EXT_texture_webp")

# Primitive modes (glTF 2.0, 3.7.2.1): what trimesh decodes into triangles, and what has no surface.
TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN = 4, 5, 6
NOT_SURFACES = {0: "points", 1: "lines", 2: "a line loop", 3: "a line strip"}

_GLB_MAGIC, _GLB_JSON = b"glTF", 0x4E4F534A


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
    try:
        header = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        raise SceneError(source, "", f"expected glTF JSON, got a file that is not JSON: {err}") from err
    if not isinstance(header, dict):
        raise SceneError(source, "", f"expected glTF JSON (an object at the top), got {show(header)}")
    return header


def table(value: Any, at: At) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise at.error(f"expected a JSON object, got {show(value)}")
    return value


def items(header: Mapping[str, Any], key: str, source: str) -> list[Mapping[str, Any]]:
    """The array of objects at `key` (empty when absent)."""
    at, value = At(source, key), header.get(key, [])
    if not isinstance(value, list):
        raise at.error(f"expected an array, got {show(value)}")
    return [table(v, at.index(i)) for i, v in enumerate(value)]


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
            if isinstance(uri, str) and not uri.startswith("data:") and not (folder / urllib.parse.unquote(uri)).is_file():
                raise SceneError(source, f"{key}[{i}].uri", f"expected a file next to the glTF file (in {folder}), "
                                 f"got {show(uri)}: no such file")


def _extension_names(value: Any) -> Iterator[str]:
    """The name of every extension object anywhere in the JSON (files do not always list what they
    use in `extensionsUsed`), but in `extras`, which is the application's own data."""
    if isinstance(value, Mapping):
        for key, item in value.items():
            if key == "extensions" and isinstance(item, Mapping):
                yield from (name for name in item if isinstance(name, str))
            if key != "extras":
                yield from _extension_names(item)
    elif isinstance(value, list):
        for item in value:
            yield from _extension_names(item)


def _material_features(material: Mapping[str, Any]) -> Iterator[str]:
    """The core material properties a material uses that are not drawn (scene_format.md says what
    is): the normal map, a texture on another set than TEXCOORD_0, and blending (alphaMode MASK is
    drawn)."""
    pbr = material.get("pbrMetallicRoughness", {})
    pbr = pbr if isinstance(pbr, Mapping) else {}
    if "normalTexture" in material:
        yield "normalTexture"
    infos = [("baseColorTexture", pbr.get("baseColorTexture")), ("metallicRoughnessTexture", pbr.get("metallicRoughnessTexture")),
             ("occlusionTexture", material.get("occlusionTexture")), ("emissiveTexture", material.get("emissiveTexture"))]
    for key, info in infos:
        if not isinstance(info, Mapping):
            continue
        if info.get("texCoord", 0) != 0:
            yield f"{key}.texCoord"
        extensions = info.get("extensions")
        transform = extensions.get("KHR_texture_transform") if isinstance(extensions, Mapping) else None
        if isinstance(transform, Mapping) and transform.get("texCoord", 0) != 0:
            yield f"{key}.KHR_texture_transform.texCoord"
    if material.get("alphaMode", "OPAQUE") == "BLEND":
        yield "alphaMode BLEND"


def ignored_features(header: Mapping[str, Any]) -> tuple[str, ...]:
    """What the file uses that this loader does not implement, each named once, in a stable order:
    the extensions it uses but SUPPORTED_REQUIRED lacks (sorted), then the core features read past
    (material properties, vertex colours, the animations after the first). Such a file is drawn as
    if they were absent; `plan` lists them and loading warns once."""
    used = header.get("extensionsUsed", [])
    extensions = {name for name in used if isinstance(name, str)} if isinstance(used, list) else set()
    extensions |= set(_extension_names(header))
    features: dict[str, None] = {}  # ordered, each once
    materials = header.get("materials", [])
    for material in materials if isinstance(materials, list) else []:
        if isinstance(material, Mapping):
            features |= dict.fromkeys(_material_features(material))
    meshes = header.get("meshes", [])
    for mesh in meshes if isinstance(meshes, list) else []:
        primitives = mesh.get("primitives", []) if isinstance(mesh, Mapping) else []
        for primitive in primitives if isinstance(primitives, list) else []:
            if isinstance(primitive, Mapping) and "COLOR_0" in primitive.get("attributes", {}):
                features["COLOR_0 (vertex colours)"] = None
    animations = header.get("animations", [])
    if isinstance(animations, list) and len(animations) > 1:  # gltf_animation.py plays the first alone
        features[f"{len(animations) - 1} animation(s) after the first (only animations[0] plays)"] = None
    return tuple(sorted(extensions - set(SUPPORTED_REQUIRED))) + tuple(features)


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


def scene_nodes(header: Mapping[str, Any], source: str) -> Iterator[tuple[int, np.ndarray]]:
    """Every node of the file's scene (`scene`, or the first) with its world matrix, depth first in
    the order the file lists them: parents before children, each child as parent @ local."""
    nodes, scenes = items(header, "nodes", source), items(header, "scenes", source)
    if not scenes:
        return
    chosen = index(header.get("scene", 0), len(scenes), At(source, "scene"))
    roots = scenes[chosen].get("nodes", [])
    at = At(source, f"scenes[{chosen}].nodes")
    stack = [(index(root, len(nodes), at.index(i)), np.eye(4)) for i, root in enumerate(roots)][::-1]
    seen: set[int] = set()
    while stack:
        i, parent = stack.pop()
        if i in seen:
            raise SceneError(source, f"nodes[{i}]", "expected a node tree (each node with one parent, no cycles), "
                                                    "got a node reached twice")
        seen.add(i)
        world = parent @ node_matrix(nodes[i], At(source, f"nodes[{i}]"))
        if not np.isfinite(world).all():
            raise SceneError(source, f"nodes[{i}]", "expected finite transforms, got a world matrix that overflows")
        yield i, world
        children = nodes[i].get("children", [])
        if not isinstance(children, list):
            raise SceneError(source, f"nodes[{i}].children", f"expected an array of node indices, got {show(children)}")
        child_at = At(source, f"nodes[{i}].children")
        stack.extend((index(c, len(nodes), child_at.index(k)), world) for k, c in reversed(list(enumerate(children))))


@dataclass(frozen=True, eq=False)
class Primitive:
    """One triangle primitive's arrays, in its mesh's local space, as trimesh decoded them."""

    positions: np.ndarray  # (N, 3)
    faces: np.ndarray  # (M, 3)
    normals: np.ndarray | None  # (N, 3) from the file's NORMAL, or None (glTF then asks for flat normals)
    uvs: np.ndarray | None  # (N, 2) TEXCOORD_0 in glTF's convention (v down from the image's top)


def _flat_normals(positions: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """One unit normal per face, (0, 1, 0) for a face of no area (any unit vector keeps NaN out)."""
    a, b, c = (positions[faces[:, k]] for k in range(3))
    normals = np.cross(b - a, c - a)
    lengths = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.where(lengths > 1e-30, normals / np.maximum(lengths, 1e-300), (0.0, 1.0, 0.0))


def local_mesh(group: list[Primitive]) -> Mesh:
    """The primitives of one node and material as one mesh, in the node's space. A primitive with
    the file's normals keeps them (and its shared vertices); one without gets flat normals, as the
    glTF specification asks, each triangle with its own three vertices."""
    positions, normals, uvs, faces, start = [], [], [], [], 0
    any_uvs = any(p.uvs is not None for p in group)
    for p in group:
        if p.normals is not None:
            lengths = np.linalg.norm(p.normals, axis=1, keepdims=True)
            corners = np.arange(len(p.positions))
            normal = np.where(lengths > 1e-13, p.normals / np.maximum(lengths, 1e-300), (0.0, 1.0, 0.0))
            face = p.faces
        else:
            corners = p.faces.ravel()
            normal = np.repeat(_flat_normals(p.positions, p.faces), 3, axis=0)
            face = np.arange(len(corners)).reshape(-1, 3)
        positions.append(p.positions[corners])
        normals.append(normal)
        uvs.append(p.uvs[corners] if p.uvs is not None else np.zeros((len(corners), 2)))
        faces.append(face + start)
        start += len(corners)
    return Mesh(np.concatenate(positions), np.concatenate(normals), np.concatenate(faces),
                np.concatenate(uvs) if any_uvs else None)


def primitive_modes(header: Mapping[str, Any], source: str) -> Iterator[tuple[int, int, Mapping[str, Any], int]]:
    """(mesh, primitive, its JSON, its mode) for every primitive of every mesh, in file order."""
    for m, mesh in enumerate(items(header, "meshes", source)):
        primitives = mesh.get("primitives", [])
        if not isinstance(primitives, list):
            raise SceneError(source, f"meshes[{m}].primitives", f"expected an array, got {show(primitives)}")
        for p, value in enumerate(primitives):
            primitive = table(value, At(source, f"meshes[{m}].primitives[{p}]"))
            mode = primitive.get("mode", TRIANGLES)
            yield m, p, primitive, mode


def decode_primitives(data: GltfData) -> dict[tuple[int, int], Primitive]:
    """Each triangle primitive, by (mesh, primitive). trimesh's scene keeps one geometry per
    primitive it decodes (points, lines, triangles and strips; not loops, line strips or fans), in
    the file's order, whether a node uses it or not: that order pairs them with the JSON's. Where
    an accessor it reads is sparse, trimesh read its base alone: `data` reads it whole."""
    path, header, source = data.path, data.header, data.source
    import trimesh  # only glTF and model files need it

    try:
        with np.errstate(invalid="ignore", over="ignore"):
            loaded = trimesh.load(str(path), force="scene")
    except Exception as error:  # trimesh raises anything on a bad file; the user needs the name
        raise SceneError(source, "", f"cannot read the glTF file: {type(error).__name__}: {error}") from error
    if not isinstance(loaded, trimesh.Scene):  # force="scene" promises one
        raise SceneError(source, "", f"cannot read the glTF file: trimesh gave a {type(loaded).__name__}")
    decoded = [(m, p, primitive) for m, p, primitive, mode in primitive_modes(header, source) if mode in (0, 1, 4, 5)]
    geometry = list(loaded.geometry.values())
    if len(geometry) != len(decoded):
        raise SceneError(source, "meshes", f"expected trimesh to decode the file's {len(decoded)} primitives, "
                                           f"got {len(geometry)} (a damaged file, or one trimesh cannot read)")
    result = {}
    for (m, p, primitive), mesh in zip(decoded, geometry, strict=True):
        if primitive.get("mode", TRIANGLES) not in (TRIANGLES, TRIANGLE_STRIP):
            continue
        if not isinstance(mesh, trimesh.Trimesh):
            raise SceneError(source, f"meshes[{m}].primitives[{p}]", f"expected triangles, got {type(mesh).__name__}")
        visual = mesh.visual
        uvs = getattr(visual, "uv", None)
        if uvs is not None:
            uvs = np.asarray(uvs, np.float64).copy()
            uvs[:, 1] = 1.0 - uvs[:, 1]  # trimesh flips v for a lower-left origin; glTF's is the top-left
        has_normals = "NORMAL" in primitive.get("attributes", {})
        result[m, p] = _patched(data, primitive, Primitive(
            positions=np.asarray(mesh.vertices, np.float64), faces=np.asarray(mesh.faces, np.int64),
            normals=np.asarray(mesh.vertex_normals, np.float64) if has_normals else None, uvs=uvs),
            At(source, f"meshes[{m}].primitives[{p}]"))
    largest = max((float(np.abs(p.positions).max(initial=0.0)) for p in result.values()), default=0.0)
    if not largest <= MAX_COORDINATE:  # also NaN
        raise SceneError(source, "accessors", f"expected vertex coordinates of magnitude at most {MAX_COORDINATE:g} "
                                              f"(float32 geometry squares distances), got {largest:g}")
    return result


def _sparse(header: Mapping[str, Any], value: Any) -> bool:
    """Is accessors[value] sparse? (A bad index is trimesh's to refuse: it read the file.)"""
    accessors = header.get("accessors", [])
    return isinstance(value, int) and 0 <= value < len(accessors) and "sparse" in accessors[value]


def _patched(data: GltfData, primitive: Mapping[str, Any], decoded: Primitive, at: At) -> Primitive:
    """The primitive with each sparse accessor it uses (POSITION, NORMAL, TEXCOORD_0, indices)
    read whole, substitutions made (trimesh keeps the accessors' order: process=False)."""
    attributes, header = primitive.get("attributes", {}), data.header
    arrays = {name: data.accessor(attributes[name]).astype(np.float64) for name in ("POSITION", "NORMAL", "TEXCOORD_0")
              if name in attributes and _sparse(header, attributes[name])}
    faces = decoded.faces
    if _sparse(header, primitive.get("indices")):
        import trimesh

        flat = data.accessor(primitive["indices"]).ravel()
        faces = trimesh.util.triangle_strips_to_faces([flat]) if primitive.get("mode", TRIANGLES) == TRIANGLE_STRIP \
            else flat[:len(flat) - len(flat) % 3].reshape(-1, 3)
    if not arrays and faces is decoded.faces:
        return decoded
    positions = arrays.get("POSITION", decoded.positions)
    if faces.size and not 0 <= int(faces.min()) <= int(faces.max()) < len(positions):
        raise at.key("indices").error(f"expected vertex indices in [0, {len(positions)}), got {int(faces.max())}")
    return Primitive(positions, np.asarray(faces, np.int64), arrays.get("NORMAL", decoded.normals),
                     arrays.get("TEXCOORD_0", decoded.uvs) if decoded.uvs is not None else None)


def number_at(value: Mapping[str, Any], key: str, default: float, reader: Reader[float], at: At) -> float:
    """An optional number of a JSON object, read as strictly as a scene file's."""
    return at.key(key).read(value[key], reader) if key in value else default


def extension(value: Mapping[str, Any], name: str, at: At) -> Mapping[str, Any] | None:
    """The object's extension `name`, or None."""
    extensions = table(value.get("extensions", {}), at.key("extensions"))
    return table(extensions[name], at.key("extensions").key(name)) if name in extensions else None
