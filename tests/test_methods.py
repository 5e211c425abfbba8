"""The methods a reflected ray can find objects with: depth images (the rest of the suite), the
cube map (by direction, and parallax-corrected), billboards, simplified triangles, and the
ray-traced triangles, which must agree with Embree's truth to within float noise."""

from __future__ import annotations

import json
import re
from pathlib import Path

import moderngl
import numpy as np
import pytest
import trimesh
from PIL import Image

from conftest import SCENES, assert_finite
from depthimpostor.methods.bvh import LEAF_TRIANGLES, build_bvh
from depthimpostor.cli import main
from depthimpostor.oracles.compare import compare
from depthimpostor.constants import NO_OBJECT, Method
from depthimpostor.errors import SceneError
from depthimpostor.meshes import sphere
from depthimpostor.methods.simplified import crease_shaded, simplified_mesh
from depthimpostor.methods.registry import METHODS
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene, load_scene, parse_scene

# The hard scenes too: surrounds.toml, which the methods that bake from the mirror's centre must
# refuse (no image taken from there can hold an object around it), is an ordinary scene to a ray
# tracer.
SCENE_FILES = sorted(SCENES.glob("*.toml")) + sorted((SCENES / "hard").glob("*.toml"))
BAKING = [method for method in Method if METHODS[method].bakes_images]
#: The scenes whose reflectors are all flat mirrors (the planar method refuses the others by name).
FLAT_MIRRORS = {"planar_mirror", "checker_near_mirror", "textured_near_mirror", "blend_near_mirror", "grazing", "silhouette", "top_down"}


def test_bvh_holds_every_triangle_once_inside_nested_boxes() -> None:
    mesh = trimesh.creation.icosphere(subdivisions=4)
    triangles = np.asarray(mesh.vertices)[np.asarray(mesh.faces)]
    bvh = build_bvh(triangles)
    leaves = np.nonzero(bvh.count)[0]
    assert sorted(bvh.order) == list(range(len(triangles)))
    assert bvh.count[leaves].sum() == len(triangles) and bvh.count.max() <= LEAF_TRIANGLES
    assert bvh.depth <= int(np.ceil(np.log2(len(triangles) / LEAF_TRIANGLES))) + 1
    ordered = triangles[bvh.order]
    for leaf in leaves:
        inside = ordered[bvh.first[leaf] : bvh.first[leaf] + bvh.count[leaf]].reshape(-1, 3)
        assert (inside >= bvh.lower[leaf] - 1e-6).all() and (inside <= bvh.upper[leaf] + 1e-6).all()
    for node in np.nonzero(bvh.count == 0)[0]:
        for child in (bvh.first[node], bvh.first[node] + 1):
            assert (bvh.lower[child] >= bvh.lower[node]).all() and (bvh.upper[child] <= bvh.upper[node]).all()


def test_bvh_skip_links_walk_the_tree_depth_first() -> None:
    """The shader's stackless walk: descending into every node and following the skip link out
    of every leaf visits each node once, in the order a stack (right pushed before left) would;
    skipping a node passes over exactly its subtree."""
    mesh = trimesh.creation.icosphere(subdivisions=3)
    bvh = build_bvh(np.asarray(mesh.vertices)[np.asarray(mesh.faces)])
    expected, stack = [], [0]
    while stack:
        node = stack.pop()
        expected.append(node)
        if bvh.count[node] == 0:
            stack += [bvh.first[node] + 1, bvh.first[node]]
    walked, node = [], 0
    while node >= 0:
        walked.append(node)
        node = bvh.first[node] if bvh.count[node] == 0 else bvh.skip[node]
    assert walked == expected
    position = {node: i for i, node in enumerate(walked)}
    for node in range(bvh.node_count):
        after = position[bvh.skip[node]] if bvh.skip[node] >= 0 else len(walked)
        subtree = list(walked[position[node]:after])
        assert subtree[0] == node and all(position[n] >= position[node] for n in subtree)
        if bvh.count[node]:
            assert after == position[node] + 1


