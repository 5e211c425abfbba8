"""Scene files to `Scene`: the format, as tables of variants and sections, plus the file-level checks."""

from __future__ import annotations

import json
import math
import os
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any, cast

import numpy as np

if sys.version_info >= (3, 11):
    import tomllib
else:  # tomllib joined the standard library in 3.11; tomli is the same parser (pyproject declares it)
    import tomli as tomllib

from depthimpostor.constants import MAX_BOUNCES, MAX_IOR, Wrap
from depthimpostor.errors import SceneError
from depthimpostor.hdr import HDR_SUFFIXES, MAX_SIDE, HdrImageError, read_hdr
from depthimpostor.image_files import scene_images_budget
from depthimpostor.scene import fields as f
from depthimpostor.scene.gltf import gltf_objects, gltf_scene, read_gltf
from depthimpostor.scene.gltf_file import GLTF_SUFFIXES
from depthimpostor.scene.limits import check_scene
from depthimpostor.textures import read_texture
from depthimpostor.scene.fields import NAME, RESOLUTION, SIZE, TRIANGLE_TARGET, At, Table, Variant, Vec3, read_file_bytes, read_variant, show
from depthimpostor.scene.model import (
    EXPOSURE, IMPOSTOR_RESOLUTION, SAMPLES, TONE_MAPPING, ZERO, Animation, BoxShape, Camera, CheckerMaterial, CylinderShape, DiffuseMaterial,
    Environment, GlassMaterial, Light, Material, MeshShape, MetallicRoughnessMaterial, MirrorMaterial, PlaneShape,
    RenderSettings, Scene,
    SceneObject, Shape, SphereShape, Texture, TorusKnotShape, TorusShape,
)

MODEL_PATH_VARIABLE = "DEPTHIMPOSTOR_MODEL_PATH"
MODEL_SUFFIXES = (".obj", ".ply", ".glb", ".gltf")

_COLOR, _RADIANCE, _POINT = f.vec3(f.UNIT), f.vec3(f.NON_NEGATIVE), f.vec3()
_DIRECTION = f.vec3(nonzero=True)
_LENGTH = f.number(f.POSITIVE)
_PLANE_SIZE = cast(f.Reader[tuple[float, float]], f.numbers(2, f.POSITIVE))


def _torus(t: Table) -> TorusShape:
    major, minor = t.req("major", _LENGTH), t.req("minor", _LENGTH)
    if minor >= major:  # the tube would pass through the axis: a self-intersecting spindle torus
        raise t.at.key("minor").error(f"expected a number less than major ({major:g}), got {minor:g}")
    return TorusShape(major, minor)


def _torus_knot(t: Table) -> TorusKnotShape:
    p, q = t.req("p", f.integer(f.POSITIVE)), t.req("q", f.integer(f.POSITIVE))
    if math.gcd(p, q) != 1:  # with a common factor the curve is a link, traced more than once
        raise t.at.key("q").error(f"expected an integer coprime with p ({p}), got {q}")
    return TorusKnotShape(p, q, t.req("radius", _LENGTH), t.req("tube", _LENGTH))


def model_folders(base_dir: Path) -> list[Path]:
    """Where a relative model path is looked for, in order: the scene's folder, then $DEPTHIMPOSTOR_MODEL_PATH."""
    listed = os.environ.get(MODEL_PATH_VARIABLE, "").split(os.pathsep)
    return [base_dir, *(Path(folder) for folder in listed if folder)]


def _model_file(t: Table, suffixes: tuple[str, ...]) -> tuple[Path, str]:
    """The table's `path` to a model file, found (resolved) and as written."""
    at, written = t.at.key("path"), t.req("path", NAME)
    if Path(written).suffix.lower() not in suffixes:
        raise at.error(f"expected a path to a {', '.join(suffixes)} file, got {json.dumps(written)}")
    return find_file(written, at, "model file"), written


