"""What the viewer changes between frames, each doing only the work it calls for: a camera move
or a resize re-bakes nothing, another algorithm swaps one shader variant, another resolution
re-bakes every depth image, a shader reload keeps the last good programs when the new ones do
not compile. After each change the frame equals a fresh renderer made with that setting."""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path

import moderngl
import numpy as np
import pytest

from conftest import PROJECT_ROOT, SCENES, assert_finite
from depthimpostor import constants
from depthimpostor.constants import Algorithm, Method
from depthimpostor.errors import GpuLimitError, ShaderError
from depthimpostor.graph import Pass
from depthimpostor.plan import plan_render
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Animation, Camera, Scene, load_scene
from depthimpostor.gpu.shaders import ShaderLibrary

SIZE = (160, 90)


@pytest.fixture(scope="module")
def scene() -> Scene:
    return load_scene(SCENES / "default.toml").with_overrides(size=SIZE, impostor_resolution=64)


def fresh_frame(ctx: moderngl.Context, scene: Scene, algorithm: Algorithm = Algorithm.OPTIMIZED,
                view: Camera | None = None) -> np.ndarray:
    with Renderer(ctx, scene, algorithm) as renderer:
        if view is not None:
            renderer.look_at(view)
        renderer.render()
        return renderer.read_color_float()


def assert_same_frame(actual: np.ndarray, expected: np.ndarray) -> None:
    assert_finite(actual)
    # The same GL, the same programs and the same inputs: the same pixels.
    np.testing.assert_allclose(actual, expected, atol=1e-6)


def test_camera_moves_and_resizes_re_bake_nothing(ctx: moderngl.Context, scene: Scene) -> None:
    orbit = Camera((3.5, 2.0, 3.0), scene.camera.target, scene.camera.up, 50.0)
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        baked = renderer.stats.depth_images_baked
        assert baked == 5
        renderer.look_at(orbit)
        renderer.render()
        moved = renderer.read_color_float()
        renderer.resize((96, 72))
        renderer.render()
        resized = renderer.read_color_float()
        assert renderer.stats.depth_images_baked == baked
    assert_same_frame(moved, fresh_frame(ctx, scene, view=orbit))
    assert_same_frame(resized, fresh_frame(ctx, scene.with_overrides(size=(96, 72)), view=orbit))
    assert resized.shape == (72, 96, 3)


def test_algorithm_switch_changes_the_variant_not_the_depth_images(ctx: moderngl.Context, scene: Scene) -> None:
    """Every algorithm is a mirror variant over the same depth images; the hierarchical one adds
    their pyramids (built from the images already baked) and they go when it goes."""
    frames = {}
    with Renderer(ctx, scene) as renderer:
        for algorithm in (Algorithm.OPTIMIZED, Algorithm.BASIC, Algorithm.HIERARCHICAL, Algorithm.AUTO,
                          Algorithm.OPTIMIZED):
            renderer.set_algorithm(algorithm)
            renderer.render()
            assert renderer.graph.impostors is not None
            # `auto` keeps none here: its 64^2 images are all marched linearly.
            assert (renderer.graph.impostors.pyramid is not None) == (algorithm == Algorithm.HIERARCHICAL)
            if algorithm == Algorithm.OPTIMIZED and not frames:
                assert renderer.programs.compute_variants == []  # no pyramid build compiled before it is needed
            frames[algorithm] = renderer.read_color_float()
        assert renderer.programs.compute_variants == [("depth_pyramid.comp", ())]
        assert renderer.stats.depth_images_baked == 5
        mirror_variants = {d for _, fragment, d in renderer.programs.variants if fragment == "reflector.frag"}
        # The scene's lights, materials and planes are constants of every variant (lib/shading.glsl,
        # lib/reflected_scene.glsl), and its lights are all directional (DIRECTIONAL_LIGHTS).
        assert all(light.type == "directional" for light in scene.lights)
        counts = (("LIGHT_COUNT", str(len(scene.lights))), ("PLANE_COUNT", str(len(scene.analytic_planes))))
        materials = ("MATERIAL_COUNT", str(len(scene.materials)))
        assert mirror_variants == {(("ALGORITHM", str(int(a))), ("DEFERRED", "1"), ("DIRECTIONAL_LIGHTS", "1"), counts[0],
                                    materials, ("METHOD", str(int(Method.DEPTH))), counts[1])
                                   for a in Algorithm}
    assert_same_frame(frames[Algorithm.BASIC], fresh_frame(ctx, scene, Algorithm.BASIC))
    # The hierarchical traversal finds the optimized march's hits, bit for bit.
    assert np.array_equal(frames[Algorithm.HIERARCHICAL], frames[Algorithm.OPTIMIZED])


