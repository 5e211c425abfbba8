"""The render plan and the work that follows it: each project scene's plan, the renderer doing
exactly that (programs compiled, images baked once), animation re-baking only what moved,
culling that never drops an object a ray could reach, and "auto" resolutions."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import moderngl
import numpy as np
import pytest

from conftest import SCENES, assert_finite, scene_from_toml
from depthimpostor.cli import main
from depthimpostor.constants import Algorithm, Method
from depthimpostor.culling import Reach, may_shadow, reach
from depthimpostor.geometry import scene_geometry
from depthimpostor.graph import Pass
from depthimpostor.plan import plan_render
from depthimpostor.methods.atlas import ImpostorAtlas
from depthimpostor.methods.impostors import ImpostorPass
from depthimpostor.renderer import Renderer
from depthimpostor.resolution import MAX_AUTO_RESOLUTION, MIN_AUTO_RESOLUTION
from depthimpostor.scene import Scene, load_scene

#: Per project scene: (passes, depth images, images skipped, shader variants), worked out by
#: hand: a mirror gets one image per object it may show, one more per other reflector and bounce
#: above the first; the variants are the frame's diffuse, environment and mirror (+ glass)
#: programs, the bake's diffuse and back-face programs, the shadow map's and the bounce bake's; a
#: scene with moving diffuse objects has a second frame diffuse variant (the batch's is INSTANCED).
PLAN_COUNTS = {
    "bunny.toml": (4, 1, 0, 6),
    "carousel.toml": (4, 7, 1, 7),  # the knot behind the wall mirror: skipped for it; its movers drawn one by one
    "default.toml": (4, 5, 0, 6),
    "checker_near_mirror.toml": (4, 4, 0, 6),
    "textured_near_mirror.toml": (4, 4, 0, 6),  # checker_near_mirror with image textures
    # A blended pane: the transparent pass and its variant (ALPHA_BLEND) besides the usual six.
    "blend_near_mirror.toml": (5, 3, 0, 7),
    "glass_and_mirrors.toml": (7, 15, 0, 12),  # 3 reflectors x 3 objects + 3 x 2 of bounce 2
    "grid_3x3.toml": (4, 8, 0, 6),
    "hdr_sky.toml": (4, 4, 0, 6),  # 2 mirrors x 2 objects; the sky's ENVIRONMENT_MAP variants
    "lecture_8x9.toml": (4, 72, 0, 6),
    "planar_mirror.toml": (4, 3, 0, 6),
    "shadows.toml": (5, 4, 0, 7),
    # The glTF room: its floor, walls and mirror are planes; mirror and glass ball x 2 crates and a torus.
    # Its HDR sky lights its metallic-roughness materials: the prefilter pass and its program.
    "showcase.toml": (6, 6, 0, 9),
    "two_mirrors.toml": (5, 4, 0, 8),
    # tools/make_images_per_mirror.py's bench scenes: one mirror, an image per box; at 64, images
    # found through lists, and the pass that finds those a frame's rays enter (entered_images.py).
    **{f"images_per_mirror/{family}_{count:02d}.toml": (4, count, 0, 7 if count == 64 else 6)
       for family in ("boxes", "wall") for count in (1, 4, 16, 64)},
    "hard/grazing.toml": (4, 3, 0, 6),
    "hard/huge.toml": (4, 5, 0, 6),
    "hard/silhouette.toml": (4, 1, 0, 6),
    "hard/tiny.toml": (4, 5, 0, 6),
    "hard/top_down.toml": (4, 3, 0, 6),
    "hard/touching.toml": (4, 2, 0, 6),
}
SMALL = (64, 36)


def project_scenes() -> list[str]:
    found = {str(path.relative_to(SCENES)) for path in SCENES.rglob("*.toml")}
    return sorted(found - {"hard/surrounds.toml"})  # refused by design: no frustum fits its ring


def small(name: str, resolution: int | str = 32) -> Scene:
    return load_scene(SCENES / name).with_overrides(size=SMALL, impostor_resolution=resolution)


def test_every_project_scene_has_planned_counts() -> None:
    assert set(project_scenes()) == set(PLAN_COUNTS), "a new scene needs its plan counts here"


@pytest.mark.parametrize("name", sorted(PLAN_COUNTS))
def test_plan_counts(name: str) -> None:
    plan = plan_render(load_scene(SCENES / name))
    counts = plan.counts()
    assert (counts["passes"], counts["images"], counts["skipped"], counts["variants"]) == PLAN_COUNTS[name]


@pytest.mark.parametrize("name", [n for n in sorted(PLAN_COUNTS) if n != "bunny.toml"])
def test_static_frames_do_the_planned_work_once(ctx: moderngl.Context, name: str) -> None:
    """Three frames of a static scene compile exactly the planned programs, bake every planned
    image exactly once (where a frame bakes only the images its rays may enter, those of them, at
    the first frame), and run the per-frame passes every frame."""
    frames = 3
    with Renderer(ctx, small(name)) as renderer:
        for _ in range(frames):
            renderer.render()
        plan, stats = renderer.plan, renderer.stats
        assert renderer.programs.keys == plan.program_keys
        baked = renderer.graph.baked_images
        if baked is not None and baked.lazily:
            assert set(stats.images_baked) < {image.label for image in plan.images}
            assert set(stats.images_baked.values()) == {1}
        else:
            assert dict(stats.images_baked) == {image.label: 1 for image in plan.images}
        assert set(stats.passes) == {planned.stage.value for planned in plan.passes}
        for planned in plan.passes:
            expected = 1 if planned.stage in (Pass.ENVIRONMENT_LIGHTING, Pass.SHADOW_MAPS, Pass.STAND_IN, Pass.BOUNCES,
                                              Pass.GLASS_INTERIORS) \
                else frames
            assert stats.passes[planned.stage.value] == expected, planned.stage
        assert_finite(renderer.read_color_float())


@pytest.mark.parametrize("method", [m for m in Method if m != Method.DEPTH])
def test_other_methods_follow_their_plans(ctx: moderngl.Context, method: Method) -> None:
    # The planar method refuses the carousel's sphere mirror: the planar mirror is its scene.
    with Renderer(ctx, small("planar_mirror.toml" if method == Method.PLANAR else "carousel.toml"),
                  method=method) as renderer:
        renderer.render()
        renderer.render()
        assert renderer.programs.keys == renderer.plan.program_keys
        assert dict(renderer.stats.images_baked) == {image.label: 1 for image in renderer.plan.images}


def test_hierarchical_plans_pyramids(ctx: moderngl.Context) -> None:
    plan = plan_render(small("default.toml"), algorithm=Algorithm.HIERARCHICAL)
    assert plan.runs(Pass.PYRAMIDS) and not plan_render(small("default.toml")).runs(Pass.PYRAMIDS)
    with Renderer(ctx, small("default.toml"), Algorithm.HIERARCHICAL) as renderer:
        renderer.render()
        assert renderer.programs.keys == renderer.plan.program_keys


def test_a_rough_mirror_adds_the_colour_mips(ctx: moderngl.Context) -> None:
    """Roughness > 0: one pass (the colour mips, after each bake) and one program (its compute
    shader; the mirror variant is GLOSSY instead of plain), and the renderer does what it says."""
    scene = small("default.toml").with_roughness(0.15)
    counts = plan_render(scene).counts()
    assert (counts["passes"], counts["images"], counts["skipped"], counts["variants"]) == (5, 5, 0, 7)
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        renderer.render()
        assert renderer.programs.keys == renderer.plan.program_keys
        assert renderer.stats.passes[Pass.COLOUR_MIPS.value] == 1  # built after the one bake


def test_animation_rebakes_only_the_moving_objects_images(ctx: moderngl.Context) -> None:
    frames = 4
    with Renderer(ctx, small("carousel.toml")) as renderer:
        for frame in range(frames):
            renderer.set_time(frame * 0.5)
            renderer.render()
        moving = {"turning_box", "orbiting_torus"}
        baked = renderer.stats.images_baked
        for image in renderer.plan.images:
            shows = image.label.split(" -> ")[1]
            assert baked[image.label] == (frames if shows in moving else 1), image.label
        # A moving camera re-bakes nothing, and neither does a frame at the same time.
        before = sum(baked.values())
        view = renderer.scene.camera
        renderer.look_at(dataclasses.replace(view, eye=(2.0, 3.0, 6.0)))
        renderer.render()
        renderer.set_time((frames - 1) * 0.5)
        renderer.render()
        assert sum(renderer.stats.images_baked.values()) == before
        assert_finite(renderer.read_color_float())


def test_animated_frame_matches_a_fresh_renderer(ctx: moderngl.Context) -> None:
    """Images fitted again after a move show what a renderer made at that time shows."""
    scene = small("carousel.toml", 64)
    with Renderer(ctx, scene) as moved:
        moved.render()
        moved.set_time(3.0)
        moved.render()
        frame = moved.read_color_float()
    with Renderer(ctx, scene) as fresh:
        fresh.set_time(3.0)
        fresh.render()
        expected = fresh.read_color_float()
    assert np.abs(frame - expected).max() < 1e-4


def _tiles(renderer: Renderer) -> list[tuple[np.ndarray, ...]]:
    """Every depth image of the renderer as baked: colour, both layers and the back colour."""
    baked = renderer.graph.baked_images
    assert baked is not None
    images = [baked.atlas.read(image) for image in baked.depth_images]
    return [(i.color, i.depth, i.back_layer, i.back_color) for i in images]


def test_the_bake_depth_buffer_is_kept_only_while_frames_bake(ctx: moderngl.Context) -> None:
    """A still scene lets its bakes' depth buffer go at its first frame that bakes nothing; the
    next bake makes it again and bakes the very images of the first. An animated scene bakes
    every frame and keeps it."""
    with Renderer(ctx, small("default.toml", 64)) as renderer:
        renderer.render()
        baked = renderer.graph.baked_images
        assert baked is not None and baked.atlas.keeps_bake_buffer
        first, frame = _tiles(renderer), renderer.read_color_float()
        with_buffer = baked.bytes
        renderer.render()
        assert not baked.atlas.keeps_bake_buffer
        assert with_buffer - baked.bytes == ImpostorAtlas.bake_buffer_bytes(len(baked.depth_images), 64)
        renderer.bake_again()
        renderer.render()
        assert baked.atlas.keeps_bake_buffer
        for before, after in zip(first, _tiles(renderer), strict=True):
            for a, b in zip(before, after, strict=True):
                np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(frame, renderer.read_color_float())
    # Supersampled, a frame's later sub-frames bake nothing: the frame as a whole does.
    for samples in (1, 4):
        with Renderer(ctx, small("carousel.toml", 64).with_overrides(samples=samples)) as animated:
            for time in (0.0, 0.5, 1.0):
                animated.set_time(time)
                animated.render()
                assert animated.graph.baked_images is not None and animated.graph.baked_images.atlas.keeps_bake_buffer


def test_an_image_baked_alone_is_the_image_baked_with_all(ctx: moderngl.Context) -> None:
    """A bake of some images clears and draws their tiles alone; a bake of all clears the atlas
    whole (BakedImages._clears): the same images either way, the others untouched."""
    with Renderer(ctx, small("default.toml", 64)) as renderer:
        renderer.render()
        everything = _tiles(renderer)
        baked = renderer.graph.baked_images
        assert baked is not None and len(baked.depth_images) > 2
        baked.stale = {baked.depth_images[1].slot}
        renderer.render()
        assert baked.bake_counts[baked.depth_images[1].label] == 2
        for before, after in zip(everything, _tiles(renderer), strict=True):
            for a, b in zip(before, after, strict=True):
                np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize(("name", "checker", "directional"), [
    ("lecture_8x9.toml", False, True),  # plain objects in the images, a checker floor in the frame
    ("checker_near_mirror.toml", True, True),  # checker objects in the images
    ("shadows.toml", False, False),  # point lights
])
def test_bakes_leave_out_what_they_draw_none_of(ctx: moderngl.Context, name: str, checker: bool,
                                                 directional: bool) -> None:
    """The bake's programs leave out the checker where no baked object has one (NO_CHECKER) and the
    point lights' code in a scene without one (DIRECTIONAL_LIGHTS, every shading program), and
    bake the very images the programs without those specializations bake."""
    with Renderer(ctx, small(name, 32)) as renderer:
        renderer.render()
        baked = renderer.graph.baked_images
        assert baked is not None and baked.back_layer is not None
        passes = [baked.diffuse, baked.back_layer]
        for diffuse_pass in passes:
            assert ("NO_CHECKER" not in diffuse_pass.defines) == checker
            assert ("DIRECTIONAL_LIGHTS" in diffuse_pass.defines) == directional
        assert renderer.graph.diffuse is not None and "NO_CHECKER" not in renderer.graph.diffuse.defines
        specialized, frame = _tiles(renderer), renderer.read_color_float()
        for diffuse_pass in passes:
            diffuse_pass.defines = {k: v for k, v in diffuse_pass.defines.items()
                                    if k not in ("NO_CHECKER", "DIRECTIONAL_LIGHTS")}
        renderer.bake_again()
        renderer.render()
        for before, after in zip(specialized, _tiles(renderer), strict=True):
            for a, b in zip(before, after, strict=True):
                np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(frame, renderer.read_color_float())


def test_no_pyramid_where_no_image_is_marched(ctx: moderngl.Context) -> None:
    """The hierarchical algorithm over a mirror that reflects nothing but the floor and the sky
    plans no pyramid pass, and the renderer makes no pyramid (an empty one was made before)."""
    scene = small("default.toml", 32)
    bare = dataclasses.replace(scene, objects=tuple(o for i, o in enumerate(scene.objects)
                                                      if o.is_reflector or i in scene.analytic_plane_indices))
    plan = plan_render(bare, Method.DEPTH, Algorithm.HIERARCHICAL)
    assert not plan.images and not plan.runs(Pass.PYRAMIDS) and not plan.builds_pyramids
    with Renderer(ctx, bare, Algorithm.HIERARCHICAL) as renderer:
        renderer.render()
        assert renderer.graph.impostors is not None and renderer.graph.impostors.pyramid is None
        assert_finite(renderer.read_color_float())


def test_back_faces_without_their_colours_are_baked_into_each_images_own_tile(ctx: moderngl.Context) -> None:
    """A stand-in that keeps the back layer's depth without its colour (bake_back_faces, as the
    bounce images do) bakes each image's back faces into its own tile: the same G layer the depth
    method's back-colour pass bakes."""
    class BackDepthsAlone(ImpostorPass):
        keeps_back_colors = False

    with Renderer(ctx, small("default.toml", 32)) as renderer:
        renderer.render()
        baked, world = renderer.graph.baked_images, renderer.world
        assert baked is not None and len(baked.depth_images) > 1
        alone = BackDepthsAlone(ctx, renderer.programs, world.scene, renderer.graph.meshes,
                                renderer.graph.scene_blocks.drawn_materials, world.mirrors,
                                world.reflected_objects, renderer.plan.image_plans)
        try:
            alone.bake()
            for image, own in zip(baked.depth_images, alone.depth_images, strict=True):
                np.testing.assert_array_equal(alone.atlas.read(own).back_layer, baked.atlas.read(image).back_layer)
        finally:
            alone.release()


