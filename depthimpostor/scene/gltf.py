"""glTF files onto the scene model: each mesh node's triangles become objects (one per node and
material), its materials map onto diffuse, mirror and glass by the rules of scene_format.md, and a
file given as the scene brings its first camera and its KHR_lights_punctual lights.

`read_gltf` reads a file once per (path, modification time); `gltf_scene` makes a whole Scene of
it; `gltf_objects` the objects a TOML scene's `shape = { type = "gltf" }` places.
"""

from __future__ import annotations

import dataclasses
import json
import math
import warnings
from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np

from depthimpostor.constants import MAX_IOR, MAX_LIGHTS, MAX_NAMED_TRIANGLES, Wrap
from depthimpostor.errors import SceneError, SceneWarning
from depthimpostor.meshes import Mesh
from depthimpostor.scene import fields as f
from depthimpostor.scene.fields import At, Vec3, show
from depthimpostor.scene.gltf_file import (
    NOT_SURFACES, TRIANGLE_FAN, TRIANGLE_STRIP, TRIANGLES, Primitive, PrimitiveSize, check_header, decode_primitive,
    extension, ignored_features, index, items, local_mesh, number_at, primitive_modes, primitive_size, read_json,
    scene_nodes, table, texture_set,
)
from depthimpostor.scene.gltf_animation import FileAnimation, read_animation
from depthimpostor.scene.gltf_data import GltfData
from depthimpostor.scene.gltf_deform import PartMotion, part_motion
from depthimpostor.scene.gltf_planes import Rectangle, find_rectangle, plane_placement
from depthimpostor.scene.limits import check_scene
from depthimpostor.textures import texture_from_pixels
from depthimpostor.scene.model import (
    Animation, Camera, DiffuseMaterial, Environment, GlassMaterial, GltfOrigin, GltfShape, Light, Material,
    MetallicRoughnessMaterial, MirrorMaterial, material_textures,
    PlaneShape, RenderSettings, Scene, SceneObject, Texture,
)

#: What a primitive without a material is drawn with: the specification's default material.
GLTF_DEFAULT_MATERIAL = MetallicRoughnessMaterial((1.0, 1.0, 1.0), metallic=1.0, roughness=1.0, double_sided=False)
#: The mirror rule: a material at least this metallic and at most this rough is a mirror.
MIRROR_METALLIC, MIRROR_ROUGHNESS = 0.9, 0.1
#: The glass rule: a KHR_materials_transmission factor of at least this is glass.
GLASS_TRANSMISSION = 0.5
#: The largest KHR_materials_emissive_strength read (the extension sets none; a bound keeps the
#: colours finite: 1e6 is brighter than any light a scene file can give).
MAX_EMISSIVE_STRENGTH = 1.0e6
#: The largest KHR_texture_transform rotation read, in radians (any angle is a turn of at most one
#: circle; a bound keeps the sine and cosine meaningful).
MAX_UV_ROTATION = 1.0e6
#: The largest normalTexture scale read either way (the specification bounds none; a scale of 1e3
#: already lays the mapped normal flat along the tangent plane wherever the map is not flat).
MAX_NORMAL_SCALE = 1.0e3
#: Without a camera in the file: the TOML default camera's view direction, framing the whole scene.
FRAMING_FOV_Y = Camera().fov_y
#: Without lights in the file: one light from above, as the scene_format.md example has.
DEFAULT_LIGHT = Light("directional", direction=(-0.4, -1.0, -0.3))
#: The most triangles a file may place, counted from its accessors before any is decoded (a node
#: places its mesh's triangles again, so that a small file can claim billions): the hybrid method
#: names a triangle by a float32 (MAX_NAMED_TRIANGLES), and no method draws more in useful time.
MAX_PLACED_TRIANGLES = MAX_NAMED_TRIANGLES
#: What one placed triangle costs the loader at most: its three corners' world-space position,
#: normal and UV (float64) and its indices, as `local_mesh` and `Mesh.transformed` make them.
PLACED_TRIANGLE_BYTES = 3 * 8 * (3 + 3 + 2) + 3 * 8
#: The most memory the loader's arrays may take, from the same counts: the accessors decoded (as
#: float64 and int64) and the placed triangles. A file's accessors can share bytes, so a file of
#: megabytes can claim terabytes.
MAX_DECODED_BYTES = 2 * 2**30


@dataclass(frozen=True, eq=False)
class GltfMaterial:
    label: str  # its name, or "materials[k]" when it has none: what a TOML override names
    material: Material
    textured: bool  # a mirror or glass with a texture, tinted by its mean colour (the one-line warning names it)