def find_file(written: str, at: At, kind: str) -> Path:
    """A file named in a scene (a model, a texture), looked for in model_folders, resolved."""
    _check_inside(written, at, "or in $" + MODEL_PATH_VARIABLE)
    folders = model_folders(at.base_dir)
    for folder in folders:
        candidate = folder / Path(written).expanduser()  # joining an absolute path ignores the folder
        if candidate.is_file():
            return candidate.resolve()
    searched = ", ".join(str(folder.resolve()) for folder in folders)
    raise at.error(f"expected an existing {kind}, got {json.dumps(written)}: not found in the scene's "
                   f"folder or ${MODEL_PATH_VARIABLE} (searched: {searched})")


def _check_inside(written: str, at: At, elsewhere: str = "") -> None:
    """The rule for paths (scene_format.md, "Paths"), as a glTF file's URIs keep it: a relative
    path names a file in its folder or below it (`..` may not climb out); an absolute one is taken
    as written (the scene's author wrote it; a glTF file may not)."""
    if not Path(written).expanduser().is_absolute() and f.leaves_folder(written):
        raise at.error(f"expected a path inside the scene's folder {elsewhere + ' ' if elsewhere else ''}(or an absolute "
                       f"path), got {json.dumps(written)}, which leaves it")


def _mesh(t: Table) -> MeshShape:
    return MeshShape(*_model_file(t, MODEL_SUFFIXES))


def _placed_elsewhere(t: Table) -> Shape:
    raise t.at.error('expected a glTF file to be placed by an object (shape = { type = "gltf", path = ... })')


_SHAPES: dict[str, Variant[Shape]] = {
    "plane": Variant(("size",), lambda t: PlaneShape(t.req("size", _PLANE_SIZE))),
    "box": Variant(("size",), lambda t: BoxShape(t.req("size", f.vec3(f.POSITIVE)))),
    "sphere": Variant(("radius",), lambda t: SphereShape(t.req("radius", _LENGTH))),
    "cylinder": Variant(("radius", "height"),
                        lambda t: CylinderShape(t.req("radius", _LENGTH), t.req("height", _LENGTH))),
    "torus": Variant(("major", "minor"), _torus),
    "torus_knot": Variant(("p", "q", "radius", "tube"), _torus_knot),
    "mesh": Variant(("path",), _mesh),
    # Listed so that messages name it; _objects reads such an object as several (_placed_gltf).
    "gltf": Variant(("path",), lambda t: _placed_elsewhere(t)),
}

#: A TOML texture's `wrap`: the same modes a glTF sampler has.
_WRAPS = {"repeat": Wrap.REPEAT, "clamp": Wrap.CLAMP_TO_EDGE, "mirrored_repeat": Wrap.MIRRORED_REPEAT}


def _texture(t: Table) -> Texture:
    """A diffuse material's `texture`: a path, or a table { path, scale, wrap }. The path is found
    as a model file's is: in the scene's folder, then $DEPTHIMPOSTOR_MODEL_PATH."""
    value, at = t.data["texture"], t.at.key("texture")
    table = Table({"path": value} if isinstance(value, str) else value, at, ("path", "scale", "wrap"))
    written = table.req("path", NAME)
    scale = cast(tuple[float, float], table.opt("scale", f.numbers(2, f.POSITIVE), (1.0, 1.0)))
    wrap = _WRAPS[table.opt("wrap", f.choice(list(_WRAPS)), "repeat")]
    path_at = at if isinstance(value, str) else at.key("path")
    return read_texture(find_file(written, path_at, "image file"), path_at, scale, (int(wrap), int(wrap)))


def _diffuse(t: Table) -> DiffuseMaterial:
    """A diffuse colour, or an image texture times a colour (white unless given)."""
    if "texture" not in t.data:
        return DiffuseMaterial(t.req("color", _COLOR), double_sided=_double_sided(t))
    return DiffuseMaterial(t.opt("color", _COLOR, (1.0, 1.0, 1.0)), _texture(t), double_sided=_double_sided(t))


def _double_sided(t: Table) -> bool | None:
    """glTF's doubleSided written in TOML (scene_format.md, "Faces"); None where it is not written:
    both faces there, a back face shaded as the front, as a TOML scene's surfaces always were."""
    return t.opt("double_sided", cast(f.Reader[bool | None], f.BOOLEAN), None)