def test_resolution_change_re_bakes_every_depth_image_once(ctx: moderngl.Context, scene: Scene) -> None:
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        renderer.set_impostor_resolution(128)
        for _ in range(2):
            renderer.render()
        assert renderer.stats.depth_images_baked == 5 + 5
        assert renderer.graph.impostors is not None and renderer.graph.impostors.atlas.resolution == 128
        frame = renderer.read_color_float()
    assert_same_frame(frame, fresh_frame(ctx, scene.with_overrides(impostor_resolution=128)))


def test_a_resolution_this_gl_cannot_hold_changes_nothing(ctx: moderngl.Context) -> None:
    scene = load_scene(SCENES / "lecture_8x9.toml").with_overrides(size=(64, 36), impostor_resolution=16)
    # A budget that lets the images be as large as asked (the default would make them smaller).
    scene = dataclasses.replace(scene, render=dataclasses.replace(scene.render, image_memory=2**24))
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        before = renderer.read_color_float()
        # 72 tiles of 4096^2: no GL holds that atlas; refused before anything is made.
        with pytest.raises(GpuLimitError, match="over this GL's GL_MAX_TEXTURE_SIZE .*lower --impostor-res"):
            renderer.set_impostor_resolution(4096)
        renderer.render()
        assert renderer.scene.render.impostor_resolution == 16
        assert renderer.stats.depth_images_baked == 72
        assert_same_frame(renderer.read_color_float(), before)


def test_shader_reload_keeps_the_last_good_programs(ctx: moderngl.Context, scene: Scene, tmp_path: Path) -> None:
    shaders = tmp_path / "shaders"
    shutil.copytree(PROJECT_ROOT / "shaders", shaders)
    mirror = shaders / "reflector.frag"
    original = mirror.read_text()
    with Renderer(ctx, scene, shaders=ShaderLibrary(shaders)) as renderer:
        renderer.render()
        good = renderer.read_color_float()

        mirror.write_text(original.replace("out_color = vec4(u_tint * hit.color, 1.0);", "out_color = vec4(u_tint"))
        with pytest.raises(ShaderError, match=r"reflector\.frag"):
            renderer.reload_shaders()
        renderer.render()
        assert_same_frame(renderer.read_color_float(), good)
        assert renderer.stats.depth_images_baked == 5

        mirror.write_text(original.replace("vec4(u_tint * hit.color, 1.0)", "vec4(0.5 * u_tint * hit.color, 1.0)"))
        renderer.reload_shaders()
        renderer.render()
        halved = renderer.read_color_float()
        # The shaders that bake may have changed too: every depth image is baked again.
        assert renderer.stats.depth_images_baked == 10
    changed = np.abs(halved - good).max(axis=2) > 1e-6
    assert 0.02 < changed.mean() < 0.5, "only the mirror's pixels change"
    np.testing.assert_allclose(halved[changed], 0.5 * good[changed], atol=1e-5)


def test_sample_view_shows_the_depth_images_instead_of_the_objects(ctx: moderngl.Context, scene: Scene) -> None:
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        objects = renderer.read_color_float()
        assert not any(vertex == "samples.vert" for vertex, _, _ in renderer.programs.variants)
        renderer.set_show_samples(True)
        draws = renderer.stats.draw_calls
        renderer.render()
        samples = renderer.read_color_float()
        # One points draw per depth image replaces the four reflected objects' meshes.
        # Samples, the floor, the mirror (its surface, then its screen rectangle).
        assert renderer.stats.draw_calls - draws == 5 + 1 + 2
        renderer.set_show_samples(False)
        renderer.render()
        assert_same_frame(renderer.read_color_float(), objects)
        assert renderer.stats.depth_images_baked == 5
    assert_finite(samples)
    differs = np.abs(samples - objects).max(axis=2) > 0.05
    # The objects' sides that face the camera are not in the mirror's depth images: they change.
    assert 0.01 < differs.mean() < 0.3


@pytest.fixture(scope="module")
def turning_light_scene(scene: Scene) -> Scene:
    """The default scene under a directional light that turns 20 degrees a second about X: the floor
    (an analytic plane in the mirror shader) is lit differently at each time."""
    light = dataclasses.replace(scene.lights[0], animation=Animation("rotate", (1.0, 0.0, 0.0), 20.0))
    return dataclasses.replace(scene, lights=[light])


SETTINGS_AFTER_A_MOVE = {
    "set_algorithm": lambda renderer: renderer.set_algorithm(Algorithm.BASIC),
    "set_method": lambda renderer: renderer.set_method(Method.CUBEMAP),
    "set_impostor_resolution": lambda renderer: renderer.set_impostor_resolution(32),
}


