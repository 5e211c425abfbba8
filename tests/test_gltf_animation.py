"""glTF animation as authored (scene/gltf_animation.py, gltf_deform.py): node TRS channels with
their three interpolations through the node tree, looping, morph targets and skins, each sampled
where the specification says; bad channels refused in one line; and, rendered, a skinned column
whose joint turns moves in every method's picture and in the truth's alike. Every file is built
here (tests/gltf_files.py)."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import moderngl
import numpy as np
import pytest
from PIL import Image

from conftest import assert_finite
from depthimpostor.constants import Method
from depthimpostor.errors import SceneWarning
from depthimpostor.oracles.compare import Comparison, compare
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene, load_scene
from depthimpostor.scene.gltf_file import ignored_features, read_json
from depthimpostor.scene.model import axis_rotation
from depthimpostor.world import World
from gltf_files import GltfWriter, bending_scene, quaternion, skinned_column
from test_cli import assert_one_line_error, run_in_process


def load_quietly(path: Path) -> Scene:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SceneWarning)
        return load_scene(path)


def world_positions(scene: Scene, time: float, index: int = 0) -> np.ndarray:
    """objects[index]'s world-space vertices at `time`, as every pass and the truth see them."""
    return World(scene, time=time).geometry[index].world_mesh.positions.astype(np.float64)


def animated_box(tmp_path: Path, *channels: tuple[str, Any, Any, str], parent: bool = False) -> Scene:
    """A unit box whose node (or, `parent`, whose parent node) the channels animate."""
    w = GltfWriter()
    box = w.node(mesh=w.mesh(w.box(material=w.material("Grey"), normals=True)), root=not parent, translation=[0, 0, 1])
    target = box
    if parent:
        target = w.node(name="Parent", children=[box], translation=[1, 0, 0])
    w.animation(*((target, path, times, values, interpolation) for path, times, values, interpolation in channels))
    return load_quietly(w.write(tmp_path / "a.glb"))


def moved_by(scene: Scene, time: float) -> np.ndarray:
    """The world transform of objects[0] at `time` relative to time as written (the file's rest)."""
    return scene.objects[0].model_matrix(time)


# --- node channels --------------------------------------------------------------------------------------------
def test_linear_translation_loops_over_the_clip_and_step_holds(tmp_path: Path) -> None:
    linear = animated_box(tmp_path, ("translation", [0.0, 2.0], [[0, 0, 1], [2, 0, 1]], "LINEAR"))
    for time, x in ((0.0, 0.0), (0.5, 0.5), (2.5, 0.5), (-1.5, 0.5), (1.999, 1.999)):
        np.testing.assert_allclose(moved_by(linear, time)[:3, 3], (x, 0, 0), atol=1e-9)
    step = animated_box(tmp_path, ("translation", [0.0, 1.0, 2.0], [[0, 0, 1], [3, 0, 1], [5, 0, 1]], "STEP"))
    for time, x in ((0.5, 0.0), (1.0, 3.0), (1.9, 3.0)):
        np.testing.assert_allclose(moved_by(step, time)[:3, 3], (x, 0, 0), atol=1e-9)
    assert linear.animated and linear.objects[0].moves and not linear.objects[0].deforms


def test_rotation_is_slerped_along_the_shorter_arc(tmp_path: Path) -> None:
    """0 to 350 degrees about Y: the shorter arc goes back through -5 at the middle, not on through 175."""
    scene = animated_box(tmp_path, ("rotation", [0.0, 1.0], [quaternion((0, 1, 0), 0), quaternion((0, 1, 0), 350)],
                                    "LINEAR"))
    rest = np.eye(4)
    rest[2, 3] = 1.0
    expected = np.eye(4)
    expected[:3, :3] = axis_rotation(1, -5.0)
    expected[2, 3] = 1.0
    np.testing.assert_allclose(moved_by(scene, 0.5) @ rest, expected, atol=1e-9)


