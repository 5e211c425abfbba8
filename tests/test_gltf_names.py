"""Refusals and warnings name a glTF file's objects as its author knows them: the node (index and
name), its mesh, the primitives and the material (Scene.object_label), not their place in the
renderer's list of objects; a TOML scene's objects keep `objects[i]`, numbered as the file writes
them even after an entry that places a glTF file of several parts."""

from __future__ import annotations

import dataclasses
import json
import warnings
from pathlib import Path

import moderngl
import numpy as np
import pytest
from conftest import SCENES

from depthimpostor.cli import main
from depthimpostor.constants import Method
from depthimpostor.errors import SceneError, SceneWarning
from depthimpostor.meshes import sphere, torus
from depthimpostor.plan import plan_render
from depthimpostor.renderer import Renderer
from depthimpostor.scene import DiffuseMaterial, GltfOrigin, Scene, load_scene
from gltf_files import GltfWriter
from test_gltf import mirror_scene
from test_cli import assert_one_line_error, run_in_process

RING = 'node 1 "Ring.001" (mesh 1 "torus", primitive 0, material 1 "Paint")'
GLOBE = 'node 0 "Globe" (mesh 0 "sphere", primitive 0, material 0 "Chrome")'
PEBBLE = 'node 1 "Pebble" (mesh 1 "pebble", primitive 0, material 1 "Slate")'
TOO_FAR = "expected an object within 1e+18 of the origin"


def quietly(path: Path) -> Scene:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SceneWarning)
        return load_scene(path)


def ring_file(path: Path) -> Path:
    """hard/surrounds.toml as a glTF file: a mirror ball inside a green ring, every item named."""
    w = GltfWriter()
    chrome = w.material("Chrome", (0.9, 0.9, 0.9), metallic=1.0, roughness=0.0)
    paint = w.material("Paint", (0.15, 0.7, 0.25))
    ball, ring = sphere(0.6, 24, 12), torus(1.2, 0.15, 24, 8)
    w.node(name="Globe", mesh=w.mesh(w.primitive(ball.positions, ball.indices, ball.normals, material=chrome),
                                     name="sphere"), translation=[0.0, 1.0, 0.0])
    w.node(name="Ring.001", mesh=w.mesh(w.primitive(ring.positions, ring.indices, ring.normals, material=paint),
                                        name="torus"), translation=[0.0, 1.0, 0.0])
    return w.write(path)


def far_file(path: Path) -> Path:
    """A cube near the origin, and a pebble that its nested nodes carry 1.8e18 away (each node's
    translation alone within the format's limit)."""
    w = GltfWriter()
    w.node(name="Base", mesh=w.mesh(w.box(material=w.material("Stone")), name="cube"))
    pebble = w.node(root=False, name="Pebble", mesh=w.mesh(w.box(0.1, material=w.material("Slate")), name="pebble"),
                    translation=[9e17, 0.0, 0.0])
    w.node(name="Carrier", children=[pebble], translation=[9e17, 0.0, 0.0])
    return w.write(path)


def placing(tmp_path: Path, model: str, after: str = "", **fields: str) -> Path:
    """A TOML scene: a floor (objects[0]), then the glTF file placed whole (objects[1]), then `after`."""
    placement = "".join(f"{key} = {value}\n" for key, value in fields.items())
    path = tmp_path / "placed.toml"
    path.write_text(f'[[objects]]\nname = "floor"\nshape = {{ type = "plane", size = [9.0, 9.0] }}\n'
                    f'[[objects]]\nname = "thing"\nshape = {{ type = "gltf", path = "{model}" }}\n{placement}{after}',
                    encoding="utf-8")
    return path


# --- the label ----------------------------------------------------------------------------------------------


def test_an_origin_names_node_mesh_primitives_and_material_with_or_without_names() -> None:
    named = GltfOrigin("x.glb", 12, "Cylinder.003", 5, "piston", (0,), 2, "steel")
    assert named.describe() == 'node 12 "Cylinder.003" (mesh 5 "piston", primitive 0, material 2 "steel")'
    bare = GltfOrigin("x.glb", 3, "", 0, "", (0, 2), None, "")
    assert bare.describe() == "node 3 (mesh 0, primitives 0, 2, the default material)"


def test_each_part_knows_its_node_mesh_primitives_and_material(tmp_path: Path) -> None:
    w = GltfWriter()
    red, blue = w.material("Red", (1, 0, 0)), w.material(color=(0, 0, 1))
    w.node(name="Plain", mesh=w.mesh(w.box(), name="cube"))
    pair = w.mesh(w.box(material=red), w.box(material=blue), w.box(material=red), name="pair")
    w.node(name="Pair", mesh=pair, translation=[2.0, 0.0, 0.0])
    scene = quietly(w.write(tmp_path / "parts.glb"))
    assert [scene.object_label(i) for i in range(len(scene.objects))] == [
        'node 0 "Plain" (mesh 0 "cube", primitive 0, the default material)',
        'node 1 "Pair" (mesh 1 "pair", primitives 0, 2, material 0 "Red")',
        'node 1 "Pair" (mesh 1 "pair", primitive 1, material 1)',
    ]
    assert scene.objects[1].origin == GltfOrigin(str(tmp_path / "parts.glb"), 1, "Pair", 1, "pair", (0, 2), 0, "Red")