@pytest.mark.parametrize("method", list(Method), ids=lambda m: m.option)
@pytest.mark.parametrize("path", SCENE_FILES, ids=lambda p: p.stem)
def test_every_method_renders_every_scene_finite(ctx: moderngl.Context, path: Path, method: Method) -> None:
    scene = load_scene(path).with_overrides(size=(128, 72), impostor_resolution=64)
    if method in BAKING and path.stem == "surrounds":
        with pytest.raises(SceneError, match="centre of mirror"):
            Renderer(ctx, scene, method=method)
        return
    if scene.render.max_bounces > 1 and method != Method.DEPTH:
        with pytest.raises(SceneError, match="depth method alone"):
            Renderer(ctx, scene, method=method)
        return
    if method == Method.PLANAR and path.stem not in FLAT_MIRRORS:
        # Named as the TOML scene writes it, or as the glTF file it places does (showcase.toml).
        named = r'objects\[\d+\]( \(\S+\) node \d+ .*\))?'
        with pytest.raises(SceneError, match=named + r': --method planar needs flat mirrors; "[^"]+" is (a |glass)'):
            Renderer(ctx, scene, method=method)
        return
    with Renderer(ctx, scene, method=method) as renderer:
        renderer.render()
        image = renderer.read_color_float()
        # Only the method's own stand-in exists, and only its mirror variant was compiled.
        assert type(renderer.graph.stand_in) is METHODS[method].stand_in
        mirror_variants = {dict(defines)["METHOD"] for _, fragment, defines in renderer.programs.variants
                           if fragment == "reflector.frag"}
        assert mirror_variants == {str(int(method))}
        if method not in BAKING:
            assert renderer.stats.depth_images_baked == 0
    assert_finite(image)


def assert_raytrace_matches_the_truth(ctx: moderngl.Context, scene: Scene, mirror_pixels: int = 1000) -> None:
    """The ray-traced method against Embree's truth at 320x180: float noise apart, the same."""
    with Renderer(ctx, scene.with_overrides(size=(320, 180)), reflection_data=True, method=Method.RAYTRACE) as renderer:
        renderer.render()
        figures = compare(renderer).figures
    assert figures.mirror_pixels > mirror_pixels
    assert figures.wrong_object_share < 0.001
    assert figures.color_rmse < 1e-3
    if figures.geometric_pixels:
        assert figures.geometric_error_max < 1e-3  # a share of the object's radius


@pytest.mark.parametrize("name", ["default", "bunny", "lecture_8x9", "grid_3x3", "hdr_sky"])
def test_raytrace_matches_the_embree_truth(ctx: moderngl.Context, name: str) -> None:
    assert_raytrace_matches_the_truth(ctx, load_scene(SCENES / f"{name}.toml"))


def test_method_switch_keeps_only_the_methods_resources(ctx: moderngl.Context) -> None:
    scene = load_scene(SCENES / "default.toml").with_overrides(size=(96, 54), impostor_resolution=64)
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        depth = renderer.read_color_float()
        renderer.set_method(Method.RAYTRACE)
        assert renderer.graph.impostors is None and renderer.graph.triangles is not None
        renderer.render()
        traced = renderer.read_color_float()
        renderer.set_method(Method.DEPTH)
        assert renderer.graph.triangles is None and renderer.graph.impostors is not None
        renderer.render()
        np.testing.assert_allclose(renderer.read_color_float(), depth, atol=1e-6)
        assert renderer.stats.depth_images_baked == 10
    with Renderer(ctx, scene, method=Method.RAYTRACE) as fresh:
        fresh.render()
        np.testing.assert_allclose(fresh.read_color_float(), traced, atol=1e-6)
        fragments = {fragment for _, fragment, _ in fresh.programs.variants}
        assert "window_depth.frag" not in fragments, "no baking program for a method that bakes nothing"


