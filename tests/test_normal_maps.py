"""glTF's normal maps, vertex colours and second UV set (issue 33 item 1): read from the file (the
file's tangents, or generated: scene/tangents.py), carried by every mesh point (lib/mesh_point.glsl,
oracles/mesh_points.py), and drawn by the eye's pass, the bakes, the traced hits and the truth alike."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import moderngl
import numpy as np
import pytest

from conftest import assert_finite, scene_from_toml
from depthimpostor.constants import Method
from depthimpostor.meshes import box, sphere
from depthimpostor.oracles.compare import compare
from depthimpostor.plan import plan_render
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene, load_scene
from depthimpostor.scene.gltf import read_gltf
from depthimpostor.scene.gltf_file import ignored_features, read_json
from depthimpostor.scene.tangents import generated_tangents
from gltf_files import GltfWriter, quaternion, skinned_column

UNSIGNED_BYTE = 5121


def _bumps(size: int = 32, repeats: int = 4) -> np.ndarray:
    """A tangent-space normal map of round bumps (RGB = n * 0.5 + 0.5): the height
    sin(2 pi k u) sin(2 pi k v), x along +u and y up the image (against v), as glTF stores it."""
    u = (np.arange(size) + 0.5) / size
    uu, vv = np.meshgrid(u, u)
    k = 2.0 * math.pi * repeats
    dh_du = k * np.cos(k * uu) * np.sin(k * vv) * 0.08
    dh_dv = k * np.sin(k * uu) * np.cos(k * vv) * 0.08
    n = np.stack([-dh_du, dh_dv, np.ones_like(uu)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    rgba = np.full((size, size, 4), 255, np.uint8)
    rgba[..., :3] = np.round((n * 0.5 + 0.5) * 255.0)
    return rgba


def _picture(size: int = 16) -> np.ndarray:
    """A base colour image: random colours, so that any misplaced texel shows."""
    rgba = np.random.default_rng(5).integers(40, 256, (size, size, 4), dtype=np.uint8)
    rgba[..., 3] = 255
    return rgba


def _bumpy_box(path: Path, normal_map: bool = True, tangents: bool = True, colors: bool = True,
               normal_set: int = 1) -> Path:
    """A textured box (meshes.box: the whole image on each face), turned 35 degrees, with vertex
    colours (normalized unsigned bytes, RGBA), a second UV set (the first, scaled 2 x 1.5 and
    shifted) and a normal map of bumps on that set; `tangents`: the file gives TANGENT (else the
    loader generates them)."""
    mesh = box((0.7, 0.7, 0.7))
    w = GltfWriter()
    material: dict[str, Any] = {"pbrMetallicRoughness": {"baseColorTexture": {"index": w.texture(_picture())},
                                                         "metallicFactor": 0.0, "roughnessFactor": 0.45}}
    if normal_map:
        material["normalTexture"] = {"index": w.texture(_bumps()), "texCoord": normal_set, "scale": 1.5}
    m = w._append("materials", material)
    uvs1 = np.asarray(mesh.uvs, np.float64) * (2.0, 1.5) + (0.25, 0.1)
    primitive = w.primitive(mesh.positions, mesh.indices, mesh.normals, mesh.uvs, material=m)
    primitive["attributes"]["TEXCOORD_1"] = w.accessor(uvs1, "VEC2")
    if colors:
        shade = np.random.default_rng(2).integers(90, 256, (len(mesh.positions), 4), dtype=np.uint8)
        shade[:, 3] = 255
        primitive["attributes"]["COLOR_0"] = w.raw_accessor(shade, "VEC4", UNSIGNED_BYTE)
        w.json["accessors"][-1]["normalized"] = True
    if tangents:
        set_uvs = uvs1 if normal_set == 1 else mesh.uvs
        made = generated_tangents(mesh.positions, mesh.normals, mesh.indices, set_uvs)
        assert len(made.vertices) == len(mesh.positions)  # the box's faces have vertices of their own
        primitive["attributes"]["TANGENT"] = w.accessor(made.tangents, "VEC4")
    w.node(mesh=w.mesh(primitive), rotation=quaternion((0.0, 1.0, 0.0), 35.0))
    return w.write(path)


SCENE = """
[render]
size = [240, 135]
impostor_resolution = 128
ambient = 0.25

