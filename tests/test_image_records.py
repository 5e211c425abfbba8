"""A mirror may own any number of depth images (issue 32): past the DEPTH_IMAGE_BLOCK_RECORDS a
uniform block holds, its records are read from a storage buffer (lib/baked_images.glsl), and what
the mirror shows stays right against the truth."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from types import SimpleNamespace

import moderngl
import numpy as np
import pytest
from conftest import assert_a_move_draws_a_fresh_frame, scene_from_toml

from depthimpostor import constants
from depthimpostor.constants import (
    DEPTH_IMAGE_BLOCK_RECORDS,
    Algorithm,
    Method,
    depth_image_capacity,
    depth_image_defines,
)
from depthimpostor.errors import ContextError
from depthimpostor.gpu.meshes import GpuMeshes
from depthimpostor.gpu.scene_blocks import DrawnMaterials
from depthimpostor.gpu.shaders import ProgramCache
from depthimpostor.methods.atlas import DepthImage
from depthimpostor.methods.image_cells import ORIGIN_MARGIN, GridSize, grid_size, image_cells, ray_cells
from depthimpostor.methods.impostors import ImpostorPass
from depthimpostor.oracles import reference
from depthimpostor.oracles.compare import Comparison, compare
from depthimpostor.oracles.ray_query import RayQuery
from depthimpostor.plan import plan_render
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene
from depthimpostor.world import World

HEAD = """
[render]
size = [192, 108]
impostor_resolution = 32
[camera]
eye = [0.0, 2.0, 9.0]
target = [0.0, 1.4, 0.0]
[[lights]]
type = "directional"
direction = [-0.4, -1.0, -0.3]
[[objects]]
name = "wall mirror"
shape = { type = "plane", size = [9.0, 4.0] }
material = { type = "mirror" }
position = [0.0, 2.0, 0.0]
rotation = [90.0, 0.0, 0.0]
"""


def checker_balls(count: int, z: float) -> str:
    """`count` small checkered spheres on a grid in front of the wall mirror, colours varying with the
    index, so that a ray answered by the wrong image shows the wrong object and colour."""
    text = ""
    for i in range(count):
        red, blue = (i * 37 % 100) / 100.0, (i * 61 % 100) / 100.0
        text += (f'\n[[objects]]\nname = "ball {i}"\nshape = {{ type = "sphere", radius = 0.15 }}\n'
                 f'material = {{ type = "checker", color_a = [{red:.2f}, 0.8, {blue:.2f}], color_b = [0.1, 0.1, 0.1], '
                 f"scale = 0.08 }}\nposition = [{-4.2 + (i % 20) * 0.44:.2f}, {0.3 + (i // 20) * 0.44:.2f}, {z}]\n")
    return text


def many_balls(count: int) -> Scene:
    return scene_from_toml(HEAD + checker_balls(count, 1.5), "many_balls.toml")


#: A method's frame of the hundred balls: its colours, the object each pixel's reflected ray hit,
#: and its comparison with the truth.
Frame = tuple[np.ndarray, np.ndarray, Comparison]


@pytest.fixture(scope="module")
def hundred_balls(ctx: moderngl.Context) -> Callable[[Method], Frame]:
    """Each method's frame of many_balls(100) (optimized algorithm, reflection data), made once for
    the module (several tests read the depth method's). The truth is traced for the first frame and
    reused by the others, whose rays are the same (compare checks that they are)."""
    scene = many_balls(100)
    frames: dict[Method, Frame] = {}

    def frame(method: Method) -> Frame:
        if method not in frames:
            truth = next(iter(frames.values()))[2].truth_frame if frames else None
            with Renderer(ctx, scene, Algorithm.OPTIMIZED, method=method, reflection_data=True) as renderer:
                renderer.render()
                frames[method] = (renderer.read_color_float(), renderer.read_reflection_data().object_id,
                                  compare(renderer, truth))
        return frames[method]

    return frame


def test_capacity_is_the_uniform_block_up_to_it_then_a_power_of_two() -> None:
    assert depth_image_capacity(1) == depth_image_capacity(DEPTH_IMAGE_BLOCK_RECORDS) == DEPTH_IMAGE_BLOCK_RECORDS
    assert depth_image_capacity(DEPTH_IMAGE_BLOCK_RECORDS + 1) == 2 * DEPTH_IMAGE_BLOCK_RECORDS
    assert depth_image_capacity(1000) == 1024
    assert depth_image_defines(DEPTH_IMAGE_BLOCK_RECORDS) == {}  # small scenes keep their programs
    assert depth_image_defines(1024) == {"DEPTH_IMAGE_CAPACITY": 1024, "NEEDS_STORAGE_BLOCKS": 1, "IMAGE_CELLS": 1}
    assert "IMAGE_CELLS" in depth_image_defines(128)  # a hundred images are found through lists too


@pytest.mark.parametrize(("method", "wrong_object_limit"), [(Method.DEPTH, 0.01), (Method.BILLBOARD, 0.05)])
def test_a_mirror_showing_a_hundred_objects_reads_them_all(hundred_balls: Callable[[Method], Frame], method: Method,
                                                          wrong_object_limit: float) -> None:
    plan = plan_render(many_balls(100), method)
    images = [image for image in plan.images if image.label.startswith("wall mirror")]
    assert len(images) > DEPTH_IMAGE_BLOCK_RECORDS  # past what the old uniform block held
    assert any(("DEPTH_IMAGE_CAPACITY", "128") in variant.key[1] or ("DEPTH_IMAGE_CAPACITY", 128) in variant.key[1]
               for variant in plan.variants)
    color, _, comparison = hundred_balls(method)
    assert np.isfinite(color).all()
    figures = comparison.figures
    assert figures.mirror_pixels > 1000
    # Objects are seen in the mirror, and the right ones: images past the 64th answer their rays.
    assert figures.wrong_object_share < wrong_object_limit, figures


def test_the_last_images_answer_their_rays(hundred_balls: Callable[[Method], Frame]) -> None:
    """The objects listed last (past the uniform block's 64 records) are the top rows of balls:
    where the truth sees one of them, the depth method sees the same object (a table cut short at
    64 records would leave them out of the mirror)."""
    _, seen, comparison = hundred_balls(Method.DEPTH)
    truth = comparison.truth_frame.object_id
    late = truth > DEPTH_IMAGE_BLOCK_RECORDS  # object 0 is the mirror: ball i is object i + 1
    assert late.sum() > 150
    assert (seen[late] == truth[late]).mean() > 0.97


def test_bounces_between_two_mirrors_with_more_objects_than_a_block(ctx: moderngl.Context) -> None:
    """max_bounces = 2 gives each mirror an image of the other besides one per object: past 64
    (this was refused)."""
    mirrors = "".join(
        f'\n[[objects]]\nname = "m{i}"\nshape = {{ type = "sphere", radius = 0.5 }}\nmaterial = {{ type = "mirror" }}\n'
        f"position = [{2.4 * i - 1.2}, 3.2, 1.5]\n" for i in range(2))
    text = HEAD.replace("impostor_resolution = 32\n", "impostor_resolution = 16\nmax_bounces = 2\n")
    text = text[: text.index("[[objects]]")]  # the two sphere mirrors alone (a wall fills a sphere's view)
    scene = scene_from_toml(text + mirrors + checker_balls(70, 1.5), "bounces.toml")
    with Renderer(ctx, scene, method=Method.DEPTH) as renderer:
        renderer.render()
        stand_in = renderer.graph.baked_images
        assert stand_in is not None and stand_in.bounce_bakes > 0
        assert np.isfinite(renderer.read_color_float()).all()


def test_a_gl_without_storage_buffers_is_told_what_the_scene_needs(ctx: moderngl.Context) -> None:
    """More objects than a uniform block's records on a GL older than 4.3: one line naming both."""
    scene = many_balls(DEPTH_IMAGE_BLOCK_RECORDS + 1)
    world = World(scene)
    mirrors = [g for g in world.geometry if g.object.is_mirror]
    old_gl = SimpleNamespace(version_code=330, info=ctx.info)
    with pytest.raises(ContextError, match="storage buffers, which need OpenGL 4.3; this context has 3.3"):
        ImpostorPass(old_gl, ProgramCache(ctx), scene, GpuMeshes(ctx), DrawnMaterials(ctx), mirrors,  # type: ignore[arg-type]
                     world.reflected_objects)


def test_images_past_the_memory_budget_are_made_smaller_and_the_plan_says_so() -> None:
    """A thousand objects before a mirror at 256^2 would take 1.3 GiB of images: the plan lowers
    every image to the side that fits render.image_memory, and names the budget."""
    text = HEAD.replace("impostor_resolution = 32", "impostor_resolution = 256")
    plan = plan_render(scene_from_toml(text + checker_balls(1000, 1.5), "budget.toml"))
    images = [image for image in plan.images if image.level == 0]
    assert len(images) == 1000 and {image.width for image in images} == {228}
    assert "228^2, not 256^2: 1000 images within render.image_memory = 1024 MiB" in images[0].reason
    assert plan.memory["depth images"] + plan.memory["bake depth buffer"] <= 1024 * 2**20
    smaller = plan_render(scene_from_toml(text.replace("[render]\n", "[render]\nimage_memory = 256\n")
                                          + checker_balls(1000, 1.5), "budget.toml"))
    assert {image.width for image in smaller.images} == {112}
    few = plan_render(scene_from_toml(text + checker_balls(10, 1.5), "budget.toml"))  # well within: as asked
    assert {image.width for image in few.images} == {256} and "image_memory" not in few.images[0].reason


def entered(spheres: np.ndarray, origin: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """The spheres a ray enters at t >= 0 (lib/baked_images.glsl's bound_entry, in float64)."""
    to_centre = spheres[:, :3] - origin
    along = to_centre @ direction / (direction @ direction)
    closest = to_centre - np.outer(along, direction)
    return (np.einsum("ij,ij->i", closest, closest) <= spheres[:, 3] ** 2) & (
        along + np.sqrt(np.maximum(spheres[:, 3] ** 2 - np.einsum("ij,ij->i", closest, closest), 0.0))
        / np.linalg.norm(direction) >= 0.0)


@pytest.mark.parametrize("count", [40, 700])
def test_a_rays_list_holds_every_image_it_enters_in_rising_order(count: int) -> None:
    """Spheres all around a mirror's sphere, near and far, small and large, and rays from on and
    inside it in every direction: every sphere a ray enters is in its cell's list, the lists
    ascend (the scan's tie order), and they are short (a list of everything would pass the rest)."""
    rng = np.random.default_rng(count)
    centre, radius = np.array([0.3, 1.0, -0.2]), 0.9
    places = rng.normal(size=(count, 3))
    places *= (rng.uniform(1.3, 8.0, count) / np.linalg.norm(places, axis=1))[:, None]
    spheres = np.c_[centre + places, rng.uniform(0.02, 0.4, count)]
    grown = radius * (1.0 + ORIGIN_MARGIN)  # as cells_table grows it: origins on the sphere are inside
    lists = image_cells(spheres, centre, grown)
    size = grid_size(count)
    assert lists[size.cells + 1] - lists[size.cells] == count  # the fallback cell lists every image
    origins = rng.normal(size=(4000, 3))
    origins *= (radius * np.where(rng.random(4000) < 0.7, 1.0, rng.random(4000)) / np.linalg.norm(origins, axis=1))[:, None]
    origins += centre
    directions = rng.normal(size=(4000, 3))
    cells = ray_cells(origins, directions, centre, grown, size)
    assert (cells < size.cells).all()  # every ray starts within the sphere
    lengths = []
    for origin, direction, cell in zip(origins, directions, cells, strict=True):
        listed = lists[lists[cell]:lists[cell + 1]]
        assert (np.diff(listed) > 0).all()
        assert set(np.flatnonzero(entered(spheres, origin, direction))) <= set(listed.tolist())
        lengths.append(len(listed))
    assert np.mean(lengths) < 0.25 * count
    # A ray from outside the sphere reads the list of every image.
    outside = ray_cells(centre + np.array([[0.0, 2 * radius, 0.0]]), np.array([[1.0, 0.0, 0.0]]), centre, grown, size)
    assert outside[0] == size.cells


def test_the_lists_are_laid_out_as_the_shader_reads_them() -> None:
    """The starts of the cells (and the fallback's), then the lists: the first start is right
    after them, each start no earlier than the one before, the last one the array's end."""
    size = GridSize(2, 2)
    spheres = np.array([[3.0, 0.0, 0.0, 0.5], [-3.0, 0.0, 0.0, 0.5], [0.0, 0.0, 4.0, 1.0]])
    lists = image_cells(spheres, np.zeros(3), 1.0, size)
    starts = lists[: size.cells + 2]
    assert starts[0] == size.cells + 2 and starts[-1] == len(lists) and (np.diff(starts) >= 0).all()
    # A ray along +x from the centre meets the first sphere alone; its cell lists it, not the second.
    cell = int(ray_cells(np.zeros((1, 3)), np.array([[1.0, 0.0, 0.0]]), np.zeros(3), 1.0, size)[0])
    listed = lists[lists[cell]:lists[cell + 1]].tolist()
    assert 0 in listed and 1 not in listed


@pytest.mark.parametrize("method", [Method.DEPTH, Method.BILLBOARD, Method.HYBRID])
def test_the_lists_see_what_the_scan_sees(ctx: moderngl.Context, monkeypatch: pytest.MonkeyPatch,
                                          method: Method) -> None:
    """The same 100 images found through the lists (IMAGE_CELLS) and by scanning every bound
    (the hybrid method's and the billboards' lists over the images' whole bounds): the same
    images visited in the same order, so the same frame."""
    scene = many_balls(100)
    frames = []
    for lists in (True, False):
        if not lists:
            monkeypatch.setattr(constants, "IMAGE_CELLS_MIN_CAPACITY", 2**30)
        with Renderer(ctx, scene, Algorithm.OPTIMIZED, method=method) as renderer:
            renderer.render()
            # Programs are kept across renderers of one context: the variant each frame needed is there.
            variants = [dict(key[1]) for key in renderer.programs.keys if "DEPTH_IMAGE_CAPACITY" in dict(key[1])]
            assert any(("IMAGE_CELLS" in defines) == lists for defines in variants)
            frames.append(renderer.read_color_float())
    assert np.isfinite(frames[0]).all()
    np.testing.assert_array_equal(frames[0], frames[1])


def test_moving_objects_list_their_images_again(ctx: moderngl.Context) -> None:
    """A hundred objects, some orbiting far across the mirror's view: after a move each ray's list
    is made again (and its table may outgrow its buffer), and the frame is a fresh renderer's."""
    orbits = "".join(
        f'\n[[objects]]\nname = "orbiter {i}"\nshape = {{ type = "box", size = [0.3, 0.3, 0.3] }}\n'
        f'material = {{ type = "checker", color_a = [0.9, 0.2, 0.{i}], color_b = [0.1, 0.1, 0.1], scale = 0.1 }}\n'
        f"position = [{-3.0 + 2.0 * i:.1f}, 2.5, 2.5]\n"
        f'animation = {{ type = "orbit", centre = [0.0, 2.5, 2.5], axis = [0, 0, 1], degrees_per_second = 60 }}\n'
        for i in range(4))
    assert_a_move_draws_a_fresh_frame(ctx, scene_from_toml(HEAD + checker_balls(96, 1.5) + orbits, "orbits.toml"),
                                      Method.DEPTH, 1.5)


#: The hundred images of one mirror, 3000 rays from the mirror toward them, and the numpy
#: reference's nearest hits of those rays.
Queried = tuple[Renderer, list[DepthImage], np.ndarray, np.ndarray, reference.RayHits]


@pytest.fixture(scope="module")
def hundred_images(ctx: moderngl.Context) -> Iterator[Queried]:
    """Baked and marched by the reference once for the module: the lists and the scan read the
    same images (a ray query makes its own record table, with or without the lists)."""
    scene = many_balls(100).with_overrides(size=(32, 18), impostor_resolution=32)
    with Renderer(ctx, scene, method=Method.DEPTH) as renderer:
        renderer.render()
        impostors = renderer.graph.impostors
        assert impostors is not None
        impostors.bake_again()  # every image (the frame baked those its rays enter): all are read below
        renderer.render()
        images = impostors.images_by_reflector[renderer.world.mirrors[0].index]
        rng = np.random.default_rng(4)
        targets = np.array([image.target.bounding_sphere[0] for image in images])[rng.integers(0, 100, 3000)]
        origins = rng.uniform((-4.0, 0.5, 0.02), (4.0, 3.5, 0.1), size=(3000, 3))  # on the wall mirror's front
        directions = targets + rng.normal(size=(3000, 3)) * 0.12 - origins
        expected = reference.nearest_depth_image_hit([impostors.atlas.read(image) for image in images], origins,
                                                     directions)
        yield renderer, images, origins, directions, expected


@pytest.mark.parametrize("lists", [True, False], ids=["listed", "scanned"])
def test_many_images_tracking_unseen_space_give_the_references_nearest_hits(ctx: moderngl.Context,
                                                                            monkeypatch: pytest.MonkeyPatch,
                                                                            hundred_images: Queried,
                                                                            lists: bool) -> None:
    """The ray query (the mirror shader's GLSL with TRACK_UNSEEN; listed: the lists over the
    images' bounds, for rays from the sphere about their origins) over 100 images of one mirror,
    against the numpy reference's nearest hit, ray by ray."""
    if not lists:
        monkeypatch.setattr(constants, "IMAGE_CELLS_MIN_CAPACITY", 2**30)
    renderer, images, origins, directions, expected = hundred_images
    impostors = renderer.graph.impostors
    assert impostors is not None and len(images) == 100
    query = RayQuery(ctx, renderer.programs, impostors.atlas, images)
    assert (("IMAGE_CELLS", 1) in query_defines(query)) == lists
    gpu = query.run(origins, directions)
    query.release()
    clear = (expected.texel_margin > 1e-3) & (expected.depth_margin > 1e-6)
    assert expected.hit.sum() > 1000
    assert (gpu.hit == expected.hit)[clear].mean() >= 0.999
    both = clear & gpu.hit & expected.hit
    assert (gpu.object_id[both] == expected.object_id[both]).mean() >= 0.999
    assert np.allclose(gpu.t[both], expected.t[both], rtol=1e-3, atol=1e-4)


def query_defines(query: RayQuery) -> set[tuple[str, int]]:
    return {(name, int(value)) for name, value in query.defines.items()}


@pytest.mark.parametrize("method", [Method.RAYTRACE, Method.HYBRID])
def test_the_traced_methods_take_more_objects_than_a_uniform_block(hundred_balls: Callable[[Method], Frame],
                                                                  method: Method) -> None:
    """100 traced objects (past the 64 records of the uniform block they once had, which refused
    more; now instances of a two-level BVH, tests/test_instances.py): the mirror shows each where
    the truth does."""
    color, seen, comparison = hundred_balls(method)
    assert np.isfinite(color).all()
    truth = comparison.truth_frame.object_id
    late = truth > 64  # the objects past what the uniform block held
    assert late.sum() > 150 and (seen[late] == truth[late]).mean() > 0.99
    assert comparison.figures.wrong_object_share < 0.001


def test_the_plan_states_each_limit_the_scene_meets() -> None:
    """`plan` says, per limit, what the scene uses of it and which memory or GL figure bounds it:
    a few objects fit the uniform block; a hundred are in a storage buffer, found through lists;
    the hybrid method's named triangles against their cap."""
    few, many = plan_render(many_balls(10)), plan_render(many_balls(100), Method.HYBRID)
    for plan in (few, many):
        assert "limits (what this scene uses of each" in plan.format()
        assert plan.limits[0] == "lights: 1 of 8 (a uniform array)"
        assert any(line.startswith("depth images' memory: ") and "of render.image_memory = 1024 MiB" in line
                   for line in plan.limits)
        assert plan.to_json()["limits"] == list(plan.limits)
    assert "depth images of one mirror: 10 (any number: up to 64 records in a uniform block (GL 3.3)" in few.format()
    assert ("depth images of one mirror: 100 (any number: a storage buffer of 128 records (GL 4.3), the images found "
            "through lists of candidates by ray") in many.format()
    triangles = sum(len(g.local_mesh.indices) for g in World(many_balls(100)).reflected_objects)
    assert f"reflected triangles: {triangles} of {constants.MAX_NAMED_TRIANGLES}" in many.format()
    assert not any("reflected triangles" in line for line in few.limits)