@dataclass(frozen=True, eq=False)
class GltfPart:
    name: str  # the node's name (or "nodes[i]"), with the material's label where a node has several
    origin: GltfOrigin  # for messages: the node, mesh, primitives and material, by index and name
    material: int | None  # index into the file's materials; None: glTF's default (white, diffuse)
    mesh: Mesh  # in the file's world space (a part that deforms: at time 0)
    rectangle: Rectangle | None  # where the mesh is one flat rectangle: placed as a plane (gltf_planes.py)
    motion: PartMotion | None = None  # how the file's animation, skin or morph targets move it; None: still


@dataclass(frozen=True, eq=False)
class GltfLight:
    node: int
    kind: str  # "directional", "point" or "spot"
    color: Vec3
    intensity: float  # as the file gives it: lux (directional) or candela (point, spot)
    world: np.ndarray  # the node's world matrix


@dataclass(frozen=True, eq=False)
class GltfFile:
    path: Path
    source: str
    materials: tuple[GltfMaterial, ...]
    parts: tuple[GltfPart, ...]
    lights: tuple[GltfLight, ...]
    camera: tuple[int, np.ndarray, float] | None  # the first camera: node, world matrix, yfov in degrees

    def material_of(self, part: GltfPart) -> GltfMaterial:
        if part.material is None:  # glTF 2.0, 3.9.6: white, metallic 1, roughness 1 (a rough white metal)
            return GltfMaterial("default", GLTF_DEFAULT_MATERIAL, False)
        return self.materials[part.material]

    def bounds(self) -> tuple[np.ndarray, float]:
        """The centre and radius of a sphere around every part (box-centred)."""
        points = np.concatenate([part.mesh.positions for part in self.parts]).astype(np.float64)
        centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
        return centre, float(np.linalg.norm(points - centre, axis=1).max())


_CACHE: dict[Path, tuple[int, GltfFile]] = {}


def read_gltf(path: Path, source: str) -> GltfFile:
    """The file read and mapped; parsed once per (resolved path, modification time)."""
    try:
        resolved = path.resolve(strict=True)
        modified = resolved.stat().st_mtime_ns
    except OSError:
        resolved, modified = path, -1  # read_json says what is wrong with it
    cached = _CACHE.get(resolved)
    if cached is not None and cached[0] == modified:
        # Named as this reader names it (a TOML scene's path, or the command line's): messages say it.
        return cached[1] if cached[1].source == source else dataclasses.replace(cached[1], source=source)
    header = read_json(path, source)
    check_header(header, source, resolved.parent)
    ignored = ignored_features(header)
    if ignored:
        warnings.warn(SceneWarning(f"{source}: {len(ignored)} glTF feature(s) this loader does not implement, "
                                   f"drawn as if absent: {', '.join(ignored)}"), stacklevel=2)
    data = GltfData(resolved, header, source)
    walked = scene_nodes(header, source)
    primitives = _decoded(data, walked)
    parts = _parts(data, primitives, ignored, read_animation(data), walked)
    if not parts:
        raise SceneError(source, "", "expected a scene with at least one mesh node holding triangles, got none")
    used = _used_materials(header, source, primitives)
    materials = tuple(_material(header, k, value, data if k in used else None, source)
                      for k, value in enumerate(items(header, "materials", source)))
    model = GltfFile(resolved, source, materials, tuple(parts), _lights(header, source, walked),
                     _camera(header, source, walked))
    _CACHE[resolved] = (modified, model)
    return model


def _decoded(data: GltfData, walked: list[tuple[int, np.ndarray]]) -> dict[tuple[int, int], Primitive]:
    """The triangle primitives of the meshes the scene's nodes place, by (mesh, primitive), decoded
    once the counts of them all are known to fit: MAX_PLACED_TRIANGLES and MAX_DECODED_BYTES."""
    header, source = data.header, data.source
    sizes: dict[tuple[int, int], tuple[Mapping[str, Any], int, PrimitiveSize]] = {}
    meshes, nodes = items(header, "meshes", source), items(header, "nodes", source)
    placed = {index(nodes[i]["mesh"], len(meshes), At(source, f"nodes[{i}].mesh")) for i, _ in walked if "mesh" in nodes[i]}
    for m, p, primitive, mode in primitive_modes(header, source):
        if m in placed and mode in (TRIANGLES, TRIANGLE_STRIP):
            sizes[m, p] = primitive, mode, primitive_size(data, primitive, mode, At(source, f"meshes[{m}].primitives[{p}]"))
    by_mesh = Counter[int]()
    for (m, _), (_, _, size) in sizes.items():
        by_mesh[m] += size.triangles
    triangles = sum(by_mesh[nodes[i]["mesh"]] for i, _ in walked if "mesh" in nodes[i])
    if triangles > MAX_PLACED_TRIANGLES:
        raise SceneError(source, "meshes", f"expected at most {MAX_PLACED_TRIANGLES:,} triangles placed by the scene's "
                         f"nodes (a float32 names each in the hybrid method), got {triangles:,}, counted from the "
                         "accessors before decoding")
    decoded = sum(size.decoded_bytes for _, _, size in sizes.values()) + triangles * PLACED_TRIANGLE_BYTES
    if decoded > MAX_DECODED_BYTES:
        raise SceneError(source, "accessors", f"expected geometry that decodes into at most "
                         f"{MAX_DECODED_BYTES / 2**30:g} GiB, got {decoded / 2**30:.3g} GiB, counted from the accessors "
                         "before decoding (their counts, and the triangles the nodes place)")
    return {key: decode_primitive(data, primitive, mode, At(source, f"meshes[{key[0]}].primitives[{key[1]}]"))
            for key, (primitive, mode, _) in sizes.items()}