def test_compare_reports_the_method(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "report"
    assert main(["compare", str(SCENES / "default.toml"), "--size", "96x54", "--method", "raytrace", "-o", str(out)]) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["settings"]["method"] == "raytrace"
    assert "wrong object" in capsys.readouterr().out


def _scene_file(folder: Path, text: str, name: str) -> Scene:
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return load_scene(path)


def _reflection(ctx: moderngl.Context, scene: Scene, method: Method) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(colours, object ids, mirror mask) of one frame."""
    with Renderer(ctx, scene, reflection_data=True, method=method) as renderer:
        renderer.render()
        data = renderer.read_reflection_data()
        return renderer.read_color_float(), data.object_id, data.mirror_mask


def _around_a_mirror_sphere(eye: str, light_direction: str, objects: str) -> str:
    """A scene: a unit mirror sphere at the origin, seen from `eye`, among `objects`."""
    return f"""
[render]
size = [240, 240]
impostor_resolution = 512
[camera]
eye = {eye}
target = [0.0, 0.0, 0.0]
fov_y = 38.0
[environment]
type = "constant"
color = [0.2, 0.2, 0.25]
[[lights]]
type = "directional"
direction = {light_direction}
[[objects]]
name = "mirror"
shape = {{ type = "sphere", radius = 1.0 }}
material = {{ type = "mirror" }}
{objects}"""


# Two objects 1,000 radii away, large enough to fill part of the mirror, lit on the sides that
# face it.
FAR_OBJECTS = _around_a_mirror_sphere("[0.0, 0.0, 4.0]", "[0.3, -0.4, 1.0]", """
[[objects]]
name = "far_box"
shape = { type = "box", size = [500.0, 500.0, 500.0] }
material = { type = "diffuse", color = [0.9, 0.2, 0.1] }
position = [300.0, 250.0, 1000.0]
rotation = [20.0, 30.0, 0.0]
[[objects]]
name = "far_sphere"
shape = { type = "sphere", radius = 300.0 }
material = { type = "diffuse", color = [0.1, 0.6, 0.9] }
position = [-450.0, -150.0, 900.0]
""")


def test_cubemap_equals_depth_images_for_objects_far_away(ctx: moderngl.Context, tmp_path: Path) -> None:
    scene = _scene_file(tmp_path, FAR_OBJECTS, "far_objects.toml")
    depth, depth_object, mask = _reflection(ctx, scene, Method.DEPTH)
    cube, cube_object, _ = _reflection(ctx, scene, Method.CUBEMAP)
    on_objects = mask & (depth_object != NO_OBJECT)
    assert on_objects.sum() > 0.03 * mask.sum(), "the far objects fill part of the mirror"
    # The offset of a reflected ray's origin from the mirror's centre is 1e-3 of the distance:
    # the same objects, and the same colours up to the two images' different sampling.
    assert (depth_object != cube_object)[mask].mean() < 0.01
    assert np.median(np.abs(depth - cube).max(axis=2)[on_objects]) < 0.01


@pytest.mark.parametrize("name", ["default", "planar_mirror"])
def test_cubemap_differs_visibly_for_near_objects(ctx: moderngl.Context, name: str) -> None:
    scene = load_scene(SCENES / f"{name}.toml").with_overrides(size=(320, 180))
    _, depth_object, mask = _reflection(ctx, scene, Method.DEPTH)
    _, cube_object, _ = _reflection(ctx, scene, Method.CUBEMAP)
    _, parallax_object, _ = _reflection(ctx, scene, Method.CUBEMAP_PARALLAX)
    plain = (cube_object != depth_object)[mask].mean()
    assert plain > 0.05, "near objects seen by direction alone land elsewhere in the mirror"
    assert (parallax_object != depth_object)[mask].mean() < plain, "the parallax correction brings them closer"


def test_both_cube_map_lookups_share_one_bake(ctx: moderngl.Context) -> None:
    scene = load_scene(SCENES / "default.toml").with_overrides(size=(96, 54), impostor_resolution=64)
    with Renderer(ctx, scene, method=Method.CUBEMAP) as renderer:
        renderer.render()
        plain = renderer.read_color_float()
        cube_map = renderer.graph.stand_in
        renderer.set_method(Method.CUBEMAP_PARALLAX)
        renderer.render()
        assert renderer.graph.stand_in is cube_map and renderer.stats.depth_images_baked == 6
        assert np.abs(renderer.read_color_float() - plain).max() > 0.1


# A flat square facing the mirror's centre (its thin side along the line between them), seen in
# the mirror by a camera beside it.
FLAT_FACING = _around_a_mirror_sphere("[2.5, 0.3, 2.5]", "[-1.0, -0.4, -0.2]", """
[[objects]]
name = "card"
shape = { type = "box", size = [0.0005, 1.6, 1.6] }
material = { type = "checker", color_a = [0.9, 0.8, 0.1], color_b = [0.1, 0.3, 0.8], scale = 0.4 }
position = [2.5, 0.0, 0.0]
""")


def test_billboard_is_exact_for_a_flat_object_facing_the_mirror(ctx: moderngl.Context, tmp_path: Path) -> None:
    scene = _scene_file(tmp_path, FLAT_FACING, "flat_facing.toml")
    with Renderer(ctx, scene, reflection_data=True, method=Method.BILLBOARD) as renderer:
        renderer.render()
        figures = compare(renderer).figures
    assert figures.geometric_pixels > 0.03 * figures.mirror_pixels, "the card fills part of the mirror"
    # Only texels along the card's outline may differ (the texture's sampling), and the hit
    # points lie on the card: its half thickness is 0.02 % of its radius.
    assert figures.wrong_object_share < 0.01
    assert figures.geometric_error_p95 < 0.001
    assert figures.color_rmse < 0.05


def test_simplified_meshes_keep_the_shape_with_fewer_triangles() -> None:
    original = sphere(1.0)
    simple = simplified_mesh(original, 400)
    assert 300 <= len(simple.indices) <= 400 < len(original.indices)
    radii = np.linalg.norm(simple.positions, axis=1)
    assert np.abs(radii - 1.0).max() < 0.02, "vertices stay on the sphere"
    centres = simple.positions[simple.indices].mean(axis=1)
    normals = simple.normals[simple.indices].mean(axis=1)
    assert (np.einsum("ij,ij->i", centres, normals) > 0).all(), "normals point outward"
    assert simplified_mesh(original, len(original.indices)) is original, "nothing to do, nothing done"


def test_crease_shading_keeps_flat_faces_flat_and_smooths_the_rest() -> None:
    cube = trimesh.creation.box()  # 8 shared corners: every edge is a 90-degree crease
    shaded = crease_shaded(np.asarray(cube.vertices, float), np.asarray(cube.faces))
    assert np.allclose(np.abs(shaded.normals).max(axis=1), 1.0), "each corner takes its own face's normal"
    ball = trimesh.creation.icosphere(subdivisions=3)
    smooth = crease_shaded(np.asarray(ball.vertices, float), np.asarray(ball.faces))
    radial = smooth.positions / np.linalg.norm(smooth.positions, axis=1, keepdims=True)
    assert np.einsum("ij,ij->i", smooth.normals, radial).min() > 0.999, "smooth where the surface is smooth"


def test_simplified_traces_fewer_triangles_with_the_same_traversal(ctx: moderngl.Context) -> None:
    scene = load_scene(SCENES / "default.toml").with_overrides(size=(320, 180))
    with Renderer(ctx, scene, reflection_data=True, method=Method.SIMPLIFIED) as renderer:
        renderer.render()
        figures = compare(renderer).figures
        triangles = renderer.graph.triangles
        assert triangles is not None
        assert triangles.triangle_count <= scene.render.simplified_triangles * len(renderer.world.reflected_objects)
    assert figures.wrong_object_share < 0.01 and figures.geometric_error_median < 0.01
    # With a target above every object's count nothing is simplified: the ray-traced frame, exactly.
    everything = scene.with_overrides(simplified_triangles=10**6)
    simplified, _, _ = _reflection(ctx, everything, Method.SIMPLIFIED)
    traced, _, _ = _reflection(ctx, everything, Method.RAYTRACE)
    np.testing.assert_array_equal(simplified, traced)


def test_compare_reports_the_same_figures_for_every_method(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "report"
    arguments = ["compare", str(SCENES / "default.toml"), "--size", "96x54", "--impostor-res", "64"]
    assert main([*arguments, "--method", "all", "-o", str(out)]) == 0
    reports = {}
    compared = [method for method in Method if method != Method.PLANAR]  # planar refuses the sphere mirror
    assert not (out / Method.PLANAR.option).exists()
    for method in compared:
        folder = out / method.option
        assert sorted(path.name for path in folder.iterdir()) == ["difference.png", "render.png", "report.json", "truth.png"]
        reports[method] = json.loads((folder / "report.json").read_text())
        assert reports[method]["settings"]["method"] == method.option
    printed = capsys.readouterr().out
    assert printed.count("wrong object") == len(compared) + 1  # each method's table, and the summary's header
    fields = {name for name in reports[Method.DEPTH]["figures"] if name != "worst_pixels"}
    for method, report in reports.items():
        figures = report["figures"]
        assert set(figures) - {"worst_pixels"} == fields
        assert all(np.isfinite(figures[name]) for name in fields if name != "psnr_db"), method
        assert figures["mirror_pixels"] == reports[Method.DEPTH]["figures"]["mirror_pixels"]
    # The summary: one row per method, and the mirrors of every method and the truth side by side.
    table = (out / "methods.md").read_text().splitlines()
    assert [row.split("|")[1].strip() for row in table[2:]] == [f"`{method.option}`" for method in
                                                                  (*compared, Method.PLANAR)]
    assert 'refused: --method planar needs flat mirrors; "mirror" is a sphere' in table[-1]
    sheet = np.asarray(Image.open(out / "methods.png"))
    assert sheet.shape[1] > (len(compared) + 1) * 20 and sheet.ndim == 3


def test_a_mirror_with_nothing_to_reflect_renders_with_every_method(ctx: moderngl.Context, tmp_path: Path) -> None:
    """A mirror over a floor and nothing else: every method shows the floor and the sky as the
    depth method does (the triangle methods once ended in numpy's "need at least one array to
    concatenate": their BVH now holds one degenerate triangle no ray meets)."""
    scene = parse_scene({
        "render": {"size": [96, 64]},
        "objects": [
            {"name": "mirror", "shape": {"type": "sphere", "radius": 1.0}, "material": {"type": "mirror"},
             "position": [0.0, 1.0, 0.0]},
            {"name": "floor", "shape": {"type": "plane", "size": [10.0, 10.0]},
             "material": {"type": "checker", "color_a": [0.9, 0.9, 0.9], "color_b": [0.2, 0.2, 0.2], "scale": 0.5}},
        ],
    }, "lonely.toml", tmp_path)
    frames = {}
    for method in Method:
        if method == Method.PLANAR:  # a sphere: refused by name (test_eye_methods.py)
            continue
        with Renderer(ctx, scene, method=method) as renderer:
            renderer.render()
            frames[method] = renderer.read_color_float()
        assert_finite(frames[method])
    for method in (Method.RAYTRACE, Method.SIMPLIFIED, Method.HYBRID):
        assert np.abs(frames[method] - frames[Method.DEPTH]).max() < 1e-5, method.name


def test_registry_has_every_method_and_its_chunks_are_the_shaders() -> None:
    """methods/registry.py is the one table of methods: every `Method` has a row, and a row's GLSL
    chunks are the files lib/reflected_scene.glsl includes under that method's `#if` branch."""
    assert set(METHODS) == set(Method)
    source = (Path(__file__).resolve().parent.parent / "shaders" / "lib" / "reflected_scene.glsl").read_text()
    dispatch = source[source.index("#if METHOD == METHOD_DEPTH\n"):source.index("#endif", source.index("#if METHOD == METHOD_DEPTH\n"))]
    branches = re.split(r"^#(?:if|elif|else)\b(.*)$", dispatch, flags=re.M)[1:]
    included: dict[Method, tuple[str, ...]] = {}
    for condition, body in zip(branches[::2], branches[1::2], strict=True):
        chunks = tuple(re.findall(r'#include "([^"]+)"', body))
        named = [m for m in Method if f"METHOD_{m.name}" in condition]
        for method in named or [m for m in Method if m not in included]:  # the #else branch: the rest
            included[method] = chunks
    assert {method: spec.glsl for method, spec in METHODS.items()} == included