def _metallic_roughness(t: Table) -> MetallicRoughnessMaterial:
    """glTF's material model written in TOML: a base colour (times an image texture), metallic,
    roughness and emissive (docs/scene_format.md). What a glTF material becomes can be overridden
    with it (a rough metal the glTF rules would make a mirror, say)."""
    texture = _texture(t) if "texture" in t.data else None
    default = MetallicRoughnessMaterial()
    return MetallicRoughnessMaterial(
        t.opt("color", _COLOR, (1.0, 1.0, 1.0) if texture is not None else default.color), texture,
        t.opt("metallic", f.number(f.UNIT), default.metallic), t.opt("roughness", f.number(f.UNIT), default.roughness),
        t.opt("emissive", _RADIANCE, default.emissive), **_alpha(t), double_sided=_double_sided(t))


def _alpha(t: Table) -> dict[str, Any]:
    """glTF's alpha written in TOML: `alpha` (the base colour's, times the texture's) and
    `alpha_mode` = "opaque" (alpha ignored), "mask" (cut away under `alpha_cutoff`) or "blend"."""
    mode = t.opt("alpha_mode", f.choice(("opaque", "mask", "blend")), "opaque")
    if "alpha_cutoff" in t.data and mode != "mask":
        raise t.at.key("alpha_cutoff").error(f'only with alpha_mode = "mask", not "{mode}"')
    cutoff = t.opt("alpha_cutoff", f.number(f.UNIT), 0.5) if mode == "mask" else None
    return {"alpha": t.opt("alpha", f.number(f.UNIT), 1.0), "alpha_cutoff": cutoff, "blend": mode == "blend"}


_MATERIALS: dict[str, Variant[Material]] = {
    "diffuse": Variant(("color", "texture", "double_sided"), _diffuse),
    "metallic_roughness": Variant(("color", "texture", "metallic", "roughness", "emissive", "alpha",
                                          "alpha_mode", "alpha_cutoff", "double_sided"), _metallic_roughness),
    "checker": Variant(("color_a", "color_b", "scale", "double_sided"), lambda t: CheckerMaterial(
        t.req("color_a", _COLOR), t.req("color_b", _COLOR), t.opt("scale", _LENGTH, 1.0),
        double_sided=_double_sided(t))),
    "mirror": Variant(("tint", "roughness"), lambda t: MirrorMaterial(
        t.opt("tint", _COLOR, MirrorMaterial().tint), t.opt("roughness", f.number(f.UNIT), MirrorMaterial().roughness))),
    "glass": Variant(("ior", "tint"), lambda t: GlassMaterial(
        t.opt("ior", f.number(f.Bounds(1.0, MAX_IOR)), GlassMaterial().ior), t.opt("tint", _COLOR, GlassMaterial().tint))),
}


def _rate(t: Table) -> float:
    rate = t.req("degrees_per_second", f.number())
    if rate == 0:
        raise t.at.key("degrees_per_second").error("expected a number other than 0 (an animation that never "
                                                   "turns is a mistake: leave animation out), got 0")
    return rate


def _rotate(t: Table) -> Animation:
    if "centre" in t.data:
        raise t.at.key("centre").error(f'expected no centre with type = "rotate", which turns a thing about its '
                                       f'own position (type = "orbit" turns it about a centre), '
                                       f'got {show(t.data["centre"])}')
    return Animation("rotate", t.req("axis", _DIRECTION), _rate(t))


_ANIMATIONS: dict[str, Variant[Animation]] = {
    "rotate": Variant(("axis", "degrees_per_second", "centre"), _rotate),
    "orbit": Variant(("centre", "axis", "degrees_per_second"), lambda t: Animation(
        "orbit", t.req("axis", _DIRECTION), _rate(t), t.req("centre", _POINT))),
}


def _animation(t: Table, refused: Mapping[str, str] | None = None) -> Animation | None:
    """The table's optional `animation`; a type in `refused` is an error saying why (its value)."""
    if "animation" not in t.data:
        return None
    animation = t.variant("animation", _ANIMATIONS)
    why = (refused or {}).get(animation.type)
    if why is not None:
        raise t.at.key("animation").key("type").error(why)
    return animation


