"""The hard scenes (scenes/hard/) rendered end to end: no NaN or Inf, close to the ray-traced truth,
scale-free, refused clearly where no depth image can exist, and continuous under tiny motions."""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import moderngl
import numpy as np
import pytest

from conftest import SCENES, assert_finite
from depthimpostor.oracles.compare import compare, trace_truth
from depthimpostor.constants import NO_OBJECT
from depthimpostor.renderer import Renderer
from depthimpostor.scene import load_scene

HARD = SCENES / "hard"
RENDERED = ["top_down", "grazing", "touching", "silhouette", "tiny", "huge"]


def render(ctx: moderngl.Context, scene) -> Renderer:
    renderer = Renderer(ctx, scene, reflection_data=True)
    renderer.render()
    return renderer


@pytest.mark.parametrize("name", RENDERED)
def test_hard_scene_is_finite_and_close_to_the_truth(ctx: moderngl.Context, name: str) -> None:
    scene = load_scene(HARD / f"{name}.toml").with_overrides(size=(320, 180))
    with render(ctx, scene) as renderer:
        assert_finite(renderer.read_color_float())
        figures = compare(renderer).figures
    assert figures.mirror_pixels > 2000
    assert figures.wrong_object_share < 0.012, f"{100 * figures.wrong_object_share:.2f} % wrong object"
    assert figures.geometric_error_median < 0.003, f"median {100 * figures.geometric_error_median:.3f} % of radius"


def test_scale_changes_nothing(ctx: moderngl.Context) -> None:
    """The default scene at 1e-3 and 1e4 times its size renders the same picture."""
    size = (320, 180)
    with render(ctx, load_scene(SCENES / "default.toml").with_overrides(size=size)) as renderer:
        unit = renderer.read_color_float()
    for name in ("tiny", "huge"):
        with render(ctx, load_scene(HARD / f"{name}.toml").with_overrides(size=size)) as renderer:
            scaled = renderer.read_color_float()
        difference = np.abs(scaled - unit).max(axis=2)
        assert (difference > 8 / 255).mean() < 0.002, f"{name}: {(difference > 8 / 255).mean():.2%} of pixels differ"


def test_object_surrounding_the_mirror_centre_is_refused_clearly() -> None:
    result = subprocess.run(
        [sys.executable, "-m", "depthimpostor", "render", str(HARD / "surrounds.toml"), "-o", "/dev/null"],
        capture_output=True, text=True,
    )
    assert result.returncode == 2
    assert "surrounds or touches the centre of mirror" in result.stderr
    assert "Traceback" not in result.stderr


def test_mirror_with_cancelling_normals_stays_finite(ctx: moderngl.Context) -> None:
    """Vertex normals that are exact opposites interpolate through zero inside every triangle;
    safe_normalize falls back to facing the viewer, so the ray goes back the way it came."""
    scene = load_scene(HARD / "top_down.toml").with_overrides(size=(160, 90))
    renderer = Renderer(ctx, scene, reflection_data=True)
    mirror = renderer.world.mirrors[0]
    mesh = mirror.local_mesh
    vertices = mesh.interleaved().copy()
    vertices[1::2, 3:6] *= -1.0  # alternate vertices point down: every triangle has opposite normals
    arena = renderer.graph.meshes.arena(mesh)  # the GPU's copy of the mesh, in the world's vertex buffer
    arena.vertices.write(vertices.tobytes(), offset=arena.first_vertex[mesh] * vertices.itemsize * vertices.shape[1])
    with renderer:
        renderer.render()
        assert_finite(renderer.read_color_float())
        data = renderer.read_reflection_data()
        assert data.mirror_mask.sum() > 1000
        assert np.isfinite(data.direction[data.mirror_mask]).all()
        assert np.allclose(np.linalg.norm(data.direction[data.mirror_mask], axis=1), 1.0, atol=1e-4)


def changed_pixels(before: np.ndarray, after: np.ndarray) -> int:
    return int((np.abs(before - after).max(axis=2) > 2 / 255).sum())


@pytest.mark.parametrize("moved", ["camera", "object"])
def test_tiny_motion_changes_only_what_the_truth_changes(ctx: moderngl.Context, moved: str) -> None:
    """Moving the camera or an object by 1e-6 of the scene's size changes next to no pixel beyond
    2/255, and no more than the ray-traced truth itself changes (at silhouettes)."""
    scene = load_scene(SCENES / "default.toml").with_overrides(size=(320, 180))
    step = 1e-6 * 10.0  # the floor, the scene's largest extent, is 20 units across
    if moved == "camera":
        eye = tuple(np.add(scene.camera.eye, [step, -step, step]).tolist())
        nudged = dataclasses.replace(scene, camera=dataclasses.replace(scene.camera, eye=eye))
    else:
        objects = list(scene.objects)
        index = next(i for i, o in enumerate(objects) if o.name == "green_torus")
        position = tuple(np.add(objects[index].position, [step, step, -step]).tolist())
        objects[index] = dataclasses.replace(objects[index], position=position)
        nudged = dataclasses.replace(scene, objects=tuple(objects))
    frames, truths = [], []
    for version in (scene, nudged):
        with render(ctx, version) as renderer:
            image = np.clip(renderer.read_color_float(), 0.0, 1.0)
            data = renderer.read_reflection_data()
            truth = trace_truth(renderer, data)
            frames.append(image)
            truths.append(np.where(data.mirror_mask[..., None], truth.color, image))
            assert (truth.object_id[data.mirror_mask] != NO_OBJECT).any()
    ours, theirs = changed_pixels(*frames), changed_pixels(*truths)
    assert ours <= max(4, 2 * theirs), f"{ours} pixels changed, the truth {theirs}"
