"""glTF scenes (scene/gltf.py): the node tree's transforms, the material rules, the first camera,
KHR_lights_punctual, a glb placed in a TOML scene, the bad inputs, and a glTF scene through every
method and against the truth. Every file is built here (tests/gltf_files.py): nothing downloaded."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import moderngl
import numpy as np
import pytest

from conftest import PROJECT_ROOT, assert_finite
from depthimpostor.cli import main
from depthimpostor.constants import Method
from depthimpostor.errors import SceneWarning
from depthimpostor.geometry import scene_geometry
from depthimpostor.plan import plan_render
from depthimpostor.renderer import Renderer
from depthimpostor.scene import DiffuseMaterial, GlassMaterial, MirrorMaterial, Scene, load_scene
from depthimpostor.scene.gltf import DEFAULT_LIGHT
from depthimpostor.scene.model import MetallicRoughnessMaterial, axis_rotation
from gltf_files import GltfWriter, quaternion
from test_methods import assert_raytrace_matches_the_truth
from test_cli import assert_one_line_error, run_in_process, run_subprocess

TRIANGLE = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]


def load_quietly(path: Path) -> Scene:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SceneWarning)
        return load_scene(path)


def one_box(tmp_path: Path, name: str = "s.glb", **node: object) -> Path:
    w = GltfWriter()
    w.node(mesh=w.mesh(w.box(material=w.material("Grey", (0.5, 0.5, 0.5)))), **node)
    return w.write(tmp_path / name)


def rotation_y(degrees: float) -> np.ndarray:
    return axis_rotation(1, degrees)


# --- transforms ---------------------------------------------------------------------------------------


def test_a_parent_rotation_and_child_translation_land_where_the_math_says(tmp_path: Path) -> None:
    w = GltfWriter()
    box = w.mesh(w.box(0.5))
    child = w.node(root=False, translation=[1.0, 0.0, 0.0], mesh=box)
    w.node(translation=[0.0, 1.0, 0.0], rotation=quaternion((0, 1, 0), 90), children=[child])
    # The same placement as one column-major matrix on a root node: both forms are read alike.
    matrix = np.eye(4)
    matrix[:3, :3], matrix[:3, 3] = rotation_y(90), [0.0, 1.0, 0.0]
    matrix = matrix @ np.array([[1, 0, 0, 1], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], float)
    w.node(matrix=matrix.T.ravel().tolist(), mesh=box)
    scene = load_quietly(w.write(tmp_path / "tree.glb"))
    local = np.asarray(w.json["accessors"][w.json["meshes"][box]["primitives"][0]["attributes"]["POSITION"]]["min"])
    expected_min_corner = rotation_y(90) @ (local + [1.0, 0.0, 0.0]) + [0.0, 1.0, 0.0]
    for obj in scene.objects:
        positions = obj.shape.mesh.positions  # type: ignore[union-attr]
        # Turned 90 degrees about +Y, +X goes to -Z: the box's centre lands at (0, 1, -1).
        assert np.allclose(positions.mean(axis=0), [0.0, 1.0, -1.0], atol=1e-6)
        assert np.isclose(positions, expected_min_corner, atol=1e-6).all(axis=1).any()


@pytest.mark.parametrize("scale", [[-1.0, 2.0, 0.5], [1.0, 1.0, -3.0], [2.0, 0.5, 1.0]])
@pytest.mark.parametrize("file_normals", [True, False])
def test_mirroring_and_non_uniform_scales_keep_triangles_and_normals_outward(
        tmp_path: Path, scale: list[float], file_normals: bool) -> None:
    w = GltfWriter()
    w.node(mesh=w.mesh(w.box(1.0, normals=file_normals)), scale=scale, rotation=quaternion((1, 1, 0), 30))
    mesh = load_quietly(w.write(tmp_path / "s.glb")).objects[0].shape.mesh  # type: ignore[union-attr]
    corners = mesh.positions[mesh.indices].astype(np.float64)
    geometric = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    outward = corners.mean(axis=1) - mesh.positions.mean(axis=0)
    assert (np.einsum("ij,ij->i", geometric, outward) > 0).all()  # wound counter-clockwise from outside
    for k in range(3):
        assert (np.einsum("ij,ij->i", geometric, mesh.normals[mesh.indices[:, k]]) > 0).all()
    # Exactly R @ S of the unit box's corners: undoing them gives back coordinates of +-0.5.
    k = np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)
    cross = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    c, s = np.cos(np.radians(30)), np.sin(np.radians(30))
    turn = c * np.eye(3) + s * cross + (1 - c) * np.outer(k, k)
    local = np.linalg.solve(turn @ np.diag(scale), mesh.positions.T.astype(np.float64)).T
    assert np.allclose(np.abs(local), 0.5, atol=1e-5)


def test_without_file_normals_each_triangle_is_flat(tmp_path: Path) -> None:
    mesh = load_quietly(one_box(tmp_path)).objects[0].shape.mesh  # type: ignore[union-attr]
    assert len(mesh.positions) == 3 * len(mesh.indices)  # each triangle its own three vertices
    corners = mesh.positions[mesh.indices]
    face = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    face /= np.linalg.norm(face, axis=1, keepdims=True)
    assert np.allclose(mesh.normals[mesh.indices], face[:, None, :], atol=1e-6)


# --- materials ----------------------------------------------------------------------------------------


@pytest.mark.parametrize(("fields", "expected"), [
    ({"color": (0.2, 0.4, 0.6), "metallic": 0.0, "roughness": 0.5}, MetallicRoughnessMaterial((0.2, 0.4, 0.6), None, 0.0, 0.5, double_sided=False)),
    ({"color": (0.9, 0.8, 0.7), "metallic": 1.0, "roughness": 0.05}, MirrorMaterial((0.9, 0.8, 0.7))),
    ({"color": (1.0, 1.0, 1.0), "metallic": 0.9, "roughness": 0.1}, MirrorMaterial((1.0, 1.0, 1.0))),
    ({"color": (0.9, 0.8, 0.7), "metallic": 1.0, "roughness": 0.2}, MetallicRoughnessMaterial((0.9, 0.8, 0.7), None, 1.0, 0.2, double_sided=False)),
    ({"color": (0.9, 0.8, 0.7), "metallic": 0.5, "roughness": 0.0}, MetallicRoughnessMaterial((0.9, 0.8, 0.7), None, 0.5, 0.0, double_sided=False)),
    ({"color": (0.8, 1.0, 0.9), "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                                               "KHR_materials_ior": {"ior": 1.33}}}, GlassMaterial(1.33, (0.8, 1.0, 0.9))),
    ({"color": (0.8, 1.0, 0.9), "extensions": {"KHR_materials_transmission": {"transmissionFactor": 0.6}}},
     GlassMaterial(1.5, (0.8, 1.0, 0.9))),
    ({"color": (0.8, 1.0, 0.9), "extensions": {"KHR_materials_transmission": {"transmissionFactor": 0.3}}},
     MetallicRoughnessMaterial((0.8, 1.0, 0.9), None, 0.0, 1.0, double_sided=False)),
    ({"color": (0.5, 0.5, 0.5), "emissiveFactor": [1.0, 0.5, 0.0],
      "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}}},
     MetallicRoughnessMaterial((0.5, 0.5, 0.5), None, 0.0, 1.0, (4.0, 2.0, 0.0), double_sided=False)),
], ids=["diffuse", "mirror", "mirror_at_the_bounds", "too_rough", "half_metal", "glass", "glass_default_ior",
        "little_transmission", "emissive"])
def test_materials_map_by_the_documented_rules(tmp_path: Path, fields: dict[str, object], expected: object) -> None:
    w = GltfWriter()
    w.node(mesh=w.mesh(w.box(material=w.material("M", **fields))))  # type: ignore[arg-type]
    assert load_quietly(w.write(tmp_path / "m.glb")).objects[0].material == expected


def test_a_primitive_without_a_material_is_glTFs_default_white_rough_metal(tmp_path: Path) -> None:
    """glTF 2.0, 3.9.6: white, metallic 1, roughness 1, single-sided (it was drawn as a white
    diffuse material, twice as bright as pyrender draws it: results/llvmpipe/independent.md)."""
    w = GltfWriter()
    w.node(mesh=w.mesh(w.box()))
    assert load_quietly(w.write(tmp_path / "m.glb")).objects[0].material == MetallicRoughnessMaterial(
        (1.0, 1.0, 1.0), metallic=1.0, roughness=1.0, double_sided=False)


def test_a_node_with_two_materials_is_two_objects(tmp_path: Path) -> None:
    w = GltfWriter()
    red, blue = w.material("Red", (1, 0, 0)), w.material("Blue", (0, 0, 1))
    w.node(name="Pair", mesh=w.mesh(w.box(material=red), w.box(material=blue), w.box(material=red)))
    objects = load_quietly(w.write(tmp_path / "m.glb")).objects
    assert [o.name for o in objects] == ["Pair (Red)", "Pair (Blue)"]
    assert [len(o.shape.mesh.indices) for o in objects] == [24, 12]  # type: ignore[union-attr]


def _textured(w: GltfWriter, name: str, **pbr: object) -> tuple[np.ndarray, int]:
    image = np.zeros((4, 8, 4), np.uint8)
    image[..., 3] = 255
    image[:, :4, 0] = 255  # left half red, right half black: the linear mean is 0.5 red
    image[:2, :, 2] = 188  # the top half sRGB 188 blue, about 0.5 in linear: 0.25 in the mean
    material = w.material(name, (0.5, 1.0, 1.0), pbrMetallicRoughness={
        "baseColorFactor": [0.5, 1.0, 1.0, 1.0], "baseColorTexture": {"index": w.texture(image)}, **pbr})
    return image, material


def test_a_textured_diffuse_material_keeps_its_texture_and_factor_without_a_warning(tmp_path: Path) -> None:
    w = GltfWriter()
    image, wood = _textured(w, "Wood")
    uvs = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]
    w.node(mesh=w.mesh(w.primitive(TRIANGLE, [[0, 1, 2]], uvs=uvs, material=wood)))
    path = w.write(tmp_path / "wood.glb")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # textures are drawn: no warning
        obj = load_scene(path).objects[0]
    material = obj.material
    assert isinstance(material, DiffuseMaterial) and material.texture is not None
    assert material.color == (0.5, 1.0, 1.0)  # the factor alone: the texel multiplies it when drawn
    assert np.allclose(material.texture.mean_color, (0.5, 0.0, 0.5029 / 2), atol=2e-3)
    assert np.array_equal(material.texture.image, image)
    assert material.texture.sampler == {"magFilter": 9729, "wrapS": 10497}
    assert np.allclose(obj.shape.mesh.uvs, uvs)  # type: ignore[union-attr]


def test_a_textured_mirror_is_tinted_by_the_mean_colour_with_one_warning(tmp_path: Path) -> None:
    w = GltfWriter()
    _, chrome = _textured(w, "Chrome", metallicFactor=1.0, roughnessFactor=0.0)
    w.node(mesh=w.mesh(w.primitive(TRIANGLE, [[0, 1, 2]], uvs=[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], material=chrome)))
    with pytest.warns(SceneWarning) as caught:
        obj = load_scene(w.write(tmp_path / "chrome.glb")).objects[0]
    assert len(caught) == 1 and '"Chrome"' in str(caught[0].message)
    assert "textures are not drawn on mirrors and glass" in str(caught[0].message)
    assert isinstance(obj.material, MirrorMaterial)
    assert np.allclose(obj.material.tint, (0.5 * 0.5, 0.0, 0.5029 / 2), atol=2e-3)  # the factor times the mean


# --- camera and lights ---------------------------------------------------------------------------------


def test_the_first_camera_is_placed_by_its_node_tree(tmp_path: Path) -> None:
    w = GltfWriter()
    w.json["cameras"] = [{"type": "perspective", "perspective": {"yfov": 0.5, "znear": 0.1}}]
    box = w.mesh(w.box())
    # A mesh under the camera's node stays in the scene (trimesh's graph leaves it out).
    camera = w.node(root=False, camera=0, translation=[0.0, 0.0, 5.0], children=[w.node(root=False, mesh=box)])
    w.node(translation=[1.0, 2.0, 0.0], rotation=quaternion((0, 1, 0), 90), children=[camera])
    scene = load_quietly(w.write(tmp_path / "c.glb"))
    assert np.allclose(scene.camera.eye, [6.0, 2.0, 0.0])
    assert np.allclose(np.subtract(scene.camera.target, scene.camera.eye), [-1.0, 0.0, 0.0])  # -Z turned to -X
    assert np.allclose(scene.camera.up, [0.0, 1.0, 0.0]) and np.isclose(scene.camera.fov_y, np.degrees(0.5))
    assert len(scene.objects) == 1 and np.allclose(scene.objects[0].shape.mesh.positions.mean(axis=0), [6, 2, 0])  # type: ignore[union-attr]


def test_without_a_camera_every_part_is_in_view(tmp_path: Path) -> None:
    w = GltfWriter()
    box = w.mesh(w.box())
    for x in (-40.0, 0.0, 40.0):
        w.node(mesh=box, translation=[x, 10.0, 3.0])
    scene = load_quietly(w.write(tmp_path / "far.glb"))
    eye, target = np.asarray(scene.camera.eye), np.asarray(scene.camera.target)
    view = (target - eye) / np.linalg.norm(target - eye)
    for obj in scene.objects:
        towards = obj.shape.mesh.positions - eye  # type: ignore[union-attr]
        cosine = towards @ view / np.linalg.norm(towards, axis=1)
        assert (cosine > np.cos(np.radians(scene.camera.fov_y / 2))).all()


def test_lights_map_onto_the_light_model(tmp_path: Path) -> None:
    w = GltfWriter()
    w.node(mesh=w.mesh(w.box(2.0)))  # the scene's bounds: centre 0, radius sqrt(3)
    w.node(extensions={"KHR_lights_punctual": {"light": w.light(type="directional", intensity=2.0, color=[1, 0.5, 0])}},
           rotation=quaternion((1, 0, 0), -90))
    w.node(extensions={"KHR_lights_punctual": {"light": w.light(type="point", intensity=32.0)}}, translation=[0, 4, 0])
    w.node(extensions={"KHR_lights_punctual": {"light": w.light(type="point", intensity=6.0)}}, translation=[0, 0.5, 0])
    w.node(extensions={"KHR_lights_punctual": {"light": w.light(type="spot", intensity=16.0)}}, translation=[4, 0, 0])
    with pytest.warns(SceneWarning, match=r"1 spot light\(s\) \(nodes\[4\]\) lit as point lights"):
        sun, point, inside, spot = load_scene(w.write(tmp_path / "l.glb")).lights
    assert sun.type == "directional" and np.allclose(sun.direction, [0, -1, 0]) and sun.intensity == 2.0
    assert sun.color == (1.0, 0.5, 0.0)
    assert point.type == "point" and np.allclose(point.position, [0, 4, 0]) and np.isclose(point.intensity, 32 / 16)
    assert np.isclose(inside.intensity, 6.0 / 3.0)  # nearer than the scene's radius: taken at the radius
    assert spot.type == "point" and np.isclose(spot.intensity, 1.0)
    assert load_quietly(one_box(tmp_path)).lights == (DEFAULT_LIGHT,)


# --- placed in a TOML scene ------------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", [".glb", ".gltf"])
def test_a_toml_scene_places_a_gltf_and_overrides_a_material(tmp_path: Path, suffix: str) -> None:
    w = GltfWriter()
    chrome, grey = w.material("Chrome", (0.5, 0.5, 0.5)), w.material("Grey", (0.5, 0.5, 0.5))
    w.node(name="Ball", mesh=w.mesh(w.box(material=chrome)), translation=[1.0, 0.0, 0.0])
    w.node(name="Cube", mesh=w.mesh(w.box(material=grey)))
    w.write(tmp_path / f"thing{suffix}")
    (tmp_path / "s.toml").write_text(f"""