# What a light's animation cannot be: an explanation per type.
_LIGHT_ANIMATIONS_REFUSED = {
    "point": {"rotate": 'expected "orbit" for a point light (a point light turned about itself does not move), '
                        'got "rotate"'},
    "directional": {"orbit": 'expected "rotate" for a directional light (it has no position to orbit; "rotate" '
                             'turns its direction), got "orbit"'},
}

SHADOW_KINDS = ("none", "hard", "soft")


def _light(t: Table, kind: str, direction: Vec3 = ZERO, position: Vec3 = ZERO) -> Light:
    d = Light(kind)
    shadows = t.opt("shadows", f.choice(SHADOW_KINDS), d.shadows)
    if kind == "directional" and shadows != "none":
        # A shadow map is a depth image taken from the light's position, which a directional light lacks.
        raise t.at.key("shadows").error(f'expected "none" for a directional light (shadows need a point '
                                        f'light, whose position a shadow map is taken from), got "{shadows}"')
    if shadows == "soft":
        radius = t.req("radius", _LENGTH)
    elif "radius" in t.data:
        raise t.at.key("radius").error(f'expected no radius unless shadows = "soft" (the light is a point '
                                       f'otherwise), got shadows = "{shadows}"')
    else:
        radius = d.radius
    return Light(kind, direction, position, color=t.opt("color", _RADIANCE, d.color),
                 intensity=t.opt("intensity", f.number(f.NON_NEGATIVE), d.intensity), shadows=shadows, radius=radius,
                 animation=_animation(t, _LIGHT_ANIMATIONS_REFUSED[kind]))


_LIGHTS: dict[str, Variant[Light]] = {
    "directional": Variant(("direction", "color", "intensity", "shadows", "animation"),
                           lambda t: _light(t, "directional", direction=t.req("direction", _DIRECTION))),
    "point": Variant(("position", "color", "intensity", "shadows", "radius", "animation"),
                     lambda t: _light(t, "point", position=t.req("position", _POINT))),
}


def _gradient(t: Table) -> Environment:
    d = Environment()
    horizon = t.opt("horizon", _RADIANCE, d.horizon)
    return Environment("gradient", horizon, t.opt("zenith", _RADIANCE, d.zenith), horizon,
                       t.opt("ground", _RADIANCE, d.ground))


def _constant(t: Table) -> Environment:
    color = t.req("color", _RADIANCE)
    return Environment("constant", color, color, color, color)


#: The largest side of an environment map: GL 4.1 and later guarantee textures of 16384 texels a
#: side (hdr.py reads it from the file's header, before decoding).
MAX_ENVIRONMENT_SIDE = MAX_SIDE


def _equirect(t: Table) -> Environment:
    at, written = t.at.key("path"), t.req("path", NAME)
    if Path(written).suffix.lower() not in HDR_SUFFIXES:
        raise at.error(f"expected a path to a {' or '.join(HDR_SUFFIXES)} file, got {json.dumps(written)}")
    _check_inside(written, at)
    path = t.at.base_dir / Path(written).expanduser()  # joining an absolute path ignores the folder
    if not path.is_file():
        raise at.error(f"expected an existing HDR image, got {json.dumps(written)}: not found "
                       f"(looked for {path.resolve()})")
    try:
        image = read_hdr(path)
    except HdrImageError as error:
        raise at.error(f"{json.dumps(written)}: {error}") from None
    except OSError as error:
        raise at.error(f"cannot read {json.dumps(written)}: {error.strerror or error}") from None
    height, width = image.shape[:2]
    if max(width, height) > MAX_ENVIRONMENT_SIDE:
        raise at.error(f"expected an image of at most {MAX_ENVIRONMENT_SIDE} pixels a side, got {width}x{height}")
    # Radiance is not negative; a few processed files hold tiny negative values, which would shade as
    # negative light: they are taken as 0, by the shader and the truth alike (they read this array).
    image = np.maximum(image, 0.0)
    image.flags.writeable = False
    d = Environment()
    return Environment("equirect", path=path.resolve(), image=image,
                       intensity=t.opt("intensity", f.number(f.NON_NEGATIVE), d.intensity),
                       rotation=t.opt("rotation", f.number(f.Bounds(-360.0, 360.0)), d.rotation))