def test_cubic_spline_is_appendix_cs_hermite_with_scaled_tangents(tmp_path: Path) -> None:
    """Keys at t = 1 and 3 (interval 2): p(s) = (2s^3 - 3s^2 + 1) v0 + 2 (s^3 - 2s^2 + s) b0
    + (-2s^3 + 3s^2) v1 + 2 (s^3 - s^2) a1, at t = 1.6 (s = 0.3)."""
    v0, b0, a1, v1 = 1.0, 4.0, -2.0, 3.0
    rows = [[9, 0, 1], [v0, 0, 1], [b0, 0, 0], [a1, 0, 0], [v1, 0, 1], [9, 0, 0]]  # (in, value, out) per key
    scene = animated_box(tmp_path, ("translation", [1.0, 3.0], rows, "CUBICSPLINE"))
    s = 0.3
    x = (2 * s**3 - 3 * s**2 + 1) * v0 + 2 * (s**3 - 2 * s**2 + s) * b0 + (-2 * s**3 + 3 * s**2) * v1 \
        + 2 * (s**3 - s**2) * a1
    np.testing.assert_allclose(moved_by(scene, 1.6)[:3, 3], (x, 0, 0), atol=1e-6)
    np.testing.assert_allclose(moved_by(scene, 0.5)[:3, 3], (v0, 0, 0), atol=1e-6)  # before the first key: its value


def test_a_parents_animation_moves_its_child(tmp_path: Path) -> None:
    """The parent at (1, 0, 0) turns about Y: the child box, 1 along Z from it, swings round it."""
    scene = animated_box(tmp_path, ("rotation", [0.0, 1.0], [quaternion((0, 1, 0), 0), quaternion((0, 1, 0), 90)],
                                    "LINEAR"), parent=True)
    centre = world_positions(scene, 1.0 - 1e-9).mean(axis=0)  # just before the loop: 90 degrees
    np.testing.assert_allclose(centre, (2.0, 0.0, 0.0), atol=1e-5)
    np.testing.assert_allclose(world_positions(scene, 0.0).mean(axis=0), (1.0, 0.0, 1.0), atol=1e-6)


def test_a_file_without_animations_is_still_at_every_time(tmp_path: Path) -> None:
    w = GltfWriter()
    w.node(mesh=w.mesh(w.box(material=w.material("Grey"))), translation=[0, 0, 1])
    scene = load_quietly(w.write(tmp_path / "still.glb"))
    assert not scene.animated and scene.objects[0].motion is None


# --- bad channels -------------------------------------------------------------------------------------------
def bad_animation(tmp_path: Path, case: str) -> tuple[Path, str]:
    w = GltfWriter()
    node = w.node(mesh=w.mesh(w.box(material=w.material("Grey"))))
    w.animation((node, "translation", [0.0, 1.0], [[0, 0, 0], [1, 0, 0]], "LINEAR"))
    animation = w.json["animations"][0]
    if case == "sampler":
        animation["channels"][0]["sampler"] = 3
        fragment = "animations[0].channels[0].sampler: expected an index in [0, 1), got 3"
    elif case == "input":
        animation["samplers"][0]["input"] = w.raw_accessor(np.array([1.0, 0.5]), "SCALAR")
        fragment = "animations[0].samplers[0].input: expected keyframe times >= 0, finite and strictly increasing"
    elif case == "output":
        animation["samplers"][0]["output"] = w.raw_accessor(np.zeros((3, 3)), "VEC3")
        fragment = ("animations[0].samplers[0].output: expected 2 values of 3 components for translation "
                    "(2 keyframes, LINEAR), got 3 of 3 (the sampler of channels[0], the translation of nodes[0])")
    elif case == "path":
        animation["channels"][0]["target"]["path"] = "position"
        fragment = 'animations[0].channels[0].target.path: expected "translation", "rotation", "scale" or "weights"'
    elif case == "matrix":
        w.json["nodes"][node]["matrix"] = np.eye(4).ravel().tolist()
        fragment = "animations[0].channels[0].target.node: expected a node with TRS properties"
    elif case == "joints":
        w = GltfWriter()
        skinned_column(w, w.material("Blue"))
        attributes = w.json["meshes"][0]["primitives"][0]["attributes"]
        attributes["JOINTS_0"] = w.raw_accessor(np.tile([0, 2, 0, 0], (36, 1)), "VEC4", 5123)
        fragment = "meshes[0].primitives[0].attributes.JOINTS_0: expected unsigned integer joint indices below the skin's 2"
    else:
        animation["samplers"][0]["interpolation"] = "SMOOTH"
        fragment = "animations[0].samplers[0].interpolation: expected one of LINEAR, STEP, CUBICSPLINE"
    return w.write(tmp_path / "x.glb"), fragment


