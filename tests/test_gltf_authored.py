"""glTF read as authored (scene/gltf_data.py, gltf_file.py): sparse accessors patch what they
patch (they drew as the unpatched mesh, silently), a file requiring an extension the loader does not
implement is refused by name, and what a file uses but the loader does not implement is named by
`plan` and in one warning line. No GL context but for one `render` run as a user runs it."""

from __future__ import annotations

import json
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from depthimpostor.constants import Method
from depthimpostor.errors import SceneWarning
from depthimpostor.meshes import Mesh
from depthimpostor.plan import plan_render
from depthimpostor.scene import load_scene
from depthimpostor.scene.gltf import read_gltf
from gltf_files import GltfWriter
from test_cli import assert_one_line_error, run_in_process, run_subprocess

QUAD = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
QUAD_FACES = np.array([[0, 1, 2], [0, 2, 3]])
QUAD_UVS = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], float)
UP = np.array([[0, 0, 1]] * 4, float)


def loaded_mesh(path: Path) -> Mesh:
    """The file's one part as the loader reads it (before a flat rectangle becomes a plane)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SceneWarning)
        model = read_gltf(path, str(path))
    assert len(model.parts) == 1
    return model.parts[0].mesh


def one_quad(tmp_path: Path, name: str, positions: object, indices: object, normals: object = None, uvs: object = None,
             mode: int | None = None, w: GltfWriter | None = None) -> Path:
    """A file of one quad primitive whose accessors are given (an index, or an array to write)."""
    w = w or GltfWriter()
    textured = w.material("Painted", pbrMetallicRoughness={"baseColorTexture": {"index": w.texture(np.full((2, 2, 4), 200))}})
    primitive = w.primitive(QUAD, QUAD_FACES, material=textured, mode=mode)
    attributes = primitive["attributes"]
    for key, value in (("POSITION", positions), ("NORMAL", normals), ("TEXCOORD_0", uvs)):
        if value is not None:
            attributes[key] = value if isinstance(value, int) else w.accessor(np.asarray(value), f"VEC{np.shape(value)[1]}")
    primitive["indices"] = indices if isinstance(indices, int) else w.accessor(np.asarray(indices).ravel(), "SCALAR")
    w.node(mesh=w.mesh(primitive))
    return w.write(tmp_path / name)


def assert_same_mesh(a: Mesh, b: Mesh) -> None:
    assert np.array_equal(a.positions, b.positions) and np.array_equal(a.indices, b.indices)
    assert np.array_equal(a.normals, b.normals)
    assert a.uvs is not None and b.uvs is not None and np.array_equal(a.uvs, b.uvs)


# --- sparse accessors ----------------------------------------------------------------------------------------


def test_sparse_positions_on_a_base_load_as_the_patched_mesh(tmp_path: Path) -> None:
    """A quad whose corner 2 a sparse accessor moves up to z = 0.5 loads as the same quad written
    densely with that corner moved: it loaded (and drew) flat, as the base alone."""
    patched = QUAD.copy()
    patched[2] = [1.5, 1.25, 0.5]
    w = GltfWriter()
    sparse = one_quad(tmp_path, "sparse.glb", w.sparse(QUAD, [2], patched[2:3], "VEC3"), QUAD_FACES, UP, QUAD_UVS, w=w)
    dense = one_quad(tmp_path, "dense.glb", patched, QUAD_FACES, UP, QUAD_UVS)
    mesh = loaded_mesh(sparse)
    assert np.allclose(mesh.positions[2], [1.5, 1.25, 0.5])
    assert_same_mesh(mesh, loaded_mesh(dense))


def test_every_sparse_attribute_and_indices_without_a_base_read_as_written(tmp_path: Path) -> None:
    """Sparse accessors without a bufferView (zeros, then substitutions) for the positions, normals,
    UVs and indices: the same mesh as the dense file."""
    w = GltfWriter()
    corners = [1, 2, 3]  # corner 0 stays at the zeros the base gives
    positions = w.sparse(None, corners, QUAD[corners], "VEC3", count=4)
    normals = w.sparse(None, [0, 1, 2, 3], UP, "VEC3", count=4)
    uvs = w.sparse(None, [0, 1, 2, 3], QUAD_UVS, "VEC2", count=4)
    indices = w.sparse(None, [1, 2, 4, 5], [1, 2, 2, 3], "SCALAR", count=6)  # 0, 1, 2, 0, 2, 3
    mesh = loaded_mesh(one_quad(tmp_path, "sparse.glb", positions, indices, normals, uvs, w=w))
    assert_same_mesh(mesh, loaded_mesh(one_quad(tmp_path, "dense.glb", QUAD, QUAD_FACES, UP, QUAD_UVS)))


def test_sparse_indices_of_a_triangle_strip_read_as_a_strip(tmp_path: Path) -> None:
    """A strip 0 1 3 2 (the quad) written as 0 1 2 2 with the last two patched: the same quad."""
    w = GltfWriter()
    strip = w.sparse([0, 1, 2, 2], [2, 3], [3, 2], "SCALAR")
    sparse = loaded_mesh(one_quad(tmp_path, "sparse.glb", QUAD, strip, UP, QUAD_UVS, mode=5, w=w))
    assert_same_mesh(sparse, loaded_mesh(one_quad(tmp_path, "dense.glb", QUAD, [0, 1, 3, 2], UP, QUAD_UVS, mode=5)))
    assert len(sparse.indices) == 2


def test_a_sparse_index_past_the_accessor_is_refused_in_one_line(tmp_path: Path,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    w = GltfWriter()
    path = one_quad(tmp_path, "x.glb", w.sparse(QUAD, [7], [[0, 0, 1]], "VEC3"), QUAD_FACES, w=w)
    assert_one_line_error(*run_in_process(["plan", str(path)], capsys), f"{path}: accessors[",
                          "].sparse.indices: expected indices below the accessor's count 4, got 7")


# --- extensions and features the loader does not implement -------------------------------------------------------


def test_a_file_requiring_extensions_the_loader_lacks_is_refused_naming_them(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    w = GltfWriter()
    w.node(mesh=w.mesh(w.box()))
    w.json["extensionsUsed"] = w.json["extensionsRequired"] = ["KHR_lights_punctual", "KHR_draco_mesh_compression",
                                                               "KHR_texture_basisu"]
    path = w.write(tmp_path / "x.glb")
    assert_one_line_error(*run_in_process(["plan", str(path)], capsys), f"{path}: extensionsRequired: expected only "
                          "extensions this reader supports", 'got "KHR_draco_mesh_compression", "KHR_texture_basisu"')


def clearcoat_file(tmp_path: Path) -> Path:
    """A file using KHR_materials_clearcoat (not required) and a normal map on a third UV set, beside
    a texture transform that is drawn (KHR_texture_transform: not listed)."""
    w = GltfWriter()
    texture = w.texture(np.full((2, 2, 4), 200))
    coated = w.material("Coated", pbrMetallicRoughness={"baseColorTexture": {
        "index": texture, "extensions": {"KHR_texture_transform": {"scale": [2, 2]}}}},
        normalTexture={"index": texture, "texCoord": 2}, extensions={"KHR_materials_clearcoat": {"clearcoatFactor": 1.0}})
    w.node(mesh=w.mesh(w.primitive(QUAD, QUAD_FACES, UP, QUAD_UVS, material=coated)))
    w.json["extensionsUsed"] = ["KHR_materials_clearcoat", "KHR_texture_transform"]
    return w.write(tmp_path / "coated.glb")


IGNORED = "KHR_materials_clearcoat, normalTexture.texCoord 2 (TEXCOORD_0 and TEXCOORD_1 are read)"


def test_plan_lists_what_a_file_uses_that_the_loader_ignores(tmp_path: Path) -> None:
    """The file loads (drawn as if they were absent); `plan` names them on one line, its JSON too,
    and loading says so in one warning line."""
    path = clearcoat_file(tmp_path)
    with pytest.warns(SceneWarning, match=f"coated.glb: 2 glTF feature\\(s\\) this loader does not implement, drawn "
                                          f"as if absent: {re.escape(IGNORED)}$"):
        scene = load_scene(path)
    plan = plan_render(scene, Method.DEPTH)
    assert f"ignored in {path} (not implemented, drawn as if absent): {IGNORED}" in plan.format().splitlines()
    assert plan.to_json()["ignored"] == {str(path): IGNORED.split(", ")}
    assert json.loads(json.dumps(plan.to_json()))["ignored"] == {str(path): IGNORED.split(", ")}


def test_a_file_placed_by_a_toml_scene_is_listed_under_its_name(tmp_path: Path) -> None:
    clearcoat_file(tmp_path)
    toml = tmp_path / "s.toml"
    toml.write_text('[[objects]]\nname = "x"\nshape = { type = "gltf", path = "coated.glb" }\n'
                    '[[objects]]\nname = "y"\nshape = { type = "gltf", path = "coated.glb" }\n', encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SceneWarning)
        plan = plan_render(load_scene(toml), Method.DEPTH)
    assert plan.ignored_lines() == [f"ignored in coated.glb (not implemented, drawn as if absent): {IGNORED}"]


def test_a_file_the_loader_reads_whole_lists_nothing_ignored(tmp_path: Path) -> None:
    w = GltfWriter()
    w.node(mesh=w.mesh(w.box(material=w.material("Grey"))))
    w.node(extensions={"KHR_lights_punctual": {"light": w.light(type="directional")}})
    plan = plan_render(load_scene(w.write(tmp_path / "x.glb")), Method.DEPTH)
    assert plan.ignored == () and "ignored" not in plan.format()


def test_render_warns_in_one_line_and_draws(tmp_path: Path) -> None:
    """Run as a user runs it (pytest records warnings in-process instead of printing them)."""
    path, out = clearcoat_file(tmp_path), tmp_path / "out.png"
    code, stdout, stderr = run_subprocess(["render", str(path), "-o", str(out), "--size", "32x24", "--method", "raytrace"])
    assert code == 0 and out.exists(), stderr
    assert stderr.splitlines() == [f"depthimpostor: warning: {path}: 2 glTF feature(s) this loader does not implement, "
                                   f"drawn as if absent: {IGNORED}"]


# --- a texture on a UV set the primitive lacks ------------------------------------------------------------------


@pytest.mark.parametrize("where", ["occlusionTexture", "transform"])
def test_a_texture_on_a_uv_set_the_primitive_lacks_is_refused_in_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], where: str) -> None:
    """A texture reading TEXCOORD_1 (by its texCoord, or KHR_texture_transform's) on a primitive
    without it: refused naming the file, the primitive, the texture and the material (it read
    (0, 0) at every vertex, with no message); the same file with TEXCOORD_1 loads."""
    transform = where == "transform"
    key, holder = ("baseColorTexture", "pbrMetallicRoughness.") if transform else ("occlusionTexture", "")

    def written(with_set: bool) -> Path:
        w = GltfWriter()
        info: dict[str, object] = {"index": w.texture(np.full((2, 2, 4), 200))}
        info |= {"extensions": {"KHR_texture_transform": {"texCoord": 1}}} if transform else {"texCoord": 1}
        w.material("Plain")
        m = w.material("Paint", **({} if transform else {key: info}))
        if transform:
            w.json["materials"][m]["pbrMetallicRoughness"][key] = info
        plain = w.primitive(QUAD, QUAD_FACES, UP, QUAD_UVS, material=0)
        painted = w.primitive(QUAD + [0, 0, 1], QUAD_FACES, UP, QUAD_UVS, material=m)
        if with_set:
            painted["attributes"]["TEXCOORD_1"] = w.accessor(QUAD_UVS, "VEC2")
        w.node(mesh=w.mesh(plain, painted))
        return w.write(tmp_path / f"x{int(with_set)}.gltf")

    path = written(False)
    assert_one_line_error(*run_in_process(["plan", str(path)], capsys),
                          f"{path}: meshes[0].primitives[1].attributes: expected TEXCOORD_1, which {holder}{key} of "
                          'material "Paint" (materials[1]) reads (texCoord 1), got none')
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SceneWarning)
        assert len(read_gltf(written(True), "x1.gltf").parts) == 2