def _used_materials(header: Mapping[str, Any], source: str, primitives: dict[tuple[int, int], Primitive]) -> set[int]:
    """The materials some triangle primitive is drawn with."""
    used = set()
    for m, p, primitive, _ in primitive_modes(header, source):
        if (m, p) in primitives and "material" in primitive:
            used.add(index(primitive["material"], len(items(header, "materials", source)),
                           At(source, f"meshes[{m}].primitives[{p}].material")))
    return used


def _parts(data: GltfData, primitives: dict[tuple[int, int], Primitive], ignored: tuple[str, ...],
           animation: FileAnimation | None, walked: list[tuple[int, np.ndarray]]) -> list[GltfPart]:
    """One part per mesh node and material, in the order the node tree is walked, each with how
    it moves (gltf_deform.py) where the file animates, skins or morphs it."""
    header, source = data.header, data.source
    meshes, nodes = items(header, "meshes", source), items(header, "nodes", source)
    materials = items(header, "materials", source)
    by_mode: dict[int, list[str]] = {}
    for m, p, _, mode in primitive_modes(header, source):
        if mode == TRIANGLE_FAN:
            raise SceneError(source, f"meshes[{m}].primitives[{p}].mode", "expected triangles or a triangle strip "
                             "(export triangle fans as triangles), got a fan (6)")
        if mode in NOT_SURFACES:
            by_mode.setdefault(mode, []).append(f"meshes[{m}].primitives[{p}]")
    if by_mode:
        skipped = sum(len(where) for where in by_mode.values())
        kinds = ", ".join(NOT_SURFACES[mode] for mode in sorted(by_mode))
        first = next(iter(by_mode.values()))[0]
        warnings.warn(SceneWarning(f"{source}: {skipped} primitive(s) that are not triangles ({kinds}; the first "
                                   f"{first}) have no surface to shade or reflect: left out"), stacklevel=3)
    names = [_name(node) for node in nodes]
    named = Counter(names)
    parts = []
    worlds = dict(walked)
    for i, world in worlds.items():
        if "mesh" not in nodes[i]:
            continue
        m = index(nodes[i]["mesh"], len(meshes), At(source, f"nodes[{i}].mesh"))
        groups: dict[int | None, list[tuple[int, Primitive]]] = {}
        for p, value in enumerate(meshes[m].get("primitives", [])):
            if (m, p) in primitives and len(primitives[m, p].faces):
                material = value.get("material")
                if material is not None:
                    index(material, len(materials), At(source, f"meshes[{m}].primitives[{p}].material"))
                    _check_uv_sets(header, source, m, p, primitives[m, p], material)
                groups.setdefault(material, []).append((p, primitives[m, p]))
        if abs(np.linalg.det(world[:3, :3])) <= 1e-12 * float(np.linalg.norm(world[:3, :3])) ** 3 \
                and "skin" not in nodes[i]:  # (a skinned mesh is placed by its joints alone)
            continue  # scaled to nothing: glTF's way to hide a node, which has no surface to draw
        node = names[i] if names[i] and named[names[i]] == 1 else f"nodes[{i}]"
        for material, group in groups.items():
            label = "default" if material is None else _label(header, material)
            name = node if len(groups) == 1 else f"{node} ({label})"
            origin = GltfOrigin(source, i, names[i], m, _name(meshes[m]), tuple(p for p, _ in group), material,
                                "" if material is None else _name(materials[material]), ignored=ignored)
            tangent_set = _normal_map_set(materials, material)
            motion = part_motion(data, animation, worlds, i, m, group, tangent_set)
            if motion is not None and motion.deforms:
                parts.append(GltfPart(name, origin, material, motion.mesh_at(0.0), None, motion))
                continue
            mesh = local_mesh([primitive for _, primitive in group], tangent_set).transformed(world)
            parts.append(GltfPart(name, origin, material, mesh, find_rectangle(mesh) if motion is None else None, motion))
    return parts


