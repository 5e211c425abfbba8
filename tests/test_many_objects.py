"""Many objects (issue 24, item 5): round primitives tessellated for their size on screen (lod.py),
and the still diffuse objects drawn in one call (gpu/batches.py) with the same pixels as one
draw per object."""

from __future__ import annotations

import dataclasses

import moderngl
import numpy as np
import pytest
from conftest import SCENES, assert_finite, scene_from_toml

import depthimpostor.passes.diffuse as diffuse_module
import depthimpostor.render_graph as render_graph_module
from depthimpostor.geometry import scene_geometry
from depthimpostor.gpu.context import bind_default_framebuffer
from depthimpostor.gpu.gl_state import BASE
from depthimpostor.constants import Method
from depthimpostor.lod import EyeView
from depthimpostor.scene.model import Camera
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene, load_scene
from depthimpostor.world import World

HEAD = """
[render]
size = [160, 90]
impostor_resolution = 32
[camera]
eye = [0.0, 1.6, 5.0]
target = [0.0, 0.3, 0.0]
[[lights]]
type = "directional"
direction = [-0.4, -1.0, -0.3]
[[objects]]
name = "floor"
shape = { type = "plane", size = [20.0, 20.0] }
material = { type = "checker", color_a = [0.8, 0.8, 0.8], color_b = [0.35, 0.35, 0.35], scale = 1.0 }
"""

SHAPES = ('{ type = "sphere", radius = 0.06 }', '{ type = "box", size = [0.1, 0.1, 0.1] }',
          '{ type = "torus", major = 0.06, minor = 0.02 }', '{ type = "cylinder", radius = 0.05, height = 0.1 }')
MATERIALS = ('{ type = "diffuse", color = [0.85, 0.15, 0.12] }',
             '{ type = "checker", color_a = [0.2, 0.7, 0.3], color_b = [0.9, 0.9, 0.2], scale = 0.03 }',
             '{ type = "diffuse", color = [0.9, 0.9, 0.9], texture = { path = "textures/checker_f.png" } }')


def many_objects(side: int = 12) -> Scene:
    """The floor and side x side small objects of every shape and material kind."""
    objects = []
    for i in range(side):
        for j in range(side):
            k = i * side + j
            objects.append(f'[[objects]]\nname = "o{k}"\nshape = {SHAPES[k % len(SHAPES)]}\n'
                           f'material = {MATERIALS[(k // len(SHAPES)) % len(MATERIALS)]}\n'
                           f"position = [{-1.5 + 3.0 * i / (side - 1):.3f}, 0.06, {-1.5 + 3.0 * j / (side - 1):.3f}]\n"
                           f"rotation = [0.0, {7.0 * k % 90:.1f}, 0.0]\n")
    return scene_from_toml(HEAD + "\n".join(objects), base_dir=SCENES)


def spheres(*placements: tuple[float, tuple[float, float, float]], mirror: bool = False) -> Scene:
    """Diffuse spheres of (radius, position), and, if asked for, a planar mirror facing the eye."""
    text = HEAD + ('[[objects]]\nname = "mirror"\nshape = { type = "plane", size = [3.0, 2.0] }\n'
                   'material = { type = "mirror" }\nposition = [0.0, 1.0, -1.0]\nrotation = [90.0, 0.0, 0.0]\n'
                   if mirror else "")
    for k, (radius, position) in enumerate(placements):
        text += (f'[[objects]]\nname = "ball{k}"\nshape = {{ type = "sphere", radius = {radius} }}\n'
                 f'material = {{ type = "diffuse", color = [0.9, 0.5, 0.1] }}\nposition = {list(position)}\n')
    return scene_from_toml(text)


#: A sphere's triangles at its full tessellation (96 x 48: the mirror sphere's).
FULL = 96 * 2 * (48 - 1)


def triangles(world: World, name: str) -> int:
    return next(len(g.local_mesh.indices) for g in world.geometry if g.object.name == name)


def test_a_small_far_sphere_gets_fewer_triangles_than_a_large_near_one() -> None:
    world = World(spheres((0.05, (2.0, 0.05, -30.0)), (0.8, (-1.0, 0.8, 1.0))).with_overrides(size=(960, 540)))
    far, near = triangles(world, "ball0"), triangles(world, "ball1")
    assert FULL // 5 <= near < FULL  # 300 pixels across: 48 x 24 keeps it within a third of a pixel
    assert far <= near // 64  # 2 pixels across
    close = World(spheres((0.8, (0.0, 1.6, 3.0))).with_overrides(size=(960, 540)))
    assert triangles(close, "ball0") == FULL  # 1.2 units from the eye: 900 pixels across