def _scene(text: str) -> Scene:
    return scene_from_toml(text)


SHADOWED = """
[render]
size = [64, 36]
impostor_resolution = 32
[camera]
eye = [0.0, 2.0, 7.0]
target = [0.0, 0.8, 0.0]
[[lights]]
type = "point"
position = [0.0, 6.0, 0.0]
shadows = "hard"
{light_animation}
[[objects]]
name = "floor"
shape = {{ type = "plane", size = [20.0, 20.0] }}
[[objects]]
name = "mirror"
shape = {{ type = "sphere", radius = 0.8 }}
material = {{ type = "mirror" }}
position = [0.0, 1.0, 0.0]
[[objects]]
name = "mover"
shape = {{ type = "sphere", radius = 0.3 }}
position = [2.0, 1.2, 0.0]
animation = {{ type = "orbit", centre = [2.0, 1.2, 0.6], axis = [0.0, 1.0, 0.0], degrees_per_second = 20.0 }}
[[objects]]
name = "below"
shape = {{ type = "box", size = [1.2, 0.3, 1.2] }}
position = [2.0, 0.15, 0.3]
[[objects]]
name = "far_away"
shape = {{ type = "box", size = [0.5, 0.5, 0.5] }}
position = [-2.5, 0.25, 0.5]
"""