#: A material's texture infos (where in the material, the key), in the order messages name them.
_TEXTURE_INFOS = (("pbrMetallicRoughness", "baseColorTexture"), ("pbrMetallicRoughness", "metallicRoughnessTexture"),
                  (None, "normalTexture"), (None, "occlusionTexture"), (None, "emissiveTexture"))


def _check_uv_sets(header: Mapping[str, Any], source: str, m: int, p: int, primitive: Primitive, k: int) -> None:
    """Refuses a primitive that lacks TEXCOORD_1 when a texture of its material (materials[k])
    reads that set: glTF 2.0 (3.9.2's texCoord) says the primitive MUST have it, and the loader
    would read (0, 0) there for every vertex (as glTF-Sample-Viewer does), one texel over the
    whole surface, with no message. (A part without TEXCOORD_0 at all is drawn in its textures'
    mean colour, with a warning: gltf_objects.)"""
    if primitive.uvs1 is not None:
        return
    material = header["materials"][k]
    for holder_key, key in _TEXTURE_INFOS:
        holder = material.get(holder_key, {}) if holder_key is not None else material
        info = holder.get(key) if isinstance(holder, Mapping) else None
        if isinstance(info, Mapping) and texture_set(info) == 1:
            where = f"{holder_key}.{key}" if holder_key is not None else key
            name = _name(material)
            raise SceneError(source, f"meshes[{m}].primitives[{p}].attributes",
                             f"expected TEXCOORD_1, which {where} of material "
                             f"{json.dumps(name) + ' ' if name else ''}(materials[{k}]) reads (texCoord 1), got none")


def _normal_map_set(materials: list[Mapping[str, Any]], material: int | None) -> int | None:
    """The UV set materials[material]'s normalTexture reads (its tangents are made from it), or None
    where it has none."""
    info = materials[material].get("normalTexture") if material is not None else None
    return texture_set(info) if isinstance(info, Mapping) else None


def _name(value: Mapping[str, Any]) -> str:
    """An item's `name`, "" where it has none (or one that is not a string)."""
    name = value.get("name")
    return name if isinstance(name, str) else ""


def _label(header: Mapping[str, Any], k: int) -> str:
    return _name(header["materials"][k]) or f"materials[{k}]"


def _texture(header: Mapping[str, Any], info: Mapping[str, Any], data: GltfData, at: At, source: str,
             srgb: bool = True) -> Texture:
    """A baseColorTexture: its image (EXT_texture_webp's where given, else `source`), decoded as
    written (image_files.py), its sampler's wrap modes, the UV set it reads (texCoord, or its
    KHR_texture_transform's: gltf_file.texture_set) and its KHR_texture_transform (offset,
    rotation, scale)."""
    textures = items(header, "textures", source)
    t = index(info.get("index"), len(textures), at.key("index"))
    texture_at = At(source, f"textures[{t}]")
    texture = textures[t]
    webp = extension(texture, "EXT_texture_webp", texture_at)
    image = webp.get("source") if webp is not None else texture.get("source")
    if image is None:
        others = ", ".join(table(texture.get("extensions", {}), texture_at.key("extensions")))
        raise texture_at.key("source").error("expected an image this loader reads (PNG, JPEG, WebP...), got none"
                                             + (f" (only {others}'s, which it does not read)" if others else ""))
    pixels = data.image(index(image, len(items(header, "images", source)), texture_at.key("source")))
    sampler: dict[str, int] = {}
    if "sampler" in texture:
        samplers = items(header, "samplers", source)
        chosen = samplers[index(texture["sampler"], len(samplers), at.key("sampler"))]
        sampler = {k: v for k, v in chosen.items() if isinstance(v, int) and not isinstance(v, bool)}
        sampler_at = At(source, f"samplers[{texture['sampler']}]")
        for key in ("wrapS", "wrapT"):
            if key in sampler and sampler[key] not in {int(mode) for mode in Wrap}:
                raise sampler_at.key(key).error(f"expected a wrap mode {', '.join(str(int(m)) for m in Wrap)}, "
                                                f"got {show(sampler[key])}")
    texture_read = texture_from_pixels(pixels, sampler, name=f"{Path(source).name} images[{image}]")
    if not srgb or texture_set(info):
        texture_read = dataclasses.replace(texture_read, srgb=srgb, uv_set=texture_set(info))
    transform = extension(info, "KHR_texture_transform", at)
    if transform is None:
        return texture_read
    transform_at = at.key("extensions").key("KHR_texture_transform")
    offset = transform_at.key("offset").read(transform.get("offset", [0, 0]), f.numbers(2))
    scale = transform_at.key("scale").read(transform.get("scale", [1, 1]), f.numbers(2))
    rotation = number_at(transform, "rotation", 0.0, f.number(f.Bounds(-MAX_UV_ROTATION, MAX_UV_ROTATION)),
                         transform_at)
    return dataclasses.replace(texture_read, scale=(float(scale[0]), float(scale[1])),
                               offset=(float(offset[0]), float(offset[1])), rotation=rotation)