[camera]
eye = [1.4, 2.0, 3.4]
target = [0.1, 1.0, -1.5]
fov_y = 45.0

[[lights]]
type = "directional"
direction = [-0.5, -1.0, -0.4]

[[lights]]
type = "point"
position = [0.8, 2.2, 1.2]
intensity = 1.2

[[objects]]
name = "floor"
shape = { type = "plane", size = [20.0, 20.0] }
material = { type = "diffuse", color = [0.5, 0.5, 0.5] }

[[objects]]
name = "mirror"
shape = { type = "plane", size = [5.0, 2.6] }
material = { type = "mirror", tint = [0.95, 0.95, 0.95] }
position = [0.0, 1.4, -1.5]
rotation = [90.0, 0.0, 0.0]

[[objects]]
name = "bumpy"
shape = { type = "gltf", path = "bumpy.glb" }
position = [-0.9, 0.6, -0.6]
scale = [1.6, 1.6, 1.6]
"""


def _scene(folder: Path, **options: bool) -> Scene:
    folder.mkdir(parents=True, exist_ok=True)
    _bumpy_box(folder / "bumpy.glb", **options)
    return scene_from_toml(SCENE, str(folder / "scene.toml"), folder)


@pytest.fixture(scope="module")
def scenes(tmp_path_factory: pytest.TempPathFactory) -> dict[bool, Scene]:
    """The bumpy box beside the mirror, with and without its normal map."""
    folder = tmp_path_factory.mktemp("bumps")
    return {mapped: _scene(folder / str(mapped), normal_map=mapped) for mapped in (True, False)}


@pytest.mark.parametrize("method", [Method.RAYTRACE, Method.HYBRID])
def test_the_bumps_show_in_the_mirror_as_the_truth_has_them(ctx: moderngl.Context, scenes: dict[bool, Scene],
                                                            method: Method) -> None:
    """Beside the mirror, the traced hits read the normal map (on TEXCOORD_1, in the file's tangents),
    the vertex colours and the second UV set where the truth's exact hits do: wrong object 0 and
    colour within float noise, with and without the map; and the map changes what the mirror shows
    of the box (its bumps), and what the eye sees of it."""
    renders = {}
    for mapped, scene in scenes.items():
        with Renderer(ctx, scene, method=method, reflection_data=True) as renderer:
            renderer.render()
            result = compare(renderer)
        assert_finite(result.render)
        assert_finite(result.truth)
        figures = result.figures
        assert figures.object_pixels > 500 and figures.wrong_object_share == 0.0, (mapped, figures.wrong_object_share)
        assert figures.color_rmse < 1e-3, (mapped, figures.color_rmse)
        renders[mapped] = (result.render, result.mirror_mask)
    both = renders[True][1] & renders[False][1]
    differs = np.abs(renders[True][0] - renders[False][0]).max(axis=2)
    assert (differs[both] > 0.03).sum() > 100, f"the bumps changed {(differs[both] > 0.03).sum()} mirror pixels"
    assert (differs[~both] > 0.03).sum() > 100, "the eye sees no bumps"


def test_the_bakes_shade_the_bumps(ctx: moderngl.Context, scenes: dict[bool, Scene]) -> None:
    """The depth images are baked with the normal map (their colours shaded from the mirror's
    centre): the depth method's mirror shows the bumps, and stays near the truth."""
    renders = {}
    for mapped, scene in scenes.items():
        with Renderer(ctx, scene, method=Method.DEPTH, reflection_data=True) as renderer:
            renderer.render()
            result = compare(renderer)
        assert_finite(result.render)
        assert result.figures.wrong_object_share < 0.02 and result.figures.color_rmse < 0.1, result.figures
        renders[mapped] = (result.render, result.mirror_mask)
    both = renders[True][1] & renders[False][1]
    assert (np.abs(renders[True][0] - renders[False][0]).max(axis=2)[both] > 0.03).sum() > 100


def _quad(path: Path, tangents: bool = False, color: Any = None, color_component: int = 5126,
          base: tuple[float, float, float] = (1.0, 1.0, 1.0), uv_set: int = 0, swap_sets: bool = False,
          normal_map: bool = False) -> Path:
    """A unit square facing +Z (UVs over the whole image, v down), textured; `color`: a constant
    COLOR_0 (floats VEC3, or normalized unsigned bytes VEC4); `uv_set` the base colour texture's
    texCoord; `swap_sets`: TEXCOORD_0 constant and the square's UVs on TEXCOORD_1."""
    w = GltfWriter()
    info: dict[str, Any] = {"index": w.texture(_picture())}
    if uv_set:
        info["texCoord"] = uv_set
    material: dict[str, Any] = {"pbrMetallicRoughness": {"baseColorTexture": info, "baseColorFactor": [*base, 1.0],
                                                         "metallicFactor": 0.0, "roughnessFactor": 0.6}}
    if normal_map:
        material["normalTexture"] = {"index": w.texture(_bumps())}
    m = w._append("materials", material)
    positions = np.array([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], np.float32)
    uvs = np.array([(0, 1), (1, 1), (1, 0), (0, 0)], np.float32)
    quad = w.primitive(positions, np.array([[0, 1, 2], [0, 2, 3]]), np.tile((0.0, 0.0, 1.0), (4, 1)),
                       np.full((4, 2), 0.3) if swap_sets else uvs, material=m)
    if swap_sets:
        quad["attributes"]["TEXCOORD_1"] = w.accessor(uvs, "VEC2")
    if tangents:
        quad["attributes"]["TANGENT"] = w.accessor(np.tile((1.0, 0.0, 0.0, 1.0), (4, 1)), "VEC4")
    if color is not None:
        values = np.tile(np.asarray(color), (4, 1))
        if color_component == UNSIGNED_BYTE:
            quad["attributes"]["COLOR_0"] = w.raw_accessor(values, "VEC4", UNSIGNED_BYTE)
            w.json["accessors"][-1]["normalized"] = True
        else:
            quad["attributes"]["COLOR_0"] = w.accessor(values, "VEC3")
    w.node(mesh=w.mesh(quad))
    return w.write(path)


def _render(ctx: moderngl.Context, path: Path, method: Method = Method.RAYTRACE) -> np.ndarray:
    scene = load_scene(path).with_overrides(size=(64, 64))
    with Renderer(ctx, scene, method=method) as renderer:
        renderer.render()
        color = renderer.read_color_float()
    assert_finite(color)
    return color


def test_a_files_tangents_and_generated_ones_agree_on_a_quad(ctx: moderngl.Context, tmp_path: Path) -> None:
    """On a flat square, the tangents generated for its normal map (scene/tangents.py) are the ones
    a file gives (+X, w = 1: the bitangent N x T = +Y up the image), and draw the same picture."""
    given = read_gltf(_quad(tmp_path / "given.glb", tangents=True, normal_map=True), "given.glb").parts[0].mesh
    made = read_gltf(_quad(tmp_path / "made.glb", normal_map=True), "made.glb").parts[0].mesh
    assert given.tangents is not None and made.tangents is not None
    np.testing.assert_allclose(made.tangents, given.tangents, atol=1e-6)
    np.testing.assert_allclose(made.tangents, np.tile((1.0, 0.0, 0.0, 1.0), (4, 1)), atol=1e-6)
    assert np.abs(_render(ctx, tmp_path / "given.glb") - _render(ctx, tmp_path / "made.glb")).max() < 1e-6
    plain = _render(ctx, _quad(tmp_path / "plain.glb"))
    assert np.abs(_render(ctx, tmp_path / "made.glb") - plain).max() > 0.05  # the bumps show


def test_generated_tangents_follow_the_uvs() -> None:
    """A square whose UVs are turned a quarter (u up the square): the tangent is +Y; mirrored UVs
    (u to the left) turn it to -X and keep the bitangent up the image (w = -1 for a flipped v)."""
    positions = np.array([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], float)
    normals = np.tile((0.0, 0.0, 1.0), (4, 1))
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    turned = np.array([(0, 1), (0, 0), (1, 0), (1, 1)], float)  # u grows with y, v against x
    np.testing.assert_allclose(generated_tangents(positions, normals, faces, turned).tangents[:, :3], np.tile((0, 1, 0), (4, 1)),
                               atol=1e-12)
    mirrored = np.array([(1, 1), (0, 1), (0, 0), (1, 0)], float)  # u to the left, v down
    np.testing.assert_allclose(generated_tangents(positions, normals, faces, mirrored).tangents, np.tile((-1, 0, 0, -1), (4, 1)),
                               atol=1e-12)


def _mirrored_ball(path: Path, given: bool = False) -> tuple[Path, dict[str, np.ndarray]]:
    """A ball (meshes.sphere, its poles one vertex each) whose UVs mirror about two meridians,
    u = |phi / pi - 1| (seams through shared vertices: MikkTSpace splits them), v pole to pole,
    normal-mapped with bumps, with vertex colours and a second UV set. `given`: the file gives
    the tangents generated for it, on the vertices they split (written as the file's). Returns
    the file and its vertex attributes (those of the unsplit ball)."""
    mesh = sphere(0.45, segments=24, rings=12)
    direction = mesh.normals
    phi = np.arctan2(direction[:, 2], direction[:, 0]) % (2.0 * math.pi)
    attributes = {"positions": np.asarray(mesh.positions, np.float64), "normals": np.asarray(mesh.normals, np.float64),
                  "uvs": np.stack([np.abs(phi / math.pi - 1.0), np.arccos(np.clip(direction[:, 1], -1, 1)) / math.pi], 1),
                  "colors": np.random.default_rng(3).uniform(0.4, 1.0, (len(phi), 4)) * (1, 1, 1, 0) + (0, 0, 0, 1)}
    attributes["uvs1"] = attributes["uvs"] * 1.5 + 0.2
    attributes = {name: values.astype(np.float32).astype(np.float64) for name, values in attributes.items()}
    faces = np.asarray(mesh.indices)
    w = GltfWriter()
    m = w._append("materials", {"pbrMetallicRoughness": {"baseColorTexture": {"index": w.texture(_picture())},
                                                         "metallicFactor": 0.0, "roughnessFactor": 0.45},
                                "normalTexture": {"index": w.texture(_bumps()), "scale": 1.5}})
    written, tangents = dict(attributes), None
    if given:
        made = generated_tangents(attributes["positions"], attributes["normals"], faces, attributes["uvs"])
        written = {name: values[made.vertices] for name, values in attributes.items()}
        faces, tangents = made.faces, made.tangents
    primitive = w.primitive(written["positions"], faces, written["normals"], written["uvs"], material=m)
    primitive["attributes"]["TEXCOORD_1"] = w.accessor(written["uvs1"], "VEC2")
    primitive["attributes"]["COLOR_0"] = w.accessor(written["colors"], "VEC4")
    if tangents is not None:
        primitive["attributes"]["TANGENT"] = w.accessor(tangents, "VEC4")
    w.node(mesh=w.mesh(primitive))
    return w.write(path), attributes | {"faces": np.asarray(mesh.indices)}


def test_a_mirror_seam_splits_the_loaded_vertices(tmp_path: Path) -> None:
    """The loader splits the vertices MikkTSpace gives two tangents (the seams, the poles), and
    every attribute with them: each triangle corner has the file's position, normal, both UV sets
    and colour, and its tangent is MikkTSpace's, unit and perpendicular to its normal; the two
    sides of a seam have opposite signs."""
    path, file = _mirrored_ball(tmp_path / "ball.glb")
    mesh = read_gltf(path, "ball.glb").parts[0].mesh
    assert mesh.tangents is not None and mesh.colors is not None and mesh.uvs1 is not None and mesh.uvs is not None
    assert len(mesh.positions) > len(file["positions"]) + 20
    for name, values in (("positions", mesh.positions), ("normals", mesh.normals), ("uvs", mesh.uvs),
                         ("uvs1", mesh.uvs1), ("colors", mesh.colors)):
        np.testing.assert_allclose(np.asarray(values)[mesh.indices], file[name][file["faces"]], atol=1e-6, err_msg=name)
    made = generated_tangents(file["positions"], file["normals"], file["faces"], file["uvs"])
    np.testing.assert_allclose(mesh.tangents[mesh.indices], made.tangents[made.faces], atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(mesh.tangents[:, :3], axis=1), 1.0, atol=1e-5)
    assert np.abs(np.einsum("ij,ij->i", mesh.tangents[:, :3], mesh.normals)).max() < 1e-5
    seam = np.flatnonzero((np.abs(file["uvs"][:, 0] - 1.0) < 1e-6) & (np.abs(file["positions"][:, 1]) < 0.4))
    split = [mesh.tangents[np.all(np.abs(mesh.positions - file["positions"][v]) < 1e-6, axis=1), 3] for v in seam]
    assert split and all(set(signs) == {-1.0, 1.0} for signs in split)


def test_a_mirrored_balls_generated_tangents_draw_as_the_truth_has_them(ctx: moderngl.Context, tmp_path: Path) -> None:
    """The ball beside the mirror, its tangents generated (its vertices split): the traced hits
    and the eye's pass read them as the truth does (wrong object 0, colour within float noise),
    and draw what the same tangents given by the file draw."""
    renders = []
    for given in (False, True):
        folder = tmp_path / str(given)
        folder.mkdir()
        _mirrored_ball(folder / "bumpy.glb", given=given)
        scene = scene_from_toml(SCENE, str(folder / "scene.toml"), folder)
        with Renderer(ctx, scene, method=Method.RAYTRACE, reflection_data=True) as renderer:
            renderer.render()
            result = compare(renderer)
        assert_finite(result.render)
        assert_finite(result.truth)
        assert result.figures.object_pixels > 500 and result.figures.wrong_object_share == 0.0, result.figures
        assert result.figures.color_rmse < 1e-3, result.figures.color_rmse
        renders.append(result.render)
    assert np.abs(renders[0] - renders[1]).max() < 1e-5


@pytest.mark.parametrize("component", [UNSIGNED_BYTE, 5126])
def test_vertex_colours_tint_the_base_colour(ctx: moderngl.Context, tmp_path: Path, component: int) -> None:
    """COLOR_0 (normalized unsigned bytes RGBA, or floats RGB) multiplies the base colour: a square
    of one vertex colour draws as the square whose baseColorFactor is that colour, in the eye and
    through the traced hits' shading alike, and not as the untinted square."""
    color = np.array([200, 120, 60, 255]) if component == UNSIGNED_BYTE else np.array([0.8, 0.5, 0.25])
    factor = tuple(float(c) for c in (color[:3] / 255.0 if component == UNSIGNED_BYTE else color))
    tinted = _render(ctx, _quad(tmp_path / "tinted.glb", color=color, color_component=component))
    expected = _render(ctx, _quad(tmp_path / "factor.glb", base=factor))  # type: ignore[arg-type]
    plain = _render(ctx, _quad(tmp_path / "plain.glb"))
    assert np.abs(tinted - expected).max() < 2e-3
    assert np.abs(tinted - plain).max() > 0.1


def test_a_texture_on_the_second_uv_set_samples_it(ctx: moderngl.Context, tmp_path: Path) -> None:
    """A base colour texture with texCoord 1 reads TEXCOORD_1: a square whose TEXCOORD_0 is one
    constant and whose TEXCOORD_1 spans the image draws as the square whose TEXCOORD_0 spans it."""
    second = _render(ctx, _quad(tmp_path / "second.glb", uv_set=1, swap_sets=True))
    first = _render(ctx, _quad(tmp_path / "first.glb"))
    wrong = _render(ctx, _quad(tmp_path / "wrong.glb", swap_sets=True))  # texCoord 0: one texel
    assert np.abs(second - first).max() < 2e-3
    assert np.abs(second - wrong).max() > 0.1


def test_they_are_no_longer_listed_as_ignored(tmp_path: Path) -> None:
    """A file with a normal map, vertex colours and a texture on TEXCOORD_1 lists nothing as
    ignored; `plan` names the attributes the scene's programs compile in and what they cost; a
    texCoord past 1 is still listed."""
    path = _bumpy_box(tmp_path / "bumpy.glb")
    assert ignored_features(read_json(path, str(path))) == ()
    plan = plan_render(load_scene(path), Method.RAYTRACE)
    assert plan.ignored == ()
    text = plan.format()
    assert "vertex attributes: TEXCOORD_1" in text and "COLOR_0" in text and "NORMAL_MAP" in text, text
    assert "normal-mapped" in text
    header = read_json(path, str(path))
    header["materials"][0]["normalTexture"]["texCoord"] = 2
    assert ignored_features(header) == ("normalTexture.texCoord 2 (TEXCOORD_0 and TEXCOORD_1 are read)",)


def test_memory_counts_the_extra_attributes(tmp_path: Path) -> None:
    """The plan's mesh memory grows by the extra attributes' floats a vertex (TEXCOORD_1, colour,
    tangent: 2 + 4 + 4), on every vertex."""
    with_extras = load_scene(_bumpy_box(tmp_path / "a.glb"))
    without = load_scene(_bumpy_box(tmp_path / "b.glb", normal_map=False, colors=False, tangents=False))
    vertices = 24
    extra = plan_render(with_extras, Method.RAYTRACE).memory["meshes"] - plan_render(without, Method.RAYTRACE).memory["meshes"]
    assert extra == vertices * 4 * (2 + 4 + 4), extra


def test_a_skinned_parts_tangents_turn_with_it(tmp_path: Path) -> None:
    """A normal-mapped column whose top a joint bends (gltf_files.skinned_column): its tangents are
    made again from its deformed mesh at each time, unit and perpendicular to its normals, the top's
    turned with the bend and the foot's as they were."""
    w = GltfWriter()
    material = w._append("materials", {"pbrMetallicRoughness": {"metallicFactor": 0.0},
                                       "normalTexture": {"index": w.texture(_bumps())}})
    skinned_column(w, material)
    primitive = w.json["meshes"][-1]["primitives"][0]
    count = w.json["accessors"][primitive["attributes"]["POSITION"]]["count"]
    corners = np.arange(count)
    primitive["attributes"]["TEXCOORD_0"] = w.accessor(np.stack([(corners % 4) / 4.0, 1.0 - (corners // 4) / 8.0], axis=1),
                                                       "VEC2")
    part = read_gltf(w.write(tmp_path / "column.glb"), "column.glb").parts[0]
    assert part.motion is not None and part.motion.deforms
    rest, bent = part.motion.mesh_at(0.0), part.motion.mesh_at(1.0)
    for mesh in (rest, bent):
        assert mesh.tangents is not None
        np.testing.assert_allclose(np.linalg.norm(mesh.tangents[:, :3], axis=1), 1.0, atol=1e-5)
        assert np.abs(np.einsum("ij,ij->i", mesh.tangents[:, :3], mesh.normals)).max() < 1e-5
    assert rest.tangents is not None and bent.tangents is not None
    top, foot = rest.positions[:, 1] > 1.9, rest.positions[:, 1] < 0.1
    assert np.abs(bent.tangents[top, :3] - rest.tangents[top, :3]).max() > 0.3
    np.testing.assert_allclose(bent.tangents[foot], rest.tangents[foot], atol=1e-5)
