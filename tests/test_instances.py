"""The traced methods' two-level BVH (issue 32): one bottom level per distinct mesh, an instance per
reflected object under a top level (methods/instances.py, methods/triangles.py,
shaders/lib/triangles.glsl). Any number of objects, against the truth; a move rewrites the
instances alone; transforms that scale unevenly or mirror keep normals outward."""

from __future__ import annotations

import dataclasses

import moderngl
import numpy as np
import pytest
from conftest import SCENES, assert_a_move_draws_a_fresh_frame, assert_finite, scene_from_toml

from depthimpostor.constants import TRIANGLE_INSTANCE, TRIANGLE_INSTANCE_DTYPE, Algorithm, Method
from depthimpostor.gpu.std140 import Struct
from depthimpostor.gpu.texel_records import glsl_reader, texel_count, to_texels
from depthimpostor.methods import triangles as triangles_module
from depthimpostor.methods.bvh import build_box_bvh, build_bvh, build_triangle_forest, node_count
from depthimpostor.methods.instances import NODE_TEXELS, world_boxes
from depthimpostor.methods.triangles import TrianglePass
from depthimpostor.oracles.compare import TruthFrame, compare
from depthimpostor.plan import plan_render
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene

HEAD = """
[render]
size = [256, 144]
impostor_resolution = 32
[camera]
eye = [0.0, 2.0, 9.0]
target = [0.0, 1.6, 0.0]
[[lights]]
type = "directional"
direction = [-0.4, -1.0, -0.3]
[[objects]]
name = "wall mirror"
shape = { type = "plane", size = [10.0, 5.0] }
material = { type = "mirror" }
position = [0.0, 2.2, 0.0]
rotation = [90.0, 0.0, 0.0]
"""