_ENVIRONMENTS: dict[str, Variant[Environment]] = {
    "gradient": Variant(("zenith", "horizon", "ground"), _gradient),
    "constant": Variant(("color",), _constant),
    "equirect": Variant(("path", "intensity", "rotation"), _equirect),
}


def _render(t: Table) -> RenderSettings:
    d = RenderSettings()
    return RenderSettings(size=t.opt("size", SIZE, d.size),
                          impostor_resolution=t.opt("impostor_resolution", IMPOSTOR_RESOLUTION, d.impostor_resolution),
                          simplified_triangles=t.opt("simplified_triangles", TRIANGLE_TARGET, d.simplified_triangles),
                          shadow_resolution=t.opt("shadow_resolution", RESOLUTION, d.shadow_resolution),
                          image_memory=t.opt("image_memory", f.integer(f.Bounds(1, 2**24)), d.image_memory),
                          max_bounces=t.opt("max_bounces", f.integer(f.Bounds(1, MAX_BOUNCES)), d.max_bounces),
                          ambient=t.opt("ambient", f.number(f.UNIT), d.ambient),
                          tone_mapping=t.opt("tone_mapping", TONE_MAPPING, d.tone_mapping),
                          exposure=t.opt("exposure", EXPOSURE, d.exposure),
                          samples=t.opt("samples", SAMPLES, d.samples))


def read_camera(t: Table) -> Camera:
    """A camera table (the scene's [camera], a batch job's cameras[k]), checked."""
    return _camera(t)


def _camera(t: Table) -> Camera:
    d = Camera()
    camera = Camera(eye=t.opt("eye", _POINT, d.eye), target=t.opt("target", _POINT, d.target),
                    up=t.opt("up", _DIRECTION, d.up),
                    fov_y=t.opt("fov_y", f.number(f.Bounds(0, 179, open_lo=True)), d.fov_y))
    view = np.subtract(camera.target, camera.eye)
    if not np.any(view):
        raise t.at.key("target").error(f"expected a point other than camera.eye, got {show(camera.target)}")
    # The camera's right vector is normalize(cross(view, up)). Below this sine (about 0.06 degrees
    # off parallel) that cross product is mostly rounding error, and at zero it normalizes to NaN.
    sine = np.linalg.norm(np.cross(view / np.linalg.norm(view), np.divide(camera.up, np.linalg.norm(camera.up))))
    if sine < 1e-3:
        raise t.at.key("up").error(f"expected a vector not parallel to the view direction "
                                   f"(target - eye = {show(view.tolist())}), got {show(camera.up)}")
    return camera


def _object(t: Table) -> SceneObject:
    shape = t.variant("shape", _SHAPES)
    material = t.variant("material", _MATERIALS, default=DiffuseMaterial())
    if isinstance(material, GlassMaterial) and isinstance(shape, PlaneShape):
        # Refraction follows a ray through the object to where it leaves: a plane has no inside.
        raise t.at.key("material").error('expected a closed shape for a glass material (a ray refracted into it '
                                         'must leave through its back), got a plane')
    if "animation" in t.data and isinstance(shape, PlaneShape) and not isinstance(material, MirrorMaterial):
        raise t.at.key("animation").error(f"expected no animation on a plane that is not a mirror (floors and walls "
                                          f"that are not mirrors are intersected as fixed planes and cannot move), "
                                          f"got {show(t.data['animation'])}")
    position, rotation, scale, animation = _placement(t)
    return SceneObject(name=t.req("name", NAME), shape=shape, material=material, position=position,
                       rotation=rotation, scale=scale, animation=animation)


def _placement(t: Table) -> tuple[Vec3, Vec3, Vec3, Animation | None]:
    """An object's position, rotation, scale and animation."""
    return (t.opt("position", _POINT, SceneObject.position), t.opt("rotation", _POINT, SceneObject.rotation),
            t.opt("scale", f.number_or_vec3(f.POSITIVE), SceneObject.scale), _animation(t))


_PLACEMENT = ("position", "rotation", "scale", "animation")