@pytest.mark.parametrize("case", ["sampler", "input", "output", "path", "interpolation", "matrix", "joints"])
def test_a_bad_channel_is_refused_in_one_line_naming_it(tmp_path: Path, case: str,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    path, fragment = bad_animation(tmp_path, case)
    code, stdout, stderr = run_in_process(["plan", str(path)], capsys)
    assert_one_line_error(code, stdout, stderr, f"{path}: ", fragment)


# --- morph targets and skins ----------------------------------------------------------------------------------
def morphed_quad(tmp_path: Path, mesh_weights: list[float] | None = None, node_weights: list[float] | None = None,
                 animated: bool = False) -> Scene:
    """A quad in XY whose one morph target lifts vertex 2 by 1 along Z (its normals unchanged)."""
    w = GltfWriter()
    positions = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]
    primitive = w.primitive(positions, [[0, 1, 2], [0, 2, 3]], [[0, 0, 1]] * 4, material=w.material("Grey"))
    primitive["targets"] = [{"POSITION": w.accessor(np.array([[0, 0, 0], [0, 0, 0], [0, 0, 1], [0, 0, 0]], float), "VEC3")}]
    mesh = w.mesh(primitive)
    if mesh_weights is not None:
        w.json["meshes"][mesh]["weights"] = mesh_weights
    node = w.node(mesh=mesh, **({"weights": node_weights} if node_weights is not None else {}))
    if animated:
        w.animation((node, "weights", [0.0, 2.0], [0.0, 1.0], "LINEAR"))
    return load_quietly(w.write(tmp_path / "m.glb"))


def lifted(scene: Scene, time: float = 0.0) -> float:
    """How far the morph target has lifted the quad's corner (1, 1) at `time`."""
    positions = world_positions(scene, time)
    return float(positions[np.argmin(np.linalg.norm(positions[:, :2] - (1, 1), axis=1)), 2])


def test_a_morph_target_at_weight_one_moves_its_vertices(tmp_path: Path) -> None:
    assert lifted(morphed_quad(tmp_path, mesh_weights=[1.0])) == pytest.approx(1.0)
    assert lifted(morphed_quad(tmp_path, mesh_weights=[1.0], node_weights=[0.25])) == pytest.approx(0.25)  # the node's first
    unweighted = morphed_quad(tmp_path)
    assert lifted(unweighted) == 0.0 and unweighted.objects[0].deforms and unweighted.animated
    animated = morphed_quad(tmp_path, animated=True)
    assert [lifted(animated, t) for t in (0.0, 1.0, 1.5)] == pytest.approx([0.0, 0.5, 0.75])


def test_a_skinned_column_bends_where_its_joint_turns(tmp_path: Path) -> None:
    """At t = 1 the child joint (at y = 1) has turned 60 degrees about Z: a vertex above y = 1.5,
    all its own, is turned about (0, 1, 0); one below y = 0.5 stays; the blend is between."""
    w = GltfWriter()
    skinned_column(w, w.material("Blue"))
    scene = load_quietly(w.write(tmp_path / "c.glb"))
    rest, bent = world_positions(scene, 0.0), world_positions(scene, 1.0)
    assert scene.objects[0].deforms
    top, foot = rest[:, 1] > 1.55, rest[:, 1] < 0.45
    turned = (rest - (0, 1, 0)) @ axis_rotation(2, 60.0).T + (0, 1, 0)
    np.testing.assert_allclose(bent[top], turned[top], atol=1e-5)
    np.testing.assert_allclose(bent[foot], rest[foot], atol=1e-6)
    rest_normals = World(scene, time=0.0).geometry[0].world_mesh.normals
    normals = World(scene, time=1.0).geometry[0].world_mesh.normals
    assert np.isfinite(normals).all() and np.allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-5)
    np.testing.assert_allclose(normals[top], rest_normals[top] @ axis_rotation(2, 60.0).T, atol=1e-5)


def test_what_is_played_is_no_longer_listed_as_ignored(tmp_path: Path) -> None:
    """A skin, morph targets and one animation are drawn: nothing listed. A second animation is not played: listed."""
    w = GltfWriter()
    skinned_column(w, w.material("Blue"))
    path = w.write(tmp_path / "c.glb")
    assert ignored_features(read_json(path, str(path))) == ()
    w.json["animations"].append(w.json["animations"][0])
    path = w.write(tmp_path / "two.glb")
    assert ignored_features(read_json(path, str(path))) == ("1 animation(s) after the first (only animations[0] plays)",)


# --- rendered -----------------------------------------------------------------------------------------------
#: The methods that find the real (deformed) triangles, exactly as the truth does.
EXACT = {Method.RAYTRACE, Method.SIMPLIFIED, Method.HYBRID, Method.PLANAR}