def test_reflectors_and_what_they_show_keep_the_full_tessellation() -> None:
    # Two spheres a few pixels across: the one in front of the mirror is in its depth image.
    world = World(spheres((0.05, (0.5, 0.05, -8.0)), (0.05, (0.5, 0.05, 2.0)), mirror=True))
    assert triangles(world, "ball1") == FULL
    assert triangles(world, "ball0") < FULL  # behind the mirror: the eye alone sees it
    # The mirror is a plane (two triangles at every level); a mirror sphere keeps its 96 x 48.
    mirror_ball = scene_from_toml(HEAD + '[[objects]]\nname = "mirror"\nshape = { type = "sphere", radius = 0.05 }\n'
                                  'material = { type = "mirror" }\nposition = [0.0, 0.05, -20.0]\n')
    assert triangles(World(mirror_ball), "mirror") == FULL


def test_the_eye_draws_what_a_mirror_shows_at_the_eyes_level() -> None:
    """An object a mirror can show keeps its full mesh for the rays (World.geometry), and the eye's
    diffuse pass draws it at its level for the eye's frame (World.eye_drawn): a few pixels across,
    an eighth of a pixel of error allows far fewer triangles; near the eye, the full mesh."""
    world = World(spheres((0.05, (0.5, 0.05, -8.0)), (0.05, (0.5, 0.05, 2.0)), (0.8, (0.0, 1.6, 3.0)), mirror=True)
                  .with_overrides(size=(960, 540)))
    drawn = {g.object.name: g for g in world.eye_drawn}
    assert triangles(world, "ball1") == FULL and len(drawn["ball1"].local_mesh.indices) <= FULL // 16
    assert drawn["ball0"] is next(g for g in world.geometry if g.object.name == "ball0")  # its world level already
    assert triangles(world, "ball2") == FULL and drawn["ball2"].local_mesh.indices.shape[0] == FULL
    assert "mirror" not in drawn  # the reflectors are the mirror pass's
    # Drawn in one batch with the others: the eye's meshes are loaded with the world's.
    assert all(any(mesh is g.local_mesh for mesh in world.meshes) for g in world.eye_drawn)


def test_the_eye_pass_draws_the_eyes_levels(ctx: moderngl.Context, monkeypatch: pytest.MonkeyPatch) -> None:
    """The frame's diffuse pass draws World.eye_drawn, and a small sphere in front of a mirror drawn
    at its eye level changes the frame at its silhouette and shading alone (an eighth of a pixel,
    interpolated normals), while its reflection, traced against the full mesh, does not change."""
    scene = spheres((0.12, (0.5, 0.12, 2.0)), mirror=True).with_overrides(size=(160, 90))
    drawn: list[list[str | int]] = []
    draw = diffuse_module.DiffusePass.draw

    def spy(self: diffuse_module.DiffusePass, items: list, *args: object, **kwargs: object) -> int:
        drawn.append([len(g.local_mesh.indices) for g in items if g.object.name == "ball0"])
        return draw(self, items, *args, **kwargs)

    monkeypatch.setattr(diffuse_module.DiffusePass, "draw", spy)
    with Renderer(ctx, scene, method=Method.RAYTRACE) as renderer:
        renderer.render()
        levelled = renderer.read_color_float()
        assert drawn and drawn[-1] and drawn[-1][0] < FULL  # the eye's level, not the world's full mesh
        assert triangles(renderer.world, "ball0") == FULL
    monkeypatch.setattr(World, "eye_drawn", property(lambda world: world.opaque_diffuse))
    full, _ = _frame(ctx, scene)
    assert_finite(levelled)
    difference = np.abs(levelled - full).max(axis=-1)
    ball = np.abs(full - _frame(ctx, dataclasses.replace(scene, objects=scene.objects[:2]))[0]).max(axis=-1) > 0.0
    assert 0 < (difference > 1e-6).sum() <= ball.sum()  # the ball's pixels (and its reflection's), or beside them
    assert (difference > 0.1).sum() <= 0.1 * ball.sum()  # its silhouette