def _placed_gltf(t: Table, entry: int) -> list[SceneObject]:
    """`shape = { type = "gltf", path = ... }` of [[objects]] entry `entry`: the file's parts, named
    `name/part`, placed by the object's position, rotation, scale and animation on top of the file's
    node transforms, with `materials` overriding the file's by name. The file's lights and cameras
    are not placed."""
    shape = Table(t.data["shape"], t.at.key("shape"), ("type", "path"))
    path, written = _model_file(shape, GLTF_SUFFIXES)
    model = read_gltf(path, written)
    labels = [m.label for m in model.materials]
    overrides: dict[str, Material] = {}
    for label, value in Table(t.data.get("materials", {}), t.at.key("materials"), labels or ("(none)",)).data.items():
        overrides[label] = read_variant(value, t.at.key("materials").key(label), _MATERIALS)
    return gltf_objects(model, overrides, f"{t.req('name', NAME)}/", *_placement(t), placed_by=entry)


def _is_gltf(value: Any) -> bool:
    shape = value.get("shape") if isinstance(value, Mapping) else None
    return isinstance(shape, Mapping) and shape.get("type") == "gltf"


def _objects(top: Table) -> tuple[SceneObject, ...]:
    objects: list[SceneObject] = []
    index_of: dict[str, int] = {}
    for i, (value, at) in enumerate(top.array("objects", at_least=1)):
        if _is_gltf(value):
            placed = _placed_gltf(Table(value, at, ("name", "shape", "materials", *_PLACEMENT)), i)
        else:
            placed = [_object(Table(value, at, ("name", "shape", "material", *_PLACEMENT)))]
        for obj in placed:
            if obj.name in index_of:
                part = f" for {obj.origin.describe()}" if obj.origin is not None else ""
                raise at.key("name").error(f"expected a name no other object has, got {json.dumps(obj.name)}{part} "
                                           f"(already used by objects[{index_of[obj.name]}])")
            index_of[obj.name] = i
            objects.append(obj)
    return tuple(objects)


def parse_scene(data: Mapping[str, Any], source: str, base_dir: Path) -> Scene:
    """Validate already-parsed TOML data; `source` names it in errors, `base_dir` anchors model paths."""
    with scene_images_budget():  # the images it decodes share the machine's memory (image_files.py)
        return _parse_scene(data, source, base_dir)


def _parse_scene(data: Mapping[str, Any], source: str, base_dir: Path) -> Scene:
    top = Table(data, At(source, "", Path(base_dir)), ("render", "camera", "environment", "lights", "objects"))
    scene = Scene(
        source=source,
        render=_render(top.section("render", ("size", "impostor_resolution", "ambient", "simplified_triangles",
                                              "shadow_resolution", "image_memory", "max_bounces", "tone_mapping",
                                              "exposure", "samples"))),
        camera=_camera(top.section("camera", ("eye", "target", "up", "fov_y"))),
        environment=top.variant("environment", _ENVIRONMENTS, default=Environment(), default_type="gradient"),
        lights=tuple(read_variant(value, at, _LIGHTS) for value, at in top.array("lights")),
        objects=_objects(top),
    )
    check_scene(scene)  # the limits of the scene as a whole (gpu/limits.py)
    return scene


#: The largest TOML scene read (a scene of 10,000 spheres takes about 1 MiB).
MAX_SCENE_FILE_BYTES = 64 * 2**20


def load_scene(path: str | os.PathLike[str]) -> Scene:
    """Read and validate a scene file (TOML, or a glTF file as a whole scene); every problem is a
    SceneError naming the file and the field."""
    source = os.fspath(path)
    if Path(source).suffix.lower() in GLTF_SUFFIXES:
        with scene_images_budget():
            return gltf_scene(Path(source), source)
    try:
        text = read_file_bytes(Path(source), source, "a scene file", MAX_SCENE_FILE_BYTES).decode("utf-8")
    except UnicodeDecodeError as err:
        raise SceneError(source, "", f"expected UTF-8 text, got an undecodable byte at offset {err.start}") from err
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise SceneError(source, "", f"invalid TOML: {err}") from err
    return parse_scene(data, source, Path(source).resolve().parent)