def _material(header: Mapping[str, Any], k: int, value: Mapping[str, Any], data: GltfData | None,
              source: str) -> GltfMaterial:
    """The rules of scene_format.md: transmission >= 0.5 is glass (its ior from KHR_materials_ior,
    its tint the base colour); metallic >= 0.9 with roughness <= 0.1 is a mirror tinted by the base
    colour; anything else is a metallic-roughness material (its base colour, texture, metallic and
    roughness factors, and emission). A mirror's or glass's
    tint cannot hold a texture: its mean colour joins the factor there. `data` reads its texture,
    None for a material no triangle is drawn with (its texture need not be readable)."""
    at = At(source, f"materials[{k}]")
    pbr = table(value.get("pbrMetallicRoughness", {}), at.key("pbrMetallicRoughness"))
    pbr_at = at.key("pbrMetallicRoughness")
    factor = pbr_at.key("baseColorFactor").read(pbr.get("baseColorFactor", [1, 1, 1, 1]), f.numbers(4, f.UNIT))
    base = np.asarray(factor[:3], np.float64)
    metallic = number_at(pbr, "metallicFactor", 1.0, f.number(f.UNIT), pbr_at)
    roughness = number_at(pbr, "roughnessFactor", 1.0, f.number(f.UNIT), pbr_at)
    texture = None
    if "baseColorTexture" in pbr and data is not None:
        info_at = pbr_at.key("baseColorTexture")
        texture = _texture(header, table(pbr["baseColorTexture"], info_at), data, info_at, source)
    r, g, b = (float(c) for c in np.clip(base, 0.0, 1.0))
    tinted = base * np.asarray(texture.mean_color) if texture is not None else base
    tr, tg, tb = (float(c) for c in np.clip(tinted, 0.0, 1.0))
    transmission = extension(value, "KHR_materials_transmission", at)
    factor_t = number_at(transmission or {}, "transmissionFactor", 0.0, f.number(f.UNIT),
                         at.key("extensions").key("KHR_materials_transmission"))
    material: Material
    if factor_t >= GLASS_TRANSMISSION:
        ior = number_at(extension(value, "KHR_materials_ior", at) or {}, "ior", GlassMaterial().ior,
                        f.number(f.Bounds(1.0, MAX_IOR)), at.key("extensions").key("KHR_materials_ior"))
        material = GlassMaterial(ior, (tr, tg, tb))
    elif metallic >= MIRROR_METALLIC and roughness <= MIRROR_ROUGHNESS:
        material = MirrorMaterial((tr, tg, tb))
    else:
        mode = at.key("alphaMode").read(value.get("alphaMode", "OPAQUE"), f.choice(("OPAQUE", "MASK", "BLEND")))
        cutoff = (number_at(value, "alphaCutoff", 0.5, f.number(f.Bounds(0.0, math.inf)), at) if mode == "MASK"
                  else None)
        maps = _maps(header, value, data, at, source)
        material = MetallicRoughnessMaterial((r, g, b), texture, metallic, roughness, _emissive(value, at),
                                             alpha=float(factor[3]), alpha_cutoff=cutoff, blend=mode == "BLEND", **maps,
                                             double_sided=at.key("doubleSided").read(value.get("doubleSided", False),
                                                                                     f.BOOLEAN))
    return GltfMaterial(_label(header, k), material, texture is not None and not isinstance(material, DiffuseMaterial))


def _maps(header: Mapping[str, Any], value: Mapping[str, Any], data: GltfData | None, at: At,
          source: str) -> dict[str, Any]:
    """A material's metallic-roughness, occlusion (with its strength), emissive and normal (with its
    scale) maps: all data (linear) but the emissive map, colour (sRGB), as the specification
    stores them."""
    if data is None:
        return {}
    pbr_at = at.key("pbrMetallicRoughness")
    pbr = table(value.get("pbrMetallicRoughness", {}), pbr_at)
    found: dict[str, Any] = {}
    for holder, holder_at, key, field, srgb in (
            (pbr, pbr_at, "metallicRoughnessTexture", "metallic_roughness_texture", False),
            (value, at, "occlusionTexture", "occlusion_texture", False),
            (value, at, "emissiveTexture", "emissive_texture", True),
            (value, at, "normalTexture", "normal_texture", False)):
        if key in holder:
            info_at = holder_at.key(key)
            info = table(holder[key], info_at)
            found[field] = _texture(header, info, data, info_at, source, srgb)
            if key == "occlusionTexture":
                found["occlusion_strength"] = number_at(info, "strength", 1.0, f.number(f.UNIT), info_at)
            if key == "normalTexture":
                found["normal_scale"] = number_at(info, "scale", 1.0, f.number(f.Bounds(-MAX_NORMAL_SCALE,
                                                                                         MAX_NORMAL_SCALE)), info_at)
    return found