def _frame(ctx: moderngl.Context, scene: Scene) -> tuple[np.ndarray, int]:
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        image = renderer.read_color_float()
        assert_finite(image)
        return image, renderer.stats.draw_calls


def test_the_batch_draws_what_one_draw_per_object_draws(ctx: moderngl.Context, monkeypatch: pytest.MonkeyPatch) -> None:
    scene = many_objects()
    batched, batched_calls = _frame(ctx, scene)
    monkeypatch.setattr(diffuse_module, "FRONT_FACES", BASE)  # the closed solids' back faces drawn too
    uncut, _ = _frame(ctx, scene)
    monkeypatch.setattr(render_graph_module, "batches_supported", lambda ctx: False)
    alone, calls = _frame(ctx, scene)
    assert calls == len(scene.objects)  # the floor and 144 objects, one call each
    assert batched_calls == 2  # the floor; the closed solids, back faces culled
    assert (np.abs(alone - alone.mean(axis=(0, 1))) > 0.05).mean() > 0.05  # the objects are in the frame
    # The same transforms and materials from instance attributes instead of uniforms: the same
    # arithmetic (on llvmpipe, the same bits).
    assert np.abs(uncut - alone).max() <= 1e-6
    # Culling back faces changes only pixels where a back face won a depth tie with a front face
    # at their shared edge (drawn first within its mesh): a few silhouette pixels.
    changed = np.abs(batched - alone).max(axis=-1) > 1e-6
    assert changed.sum() <= 0.002 * changed.size


def render_floor(ctx: moderngl.Context, scene: Scene) -> np.ndarray:
    """The frame of `scene` with its first object (the floor) alone."""
    return _frame(ctx, dataclasses.replace(scene, objects=scene.objects[:1]))[0]


def test_levels_of_detail_barely_change_the_picture(ctx: moderngl.Context, monkeypatch: pytest.MonkeyPatch) -> None:
    """Small round objects at their level draw nearly the pixels of their full tessellation: under
    half a pixel of silhouette, and shading of interpolated normals."""
    scene = many_objects()
    coarse = World(scene)
    assert sum(len(g.local_mesh.indices) for g in coarse.geometry) * 4 < sum(
        len(g.local_mesh.indices) for g in scene_geometry(scene.objects))
    detailed, _ = _frame(ctx, scene)
    monkeypatch.setattr("depthimpostor.world.detail_levels", lambda *args: {})
    full, _ = _frame(ctx, scene)
    difference = np.abs(detailed - full).max(axis=-1)
    objects = np.abs(full - render_floor(ctx, scene)).max(axis=-1) > 0.0
    # Objects 2-5 pixels across are all silhouette: a pixel whose centre lies within half a pixel
    # of the edge may change sides. On llvmpipe: 17 % of the objects' pixels by more than 0.05.
    assert (difference > 0.05).sum() < 0.25 * objects.sum()
    assert not (difference[~objects] > 0.0).any()  # nothing else changes


def test_a_moving_object_is_drawn_alone_beside_the_batch(ctx: moderngl.Context) -> None:
    scene = load_scene(SCENES / "carousel.toml").with_overrides(size=(96, 54), impostor_resolution=32)
    moving = [g for g in World(scene).diffuse_objects if g.object.moves]
    assert moving
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        assert renderer.graph.diffuse is not None and renderer.graph.diffuse.batched
        renderer.targets.color_framebuffer.use()
        try:
            # The floor, then the still solids with back faces culled (cylinder, knot); the box and torus move.
            assert renderer.graph.diffuse.draw(renderer.world.diffuse_objects, renderer.camera.view_projection) == 2 + len(moving)
        finally:
            bind_default_framebuffer(ctx)