def _two_times(ctx: moderngl.Context, scene: Scene, method: Method) -> list[Comparison]:
    """The method's frames at t = 0 (the joint straight) and t = 1 (turned 60 degrees), each
    compared with the truth; one renderer, moved from one time to the other as `--video` moves it."""
    comparisons = []
    with Renderer(ctx, scene, reflection_data=True, method=method) as renderer:
        for time in (0.0, 1.0):
            renderer.set_time(time)
            renderer.render()
            assert_finite(renderer.read_color_float())
            comparisons.append(compare(renderer))
    return comparisons


def changed(first: np.ndarray, second: np.ndarray, before: Comparison, after: Comparison,
            mirror: bool = True) -> np.ndarray:
    """Where two pictures differ by more than 0.05 in a channel: among the pixels a mirror covers in
    both frames (`mirror`), or among those it covers in neither (the eye's direct view)."""
    where = before.mirror_mask & after.mirror_mask if mirror else ~(before.mirror_mask | after.mirror_mask)
    return (np.abs(first - second).max(axis=2) > 0.05) & where


@pytest.mark.parametrize("method", list(Method), ids=lambda m: m.option)
def test_every_method_and_the_truth_move_where_the_joint_moves(ctx: moderngl.Context, tmp_path: Path,
                                                               method: Method) -> None:
    """Between the two times the truth's reflection changes where the column bends; the method's
    picture changes there too (most of those pixels), its direct view changes, and it stays as
    near the truth at the second time as at the first (a stale image or BVH would not)."""
    scene = load_quietly(bending_scene(tmp_path / "bending.glb")).with_overrides(size=(192, 108), impostor_resolution=128)
    before, after = _two_times(ctx, scene, method)
    truth_moved, moved = changed(before.truth, after.truth, before, after), changed(before.render, after.render, before, after)
    direct_moved = changed(before.render, after.render, before, after, mirror=False)
    assert truth_moved.sum() > 200 and direct_moved.sum() > 50
    assert (moved & truth_moved).sum() >= 0.7 * truth_moved.sum()
    if method in EXACT:
        for comparison in (before, after):
            assert comparison.figures.wrong_object_share < 0.001 and comparison.figures.color_rmse < 1e-3
    else:
        assert after.figures.color_rmse <= 1.5 * before.figures.color_rmse + 0.01


# --- public samples (tests/data/gltf, scenes/MODELS.md) -------------------------------------------------------
DATA = Path(__file__).resolve().parent / "data" / "gltf"


def test_the_khronos_samples_play_their_animation_with_nothing_ignored() -> None:
    """BoxAnimated (COLLADA2GLTF): its inner box rises 2.5 and turns by node channels, its outer
    one stays; RiggedSimple: a cylinder skinned to two bones whose upper one bends it by 1.87 at 1 s."""
    for name in ("BoxAnimated", "RiggedSimple"):
        path = DATA / f"{name}.glb"
        assert ignored_features(read_json(path, str(path))) == ()
    box = load_scene(DATA / "BoxAnimated.glb")
    still, inner = box.objects
    assert not still.moves and inner.moves and not inner.deforms
    assert world_positions(box, 2.0, 1).mean(axis=0)[1] == pytest.approx(2.52, abs=0.01)
    assert World(box, time=2.0).geometry[1].local_mesh is World(box).geometry[1].local_mesh  # rigid: its mesh kept
    # Its README's trap: the rotation channel ends at 2.5 s, the translation at 3.71 s; the shorter one
    # holds its last value until the clip (the longer) loops, and then both start again together.
    turned = [inner.model_matrix(t)[:3, :3] for t in (2.5, 3.0, 3.7)]
    np.testing.assert_allclose(turned[1], turned[0], atol=1e-9)
    np.testing.assert_allclose(turned[2], turned[0], atol=1e-9)
    duration = 3.70832992
    np.testing.assert_allclose(inner.model_matrix(duration + 0.5), inner.model_matrix(0.5), atol=1e-5)
    rigged = load_scene(DATA / "RiggedSimple.glb")
    assert rigged.objects[0].deforms
    assert world_positions(rigged, 1.0)[:, 0].max() - world_positions(rigged, 0.0)[:, 0].max() == pytest.approx(1.87, abs=0.01)