def mixed_objects(count: int) -> str:
    """`count` small objects on a grid before the wall mirror, in turn: checkered balls (one shared
    mesh), textured boxes (another), and cylinders of five radii (five more meshes); every tenth
    turns (an animation), every seventh orbits a point beside it."""
    text = ""
    for i in range(count):
        red, blue = (i * 37 % 100) / 100.0, (i * 61 % 100) / 100.0
        kind = i % 3
        if kind == 0:
            shape = '{ type = "sphere", radius = 0.14 }'
            material = (f'{{ type = "checker", color_a = [{red:.2f}, 0.8, {blue:.2f}], color_b = [0.1, 0.1, 0.1], '
                        "scale = 0.07 }")
        elif kind == 1:
            shape = '{ type = "box", size = [0.22, 0.2, 0.22] }'
            material = f'{{ type = "diffuse", color = [{red:.2f}, 0.9, {blue:.2f}], texture = "textures/checker_f.png" }}'
        else:
            shape = f'{{ type = "cylinder", radius = {0.07 + 0.01 * (i % 5):.2f}, height = 0.25 }}'
            material = f'{{ type = "checker", color_a = [0.9, {red:.2f}, {blue:.2f}], color_b = [0.2, 0.1, 0.1], scale = 0.05 }}'
        x, y = -4.6 + (i % 21) * 0.46, 0.3 + (i // 21) * 0.42
        animation = ""
        if i % 10 == 0:
            animation = 'animation = { type = "rotate", axis = [0, 1, 0], degrees_per_second = 40 }\n'
        elif i % 7 == 0:
            animation = (f'animation = {{ type = "orbit", centre = [{x + 0.1:.2f}, {y:.2f}, 1.6], axis = [0, 0, 1], '
                         "degrees_per_second = 45 }\n")
        text += (f'\n[[objects]]\nname = "object {i}"\nshape = {shape}\nmaterial = {material}\n'
                 f"position = [{x:.2f}, {y:.2f}, 1.6]\nrotation = [20.0, {(37 * i) % 360}.0, 0.0]\n{animation}")
    return text


def mixed_scene(count: int) -> Scene:
    return scene_from_toml(HEAD + mixed_objects(count), "mixed.toml", SCENES)


def test_instance_records_are_whole_texels_in_the_struct_order() -> None:
    """A record is its mat4's four columns, then one texel a vec4 or ivec4 (integers as float
    values, which a texel fetch cannot flush as it may a denormal bit pattern); a member that is no
    whole texel, or an integer float32 cannot hold, is refused."""
    records = np.zeros(2, TRIANGLE_INSTANCE_DTYPE)
    records["world_to_local"] = np.arange(32, dtype=np.float32).reshape(2, 4, 4)
    records["ids"] = ((1, 2, -1, 0), (3, 4, 5, 0))
    records["mesh"] = ((7, 0, 0, 0), (2**23, 0, 0, 0))
    texels = to_texels(TRIANGLE_INSTANCE, records)
    assert texels.shape == (2 * texel_count(TRIANGLE_INSTANCE), 4) == (12, 4) and texels.dtype == np.float32
    np.testing.assert_array_equal(texels[:4], records["world_to_local"][0])
    np.testing.assert_array_equal(texels[4], (1.0, 2.0, -1.0, 0.0))
    assert texels[6 + 5, 0] == 2.0**23
    records["mesh"][1, 0] = 2**24
    with pytest.raises(ValueError, match="not exact as float32"):
        to_texels(TRIANGLE_INSTANCE, records)
    with pytest.raises(ValueError, match="vec4, ivec4 and mat4 members alone"):
        texel_count(Struct("Small", (("x", "vec2"),)))
    reader = glsl_reader(TRIANGLE_INSTANCE, "BVH_TEXTURE_WIDTH")
    assert "#define TRIANGLE_INSTANCE_TEXELS 6" in reader and "TriangleInstance read_triangle_instance(" in reader


def test_a_top_level_holds_each_instance_once_in_nested_boxes() -> None:
    rng = np.random.default_rng(5)
    for items in (1, 2, 3, 7, 64, 65, 200, 1000):
        lows = rng.uniform(-10.0, 10.0, (items, 3))
        highs = lows + rng.uniform(0.0, 1.0, (items, 3))
        bvh = build_box_bvh(lows, highs, 0.5 * (lows + highs), 1)
        assert bvh.node_count == node_count(items, 1) == 2 * items - 1
        leaves = np.nonzero(bvh.count)[0]
        assert sorted(bvh.order[bvh.first[leaves]]) == list(range(items)) and (bvh.count[leaves] == 1).all()
        for leaf in leaves:
            item = bvh.order[bvh.first[leaf]]
            assert (bvh.lower[leaf] <= lows[item]).all() and (bvh.upper[leaf] >= highs[item]).all()
        for node in np.nonzero(bvh.count == 0)[0]:
            for child in (bvh.first[node], bvh.first[node] + 1):
                assert (bvh.lower[child] >= bvh.lower[node]).all() and (bvh.upper[child] <= bvh.upper[node]).all()


def test_a_forest_holds_each_mesh_tree_as_if_built_alone() -> None:
    """Every distinct mesh's hierarchy is built in one call: tree j (root j) walks to its own
    triangles alone, leaf for leaf the ones its mesh's tree built alone holds, in the same boxes."""
    rng = np.random.default_rng(3)
    meshes = [rng.normal(size=(count, 3, 3)) * (j + 1) for j, count in enumerate((1, 4, 5, 37, 300))]
    forest = build_triangle_forest(np.concatenate(meshes), [len(mesh) for mesh in meshes])
    assert forest.node_count == sum(node_count(len(mesh)) for mesh in meshes)
    start = 0
    for root, mesh in enumerate(meshes):
        alone = build_bvh(mesh)
        walked, node = [], root
        while node >= 0:
            if forest.count[node]:
                walked.append((forest.lower[node].tobytes(), forest.upper[node].tobytes(),
                               tuple(forest.order[forest.first[node]: forest.first[node] + forest.count[node]] - start)))
            node = forest.first[node] if forest.count[node] == 0 else forest.skip[node]
        expected, node = [], 0
        while node >= 0:
            if alone.count[node]:
                expected.append((alone.lower[node].tobytes(), alone.upper[node].tobytes(),
                                 tuple(alone.order[alone.first[node]: alone.first[node] + alone.count[node]])))
            node = alone.first[node] if alone.count[node] == 0 else alone.skip[node]
        assert walked == expected
        start += len(mesh)


def test_an_instance_box_holds_its_transformed_mesh() -> None:
    """A turned, unevenly scaled, mirrored box: the world box holds every transformed corner."""
    rng = np.random.default_rng(9)
    points = rng.uniform(-1.0, 1.0, (50, 3))
    model = np.eye(4)
    model[:3, :3] = np.diag([-2.0, 0.5, 1.5]) @ np.linalg.qr(rng.normal(size=(3, 3)))[0]
    model[:3, 3] = (1e3, -5.0, 2.0)
    lows, highs = world_boxes(model[None], points.min(axis=0)[None], points.max(axis=0)[None])
    world = points @ model[:3, :3].T + model[:3, 3]
    assert (lows[0] < world.min(axis=0)).all() and (highs[0] > world.max(axis=0)).all()


@pytest.fixture(scope="module")
def two_hundred() -> tuple[Scene, list[TruthFrame]]:
    """mixed_scene(210), and the truth of its mirror's rays at t = 1.5 once traced (the world's 650,440
    triangles in Embree: seconds), for the next method's frame: the same rays (compare checks)."""
    return mixed_scene(210), []


@pytest.mark.parametrize("method", [Method.RAYTRACE, Method.HYBRID], ids=lambda m: m.option)
def test_two_hundred_objects_of_shared_and_own_meshes_match_the_truth(ctx: moderngl.Context, method: Method,
                                                                      two_hundred: tuple[Scene, list[TruthFrame]]
                                                                      ) -> None:
    """210 objects (was refused past 64), 7 meshes between them, some textured, some moving: the
    mirror shows each where the truth does, at a time when the animated ones have moved."""
    scene, truths = two_hundred
    with Renderer(ctx, scene, Algorithm.OPTIMIZED, method=method, reflection_data=True) as renderer:
        renderer.set_time(1.5)
        renderer.render()
        assert_finite(renderer.read_color_float())
        stand_in = renderer.graph.stand_in
        traced = stand_in.triangles if method == Method.HYBRID else stand_in
        assert isinstance(traced, TrianglePass)
        assert len(traced.reflected) == 210 and len(traced.distinct) == 7
        comparison = compare(renderer, truths[0] if truths else None)
        truths[:] = [comparison.truth_frame]
        figures = comparison.figures
    assert figures.mirror_pixels > 10000
    assert figures.wrong_object_share < 0.001, figures
    if method == Method.RAYTRACE:
        assert figures.color_rmse < 2e-3, figures


@pytest.mark.parametrize("method", [Method.RAYTRACE, Method.HYBRID], ids=lambda m: m.option)
def test_a_move_rewrites_the_instances_and_keeps_the_meshes_hierarchies(ctx: moderngl.Context, method: Method,
                                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """Objects orbit: the next frame builds no bottom level (build_bvh is not called), keeps the
    pass and its textures, rewrites only the node texture's front (the top level and the records),
    and draws what a renderer made at that time draws."""
    scene = mixed_scene(60)
    with Renderer(ctx, scene, method=method) as renderer:
        renderer.render()
        before = renderer.read_color_float()
        stand_in = renderer.graph.stand_in
        traced = stand_in.triangles if method == Method.HYBRID else stand_in
        assert isinstance(traced, TrianglePass)
        nodes, triangles = traced.nodes, traced.triangles
        texels = np.frombuffer(nodes.read(), np.float32).reshape(-1, 4)
        builds: list[int] = []
        monkeypatch.setattr(triangles_module, "build_triangle_forest", lambda *args: builds.append(1))
        renderer.set_time(2.0)
        renderer.render()
        moved = renderer.read_color_float()
        assert renderer.graph.stand_in is stand_in and traced.nodes is nodes and traced.triangles is triangles
        assert not builds
        after = np.frombuffer(nodes.read(), np.float32).reshape(-1, 4)
        front = traced.layout.front_texels
        assert not np.array_equal(after[:front], texels[:front])
        np.testing.assert_array_equal(after[NODE_TEXELS * traced.layout.mesh_base:], texels[NODE_TEXELS * traced.layout.mesh_base:])
    monkeypatch.undo()
    with Renderer(ctx, scene, method=method) as fresh:
        fresh.set_time(2.0)
        fresh.render()
        np.testing.assert_allclose(moved, fresh.read_color_float(), atol=1e-6)
    assert np.abs(moved - before).max() > 0.1  # the orbits show in the mirror


def test_a_lone_moving_box_is_drawn_where_it_moved(ctx: moderngl.Context) -> None:
    """One box: the whole node texture is shorter than the row a move rewrites."""
    scene = scene_from_toml(HEAD + """
[[objects]]
name = "box"
shape = { type = "box", size = [0.6, 0.6, 0.6] }
material = { type = "checker", color_a = [0.9, 0.3, 0.2], color_b = [0.1, 0.1, 0.1], scale = 0.2 }
position = [0.0, 1.0, 2.0]
animation = { type = "orbit", centre = [0.0, 1.5, 2.0], axis = [0, 0, 1], degrees_per_second = 90 }
""", "box.toml")
    with Renderer(ctx, scene, method=Method.RAYTRACE) as renderer:
        traced = renderer.graph.triangles
        assert traced is not None and traced.layout.node_texels < traced.nodes.width
    assert_a_move_draws_a_fresh_frame(ctx, scene, Method.RAYTRACE, 1.0)


def uneven_and_mirrored() -> Scene:
    """A wall mirror before a ball stretched along x and flattened along y, a textured box and a
    torus knot mirrored by a negative scale (which the scene format refuses, but glTF node matrices
    carry), one of them also stretched."""
    # Seen from the side, so that the objects do not hide their own reflections.
    text = HEAD.replace("eye = [0.0, 2.0, 9.0]", "eye = [4.5, 2.4, 4.5]").replace("target = [0.0, 1.6, 0.0]",
                                                                                "target = [-0.8, 1.3, 0.0]") + """
[[objects]]
name = "stretched ball"
shape = { type = "sphere", radius = 0.6 }
material = { type = "checker", color_a = [0.9, 0.5, 0.2], color_b = [0.1, 0.2, 0.6], scale = 0.15 }
position = [-2.5, 1.4, 2.0]
rotation = [0.0, 30.0, 20.0]
[[objects]]
name = "mirrored box"
shape = { type = "box", size = [0.8, 0.9, 0.7] }
material = { type = "diffuse", color = [0.9, 0.9, 0.9], texture = "textures/checker_f.png" }
position = [0.0, 1.2, 2.0]
rotation = [15.0, 40.0, 0.0]
[[objects]]
name = "mirrored knot"
shape = { type = "torus_knot", p = 2, q = 3, radius = 0.5, tube = 0.15 }
material = { type = "checker", color_a = [0.3, 0.9, 0.4], color_b = [0.9, 0.9, 0.9], scale = 0.1 }
position = [2.5, 1.4, 2.0]
rotation = [30.0, 0.0, 10.0]
"""
    written = scene_from_toml(text, "uneven.toml", SCENES)
    scales = {"stretched ball": (1.8, 0.6, 1.0), "mirrored box": (-1.0, 1.0, 1.0), "mirrored knot": (-1.3, 0.8, 1.0)}
    return dataclasses.replace(written, objects=tuple(
        dataclasses.replace(obj, scale=scales.get(obj.name, obj.scale)) for obj in written.objects))


@pytest.mark.parametrize("method", [Method.RAYTRACE, Method.HYBRID], ids=lambda m: m.option)
def test_uneven_and_mirroring_transforms_keep_normals_outward(ctx: moderngl.Context, method: Method) -> None:
    """The ray goes into each instance's space and the normal comes back by the inverse transpose: a
    normal turned inward (or tilted by the scale) would shade the surface as its far side, dark,
    and the hybrid's back-face test would refuse the exact surface. Both match the truth, which
    traces the world-space meshes (Mesh.transformed flips a mirrored mesh's winding)."""
    scene = uneven_and_mirrored()
    assert all(np.linalg.det(obj.model_matrix(0.0)[:3, :3]) < 0 for obj in scene.objects if obj.name.startswith("mirrored"))
    with Renderer(ctx, scene, method=method, reflection_data=True) as renderer:
        renderer.render()
        assert_finite(renderer.read_color_float())
        figures = compare(renderer).figures
    assert figures.mirror_pixels > 10000 and figures.geometric_pixels > 1000
    assert figures.wrong_object_share < 0.001, figures
    assert figures.color_rmse < 3e-3, figures
    assert figures.geometric_error_max < 1e-3, figures


def test_the_plan_counts_each_mesh_once(two_hundred: tuple[Scene, list[TruthFrame]]) -> None:
    """210 objects of 7 meshes: the BVH's memory is the meshes' hierarchies and triangles once, and
    a few texels an instance: 1.6 MiB (every object's own 650,440 triangles in one world-space
    BVH, as before, would take 103 MiB)."""
    plan = plan_render(two_hundred[0], Method.RAYTRACE)
    assert plan.memory["BVH"] < 3 * 2**20


@pytest.mark.parametrize("method", [Method.RAYTRACE, Method.HYBRID, Method.SIMPLIFIED], ids=lambda m: m.option)
def test_a_mirror_that_reflects_nothing_traces_one_degenerate_instance(ctx: moderngl.Context, method: Method) -> None:
    scene = scene_from_toml(HEAD, "empty.toml")
    with Renderer(ctx, scene, method=method, reflection_data=True) as renderer:
        renderer.render()
        assert_finite(renderer.read_color_float())
        data = renderer.read_reflection_data()
    assert data.mirror_mask.sum() > 1000 and (data.object_id[data.mirror_mask] < 0).all()


def test_the_hybrids_places_name_each_listed_triangle_in_two_floats(ctx: moderngl.Context) -> None:
    """The hybrid's place texture, built for every instance at once (TrianglePass._places_texture),
    holds per triangle of the list its depth images name (every object's own triangles, object
    after object) its place in the triangle texture and its instance's slot, as the loop over the
    objects it replaced made them, in two floats a texel (RG32F: the shader reads .xy; RGBA32F
    took 72 MB at 1,000 spheres), and the plan counts those bytes."""
    scene = mixed_scene(60)
    with Renderer(ctx, scene, method=Method.HYBRID) as renderer:
        traced = renderer.graph.stand_in.triangles
        assert isinstance(traced, TrianglePass) and traced.places is not None
        assert traced.places.components == 2
        texels = np.frombuffer(traced.places.read(), np.float32).reshape(-1, 2)
        where = np.empty(len(traced.bottom.order), np.int64)  # a triangle's place, by its place among the distinct meshes'
        where[traced.bottom.order] = np.arange(len(traced.bottom.order))
        expected: list[tuple[int, int]] = []
        for slot, item in enumerate(traced.reflected):
            first = traced.layout.mesh_first_triangles[traced.distinct[item.local_mesh]]
            expected += [(int(where[first + i]), slot) for i in range(len(item.local_mesh.indices))]
        np.testing.assert_array_equal(texels[: len(expected)], np.array(expected, np.float32))
        assert not texels[len(expected):].any()
        assert renderer.plan.memory["BVH"] == traced.bytes
