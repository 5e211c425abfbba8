"""The eye's depth (depthimpostor/eye.py): reversed-Z into a float depth buffer, no far plane, so
that objects 1e4 to 1e7 units away change no pixel of a scene within 5 units but their own."""

from __future__ import annotations

import dataclasses

import moderngl
import numpy as np
import pytest

from conftest import SCENES, assert_finite
from depthimpostor import eye
from depthimpostor.constants import Method
from depthimpostor.renderer import Renderer
from depthimpostor.scene import BoxShape, DiffuseMaterial, Scene, SceneObject, load_scene

SIZE = (160, 90)
FAR = (1e4, 1e6, 1e7)
#: Each far box is this share of its distance across: a few pixels of the frame.
FAR_BOX_SHARE = 0.02


@pytest.fixture(scope="module")
def scene() -> Scene:
    return load_scene(SCENES / "default.toml").with_overrides(size=SIZE, impostor_resolution=64)


def far_boxes(scene: Scene) -> list[SceneObject]:
    """A box at each of FAR, in the sky above the near scene (and so also in the mirror sphere's
    view of it), each in its own direction."""
    position = np.asarray(scene.camera.eye, float)
    boxes = []
    for index, distance in enumerate(FAR):
        direction = np.array([0.3 - 0.25 * index, 0.1, -1.0])
        centre = position + distance * direction / np.linalg.norm(direction)
        size = FAR_BOX_SHARE * distance
        boxes.append(SceneObject(f"far_{distance:g}", BoxShape((size, size, size)), DiffuseMaterial((0.9, 0.2, 0.6)),
                                 position=tuple(float(c) for c in centre)))
    return boxes


def frame_and_far_pixels(ctx: moderngl.Context, scene: Scene, far: set[int]) -> tuple[np.ndarray, np.ndarray]:
    """The frame, and where it shows an object of `far` (by index): seen directly (its projected
    bounding sphere, two pixels wider) or in a mirror (the reflection data's object ids)."""
    with Renderer(ctx, scene, reflection_data=True) as renderer:
        renderer.render()
        frame = renderer.read_color_float()
        reflected = np.isin(renderer.read_reflection_data().object_id, list(far))
        camera = renderer.camera
        rows, columns = np.mgrid[0:SIZE[1], 0:SIZE[0]]
        direct = np.zeros_like(reflected)
        for g in renderer.world.geometry:
            if g.index in far:
                centre, radius = g.bounding_sphere
                u, v, w = camera.camera_coordinates(centre)
                pixels = radius / (w * float(np.linalg.norm(camera.a))) + 2.0
                # Rows top first, as the frame comes back; image row v counts from the top too.
                direct |= (columns + 0.5 - u / w) ** 2 + (rows + 0.5 - v / w) ** 2 <= pixels**2
    return frame, direct | reflected


def test_far_objects_change_no_pixel_of_the_near_scene_but_their_own(ctx: moderngl.Context, scene: Scene) -> None:
    near, _ = frame_and_far_pixels(ctx, scene, set())
    with_far = dataclasses.replace(scene, objects=[*scene.objects, *far_boxes(scene)])
    far_indices = set(range(len(scene.objects), len(with_far.objects)))
    frame, far_pixels = frame_and_far_pixels(ctx, with_far, far_indices)
    assert_finite(frame)
    changed = np.abs(frame - near).max(axis=2) > 1e-6
    assert far_pixels.mean() < 0.03, "the far boxes should cover a few pixels, not the frame"
    assert changed.any(), "the far boxes should be seen"
    assert not (changed & ~far_pixels).any(), f"{int((changed & ~far_pixels).sum())} near pixels changed"


def test_the_eye_camera_has_no_far_plane_and_a_near_plane_short_of_the_nearest_object(
        ctx: moderngl.Context, scene: Scene) -> None:
    with_far = dataclasses.replace(scene, objects=[*scene.objects, *far_boxes(scene)])
    with Renderer(ctx, with_far) as renderer:
        camera = renderer.camera
        assert renderer.reversed_z and isinstance(camera, eye.EyeCamera)
        # Window depth w_near / w: 1 on the near plane, falling toward 0 and never below it.
        clip = camera.view_projection @ np.array([*with_far.objects[-1].position, 1.0])
        assert 0.0 < clip[2] / clip[3] < 1e-6
        # The floor is 1.6 below the eye; with OpenGL's depth the near plane was 1e-3 of 1e7.
        assert camera.near < 0.01


@pytest.mark.parametrize("method", [Method.DEPTH, Method.CUBEMAP, Method.RAYTRACE])
def test_reversed_z_draws_what_opengl_depth_drew(ctx: moderngl.Context, scene: Scene, method: Method,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """Without far objects, both conventions see the same surfaces: the frames agree but for a
    few pixels where two surfaces meet (the two depth buffers round differently there)."""
    with Renderer(ctx, scene, method=method) as renderer:
        renderer.render()
        reversed_frame = renderer.read_color_float()
    monkeypatch.setitem(eye._support, ctx, None)  # as on a GL without clip control
    with Renderer(ctx, scene, method=method) as renderer:
        assert not renderer.reversed_z and not isinstance(renderer.camera, eye.EyeCamera)
        renderer.render()
        opengl_frame = renderer.read_color_float()
    assert (np.abs(reversed_frame - opengl_frame).max(axis=2) > 1e-3).mean() < 0.002


def test_a_gl_without_clip_control_warns_and_keeps_the_opengl_projection(monkeypatch: pytest.MonkeyPatch) -> None:
    class OldGL:  # the little of a moderngl.Context that reversed_z reads
        version_code = 330
        extensions: set[str] = set()
        info = {"GL_RENDERER": "an old GL"}

    old = OldGL()
    monkeypatch.setattr(eye, "_support", {})
    with pytest.warns(RuntimeWarning, match=r"no glClipControl .* use a GL 4\.5 driver"):
        assert eye.reversed_z(old) is None  # type: ignore[arg-type]