@pytest.mark.parametrize("setting", SETTINGS_AFTER_A_MOVE)
def test_a_setting_changed_after_the_lights_moved_keeps_them_where_they_are(
        ctx: moderngl.Context, turning_light_scene: Scene, setting: str) -> None:
    """Programs made again for a new setting get the lights as they are now, not as written."""
    with Renderer(ctx, turning_light_scene) as renderer:
        renderer.render()
        renderer.set_time(1.0)
        SETTINGS_AFTER_A_MOVE[setting](renderer)
        renderer.render()
        frame = renderer.read_color_float()
        algorithm, method, scene = renderer.algorithm, renderer.method, renderer.scene
    with Renderer(ctx, scene, algorithm, method=method) as fresh:
        fresh.set_time(1.0)
        fresh.render()
        expected = fresh.read_color_float()
    assert_finite(frame)
    np.testing.assert_allclose(frame, expected, atol=1e-5)


def test_auto_picks_each_images_traversal_by_its_size_and_finds_the_same_hits(
        ctx: moderngl.Context, scene: Scene, monkeypatch: pytest.MonkeyPatch) -> None:
    """`--algorithm auto`: images from HIERARCHICAL_MIN_SIDE up are traversed hierarchically (and get
    pyramids), the others marched linearly, in one frame; both find the optimized march's hits. The
    threshold is lowered here so that auto resolution's sizes fall on both sides of it."""
    auto_sizes = scene.with_overrides(size=(320, 180), impostor_resolution="auto")
    sides = sorted({max(i.width, i.height) for i in plan_render(auto_sizes, Method.DEPTH, Algorithm.AUTO).images})
    assert len(sides) > 1, sides
    monkeypatch.setattr(constants, "HIERARCHICAL_MIN_SIDE", sides[-1])
    plan = plan_render(auto_sizes, Method.DEPTH, Algorithm.AUTO)
    picked = {plan.traversal(image) for image in plan.images}
    assert picked == {Algorithm.OPTIMIZED, Algorithm.HIERARCHICAL}
    assert plan.runs(Pass.PYRAMIDS) and plan.builds_pyramids
    assert {i["traversal"] for i in plan.to_json()["images"]} == {"optimized", "hierarchical"}
    assert "hierarchical (auto)" in plan.format() and "optimized (auto)" in plan.format()
    with Renderer(ctx, auto_sizes, Algorithm.AUTO) as renderer:
        renderer.render()
        assert renderer.graph.impostors is not None and renderer.graph.impostors.pyramid is not None
        auto = renderer.read_color_float()
    assert_same_frame(auto, fresh_frame(ctx, auto_sizes, Algorithm.OPTIMIZED))
    monkeypatch.setattr(constants, "HIERARCHICAL_MIN_SIDE", sides[-1] + 1)  # none that large: no pyramid
    assert not plan_render(auto_sizes, Method.DEPTH, Algorithm.AUTO).builds_pyramids


def test_a_setting_change_rebuilds_only_the_nodes_whose_plan_changed(ctx: moderngl.Context, scene: Scene) -> None:
    """RenderGraph.apply: the two cube-map lookups share their stand-in, a setting that plans the
    same images keeps them baked, and every other node (the sky, the diffuse pass) stays."""
    with Renderer(ctx, scene, method=Method.CUBEMAP) as renderer:
        renderer.render()
        graph = renderer.graph
        kept = (graph.stand_in, graph.environment, graph.diffuse)
        baked = renderer.stats.depth_images_baked
        renderer.set_method(Method.CUBEMAP_PARALLAX)
        renderer.set_impostor_resolution(scene.render.impostor_resolution)  # the same images
        renderer.render()
        assert (graph.stand_in, graph.environment, graph.diffuse) == kept
        assert renderer.stats.depth_images_baked == baked  # nothing baked again
        renderer.set_impostor_resolution(32)  # other images: a new stand-in, the old one released
        renderer.render()
        assert graph.stand_in is not kept[0] and (graph.environment, graph.diffuse) == kept[1:]
        assert renderer.stats.depth_images_baked > baked
        renderer.set_method(Method.RAYTRACE)
        assert type(graph.stand_in).__name__ == "TrianglePass" and graph.environment is kept[1]