def test_a_moving_caster_rebakes_what_its_shadow_may_fall_on(ctx: moderngl.Context) -> None:
    with Renderer(ctx, _scene(SHADOWED.format(light_animation=""))) as renderer:
        renderer.render()
        renderer.set_time(1.0)
        renderer.render()
        baked = renderer.stats.images_baked
        assert baked["mirror -> mover"] == 2  # it moved
        assert baked["mirror -> below"] == 2  # its shadow may fall on it
        assert baked["mirror -> far_away"] == 1  # out of the shadow's cone
        assert renderer.stats.shadow_maps_baked == 2


def test_a_moving_light_rebakes_every_image(ctx: moderngl.Context) -> None:
    orbit = 'animation = { type = "orbit", centre = [0.0, 6.0, 1.0], axis = [0.0, 1.0, 0.0], degrees_per_second = 30.0 }'
    scene = _scene(SHADOWED.format(light_animation=orbit).replace('animation = { type = "orbit", centre = [2.0',
                                                                   '# animation = { type = "orbit", centre = [2.0'))
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        renderer.set_time(1.0)
        renderer.render()
        assert set(renderer.stats.images_baked.values()) == {2}
        assert renderer.stats.shadow_maps_baked == 2
        assert_finite(renderer.read_color_float())


# ---------------------------------------------------------------------------- culling