@pytest.mark.parametrize("method", [Method.RAYTRACE, Method.HYBRID, Method.DEPTH], ids=lambda m: m.option)
def test_rigged_simple_before_a_mirror_matches_the_truth_at_two_times(ctx: moderngl.Context, tmp_path: Path,
                                                                       method: Method) -> None:
    """The exporter's skin (a Z-up root matrix, MAT4 inverse binds, unnormalized rounding) placed by
    a TOML scene before a mirror: the triangle methods as the truth, the depth images near it."""
    toml = tmp_path / "rigged.toml"
    toml.write_text(f"""
[camera]
eye = [2.5, 1.2, 3.5]
target = [0.0, 0.9, -0.5]
[[lights]]
type = "directional"
direction = [-0.3, -1.0, 0.5]  # from behind the cylinder: its side the mirror shows is lit
[[objects]]
name = "mirror"
shape = {{ type = "plane", size = [4.0, 2.4] }}
material = {{ type = "mirror" }}
position = [0.0, 1.2, -1.2]
rotation = [90.0, 0.0, 0.0]
[[objects]]
name = "rigged"
shape = {{ type = "gltf", path = "{DATA / 'RiggedSimple.glb'}" }}
scale = [0.2, 0.2, 0.2]
position = [0.0, 0.92, -0.3]
""", encoding="utf-8")
    scene = load_scene(toml).with_overrides(size=(160, 90), impostor_resolution=128)
    before, after = _two_times(ctx, scene, method)
    truth_moved, moved = changed(before.truth, after.truth, before, after), changed(before.render, after.render, before, after)
    assert truth_moved.sum() > 30 and (moved & truth_moved).sum() >= 0.7 * truth_moved.sum()
    for comparison in (before, after):
        if method in EXACT:
            assert comparison.figures.wrong_object_share < 0.001 and comparison.figures.color_rmse < 1e-3
        else:
            assert comparison.figures.wrong_object_share < 0.02


def test_render_plays_the_files_animation_at_its_time(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`render --time` as a user runs it: the bent column's picture (t = 1) is not the straight one's
    (t = 0), and a time a whole clip later (t = 3: the clip is 2 s long) is the same picture as t = 1."""
    path = str(bending_scene(tmp_path / "bending.glb"))
    pictures = []
    for time in ("0", "1", "3"):
        out = tmp_path / f"t{time}.png"
        code, _, stderr = run_in_process(["render", path, "--time", time, "--size", "96x54", "-o", str(out),
                                          "--method", "raytrace"], capsys)
        assert code == 0, stderr
        pictures.append(np.asarray(Image.open(out), np.int16))
    assert np.abs(pictures[1] - pictures[0]).max() > 64
    assert np.abs(pictures[2] - pictures[1]).max() <= 1


@pytest.mark.parametrize(("method", "work"), [(Method.HYBRID, "the images that show them re-baked, the BVH refitted"),
                                              (Method.RAYTRACE, "no images to re-bake, the BVH refitted"),
                                              (Method.DEPTH, "the images that show them re-baked, no BVH to refit")])
def test_plan_says_what_deforming_parts_cost_each_method(method: Method, work: str) -> None:
    """Issue 33 item 5: a scene with a skin states the per-frame work it calls for, by method; a
    scene without one says nothing of it."""
    from depthimpostor.plan import plan_render

    scene = load_scene(Path(__file__).parent / "data" / "gltf" / "RiggedSimple.glb")
    lines = [line for line in plan_render(scene, method).limits if line.startswith("deforming glTF parts")]
    assert len(lines) == 1 and ": 1, made again at every time" in lines[0] and work in lines[0]
    still = load_scene(Path(__file__).parent.parent / "scenes" / "default.toml")
    assert not any(line.startswith("deforming") for line in plan_render(still, method).limits)


def test_truth_and_compare_take_the_scene_time(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`truth --time` and `compare --time`: the truth of an animated file at another time is another
    picture, and the report states the time it measured."""
    import json

    path = str(bending_scene(tmp_path / "bending.glb"))
    pictures = []
    for time in ("0", "1"):
        out = tmp_path / f"truth{time}.png"
        code, _, stderr = run_in_process(["truth", path, "--time", time, "--size", "96x54", "-o", str(out)], capsys)
        assert code == 0, stderr
        pictures.append(np.asarray(Image.open(out), np.int16))
    assert np.abs(pictures[1] - pictures[0]).max() > 64
    report = tmp_path / "report"
    code, _, stderr = run_in_process(["compare", path, "--time", "1", "--size", "96x54", "--method", "raytrace",
                                      "-o", str(report)], capsys)
    assert code == 0, stderr
    written = json.loads(next(report.glob("*.json")).read_text())
    assert written["settings"]["time"] == 1.0
