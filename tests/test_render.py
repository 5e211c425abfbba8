"""End-to-end renders: every project scene, exact colours, the passes a scene calls for."""

from __future__ import annotations

from pathlib import Path

import moderngl
import numpy as np
import pytest

from conftest import SCENES, assert_finite
from depthimpostor.constants import Algorithm
from depthimpostor.ppc import PPC
from depthimpostor.passes.diffuse import has_checker
from depthimpostor.renderer import Renderer
from depthimpostor.scene import load_scene, parse_scene

SCENE_FILES = sorted(SCENES.glob("*.toml"))


@pytest.mark.parametrize("path", SCENE_FILES, ids=lambda p: p.stem)
@pytest.mark.parametrize("algorithm", list(Algorithm), ids=lambda a: a.name.lower())
def test_every_scene_renders_finite_pixels(ctx: moderngl.Context, path: Path, algorithm: Algorithm) -> None:
    scene = load_scene(path).with_overrides(size=(192, 108), impostor_resolution=64)
    with Renderer(ctx, scene, algorithm) as renderer:
        renderer.render()
        image = renderer.read_color_float()
    assert_finite(image)
    assert image.std() > 0.05, "the frame is (nearly) a flat colour"


def exact_colour_scene(tmp_path: Path) -> dict:
    """A white mirror sphere and pure-colour objects, ambient 1 and no lights: every pixel of an
    object is exactly its colour, and so is every mirror pixel that reflects it."""
    return {
        "render": {"size": [160, 120], "impostor_resolution": 128, "ambient": 1.0},
        "camera": {"eye": [0.0, 1.0, 4.0], "target": [0.0, 1.0, 0.0], "fov_y": 40.0},
        "environment": {"type": "constant", "color": [0.0, 0.0, 1.0]},
        "objects": [
            {"name": "mirror", "shape": {"type": "sphere", "radius": 1.0},
             "material": {"type": "mirror", "tint": [1.0, 1.0, 1.0]}, "position": [0.0, 1.0, 0.0]},
            {"name": "red", "shape": {"type": "box", "size": [0.6, 0.6, 0.6]},
             "material": {"type": "diffuse", "color": [1.0, 0.0, 0.0]}, "position": [-1.2, 1.0, 2.0]},
            {"name": "green", "shape": {"type": "torus", "major": 0.4, "minor": 0.15},
             "material": {"type": "diffuse", "color": [0.0, 1.0, 0.0]}, "position": [1.2, 1.0, 2.0],
             "rotation": [90.0, 0.0, 0.0]},
        ],
    }


def mirror_disc(image: np.ndarray) -> np.ndarray:
    """Pixels well inside the sphere's silhouette (it is centred in the frame)."""
    height, width = image.shape[:2]
    v, u = np.mgrid[0:height, 0:width]
    # The sphere's apparent radius: 1 / (4 * tan(20 deg)) of the frame height, about 0.69 * h / 2.
    radius = 0.6 * (height / 2) / (4 * np.tan(np.radians(20)))
    return (u + 0.5 - width / 2) ** 2 + (v + 0.5 - height / 2) ** 2 < radius**2


def test_mirror_shows_exactly_the_colours_it_reflects(ctx: moderngl.Context, tmp_path: Path) -> None:
    scene = parse_scene(exact_colour_scene(tmp_path), "test", tmp_path)
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        image = renderer.read_color_float()
    assert_finite(image)
    disc = image[mirror_disc(image)]
    palette = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float32)
    nearest = np.abs(disc[:, None, :] - palette[None]).max(axis=2).min(axis=1)
    assert (nearest < 1e-6).mean() > 0.99, "mirror pixels should be exactly an object's or the environment's colour"
    # Both objects are in front of the mirror, off to the sides: each shows up in the reflection.
    for colour in palette[:2]:
        assert (np.abs(disc - colour).max(axis=1) < 1e-6).sum() > 20
    # Outside the mirror, the directly visible objects have exactly their colours too.
    assert (np.abs(image[~mirror_disc(image)] - palette[0]).max(axis=1) < 1e-6).sum() > 100


def test_basic_and_optimized_render_the_same_picture(ctx: moderngl.Context) -> None:
    scene = load_scene(SCENES / "default.toml").with_overrides(size=(240, 135), impostor_resolution=128)
    images = []
    for algorithm in Algorithm:
        with Renderer(ctx, scene, algorithm) as renderer:
            renderer.render()
            images.append(renderer.read_color_float())
    differs = np.abs(images[0] - images[1]).max(axis=2) > 2 / 255
    assert differs.mean() < 0.002


def test_scene_without_mirrors_allocates_no_impostor(ctx: moderngl.Context, tmp_path: Path) -> None:
    data = exact_colour_scene(tmp_path)
    data["objects"] = data["objects"][1:]  # drop the mirror
    scene = parse_scene(data, "test", tmp_path)
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        assert renderer.graph.impostors is None
        assert renderer.graph.reflector_pass is None
        assert renderer.stats.depth_images_baked == 0
        compiled = {fragment for _, fragment, _ in renderer.programs.variants}
        assert compiled == {"environment.frag", "diffuse.frag"}
        variants = [defines for _, fragment, defines in renderer.programs.variants if fragment == "diffuse.frag"]
        # One batch of the still objects; without the checker's code where none has one (NO_CHECKER).
        checker = () if has_checker(scene.objects) else (("NO_CHECKER", "1"),)
        materials = ("MATERIAL_COUNT", str(len(scene.materials)))  # the material table's size
        assert variants == [(("INSTANCED", "1"), ("LIGHT_COUNT", str(len(scene.lights))), materials, *checker,
                             ("WRITE_DEPTH_IMAGE", "0"))]


def test_depth_images_are_baked_once_and_not_for_camera_moves(ctx: moderngl.Context) -> None:
    scene = load_scene(SCENES / "grid_3x3.toml").with_overrides(size=(96, 54), impostor_resolution=32)
    with Renderer(ctx, scene) as renderer:
        assert renderer.graph.impostors is not None
        count = len(renderer.graph.impostors.depth_images)
        assert count == 8 * 1  # eight mirrors around one object; the floor is analytic
        for _ in range(3):
            renderer.render()
        renderer.set_camera(PPC.look_at([3.0, 2.0, 3.0], [0.0, 0.5, 0.0], [0.0, 1.0, 0.0], 50.0, 96, 54))
        renderer.render()
        assert renderer.stats.depth_images_baked == count
        assert renderer.graph.impostors.bakes == count
        assert renderer.stats.frames == 4


def test_lecture_scene_has_72_depth_images(ctx: moderngl.Context) -> None:
    scene = load_scene(SCENES / "lecture_8x9.toml").with_overrides(size=(96, 54), impostor_resolution=16)
    with Renderer(ctx, scene) as renderer:
        assert renderer.graph.impostors is not None
        assert len(renderer.graph.impostors.depth_images) == 72