def _emissive(value: Mapping[str, Any], at: At) -> Vec3:
    """The light a material gives off: emissiveFactor times KHR_materials_emissive_strength's
    emissiveStrength (glTF keeps the factor in [0, 1]; the extension scales it past 1)."""
    factor = at.key("emissiveFactor").read(value.get("emissiveFactor", [0, 0, 0]), f.numbers(3, f.UNIT))
    strength_at = at.key("extensions").key("KHR_materials_emissive_strength")
    strength = number_at(extension(value, "KHR_materials_emissive_strength", at) or {}, "emissiveStrength", 1.0,
                         f.number(f.Bounds(0.0, MAX_EMISSIVE_STRENGTH)), strength_at)
    r, g, b = (float(c) * strength for c in factor)
    return (r, g, b)


def _lights(header: Mapping[str, Any], source: str, walked: list[tuple[int, np.ndarray]]) -> tuple[GltfLight, ...]:
    """The KHR_lights_punctual lights placed on nodes of the scene, in tree order."""
    defined = extension(header, "KHR_lights_punctual", At(source, ""))
    lights = (defined or {}).get("lights", [])
    if not isinstance(lights, list):
        raise At(source, "extensions.KHR_lights_punctual.lights").error(f"expected an array, got {show(lights)}")
    nodes, placed = items(header, "nodes", source), []
    for i, world in walked:
        use = extension(nodes[i], "KHR_lights_punctual", At(source, f"nodes[{i}]")) if "extensions" in nodes[i] else None
        if use is None:
            continue
        at = At(source, "extensions.KHR_lights_punctual.lights")
        k = index(use.get("light"), len(lights), At(source, f"nodes[{i}].extensions.KHR_lights_punctual.light"))
        light, at = table(lights[k], at.index(k)), at.index(k)
        kind = at.key("type").read(light.get("type"), f.choice(("directional", "point", "spot")))
        color = at.key("color").read(light.get("color", [1, 1, 1]), f.vec3(f.NON_NEGATIVE))
        intensity = number_at(light, "intensity", 1.0, f.number(f.NON_NEGATIVE), at)
        placed.append(GltfLight(i, kind, color, intensity, world))
    if len(placed) > MAX_LIGHTS:
        raise SceneError(source, "extensions.KHR_lights_punctual", f"expected at most {MAX_LIGHTS} lights placed on "
                         f"nodes (the shading loops over an array of {MAX_LIGHTS}), got {len(placed)}")
    return tuple(placed)


def _camera(header: Mapping[str, Any], source: str,
            walked: list[tuple[int, np.ndarray]]) -> tuple[int, np.ndarray, float] | None:
    """The first node of the tree that holds a camera: a perspective one, or a refusal."""
    nodes, cameras = items(header, "nodes", source), items(header, "cameras", source)
    for i, world in walked:
        if "camera" not in nodes[i]:
            continue
        c = index(nodes[i]["camera"], len(cameras), At(source, f"nodes[{i}].camera"))
        at = At(source, f"cameras[{c}]")
        if cameras[c].get("type") != "perspective":
            raise at.key("type").error(f'expected "perspective" (the renderer is a pinhole camera; an orthographic '
                                       f'one has no eye point), got {show(cameras[c].get("type"))}')
        perspective = table(cameras[c].get("perspective"), at.key("perspective"))
        yfov = at.key("perspective").key("yfov").read(perspective.get("yfov"), f.number(f.Bounds(0, math.radians(179), open_lo=True)))
        return i, world, math.degrees(yfov)
    return None


def _unit(vector: np.ndarray, at: At) -> Vec3:
    length = float(np.linalg.norm(vector))
    if not length >= f.MIN_DIRECTION_LENGTH:
        raise at.error("expected a node whose transform keeps directions (not scaled to nothing), got one that does not")
    x, y, z = (float(c) / length for c in vector)
    return (x, y, z)