[[objects]]
name = "floor"
shape = {{ type = "plane", size = [10.0, 10.0] }}
[[objects]]
name = "thing"
shape = {{ type = "gltf", path = "thing{suffix}" }}
materials = {{ "Chrome" = {{ type = "mirror", tint = [0.9, 0.9, 0.9] }} }}
position = [0.0, 2.0, 0.0]
rotation = [0.0, 90.0, 0.0]
scale = 2.0
""")
    scene = load_scene(tmp_path / "s.toml")
    assert [o.name for o in scene.objects] == ["floor", "thing/Ball", "thing/Cube"]
    assert scene.objects[1].material == MirrorMaterial((0.9, 0.9, 0.9))
    assert scene.objects[2].material == MetallicRoughnessMaterial((0.5, 0.5, 0.5), None, 0.0, 1.0, double_sided=False)
    ball = scene_geometry(scene.objects)[1].world_mesh
    # The file puts the ball at x = 1; the object scales by 2, turns +X to -Z and lifts by 2.
    assert np.allclose(ball.positions.mean(axis=0), [0.0, 2.0, -2.0], atol=1e-6)
    assert np.allclose(np.ptp(ball.positions, axis=0), [2.0, 2.0, 2.0], atol=1e-6)


# --- bad input ----------------------------------------------------------------------------------------------


def bad_file(tmp_path: Path, case: str) -> tuple[Path, str]:
    """A broken file (or TOML scene placing one) and a fragment its one-line refusal holds."""
    w = GltfWriter()
    box = w.mesh(w.box(material=w.material("Grey")))
    w.node(mesh=box)
    if case == "not_glb":
        path = tmp_path / "x.glb"
        path.write_bytes(b"PK\x03\x04 this is a zip file, not glTF")
        return path, 'expected a binary glTF file (starting with "glTF")'
    if case == "not_json":
        path = tmp_path / "x.gltf"
        path.write_text("solid cube\nendsolid\n")
        return path, "expected glTF JSON, got a file that is not JSON"
    if case == "missing_buffer":
        path = w.write(tmp_path / "x.gltf")
        (tmp_path / "x.bin").unlink()
        return path, 'buffers[0].uri: expected a file next to the glTF file'
    if case == "missing_texture":
        w.json["images"] = [{"uri": "wood.png"}]
        w.json["textures"] = [{"source": 0}]
        w.json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
        return w.write(tmp_path / "x.glb"), 'images[0].uri: expected a file next to the glTF file'
    if case == "bad_image":
        w.json["images"] = [{"bufferView": w.view(b"not a PNG at all"), "mimeType": "image/png"}]
        w.json["textures"] = [{"source": 0}]
        w.json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
        return w.write(tmp_path / "x.glb"), "images[0]: expected an image file Pillow can decode (PNG, JPEG, ...), got data in no image format"
    if case == "required_extension":
        w.json["extensionsRequired"] = ["KHR_draco_mesh_compression"]
        return w.write(tmp_path / "x.glb"), 'extensionsRequired: expected only extensions this reader supports'
    if case == "no_mesh":
        w.json["scenes"][0]["nodes"] = [w.node(root=False, name="empty")]
        return w.write(tmp_path / "x.glb"), "expected a scene with at least one mesh node holding triangles, got none"
    if case == "orthographic":
        w.json["cameras"] = [{"type": "orthographic", "orthographic": {"xmag": 1, "ymag": 1, "znear": 0, "zfar": 9}}]
        w.node(camera=0)
        return w.write(tmp_path / "x.glb"), 'cameras[0].type: expected "perspective"'
    if case == "triangle_fan":
        w.json["meshes"][box]["primitives"][0]["mode"] = 6
        return w.write(tmp_path / "x.glb"), "meshes[0].primitives[0].mode: expected triangles or a triangle strip"
    if case == "bad_factor":
        w.json["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = [2, 0, 0, 1]
        return w.write(tmp_path / "x.glb"), "materials[0].pbrMetallicRoughness.baseColorFactor: expected 4 numbers in [0, 1]"
    if case == "cycle":
        w.json["nodes"][0]["children"] = [0]
        return w.write(tmp_path / "x.glb"), "nodes[0]: expected a node tree"
    w.write(tmp_path / "x.glb")
    fields = {"unknown_override": 'materials = { "Chrom" = { type = "mirror" } }',
              "material_on_gltf": 'material = { type = "mirror" }'}[case]
    path = tmp_path / "s.toml"
    path.write_text(f'[[objects]]\nname = "x"\nshape = {{ type = "gltf", path = "x.glb" }}\n{fields}\n')
    return path, {"unknown_override": 'objects[0].materials: unknown field "Chrom"; expected one of: Grey',
                  "material_on_gltf": 'objects[0]: unknown field "material"; expected one of: name, shape, materials'}[case]


BAD = ["not_glb", "not_json", "missing_buffer", "missing_texture", "bad_image", "required_extension", "no_mesh", "orthographic",
       "triangle_fan", "bad_factor", "cycle", "unknown_override", "material_on_gltf"]


@pytest.mark.parametrize("case", BAD)
def test_bad_gltf_input_is_one_line_and_exit_2(tmp_path: Path, case: str, capsys: pytest.CaptureFixture[str]) -> None:
    path, fragment = bad_file(tmp_path, case)
    code, stdout, stderr = run_in_process(["plan", str(path)], capsys)
    assert_one_line_error(code, stdout, stderr, f"{path}: ", fragment)


def test_points_and_lines_are_left_out_with_one_warning_line(tmp_path: Path) -> None:
    """Run as a user runs it (pytest records warnings in-process instead of printing them)."""
    w = GltfWriter()
    w.node(mesh=w.mesh(w.box(), w.primitive(TRIANGLE, mode=1), w.primitive(TRIANGLE, mode=0)))
    code, stdout, stderr = run_subprocess(["plan", str(w.write(tmp_path / "x.glb"))])
    assert code == 0 and stdout
    assert stderr.splitlines() == [f"depthimpostor: warning: {tmp_path / 'x.glb'}: 2 primitive(s) that are not "
                                   "triangles (points, lines; the first meshes[0].primitives[1]) have no surface to "
                                   "shade or reflect: left out"]


def test_a_glTF_of_more_parts_than_a_uniform_block_held_is_planned(tmp_path: Path) -> None:
    """65 mesh nodes before a chrome quad were refused with --method raytrace (64 object records);
    their records are a storage buffer now, and the plan takes every one (issue 32)."""
    w = GltfWriter()
    w.node(mesh=w.mesh(w.primitive([[-2, 0, -2], [2, 0, -2], [2, 0, 2], [-2, 0, 2]], [[0, 2, 1], [0, 3, 2]],
                                   material=w.material("Chrome", metallic=1.0, roughness=0.0))))
    box = w.mesh(w.box(0.1))
    for k in range(65):
        w.node(mesh=box, translation=[0.2 * (k % 9) - 0.8, 0.5 + 0.2 * (k // 9), 0.0])
    scene = load_quietly(w.write(tmp_path / "many.glb"))
    for method in (Method.RAYTRACE, Method.DEPTH):
        plan = plan_render(scene, method)
        assert len(plan.objects) == 66
    assert len(plan_render(scene, Method.DEPTH).images) == 65


# --- rendered -----------------------------------------------------------------------------------------------


def mirror_scene(tmp_path: Path, glass: bool = True) -> Path:
    """A wall mirror (a quad turned upright by its node) behind a red box, a mirrored white box and a
    glass block, with a point light and a camera."""
    w = GltfWriter()
    chrome = w.material("Chrome", (0.95, 0.95, 0.95), metallic=1.0, roughness=0.0)
    w.node(name="Mirror", mesh=w.mesh(w.primitive([[-2, 0, -1], [2, 0, -1], [2, 0, 1], [-2, 0, 1]],
                                                  [[0, 2, 1], [0, 3, 2]], [[0, 1, 0]] * 4, material=chrome)),
           translation=[0.0, 1.0, -1.2], rotation=quaternion((1, 0, 0), 90))
    w.node(name="Red", mesh=w.mesh(w.box(0.6, w.material("Red", (0.8, 0.1, 0.1)), normals=True)),
           translation=[-0.6, 0.5, 0.0], rotation=quaternion((0, 1, 0), 30), scale=[1.0, 1.5, 0.7])
    w.node(name="White", mesh=w.mesh(w.box(0.5, w.material("White", (0.9, 0.9, 0.9)))), translation=[0.7, 0.4, -0.3],
           scale=[-1.0, 1.0, 1.0])
    if glass:
        clear = w.material("Glass", extensions={"KHR_materials_transmission": {"transmissionFactor": 1.0}})
        w.node(name="Glass", mesh=w.mesh(w.box(0.4, clear)), translation=[0.1, 0.3, 0.8])
    w.json["cameras"] = [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.05}}]
    w.node(camera=0, translation=[0.0, 2.0, 4.0], rotation=quaternion((1, 0, 0), -25))
    w.node(extensions={"KHR_lights_punctual": {"light": w.light(type="point", intensity=20.0)}}, translation=[1, 3, 2])
    return w.write(tmp_path / "mirror.glb")


@pytest.mark.parametrize("method", list(Method), ids=lambda m: m.option)
def test_every_method_renders_a_glTF_scene_finite(ctx: moderngl.Context, tmp_path: Path, method: Method) -> None:
    # The planar method is for flat mirrors alone: it refuses the glass block (tests/test_eye_methods.py).
    scene = load_scene(mirror_scene(tmp_path, glass=method != Method.PLANAR)).with_overrides(
        size=(128, 72), impostor_resolution=64)
    with Renderer(ctx, scene, method=method) as renderer:
        renderer.render()
        image = renderer.read_color_float()
    assert_finite(image)
    assert image[..., :3].std() > 0.02  # something drawn, not a flat sky


def test_raytrace_matches_the_embree_truth_on_a_glTF_scene(ctx: moderngl.Context, tmp_path: Path) -> None:
    """Mirrors only: glass exits are marched through an interior image by every method
    (methods_and_results.md), so they are not float-noise exact."""
    assert_raytrace_matches_the_truth(ctx, load_scene(mirror_scene(tmp_path, glass=False)), mirror_pixels=2000)


def test_the_commands_take_a_glb(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = str(mirror_scene(tmp_path))
    small = ["--size", "96x54", "--impostor-res", "32"]
    assert main(["render", path, "-o", str(tmp_path / "r.png"), "--frames", "1", *small]) == 0
    assert main(["truth", path, "-o", str(tmp_path / "t.png"), *small]) == 0
    assert main(["compare", path, "-o", str(tmp_path / "report"), "--method", "raytrace", *small]) == 0
    assert main(["plan", path, "--json", *small]) == 0
    printed = capsys.readouterr().out
    plan = json.loads(printed[printed.index("{"):])
    assert plan
    assert (tmp_path / "r.png").is_file() and (tmp_path / "t.png").is_file() and any((tmp_path / "report").iterdir())


def test_an_image_that_several_textures_use_is_decoded_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """AlphaBlendModeTest's images serve several slots each (base colour, a packed
    occlusion-roughness-metalness map, normals): each is decoded once, so kept and charged to the
    scene's image budget once (image_files.scene_images_budget)."""
    from depthimpostor.scene import gltf_data
    decoded: list[int] = []
    read_image = gltf_data.read_image

    def counting(data: Path | bytes) -> np.ndarray:
        decoded.append(1)
        return read_image(data)

    monkeypatch.setattr(gltf_data, "read_image", counting)
    source = PROJECT_ROOT / "tests" / "data" / "gltf" / "AlphaBlendModeTest.glb"
    copy = tmp_path / "AlphaBlendModeTest.glb"  # not the loader's cached copy of the committed file
    copy.write_bytes(source.read_bytes())
    scene = load_scene(copy)
    data = copy.read_bytes()
    (json_length,) = np.frombuffer(data[12:16], "<u4")
    images = len(json.loads(data[20:20 + int(json_length)])["images"])
    assert 0 < len(decoded) <= images < len(scene.textures)
