"""Scene files: the bundled scenes load, values and defaults come through, and bad input is named.

Every error test checks the dotted path of the bad field and part of the message, because the message
is the whole user interface of a scene-file mistake.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pyrr
import pytest

from depthimpostor.constants import MAX_LIGHTS
from depthimpostor.errors import SceneError
from depthimpostor.world import World
from depthimpostor.scene import (
    MODEL_PATH_VARIABLE,
    BoxShape,
    Camera,
    CheckerMaterial,
    CylinderShape,
    DiffuseMaterial,
    Environment,
    Light,
    MeshShape,
    MirrorMaterial,
    PlaneShape,
    RenderSettings,
    Scene,
    SceneObject,
    Shape,
    SphereShape,
    TorusKnotShape,
    TorusShape,
    load_scene,
    parse_scene,
)

REPO = Path(__file__).resolve().parents[1]
SCENE_FILES = sorted((REPO / "scenes").glob("*.toml"))
SHARED_MODELS = Path(__file__).resolve().parents[2] / "shared" / "data" / "models"


@pytest.fixture
def model_path(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> Path:
    """$DEPTHIMPOSTOR_MODEL_PATH pointing at a folder with stanford-bunny.obj (a stand-in if need be)."""
    folder = SHARED_MODELS
    if not (folder / "stanford-bunny.obj").is_file():
        import trimesh

        folder = tmp_path / "models"
        folder.mkdir()
        # About the bunny's raw size and height above y = 0, so the scene places it the same way.
        stand_in = trimesh.creation.icosphere(subdivisions=2, radius=0.08)
        stand_in.apply_translation((0.0, 0.11, 0.0))
        stand_in.export(folder / "stanford-bunny.obj")
    monkeypatch.setenv(MODEL_PATH_VARIABLE, str(folder))
    return folder


def write(folder: Path, text: str, name: str = "scene.toml") -> Path:
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


def an_object(name: str = "a", shape: str = '{ type = "sphere", radius = 1.0 }', extra: str = "") -> str:
    return f'[[objects]]\nname = "{name}"\nshape = {shape}\n{extra}\n'


OK = an_object()


# --- The bundled scenes ---------------------------------------------------------------------------


def test_the_bundled_scenes_are_all_there() -> None:
    names = {path.stem for path in SCENE_FILES}
    assert {"default", "planar_mirror", "grid_3x3", "lecture_8x9", "bunny"} <= names


@pytest.mark.parametrize("path", SCENE_FILES, ids=lambda path: path.name)
def test_bundled_scene_loads(path: Path, model_path: Path) -> None:
    scene = load_scene(path)
    assert scene.source == str(path)
    assert scene.mirrors, "every bundled scene shows a reflection"
    assert path.read_text(encoding="utf-8").startswith("# "), "each scene file opens with what it shows"


def test_default_scene_is_a_mirror_sphere_among_diffuse_objects() -> None:
    scene = load_scene(REPO / "scenes" / "default.toml")
    assert scene.render == RenderSettings(size=(960, 540), impostor_resolution=256, ambient=0.25)
    (mirror,) = scene.mirrors
    assert mirror.shape == SphereShape(1.0)
    assert mirror.position == (0.0, 1.0, 0.0)
    assert mirror.material == MirrorMaterial((0.95, 0.95, 0.95))
    floor = next(o for o in scene.objects if isinstance(o.shape, PlaneShape))
    assert floor.shape == PlaneShape((20.0, 20.0)) and isinstance(floor.material, CheckerMaterial)
    assert len(scene.lights) == 1 and scene.lights[0].type == "directional"


def test_planar_mirror_faces_plus_z() -> None:
    (mirror,) = load_scene(REPO / "scenes" / "planar_mirror.toml").mirrors
    assert isinstance(mirror.shape, PlaneShape)
    normal = mirror.model_matrix() @ (0.0, 1.0, 0.0, 0.0)
    np.testing.assert_allclose(normal[:3], (0.0, 0.0, 1.0), atol=1e-12)


def bounding_radius(shape: Shape) -> float:
    """A sphere about the local origin containing the shape (every shape is built centred there)."""
    if isinstance(shape, SphereShape):
        return shape.radius
    if isinstance(shape, BoxShape):
        return 0.5 * math.hypot(*shape.size)
    if isinstance(shape, CylinderShape):
        return math.hypot(shape.radius, 0.5 * shape.height)
    if isinstance(shape, TorusShape):
        return shape.major + shape.minor
    if isinstance(shape, TorusKnotShape):
        return shape.radius + shape.tube  # the knot's curve stays within `radius` of its centre
    raise AssertionError(f"no bound for {shape}")


def test_lecture_scene_has_8_mirrors_and_9_reflected_objects_clear_of_them() -> None:
    scene = load_scene(REPO / "scenes" / "lecture_8x9.toml")
    reflected = [o for o in scene.diffuse_objects if not isinstance(o.shape, PlaneShape)]
    assert len(scene.mirrors) == 8 and len(reflected) == 9
    for mirror in scene.mirrors:
        assert isinstance(mirror.shape, SphereShape)
        for obj in reflected:
            gap = math.dist(mirror.position, obj.position)
            bound = bounding_radius(obj.shape) * max(obj.scale)
            assert gap - mirror.shape.radius - bound >= 0.3, (mirror.name, obj.name)
            assert gap > bound, f"{obj.name}'s bounding sphere contains {mirror.name}'s centre"


def test_the_bunny_ships_beside_its_scene_and_other_models_are_found_on_the_model_path(
        model_path: Path, tmp_path: Path) -> None:
    """scenes/bunny.toml reads the PLY that ships beside it (its folder comes before the model
    path); a scene elsewhere naming a model it does not have finds it on the model path."""
    scene = load_scene(REPO / "scenes" / "bunny.toml")
    bunny = next(o for o in scene.objects if isinstance(o.shape, MeshShape))
    assert bunny.shape.written == "stanford-bunny.ply"
    assert bunny.shape.path == (REPO / "scenes" / "stanford-bunny.ply").resolve()
    assert len(World(scene).geometry[[o.name for o in scene.objects].index(bunny.name)].local_mesh.indices) == 69451
    elsewhere = tmp_path / "elsewhere.toml"
    elsewhere.write_text((REPO / "scenes" / "bunny.toml").read_text().replace("stanford-bunny.ply", "stanford-bunny.obj"))
    found = next(o for o in load_scene(elsewhere).objects if isinstance(o.shape, MeshShape))
    assert found.shape.path == (model_path / "stanford-bunny.obj").resolve() and found.shape.path.is_absolute()


# --- Values, defaults and transforms --------------------------------------------------------------

EXAMPLE = """
[render]
size = [640, 360]
impostor_resolution = 128
ambient = 0.2
[camera]
eye = [1.0, 2.0, 6.0]
target = [0.0, 0.5, 0.0]
up = [0.0, 1.0, 0.0]
fov_y = 50.0
[environment]
type = "gradient"
zenith = [0.35, 0.55, 0.9]
horizon = [0.9, 0.9, 0.95]
ground = [0.3, 0.28, 0.25]
[[lights]]
type = "directional"
direction = [-0.4, -1.0, -0.3]
color = [1.0, 0.9, 0.8]
intensity = 2
[[lights]]
type = "point"
position = [0, 3, 0]
[[objects]]
name = "mirror"
shape = { type = "sphere", radius = 1.0 }
material = { type = "mirror", tint = [0.95, 0.95, 0.95] }
position = [0.0, 1.0, 0.0]
rotation = [10.0, 20.0, 30.0]
scale = [1, 2, 3]
[[objects]]
name = "floor"
shape = { type = "plane", size = [20, 10] }
material = { type = "checker", color_a = [0.8, 0.8, 0.8], color_b = [0.3, 0.3, 0.3], scale = 0.5 }
[[objects]]
name = "knot"
shape = { type = "torus_knot", p = 2, q = 3, radius = 0.5, tube = 0.1 }
material = { type = "diffuse", color = [1, 1, 0] }
scale = 2
"""


def test_example_values_come_through(tmp_path: Path) -> None:
    scene = load_scene(write(tmp_path, EXAMPLE))
    assert scene.render == RenderSettings((640, 360), 128, 0.2)
    assert scene.camera == Camera((1.0, 2.0, 6.0), (0.0, 0.5, 0.0), (0.0, 1.0, 0.0), 50.0)
    assert scene.environment == Environment("gradient", (0.9, 0.9, 0.95), (0.35, 0.55, 0.9),
                                            (0.9, 0.9, 0.95), (0.3, 0.28, 0.25))
    assert scene.lights == (
        Light("directional", (-0.4, -1.0, -0.3), (0.0, 0.0, 0.0), (1.0, 0.9, 0.8), 2.0),
        Light("point", (0.0, 0.0, 0.0), (0.0, 3.0, 0.0), (1.0, 1.0, 1.0), 1.0),
    )
    assert scene.objects == (
        SceneObject("mirror", SphereShape(1.0), MirrorMaterial((0.95, 0.95, 0.95)), (0.0, 1.0, 0.0),
                    (10.0, 20.0, 30.0), (1.0, 2.0, 3.0)),
        SceneObject("floor", PlaneShape((20.0, 10.0)), CheckerMaterial((0.8,) * 3, (0.3,) * 3, 0.5)),
        SceneObject("knot", TorusKnotShape(2, 3, 0.5, 0.1), DiffuseMaterial((1.0, 1.0, 0.0)), scale=(2.0, 2.0, 2.0)),
    )
    assert [o.name for o in scene.mirrors] == ["mirror"]
    assert [o.name for o in scene.diffuse_objects] == ["floor", "knot"]
    # Integers written where numbers are expected become floats, so the dataclasses hold one type.
    assert all(isinstance(x, float) for x in scene.objects[1].shape.size)


def test_defaults_apply(tmp_path: Path) -> None:
    scene = load_scene(write(tmp_path, OK))
    assert scene.render == RenderSettings((960, 540), 256, 0.15)
    assert scene.camera == Camera((0.0, 1.6, 5.0), (0.0, 0.6, 0.0), (0.0, 1.0, 0.0), 45.0)
    assert scene.environment == Environment("gradient", (0.9, 0.9, 0.95), (0.35, 0.55, 0.9),
                                            (0.9, 0.9, 0.95), (0.3, 0.28, 0.25))
    assert scene.lights == ()
    (obj,) = scene.objects
    assert obj == SceneObject("a", SphereShape(1.0), DiffuseMaterial((0.8, 0.8, 0.8)),
                              (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    np.testing.assert_array_equal(obj.model_matrix(), np.eye(4))
    tints = load_scene(write(tmp_path, an_object(extra='material = { type = "mirror" }'))).objects[0].material
    assert tints == MirrorMaterial((1.0, 1.0, 1.0))
    checker = an_object(extra='material = { type = "checker", color_a = [1, 1, 1], color_b = [0, 0, 0] }')
    assert load_scene(write(tmp_path, checker)).objects[0].material == CheckerMaterial((1.0,) * 3, (0.0,) * 3, 1.0)


def test_constant_environment_fills_every_colour(tmp_path: Path) -> None:
    scene = load_scene(write(tmp_path, '[environment]\ntype = "constant"\ncolor = [0.1, 0.2, 0.3]\n' + OK))
    assert scene.environment == Environment("constant", *([(0.1, 0.2, 0.3)] * 4))


def test_gradient_environment_type_may_be_left_out(tmp_path: Path) -> None:
    scene = load_scene(write(tmp_path, "[environment]\nzenith = [0, 0, 1]\n" + OK))
    assert scene.environment.type == "gradient" and scene.environment.zenith == (0.0, 0.0, 1.0)


def test_model_matrix_scales_then_rotates_x_y_z_then_translates() -> None:
    obj = SceneObject("a", SphereShape(1.0), position=(10.0, 20.0, 30.0), rotation=(90.0, 90.0, 90.0),
                      scale=(2.0, 3.0, 4.0))
    # (1, 1, 1) scaled: (2, 3, 4); about X by 90 (y -> z): (2, -4, 3); about Y by 90 (z -> x): (3, -4, -2);
    # about Z by 90 (x -> y): (4, 3, -2); moved: (14, 23, 28).
    np.testing.assert_allclose(obj.model_matrix() @ (1.0, 1.0, 1.0, 1.0), (14.0, 23.0, 28.0, 1.0), atol=1e-12)
    assert obj.model_matrix().dtype == np.float64 and obj.model_matrix().shape == (4, 4)


def test_model_matrix_agrees_with_pyrr_rotations() -> None:
    angles = (17.0, -48.0, 123.0)
    obj = SceneObject("a", SphereShape(1.0), position=(1.0, -2.0, 3.0), rotation=angles, scale=(0.5, 2.0, 1.5))
    rx, ry, rz = (math.radians(a) for a in angles)
    linear = (pyrr.matrix33.create_from_z_rotation(rz) @ pyrr.matrix33.create_from_y_rotation(ry)
              @ pyrr.matrix33.create_from_x_rotation(rx) @ np.diag(obj.scale))
    np.testing.assert_allclose(obj.model_matrix()[:3, :3], linear, atol=1e-12)
    np.testing.assert_allclose(obj.model_matrix()[:, 3], (1.0, -2.0, 3.0, 1.0))


def test_with_overrides_replaces_render_settings(tmp_path: Path) -> None:
    scene = load_scene(write(tmp_path, OK))
    changed = scene.with_overrides(size=(320, 200), impostor_resolution=64, simplified_triangles=100)
    assert changed.render == RenderSettings((320, 200), 64, scene.render.ambient, 100)
    assert changed.objects == scene.objects and scene.render.size == (960, 540)
    assert scene.with_overrides() == scene


@pytest.mark.parametrize(("kwargs", "path", "fragment"), [
    ({"size": (0, 200)}, "--size", "expected 2 integers in [1, 16384], got [0, 200]"),
    ({"size": (320,)}, "--size", "expected 2 integers"),
    ({"impostor_resolution": 5000}, "--impostor-res", 'expected an integer in [4, 4096] or "auto", got 5000'),
    ({"impostor_resolution": "big"}, "--impostor-res", 'expected an integer in [4, 4096] or "auto", got "big"'),
    ({"impostor_resolution": True}, "--impostor-res", "got true"),
    ({"simplified_triangles": 0}, "--simplified-triangles", "expected an integer >= 4, got 0"),
])
def test_with_overrides_checks_values(tmp_path: Path, kwargs: dict[str, object], path: str, fragment: str) -> None:
    scene = load_scene(write(tmp_path, OK))
    with pytest.raises(SceneError) as caught:
        scene.with_overrides(**kwargs)  # type: ignore[arg-type]
    assert caught.value.source == "command line" and caught.value.path == path
    assert str(caught.value).startswith(f"command line: {path}: ") and fragment in str(caught.value)


def test_mesh_paths_try_the_scene_folder_before_the_model_path(tmp_path: Path,
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    first, second, scene_dir = tmp_path / "first", tmp_path / "second", tmp_path / "scene"
    for folder in (first, second, scene_dir):
        folder.mkdir()
    (second / "m.obj").write_text("v 0 0 0\n")
    (second / "n.ply").write_text("ply\n")
    (scene_dir / "n.ply").write_text("ply\n")
    monkeypatch.setenv(MODEL_PATH_VARIABLE, os.pathsep.join([str(first), str(second)]))
    text = an_object("m", '{ type = "mesh", path = "m.obj" }') + an_object("n", '{ type = "mesh", path = "n.ply" }')
    m, n = load_scene(write(scene_dir, text)).objects
    assert m.shape == MeshShape((second / "m.obj").resolve(), "m.obj")
    assert n.shape == MeshShape((scene_dir / "n.ply").resolve(), "n.ply")


def test_missing_mesh_names_the_file_and_every_folder_searched(tmp_path: Path,
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    models = tmp_path / "models"
    monkeypatch.setenv(MODEL_PATH_VARIABLE, str(models))
    path = write(tmp_path, an_object(shape='{ type = "mesh", path = "nothing.glb" }'))
    with pytest.raises(SceneError) as caught:
        load_scene(path)
    message = str(caught.value)
    assert caught.value.path == "objects[0].shape.path"
    assert '"nothing.glb"' in message and str(tmp_path.resolve()) in message and str(models.resolve()) in message


def test_parse_scene_takes_data_already_read(tmp_path: Path) -> None:
    data = {"objects": [{"name": "a", "shape": {"type": "box", "size": [1, 2, 3]}}]}
    scene = parse_scene(data, "inline", tmp_path)
    assert isinstance(scene, Scene) and scene.objects[0].shape == BoxShape((1.0, 2.0, 3.0))
    with pytest.raises(SceneError, match=r"^inline: objects\[0\]\.shape\.size: expected 3 numbers > 0"):
        parse_scene({"objects": [{"name": "a", "shape": {"type": "box", "size": [1, 2]}}]}, "inline", tmp_path)


# --- Files that cannot be read --------------------------------------------------------------------


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(SceneError, match=r"nope\.toml: no such file$") as caught:
        load_scene(tmp_path / "nope.toml")
    assert caught.value.source == str(tmp_path / "nope.toml")


def test_directory_is_not_a_scene(tmp_path: Path) -> None:
    with pytest.raises(SceneError, match="expected a scene file, got a directory"):
        load_scene(tmp_path)


def test_file_that_is_not_utf8(tmp_path: Path) -> None:
    path = tmp_path / "latin1.toml"
    path.write_bytes('# caf\xe9\n'.encode("latin-1") + OK.encode())
    with pytest.raises(SceneError, match="expected UTF-8 text"):
        load_scene(path)


# --- Bad values, each named by its dotted path ----------------------------------------------------

LIGHT = '[[lights]]\ntype = "directional"\ndirection = [0, -1, 0]\n'
POINT_LIGHT = '[[lights]]\ntype = "point"\nposition = [0, 3, 0]\n'
FLOOR = '{ type = "plane", size = [10.0, 10.0] }'


def animated(animation: str, shape: str = '{ type = "sphere", radius = 1.0 }', material: str = "") -> str:
    """A scene of one object with `animation = {animation}` (and `material` when given)."""
    return an_object(shape=shape, extra=f"animation = {{ {animation} }}\n{material}")


ROTATE = 'type = "rotate", axis = [0, 1, 0], degrees_per_second = 30'
ORBIT = 'type = "orbit", centre = [0, 0, 0], axis = [0, 1, 0], degrees_per_second = -20'

ANIMATION_CASES = [
    ("animation_type", animated('type = "spin", axis = [0, 1, 0], degrees_per_second = 30'),
     "objects[0].animation.type", 'expected one of: rotate, orbit, got "spin"'),
    ("animation_without_type", animated("axis = [0, 1, 0], degrees_per_second = 30"), "objects[0].animation.type",
     "missing required field; expected one of: rotate, orbit"),
    ("animation_not_a_table", an_object(extra='animation = "rotate"'), "objects[0].animation",
     'expected a table, got "rotate"'),
    ("animation_unknown_field", animated(ROTATE + ", speed = 2"), "objects[0].animation",
     'unknown field "speed"; expected one of: type, axis, degrees_per_second, centre'),
    ("animation_zero_axis", OK.replace('"a"', '"b"') + animated('type = "rotate", axis = [0, 0, 0], '
                                                                 'degrees_per_second = 30'),
     "objects[1].animation.axis", "expected 3 numbers, of length at least 1e-09, got [0, 0, 0]"),
    ("animation_missing_axis", animated('type = "orbit", centre = [0, 0, 0], degrees_per_second = 30'),
     "objects[0].animation.axis", "missing required field; expected 3 numbers, of length at least 1e-09"),
    *((f"animation_rate_{name}", animated(f'type = "rotate", axis = [0, 1, 0], degrees_per_second = {rate}'),
       "objects[0].animation.degrees_per_second", fragment)
      for name, rate, fragment in [
          ("zero", "0", "expected a number other than 0 (an animation that never turns is a mistake: leave "
                        "animation out), got 0"),
          ("infinite", "-inf", "expected a number, got -inf"),
          ("nan", "nan", "expected a number, got nan"),
          ("text", '"fast"', 'expected a number, got "fast"'),
      ]),
    ("orbit_without_centre", animated('type = "orbit", axis = [0, 1, 0], degrees_per_second = 30'),
     "objects[0].animation.centre", "missing required field; expected 3 numbers"),
    ("rotate_with_centre", animated(ROTATE + ", centre = [1, 2, 3]"), "objects[0].animation.centre",
     'expected no centre with type = "rotate", which turns a thing about its own position '
     '(type = "orbit" turns it about a centre), got [1, 2, 3]'),
    ("point_light_rotates", POINT_LIGHT + f"animation = {{ {ROTATE} }}\n" + OK, "lights[0].animation.type",
     'expected "orbit" for a point light (a point light turned about itself does not move), got "rotate"'),
    ("directional_light_orbits", LIGHT + f"animation = {{ {ORBIT} }}\n" + OK, "lights[0].animation.type",
     'expected "rotate" for a directional light (it has no position to orbit'),
    ("light_animation_zero_axis", LIGHT + 'animation = { type = "rotate", axis = [0, 0, 0], degrees_per_second = 1 }'
     "\n" + OK, "lights[0].animation.axis", "of length at least 1e-09"),
    ("diffuse_plane_animated", OK.replace('"a"', '"b"') + animated(ROTATE, FLOOR), "objects[1].animation",
     "expected no animation on a plane that is not a mirror (floors and walls that are not mirrors are "
     "intersected as fixed planes and cannot move), got {type = \"rotate\""),
    ("checker_plane_animated", animated(ORBIT, FLOOR, 'material = { type = "checker", color_a = [1, 1, 1], '
                                                      'color_b = [0, 0, 0] }'),
     "objects[0].animation", "expected no animation on a plane that is not a mirror"),
]

BAD_CASES = [
    ("bool_as_number", "[render]\nambient = true\n" + OK, "render.ambient", "expected a number in [0, 1], got true"),
    ("bool_in_vector", "[camera]\neye = [0.0, true, 5.0]\n" + OK, "camera.eye",
     "expected 3 numbers, got [0.0, true, 5.0]"),
    ("not_finite", "[render]\nambient = nan\n" + OK, "render.ambient", "got nan"),
    ("unknown_shape_field", an_object(shape='{ type = "sphere", radiuss = 1.0 }'), "objects[0].shape",
     'unknown field "radiuss"; expected one of: type, radius'),
    ("unknown_shape_type", an_object(shape='{ type = "cone", radius = 1.0 }'), "objects[0].shape.type",
     'expected one of: plane, box, sphere, cylinder, torus, torus_knot, mesh, gltf, got "cone"'),
    ("missing_shape_type", an_object(shape="{ radius = 1.0 }"), "objects[0].shape.type",
     "missing required field; expected one of: plane, box"),
    ("missing_shape", '[[objects]]\nname = "a"\n', "objects[0].shape", "missing required field"),
    ("shape_not_table", an_object(shape='"sphere"'), "objects[0].shape", 'expected a table, got "sphere"'),
    ("missing_radius", an_object(shape='{ type = "sphere" }'), "objects[0].shape.radius",
     "missing required field; expected a number > 0"),
    ("missing_mesh_file", an_object(shape='{ type = "mesh", path = "missing.obj" }'), "objects[0].shape.path",
     'got "missing.obj": not found'),
    ("mesh_format", an_object(shape='{ type = "mesh", path = "model.stl" }'), "objects[0].shape.path",
     'expected a path to a .obj, .ply, .glb, .gltf file, got "model.stl"'),
    ("duplicate_names", OK + an_object(), "objects[1].name", 'got "a" (already used by objects[0])'),
    ("bad_toml_syntax", "[render\nsize = [1, 2]\n" + OK, "", "invalid TOML: "),
    ("wrong_vector_length", an_object(extra="position = [1.0, 2.0]"), "objects[0].position",
     "expected 3 numbers, got [1.0, 2.0]"),
    ("color_not_a_vector", an_object(extra='material = { type = "diffuse", color = "red" }'),
     "objects[0].material.color", 'expected 3 numbers in [0, 1], got "red"'),
    ("color_out_of_range", OK + an_object("b", extra='material = { type = "diffuse", color = [1.5, 0, 0] }'),
     "objects[1].material.color", "expected 3 numbers in [0, 1], got [1.5, 0, 0]"),
    ("unknown_material", an_object(extra='material = { type = "crystal" }'), "objects[0].material.type",
     'expected one of: diffuse, metallic_roughness, checker, mirror, glass, got "crystal"'),
    ("glass_ior_below_air", an_object(extra='material = { type = "glass", ior = 0.9 }'), "objects[0].material.ior",
     "expected a number in [1, 4], got 0.9"),
    ("glass_plane", an_object(shape='{ type = "plane", size = [1.0, 1.0] }', extra='material = { type = "glass" }'),
     "objects[0].material", "expected a closed shape for a glass material"),
    ("glass_tint", an_object(extra='material = { type = "glass", tint = [1.5, 1, 1] }'), "objects[0].material.tint",
     "expected 3 numbers in [0, 1]"),
    ("checker_scale", an_object(extra='material = { type = "checker", color_a = [1, 1, 1], color_b = [0, 0, 0], '
                                      'scale = 0 }'), "objects[0].material.scale", "expected a number > 0, got 0"),
    ("zero_direction", '[[lights]]\ntype = "directional"\ndirection = [0, 0, 0]\n' + OK, "lights[0].direction",
     "expected 3 numbers, of length at least 1e-09, got [0, 0, 0]"),
    ("field_of_another_light_type", '[[lights]]\ntype = "point"\ndirection = [0, -1, 0]\n' + OK, "lights[0]",
     'unknown field "direction"; expected one of: type, position, color, intensity'),
    ("light_without_type", "[[lights]]\ndirection = [0, -1, 0]\n" + OK, "lights[0].type",
     "missing required field; expected one of: directional, point"),
    ("negative_intensity", LIGHT + "intensity = -1\n" + OK, "lights[0].intensity", "expected a number >= 0, got -1"),
    ("lights_not_an_array", '[lights]\ntype = "point"\n' + OK, "lights", "expected an array of tables ([[lights]])"),
    ("too_many_lights", LIGHT * (MAX_LIGHTS + 1) + OK, "lights",
     f"expected at most {MAX_LIGHTS} [[lights]] tables, got {MAX_LIGHTS + 1}"),
    ("eye_equals_target", "[camera]\neye = [1.0, 2.0, 3.0]\ntarget = [1, 2, 3]\n" + OK, "camera.target",
     "expected a point other than camera.eye, got [1.0, 2.0, 3.0]"),
    ("up_parallel_to_view", "[camera]\neye = [0.0, 5.0, 0.0]\ntarget = [0.0, 0.0, 0.0]\n" + OK, "camera.up",
     "expected a vector not parallel to the view direction (target - eye = [0.0, -5.0, 0.0]), got [0.0, 1.0, 0.0]"),
    ("zero_up", "[camera]\nup = [0, 0, 0]\n" + OK, "camera.up", "of length at least 1e-09"),
    ("tiny_light_direction", '[[lights]]\ntype = "directional"\ndirection = [1e-200, 0, 0]\n' + OK,
     "lights[0].direction", "expected 3 numbers, of length at least 1e-09, got [1e-200, 0, 0]"),
    ("fov_zero", "[camera]\nfov_y = 0\n" + OK, "camera.fov_y", "expected a number in (0, 179], got 0"),
    ("no_objects", "[render]\nambient = 0.5\n", "objects", "expected at least 1 [[objects]] table(s), got 0"),
    ("empty_objects", "objects = []\n", "objects", "expected at least 1"),
    ("size_out_of_range", "[render]\nsize = [0, 540]\n" + OK, "render.size",
     "expected 2 integers in [1, 16384], got [0, 540]"),
    ("size_of_floats", "[render]\nsize = [960.0, 540.0]\n" + OK, "render.size", "expected 2 integers"),
    *((f"resolution_{name}", f"[render]\nimpostor_resolution = {value}\n" + OK, "render.impostor_resolution",
       f'expected an integer in [4, 4096] or "auto", got {value}')
      for name, value in [("float", "256.0"), ("word", '"big"'), ("auto_in_capitals", '"AUTO"'), ("too_small", "2"),
                          ("bool", "true")]),
    ("shadow_resolution_auto", '[render]\nshadow_resolution = "auto"\n' + OK, "render.shadow_resolution",
     'expected an integer in [4, 4096], got "auto"'),
    ("unknown_section", '[[object]]\nname = "a"\n' + OK, "",
     'unknown field "object"; expected one of: render, camera, environment, lights, objects'),
    ("unknown_render_field", "[render]\nwidth = 100\n" + OK, "render",
     'unknown field "width"; expected one of: size, impostor_resolution, ambient, simplified_triangles'),
    ("simplified_too_few", "[render]\nsimplified_triangles = 3\n" + OK, "render.simplified_triangles",
     "expected an integer >= 4, got 3"),
    ("tone_mapping_unknown", '[render]\ntone_mapping = "filmic"\n' + OK, "render.tone_mapping",
     'expected one of: none, aces, reinhard, got "filmic"'),
    ("exposure_too_large", "[render]\nexposure = 30\n" + OK, "render.exposure", "expected a number in [-20, 20], got 30"),
    ("exposure_text", '[render]\nexposure = "+1"\n' + OK, "render.exposure", 'got "+1"'),
    ("unknown_object_field", an_object(extra="colour = [1, 0, 0]"), "objects[0]", 'unknown field "colour"'),
    ("missing_name", '[[objects]]\nshape = { type = "sphere", radius = 1.0 }\n', "objects[0].name",
     "missing required field; expected a non-empty string"),
    ("empty_name", an_object(name=""), "objects[0].name", 'expected a non-empty string, got ""'),
    ("torus_minor_not_below_major", an_object(shape='{ type = "torus", major = 0.5, minor = 0.5 }'),
     "objects[0].shape.minor", "expected a number less than major (0.5), got 0.5"),
    ("knot_not_coprime", an_object(shape='{ type = "torus_knot", p = 2, q = 4, radius = 1, tube = 0.1 }'),
     "objects[0].shape.q", "expected an integer coprime with p (2), got 4"),
    ("knot_p_float", an_object(shape='{ type = "torus_knot", p = 2.0, q = 3, radius = 1, tube = 0.1 }'),
     "objects[0].shape.p", "expected an integer > 0, got 2.0"),
    ("plane_size", an_object(shape='{ type = "plane", size = [1.0, 0.0] }'), "objects[0].shape.size",
     "expected 2 numbers > 0, got [1.0, 0.0]"),
    ("negative_scale", an_object(extra="scale = -1.0"), "objects[0].scale",
     "expected a number > 0 or 3 numbers > 0, got -1.0"),
    ("environment_type", '[environment]\ntype = "hdri"\n' + OK, "environment.type",
     'expected one of: gradient, constant, equirect, got "hdri"'),
    ("constant_without_color", '[environment]\ntype = "constant"\n' + OK, "environment.color",
     "missing required field; expected 3 numbers >= 0"),
    ("gradient_with_color", '[environment]\ncolor = [1, 1, 1]\n' + OK, "environment",
     'unknown field "color"; expected one of: type, zenith, horizon, ground'),
    *ANIMATION_CASES,
]


@pytest.mark.parametrize(("text", "path", "fragment"), [case[1:] for case in BAD_CASES],
                         ids=[case[0] for case in BAD_CASES])
def test_bad_scene_is_named_by_path(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                    text: str, path: str, fragment: str) -> None:
    monkeypatch.setenv(MODEL_PATH_VARIABLE, str(tmp_path / "models"))
    file = write(tmp_path, text, "bad.toml")
    with pytest.raises(SceneError) as caught:
        load_scene(file)
    error = caught.value
    assert (error.source, error.path) == (str(file), path)
    assert str(error).startswith(f"{file}: {path}: " if path else f"{file}: ")
    assert fragment in str(error), str(error)
    assert "\n" not in str(error), "the CLI prints the message on one line"