def _scene_camera(model: GltfFile) -> Camera:
    """The file's first camera (looking down its node's -Z with +Y up, aspect from the frame), or
    one framing every part from the TOML default camera's direction."""
    if model.camera is None:
        centre, radius = model.bounds()
        away = np.subtract(Camera().eye, Camera().target)
        distance = max(radius, 1e-6) / math.sin(math.radians(FRAMING_FOV_Y) / 2.0)
        eye = centre + distance * away / np.linalg.norm(away)
        return Camera(tuple(eye.tolist()), tuple(centre.tolist()), (0.0, 1.0, 0.0), FRAMING_FOV_Y)
    node, world, fov_y = model.camera
    at = At(model.source, f"nodes[{node}]")
    forward, up = _unit(world[:3, :3] @ (0.0, 0.0, -1.0), at), _unit(world[:3, :3] @ (0.0, 1.0, 0.0), at)
    eye = world[:3, 3]
    target = eye + np.asarray(forward)
    if np.linalg.norm(np.cross(forward, up)) < 1e-3:  # a shear can fold up onto the view direction
        raise at.error("expected a camera whose up (+Y) and view (-Z) directions stay apart, got a sheared transform")
    return Camera(tuple(eye.tolist()), tuple(target.tolist()), up, fov_y)


def _scene_lights(model: GltfFile) -> tuple[Light, ...]:
    """The file's lights on the renderer's unitless model (scene_format.md): a directional light
    keeps its intensity (1 lux gives what intensity 1 gives); a point or spot light (candela, falling
    off with the square of distance, which the renderer's point lights do not) gets the irradiance it
    gives at the scene's centre, no nearer than the scene's radius: intensity / d^2. A spot light's
    cone is not drawn: it lights all round, with a warning."""
    if not model.lights:
        return (DEFAULT_LIGHT,)
    centre, radius = model.bounds()
    lights = []
    for light in model.lights:
        at = At(model.source, f"nodes[{light.node}]")
        if light.kind == "directional":
            direction = _unit(light.world[:3, :3] @ (0.0, 0.0, -1.0), at)
            lights.append(Light("directional", direction=direction, color=light.color, intensity=light.intensity))
            continue
        position = light.world[:3, 3]
        distance = max(float(np.linalg.norm(position - centre)), radius)
        x, y, z = (float(c) for c in position)
        lights.append(Light("point", position=(x, y, z), color=light.color, intensity=light.intensity / distance ** 2))
    spots = [f"nodes[{light.node}]" for light in model.lights if light.kind == "spot"]
    if spots:
        warnings.warn(SceneWarning(f"{model.source}: {len(spots)} spot light(s) ({', '.join(spots)}) lit as point "
                                   f"lights: the renderer has no cone, so they light all round"), stacklevel=3)
    return tuple(lights)


def _as_plane(part: GltfPart, material: Material, position: Vec3, rotation: Vec3, scale: Vec3,
              animation: Animation | None, scaled: dict[tuple[int, float, float], Texture]) -> SceneObject | None:
    """The part as a `plane` object where it is one rectangle (scene_format.md, "glTF rectangles"):
    not glass (a plane has no inside), not moving (floors and walls are fixed planes), under a
    uniform scale (a plane's placement has one), its texture (if any) on UVs that are the plane's
    times a scale, which the plane's texture then carries (one texture per image and scale, in
    `scaled`, so that two walls tiled alike share a texture slot)."""
    rectangle = part.rectangle
    if rectangle is None or isinstance(material, GlassMaterial) or animation is not None or len(set(scale)) != 1:
        return None
    if part.mesh.colors is not None or any(texture.uv_set for texture in material_textures(material)):
        return None  # a plane has one UV set of its own, and no vertex colours
    if material_textures(material):
        if rectangle.uv_scale is None:
            return None
        if rectangle.uv_scale != (1.0, 1.0):
            uv_scale = rectangle.uv_scale

            def rescaled(texture: Texture | None) -> Texture | None:
                if texture is None:
                    return None
                repeats = (texture.scale[0] * uv_scale[0], texture.scale[1] * uv_scale[1])
                return scaled.setdefault((id(texture), *repeats), dataclasses.replace(texture, scale=repeats))

            assert isinstance(material, DiffuseMaterial)  # only they hold textures
            material = dataclasses.replace(material, texture=rescaled(material.texture))
            if isinstance(material, MetallicRoughnessMaterial):
                material = dataclasses.replace(
                    material, metallic_roughness_texture=rescaled(material.metallic_roughness_texture),
                    occlusion_texture=rescaled(material.occlusion_texture),
                    emissive_texture=rescaled(material.emissive_texture), normal_texture=rescaled(material.normal_texture))
    placed = plane_placement(rectangle, position, rotation, scale[0])
    if placed is None:
        return None
    width, depth = rectangle.size
    return SceneObject(name=part.name, shape=PlaneShape((scale[0] * width, scale[0] * depth)), material=material,
                       position=placed[0], rotation=placed[1])