def test_the_eye_levels_made_up_front(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every level of every round shape the eye may draw is made with the world (a resized frame
    finds its levels loaded), unless the shapes are many: then those the first settings draw
    coarser alone (World.eye_meshes, EYE_LEVEL_SHAPES)."""
    scene = spheres((0.05, (0.5, 0.05, 2.0)), (0.8, (0.0, 1.6, 3.0)), mirror=True).with_overrides(size=(960, 540))
    made = {shape.radius for shape, _, _ in World(scene).eye_meshes}
    assert made == {0.05, 0.8}  # the near sphere is drawn whole now, and may not be at another size
    monkeypatch.setattr("depthimpostor.world.EYE_LEVEL_SHAPES", 1)
    assert {shape.radius for shape, _, _ in World(scene).eye_meshes} == {0.05}


def test_a_resized_frame_of_many_shapes_draws_what_is_loaded(ctx: moderngl.Context, monkeypatch: pytest.MonkeyPatch) -> None:
    """Past EYE_LEVEL_SHAPES, a shape the first settings draw whole gets no levels; a smaller frame
    later draws it whole too (its levels were never loaded with the world's meshes), not coarser
    from meshes its batch cannot draw (a reviewer's case: it raised)."""
    monkeypatch.setattr("depthimpostor.world.EYE_LEVEL_SHAPES", 1)
    scene = spheres((0.3, (0.5, 0.3, 2.0)), (0.8, (0.0, 1.6, 3.0)), mirror=True).with_overrides(size=(960, 540))
    with Renderer(ctx, scene, method=Method.RAYTRACE) as renderer:
        renderer.render()
        assert not renderer.world.eye_meshes
        renderer.resize((40, 22))
        renderer.render()
        assert_finite(renderer.read_color_float())
        assert all(g.local_mesh is full.local_mesh for g, full in zip(renderer.world.eye_drawn, renderer.world.opaque_diffuse,
                                                                 strict=True))


def _textured_ball(radius: float, position: tuple[float, float, float], mirror: bool = False) -> Scene:
    """The floor (with, if asked for, the planar mirror facing the eye) and one textured sphere."""
    text = HEAD + ('[[objects]]\nname = "mirror"\nshape = { type = "plane", size = [3.0, 2.0] }\n'
                   'material = { type = "mirror" }\nposition = [0.0, 1.0, -1.0]\nrotation = [90.0, 0.0, 0.0]\n'
                   if mirror else "")
    text += (f'[[objects]]\nname = "ball0"\nshape = {{ type = "sphere", radius = {radius} }}\n'
             f'material = {MATERIALS[2]}\nposition = {list(position)}\n')
    return scene_from_toml(text, base_dir=SCENES).with_overrides(size=(192, 108))


def _drawn_triangles(renderer: Renderer, name: str) -> int:
    drawn = renderer.world.eye_drawn_for(EyeView.of_camera(renderer.camera))
    return next(len(g.local_mesh.indices) for g in drawn if g.object.name == name)


@pytest.mark.parametrize("mirror", [False, True], ids=["seen-by-the-eye-alone", "in-front-of-a-mirror"])
def test_a_camera_moved_close_draws_the_object_at_its_level_for_that_camera(ctx: moderngl.Context, mirror: bool) -> None:
    """The eye's levels are chosen for the frame's camera, not the scene file's: a textured ball a
    few pixels across from the scene's camera is drawn coarse, and once a viewer, a video or a
    dataset frame moves the camera up to it, at the level a renderer made at that camera draws,
    with that renderer's picture (its facets would show: a silhouette and texture sliding by
    pixels). Behind the mirror the world holds it coarse (no ray can meet it); in front of it the
    world keeps its full mesh for the rays, and the eye drew a coarser one."""
    position = (0.4, 0.1, 2.0) if mirror else (2.0, 0.1, -30.0)
    scene = _textured_ball(0.1, position, mirror)
    close = Camera(eye=(position[0] + 0.15, 0.25, position[2] + 0.3), target=position)
    with Renderer(ctx, dataclasses.replace(scene, camera=close), method=Method.RAYTRACE) as made_there:
        made_there.render()
        there = _drawn_triangles(made_there, "ball0")
        expected = made_there.read_color_float()
    with Renderer(ctx, scene, method=Method.RAYTRACE) as renderer:
        renderer.render()
        far = _drawn_triangles(renderer, "ball0")
        assert far <= there // 4
        renderer.look_at(close)
        renderer.render()
        assert _drawn_triangles(renderer, "ball0") == there
        moved = renderer.read_color_float()
        renderer.look_at(scene.camera)  # and back: the coarse level again
        assert _drawn_triangles(renderer, "ball0") == far
    assert_finite(moved)
    # The ball fills most of the frame; the two differ at most by rounding (the eye's near and far
    # planes are fitted to each world's bounds, which the coarse ball's change slightly).
    assert np.abs(moved - expected).max(axis=-1).mean() < 1e-3
    assert np.mean(np.abs(moved - expected).max(axis=-1) > 4 / 255) < 0.002