def test_a_toml_scene_numbers_its_entries_after_a_placed_file_as_written(tmp_path: Path) -> None:
    """The placed file makes three objects: the sphere after it is still entry 2, not objects[4]."""
    far_file(tmp_path / "far.glb")
    ball = '[[objects]]\nname = "ball"\nshape = { type = "sphere", radius = 0.5 }\n'
    scene = load_scene(placing(tmp_path, "far.glb", ball, scale="0.1"))  # 0.1 brings the pebble within the limit
    assert [o.name for o in scene.objects] == ["floor", "thing/Base", "thing/Pebble", "ball"]  # the tree's order
    assert [scene.object_label(i) for i in (0, 3)] == ["objects[0]", "objects[2]"]
    assert scene.object_label(2) == f"objects[1] (far.glb) {PEBBLE}"
    assert scene.object_label(3, "material.texture") == "objects[2].material.texture"


# --- refusals ----------------------------------------------------------------------------------------------


def test_a_part_too_far_is_refused_naming_its_node(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = far_file(tmp_path / "far.glb")
    with pytest.raises(SceneError) as refused:
        load_scene(path)
    assert refused.value.path == PEBBLE
    assert str(refused.value).startswith(f"{path}: {PEBBLE}: {TOO_FAR}")
    code, stdout, stderr = run_in_process(["plan", str(path)], capsys)
    assert_one_line_error(code, stdout, stderr, f"{path}: {PEBBLE}: {TOO_FAR}")


def test_a_placed_part_too_far_names_the_entry_and_the_node(tmp_path: Path) -> None:
    """The placement's scale takes the file's pebble past the limit; the file is named as the TOML
    scene names it, though it was read before under another name."""
    w = GltfWriter()
    w.node(name="Base", mesh=w.mesh(w.box(material=w.material("Stone")), name="cube"))
    w.node(name="Pebble", mesh=w.mesh(w.box(0.1, material=w.material("Slate")), name="pebble"), translation=[1e9, 0, 0])
    assert len(load_scene(w.write(tmp_path / "far.glb")).objects) == 2  # read (and cached) under its full path first
    with pytest.raises(SceneError) as refused:
        load_scene(placing(tmp_path, "far.glb", scale="1e10"))
    assert refused.value.path == 'objects[1] (far.glb) node 1 "Pebble" (mesh 1 "pebble", primitive 0, material 1 "Slate")'
    assert TOO_FAR in str(refused.value)


def test_an_object_after_a_placed_file_is_refused_as_its_entry(tmp_path: Path) -> None:
    far_file(tmp_path / "near.glb")
    text = '[[objects]]\nname = "huge"\nshape = { type = "sphere", radius = 1e17 }\nscale = 20.0\n'
    path = placing(tmp_path, "near.glb", text, scale="0.1")  # 0.1 brings the file's pebble within the limit
    with pytest.raises(SceneError) as refused:
        load_scene(path)
    assert refused.value.path == "objects[2]" and TOO_FAR in str(refused.value)


@pytest.mark.parametrize("method", [Method.DEPTH, Method.CUBEMAP], ids=lambda m: m.option)
def test_a_part_around_a_mirrors_centre_is_named_by_plan_and_render_alike(
        ctx: moderngl.Context, tmp_path: Path, method: Method) -> None:
    scene = load_scene(ring_file(tmp_path / "ring.glb")).with_overrides(size=(64, 36), impostor_resolution=16)
    with pytest.raises(SceneError) as planned:
        plan_render(scene, method)
    with pytest.raises(SceneError) as rendered:
        Renderer(ctx, scene, method=method).release()
    assert str(planned.value) == str(rendered.value)
    assert planned.value.path == RING
    assert 'centre of mirror "Globe"' in str(planned.value)


def test_a_placed_part_around_a_mirrors_centre_names_the_entry_and_the_node(tmp_path: Path) -> None:
    ring_file(tmp_path / "ring.glb")
    scene = load_scene(placing(tmp_path, "ring.glb"))
    with pytest.raises(SceneError) as refused:
        plan_render(scene, Method.DEPTH)
    assert refused.value.path == f"objects[1] (ring.glb) {RING}"
    assert 'object "thing/Ring.001" surrounds or touches the centre of mirror "thing/Globe"' in str(refused.value)


def test_a_curved_mirror_refused_by_the_planar_method_is_named(tmp_path: Path) -> None:
    scene = load_scene(ring_file(tmp_path / "ring.glb"))
    with pytest.raises(SceneError) as refused:
        plan_render(scene, Method.PLANAR)
    assert refused.value.path == GLOBE
    assert '--method planar needs flat mirrors; "Globe" is a' in str(refused.value)


def textured_file(path: Path) -> Path:
    """A textured triangle with TEXCOORD_0, and a crate whose material has a texture but whose
    primitive has no TEXCOORD_0."""
    w = GltfWriter()
    image = np.full((2, 2, 4), 200, np.uint8)
    wood = w.material("Wood", pbrMetallicRoughness={"baseColorTexture": {"index": w.texture(image)}})
    w.node(name="Sign", mesh=w.mesh(w.primitive([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]],
                                                uvs=[[0, 0], [1, 0], [0, 1]], material=wood), name="sign"))
    w.node(name="Crate", mesh=w.mesh(w.box(material=wood), name="crate"), translation=[3.0, 0.0, 0.0])
    return w.write(path)