def gltf_objects(model: GltfFile, overrides: Mapping[str, Material], prefix: str = "",
                 position: Vec3 = (0.0, 0.0, 0.0), rotation: Vec3 = (0.0, 0.0, 0.0), scale: Vec3 = (1.0, 1.0, 1.0),
                 animation: Animation | None = None, placed_by: int | None = None) -> list[SceneObject]:
    """The file's parts as objects named `prefix` + part name, each placed by the position, rotation,
    scale and animation given (on top of the file's node transforms), with `overrides` (by material
    label) replacing the file's materials; `placed_by` the TOML scene's [[objects]] entry that
    places the file (its objects' origins say so). Warns once for the textured mirrors and glass,
    whose tint takes the texture's mean colour."""
    objects, textured, no_uvs = [], [], []
    scaled: dict[tuple[int, float, float], Texture] = {}
    for part in model.parts:
        mapped = model.material_of(part)
        material = overrides.get(mapped.label, mapped.material)
        if mapped.textured and mapped.label not in overrides and mapped.label not in textured:
            textured.append(mapped.label)
        if isinstance(material, DiffuseMaterial) and material_textures(material) and part.mesh.uvs is None:
            # A textured material on a part without TEXCOORD_0: nothing says where the images go.
            mean = material.texture.mean_color if material.texture is not None else (1.0, 1.0, 1.0)
            tint = np.clip(np.multiply(material.color, mean), 0.0, 1.0)
            material = dataclasses.replace(material, color=(float(tint[0]), float(tint[1]), float(tint[2])), texture=None)
            if isinstance(material, MetallicRoughnessMaterial):
                material = dataclasses.replace(material, metallic_roughness_texture=None, occlusion_texture=None,
                                               emissive_texture=None, normal_texture=None)
            no_uvs.append(part.origin.describe())
        origin = dataclasses.replace(part.origin, file=model.source, placed_by=placed_by)
        plane = _as_plane(part, material, position, rotation, scale, animation, scaled)
        if plane is not None:
            objects.append(dataclasses.replace(plane, name=prefix + part.name, origin=origin))
            continue
        objects.append(SceneObject(name=prefix + part.name, shape=GltfShape(model.path, part.mesh, part.motion),
                                   material=material, position=position, rotation=rotation, scale=scale,
                                   animation=animation, origin=origin))
    if no_uvs:
        warnings.warn(SceneWarning(f"{model.source}: {len(no_uvs)} textured part(s) without TEXCOORD_0 (the first "
                                   f"{no_uvs[0]}) drawn in the mean colour of their texture"), stacklevel=3)
    if textured:
        names = ", ".join(f'"{label}"' for label in textured)
        warnings.warn(SceneWarning(f"{model.source}: textures are not drawn on mirrors and glass: material(s) {names} "
                                   f"are tinted by the mean colour of their baseColorTexture times baseColorFactor"),
                      stacklevel=3)
    return objects


def gltf_trimesh(resolved: Path, shown: Path) -> Any:
    """A glTF file's parts as one trimesh mesh in the file's world space (as trimesh's own
    `force="mesh"` flattens a scene), for a `mesh` shape (meshes.load_mesh_file finishes it): read
    here, its checks before any decoding are that shape's too (trimesh's reader walked a chain of
    nodes in quadratic time, decoded every texture and read every accessor before a count could be
    checked). UVs in trimesh's convention (v up), as meshes.py reads a file's."""
    import trimesh

    meshes = [part.mesh for part in read_gltf(resolved, str(shown)).parts]
    starts = np.cumsum([0] + [len(mesh.positions) for mesh in meshes])
    faces = np.concatenate([np.asarray(mesh.indices, np.int64) + start for mesh, start in zip(meshes, starts, strict=False)])
    visual = None
    if all(mesh.uvs is not None for mesh in meshes):
        uvs = np.concatenate([np.asarray(mesh.uvs, np.float64) for mesh in meshes])
        texture_visuals = cast(Callable[..., Any], trimesh.visual.TextureVisuals)  # trimesh has no hints
        visual = texture_visuals(uv=np.stack([uvs[:, 0], 1.0 - uvs[:, 1]], axis=1))
    positions = np.concatenate([np.asarray(mesh.positions, np.float64) for mesh in meshes])
    return trimesh.Trimesh(positions, faces, visual=visual, process=False)


def gltf_scene(path: Path, source: str) -> Scene:
    """A glTF file as a whole scene: its parts, its first camera (or a framing one), its lights (or
    one default light), and the TOML format's default render settings and environment."""
    model = read_gltf(path, source)
    scene = Scene(source=source, render=RenderSettings(), camera=_scene_camera(model), environment=Environment(),
                  lights=_scene_lights(model), objects=tuple(gltf_objects(model, {})))
    check_scene(scene)
    return scene