def _random_unit(rng: np.random.Generator, count: int) -> np.ndarray:
    v = rng.normal(size=(count, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _reflected_rays_reach(mirror_geometry, centre: np.ndarray, radius: float, rng: np.random.Generator) -> bool:
    """Does any of many reflected rays, as the mirror shader makes them (interpolated normal,
    front faces only), meet the sphere (centre, radius)?"""
    mesh = mirror_geometry.world_mesh
    tri = rng.integers(0, len(mesh.indices), 20000)
    weights = rng.dirichlet((1.0, 1.0, 1.0), len(tri))
    corners = mesh.positions[mesh.indices[tri]].astype(float)
    normals = mesh.normals[mesh.indices[tri]].astype(float)
    points = np.einsum("ti,tij->tj", weights, corners)
    normal = np.einsum("ti,tij->tj", weights, normals)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    face = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    view = _random_unit(rng, len(tri))
    view = np.where((np.einsum("tj,tj->t", view, face) < 0)[:, None], view, -view)  # front-facing only
    reflected = view - 2.0 * np.einsum("tj,tj->t", view, normal)[:, None] * normal
    to_centre = centre - points
    along = np.einsum("tj,tj->t", to_centre, reflected)
    miss = np.linalg.norm(to_centre - np.maximum(along, 0.0)[:, None] * reflected, axis=1)
    return bool(np.any(miss <= radius))


@pytest.mark.parametrize("shape, position, expected", [
    ('{ type = "plane", size = [2.0, 2.0] }', [0.0, 0.0, -1.2], Reach.BEHIND),
    ('{ type = "plane", size = [2.0, 2.0] }', [0.0, 0.0, 1.5], Reach.REACHABLE),
    ('{ type = "plane", size = [2.0, 2.0] }', [0.0, 0.0, -0.1], Reach.REACHABLE),  # straddles the plane
    ('{ type = "sphere", radius = 1.0 }', [0.0, 0.0, 0.0], Reach.OUTSIDE_DIRECTIONS),  # inside the sphere
    ('{ type = "sphere", radius = 1.0 }', [0.0, 0.0, -3.0], Reach.REACHABLE),
    ('{ type = "box", size = [2.0, 2.0, 2.0] }', [0.0, 0.0, -0.2], Reach.BEHIND),  # inside the box
])
def test_culling_never_drops_what_a_reflected_ray_reaches(shape: str, position: list[float], expected: Reach) -> None:
    rotation = "[90.0, 0.0, 0.0]" if "plane" in shape else "[0.0, 0.0, 0.0]"
    scene = _scene(f"""
[[objects]]
name = "mirror"
shape = {shape}
material = {{ type = "mirror" }}
rotation = {rotation}
[[objects]]
name = "ball"
shape = {{ type = "sphere", radius = 0.25 }}
position = {position}
""")
    mirror, ball = scene_geometry(scene.objects)
    assert reach(mirror, ball) is expected
    centre, radius = ball.bounding_sphere
    if expected is not Reach.REACHABLE:
        assert not _reflected_rays_reach(mirror, centre, radius, np.random.default_rng(7))


def test_culling_keeps_what_a_move_may_bring_in_front() -> None:
    scene = _scene("""
[[objects]]
name = "mirror"
shape = { type = "plane", size = [2.0, 2.0] }
material = { type = "mirror" }
rotation = [90.0, 0.0, 0.0]
[[objects]]
name = "ball"
shape = { type = "sphere", radius = 0.25 }
position = [0.0, 0.0, -2.0]
animation = { type = "orbit", centre = [0.0, 0.0, 0.0], axis = [0.0, 1.0, 0.0], degrees_per_second = 10.0 }
""")
    mirror, ball = scene_geometry(scene.objects)
    assert reach(mirror, ball) is Reach.REACHABLE  # behind now, in front in 18 seconds


def test_may_shadow_is_conservative() -> None:
    """No segment from a point of the light to a point of the caster, continued, meets a
    receiver that may_shadow clears."""
    rng = np.random.default_rng(3)
    light, light_radius = np.zeros(3), 0.3
    for _ in range(200):
        caster = (rng.uniform(-3, 3, 3), rng.uniform(0.1, 0.8))
        receiver = (rng.uniform(-5, 5, 3), rng.uniform(0.1, 1.0))
        if may_shadow(light, light_radius, caster, receiver):
            continue
        starts = light + _random_unit(rng, 4000) * light_radius * rng.uniform(0, 1, (4000, 1)) ** (1 / 3)
        through = caster[0] + _random_unit(rng, 4000) * caster[1] * rng.uniform(0, 1, (4000, 1)) ** (1 / 3)
        direction = through - starts
        direction /= np.linalg.norm(direction, axis=1, keepdims=True)
        to_receiver = receiver[0] - through
        along = np.maximum(np.einsum("tj,tj->t", to_receiver, direction), 0.0)
        miss = np.linalg.norm(to_receiver - along[:, None] * direction, axis=1)
        assert np.all(miss > receiver[1])


# ---------------------------------------------------------------------------- auto resolution


def test_auto_resolution_follows_the_pixels(ctx: moderngl.Context) -> None:
    """Images are powers of two within bounds; a planar mirror's need more samples than a convex
    one's; twice the frame's size asks for twice the samples."""
    def sides(name: str, size: tuple[int, int]) -> list[int]:
        scene = load_scene(SCENES / name).with_overrides(size=size, impostor_resolution="auto")
        with Renderer(ctx, scene) as renderer:
            renderer.render()
            assert_finite(renderer.read_color_float())
            assert renderer.graph.baked_images is not None
            return [image.camera.width for image in renderer.graph.baked_images.depth_images]

    for side in sides("default.toml", (480, 270)) + sides("planar_mirror.toml", (480, 270)):
        assert MIN_AUTO_RESOLUTION <= side <= MAX_AUTO_RESOLUTION and math.log2(side).is_integer()
    assert max(sides("planar_mirror.toml", (480, 270))) > max(sides("default.toml", (480, 270)))
    small_sides, large_sides = sides("default.toml", (240, 135)), sides("default.toml", (960, 540))
    for low, high in zip(small_sides, large_sides, strict=False):
        assert high == min(MAX_AUTO_RESOLUTION, 4 * low) or low == MIN_AUTO_RESOLUTION


# ---------------------------------------------------------------------------- command line


def test_plan_command(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", str(SCENES / "carousel.toml")]) == 0
    text = capsys.readouterr().out
    assert "wall_mirror -> hidden_knot: behind the mirror" in text
    assert main(["plan", str(SCENES / "glass_and_mirrors.toml"), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["counts"] == {"passes": 7, "images": 15, "skipped": 0, "variants": 12}
    assert {"stages": ["screen_rect.vert", "reflector.frag"], "why": "glass (GLASS), depth method, deferred"}.items() <= \
        {"stages": data["variants"][-1]["stages"], "why": data["variants"][-1]["why"]}.items()


def test_render_stats(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "frame.png"
    assert main(["render", str(SCENES / "carousel.toml"), "--size", "64x36", "--impostor-res", "auto",
                 "--frames", "2", "--stats", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert out.is_file()
    assert "images baked: 15 bakes of the 7 planned images: 3 baked once, 4 more than once" in text
    assert "reflected objects 3" in text and "mirrors and glass 3" in text