def test_a_refused_setting_leaves_the_graph_drawing_by_the_plan_it_had(
        ctx: moderngl.Context, scene: Scene, monkeypatch: pytest.MonkeyPatch) -> None:
    """A stand-in this GL refuses (here SSR's, as on a GL without compute shaders) is refused before
    anything is replaced: the renderer and its graph keep the old plan, and draw what they drew."""
    from depthimpostor.errors import ContextError
    from depthimpostor.methods.screen_space import ScreenSpacePass

    def refuse(*args: object, **kwargs: object) -> None:
        raise ContextError("no compute shaders here")

    with Renderer(ctx, scene) as renderer:
        renderer.render()
        before = renderer.read_color_float()
        monkeypatch.setattr(ScreenSpacePass, "__init__", refuse)
        with pytest.raises(ContextError):
            renderer.set_method(Method.SSR)
        assert renderer.method == Method.DEPTH and renderer.graph.plan is renderer.plan
        renderer.set_time(0.0)
        renderer.bake_again()
        renderer.render()
        assert renderer.stats.depth_images_baked == 10  # the depth images, baked again on asking
        assert_same_frame(renderer.read_color_float(), before)


def test_an_edited_scene_may_gain_or_lose_its_reflectors(ctx: moderngl.Context, scene: Scene) -> None:
    """set_scene from a scene without a reflector to one with (the frame's reflector surfaces are
    made then) and back (they go): each frame the one a fresh renderer draws."""
    bare = dataclasses.replace(scene, objects=tuple(o for o in scene.objects if not o.is_reflector))
    with Renderer(ctx, bare) as renderer:
        renderer.render()
        assert renderer.targets.surfaces is None
        renderer.set_scene(scene)
        renderer.render()
        assert renderer.targets.surfaces is not None
        assert_same_frame(renderer.read_color_float(), fresh_frame(ctx, scene))
        renderer.set_scene(bare)
        renderer.render()
        assert renderer.targets.surfaces is None
        assert_same_frame(renderer.read_color_float(), fresh_frame(ctx, bare))


def test_a_resize_makes_glass_interiors_of_the_new_frame(ctx: moderngl.Context) -> None:
    """A glass object's interior image is as large as the frame's larger side: a resize makes it
    again at the new size (the plan counts it so), and the frame is a fresh renderer's."""
    glass = load_scene(SCENES / "glass_and_mirrors.toml").with_overrides(size=(96, 54), impostor_resolution=32)
    larger = glass.with_overrides(size=(128, 72))
    with Renderer(ctx, glass) as renderer:
        renderer.render()
        renderer.resize((128, 72))
        renderer.render()
        interiors = renderer.graph.glass_interiors
        assert interiors and all(interior.size == 128 for interior in interiors.values())
        assert_same_frame(renderer.read_color_float(), fresh_frame(ctx, larger))


def test_an_edited_scene_brings_its_texture_table_to_every_program(ctx: moderngl.Context) -> None:
    """Another texture of the same count (a size of its own: other texel rectangles; another wrap)
    reaches the programs made before the edit as well as those made after: the frame is a fresh
    renderer's."""
    textured = load_scene(SCENES / "textured_near_mirror.toml").with_overrides(size=(96, 54), impostor_resolution=32)
    old = textured.textures[0]
    rng = np.random.default_rng(7)
    image = np.concatenate([rng.integers(0, 256, (24, 40, 3)), np.full((24, 40, 1), 255)], axis=2).astype(np.uint8)
    new = dataclasses.replace(old, image=image, sampler={"wrapS": 33071, "wrapT": 33648}, scale=(2.0, 3.0))

    def swapped(material: object) -> object:
        return dataclasses.replace(material, texture=new) if getattr(material, "texture", None) is old else material  # type: ignore[type-var]

    edited = dataclasses.replace(textured, objects=tuple(dataclasses.replace(o, material=swapped(o.material))
                                                          for o in textured.objects))
    assert len(edited.textures) == len(textured.textures) and edited.textures[0] is new
    with Renderer(ctx, textured) as renderer:
        renderer.render()
        renderer.set_scene(edited)
        renderer.render()
        assert_same_frame(renderer.read_color_float(), fresh_frame(ctx, edited))


def test_a_refused_resize_keeps_the_frame_targets(ctx: moderngl.Context, scene: Scene,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """A change the graph refuses after the plan accepted it leaves the frame's targets as they were
    (the new ones are made first and let go), and the renderer draws on as before."""
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        before, targets = renderer.read_color_float(), renderer.targets

        def refuse(*_: object) -> None:
            raise RuntimeError("refused")
        monkeypatch.setattr(renderer.graph, "apply", refuse)
        with pytest.raises(RuntimeError):
            renderer.resize((SIZE[0] * 2, SIZE[1] * 2))
        monkeypatch.undo()
        assert renderer.targets is targets and targets.size == SIZE
        renderer.render()
        assert_same_frame(renderer.read_color_float(), before)