def test_a_textured_part_without_texcoords_is_named_in_the_warning(tmp_path: Path) -> None:
    with pytest.warns(SceneWarning) as caught:
        scene = load_scene(textured_file(tmp_path / "crate.glb"))
    assert len(caught) == 1
    assert ('1 textured part(s) without TEXCOORD_0 (the first node 1 "Crate" (mesh 1 "crate", primitive 0, '
            'material 0 "Wood")) drawn in the mean colour of their texture') in str(caught[0].message)
    drawn = scene.objects[1].material
    assert isinstance(drawn, DiffuseMaterial) and drawn.texture is None  # the mean colour, no texture


def test_a_texture_given_in_code_to_a_part_without_texcoords_is_refused_naming_it(tmp_path: Path) -> None:
    loaded = quietly(textured_file(tmp_path / "crate.glb"))
    crate = dataclasses.replace(loaded.objects[1], material=loaded.objects[0].material)
    scene = dataclasses.replace(loaded, objects=(loaded.objects[0], crate))
    with pytest.raises(SceneError) as refused:
        plan_render(scene)
    assert refused.value.path == 'node 1 "Crate" (mesh 1 "crate", primitive 0, material 0 "Wood") material.texture'
    assert "got a glTF part without TEXCOORD_0" in str(refused.value)


def test_a_name_two_parts_share_is_refused_naming_the_node(tmp_path: Path) -> None:
    """Two materials named alike on one node make two parts named alike."""
    w = GltfWriter()
    steel, other = w.material("Steel", (0.5, 0.5, 0.5)), w.material("Steel", (0.2, 0.2, 0.2))
    w.node(name="Pair", mesh=w.mesh(w.box(material=steel), w.box(material=other), name="pair"))
    w.write(tmp_path / "pair.glb")
    with pytest.raises(SceneError) as refused:
        load_scene(placing(tmp_path, "pair.glb"))
    assert str(refused.value).endswith('objects[1].name: expected a name no other object has, got "thing/Pair (Steel)" '
                                       'for node 0 "Pair" (mesh 0 "pair", primitive 1, material 1 "Steel") '
                                       "(already used by objects[1])")


# --- reports ----------------------------------------------------------------------------------------------


def test_plan_lists_each_glTF_part_with_its_node_mesh_and_material(tmp_path: Path,
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    path = placing(tmp_path, "far.glb", scale="0.1")
    far_file(tmp_path / "far.glb")
    assert main(["plan", str(path), "--size", "64x36"]) == 0
    text = capsys.readouterr().out
    assert ("glTF parts (2):\n"
            '  thing/Base: objects[1] (far.glb) node 0 "Base" (mesh 0 "cube", primitive 0, material 0 "Stone")\n'
            f"  thing/Pebble: objects[1] (far.glb) {PEBBLE}\n") in text
    assert main(["plan", str(path), "--size", "64x36", "--json"]) == 0
    assert [o["label"] for o in json.loads(capsys.readouterr().out)["objects"]] == [
        "objects[0]", 'objects[1] (far.glb) node 0 "Base" (mesh 0 "cube", primitive 0, material 0 "Stone")',
        f"objects[1] (far.glb) {PEBBLE}"]
    assert main(["plan", str(SCENES / "default.toml"), "--size", "64x36"]) == 0
    assert "glTF parts" not in capsys.readouterr().out  # a TOML scene's objects are its entries


def test_compare_names_the_objects_of_its_worst_pixels(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = mirror_scene(tmp_path, glass=False)
    assert main(["compare", str(path), "--size", "96x54", "--impostor-res", "32", "-o", str(tmp_path / "r")]) == 0
    table = capsys.readouterr().out
    worst = json.loads((tmp_path / "r" / "report.json").read_text())["figures"]["worst_pixels"]
    scene = quietly(path)
    labels = {o.name: scene.object_label(i) for i, o in enumerate(scene.objects)} | {"environment": "environment"}
    assert worst and all(labels[p[f"{key}_name"]] == p[f"{key}_label"] for p in worst for key in ("object", "truth_object"))
    assert any(p["truth_object_label"].startswith('node 1 "Red" (mesh 1, primitive 0, material 1 "Red")') for p in worst)
    rows = table[table.index("worst pixels"):].splitlines()[1:]
    assert len(rows) == len(worst) and all(f"{p['object_name']} / {p['truth_object_name']}," in row
                                           for p, row in zip(worst, rows, strict=True))
