"""The viewer's camera controls and key handling, without a window."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from conftest import PROJECT_ROOT
from depthimpostor.ppc import PPC
from depthimpostor.scene.model import Camera
from depthimpostor.viewer.app import next_resolution, save_numbered
from depthimpostor.viewer.keys import BINDINGS, KEY_CODES, KeyScriptError, controls_markdown, parse_key_script
from depthimpostor.viewer.navigation import PITCH_MARGIN_DEGREES, ZOOM_STEP, Navigation

HOME = Camera((0.0, 1.6, 5.0), (0.0, 0.6, 0.0), (0.0, 1.0, 0.0), 45.0)


def elevation(vector: np.ndarray) -> float:
    return float(np.degrees(np.arcsin(vector[1] / np.linalg.norm(vector))))


def test_orbit_circles_the_target_and_stops_short_of_the_poles() -> None:
    navigation = Navigation(HOME, scene_radius=2.0)
    start = navigation.eye.copy()
    navigation.turn(90.0, 0.0)
    assert navigation.eye == pytest.approx([np.hypot(5.0, 0.0), 1.6, 0.0], abs=1e-12), "to the eye's right: +x"
    for _ in range(3):
        navigation.turn(90.0, 0.0)
    assert navigation.eye == pytest.approx(start, abs=1e-12)
    navigation.turn(0.0, 30.0)
    assert elevation(navigation.eye - navigation.target) == pytest.approx(elevation(start - HOME.target) + 30.0)
    navigation.turn(0.0, 500.0)
    assert elevation(navigation.eye - navigation.target) == pytest.approx(90.0 - PITCH_MARGIN_DEGREES)
    assert navigation.target == pytest.approx(HOME.target)
    assert navigation.distance == pytest.approx(np.linalg.norm(np.subtract(HOME.eye, HOME.target)))


def test_orbit_from_a_camera_looking_straight_down_stays_finite() -> None:
    top_down = Camera((0.0, 5.0, 0.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), 45.0)
    navigation = Navigation(top_down, scene_radius=1.0)
    navigation.turn(10.0, -10.0)
    assert np.isfinite(navigation.eye).all()
    assert elevation(navigation.eye - navigation.target) == pytest.approx(80.0)


def test_fly_turns_about_the_eye_and_moves_along_the_view() -> None:
    navigation = Navigation(HOME, scene_radius=2.0)
    navigation.toggle_fly()
    navigation.turn(90.0, 0.0)  # look left: from -z to -x
    assert navigation.eye == pytest.approx(HOME.eye)
    forward = navigation.frame()[2]
    assert forward[0] < -0.9
    navigation.fly(1.0, 0.0, 0.0, seconds=0.5)
    assert navigation.eye == pytest.approx(np.add(HOME.eye, forward * 0.5 * 0.5 * 2.0))
    navigation.reset()
    assert navigation.view() == HOME and not navigation.flying


def test_pan_moves_the_scene_with_the_cursor_on_hidpi_screens_too() -> None:
    """The cursor moves in screen units, the frame has twice as many pixels each way: the target
    must move 2 dx frame pixels."""
    window_height, frame_size = 270, (960, 540)
    navigation = Navigation(HOME, scene_radius=2.0)
    target = np.asarray(HOME.target)
    navigation.pan(10.0, -4.0, window_height)
    view = navigation.view()
    camera = PPC.look_at(view.eye, view.target, view.up, view.fov_y, *frame_size)
    u, v, _ = camera.project(target)
    assert (u, v) == pytest.approx((frame_size[0] / 2 + 20.0, frame_size[1] / 2 - 8.0), abs=1e-6)


def test_zoom_steps_and_limits() -> None:
    navigation = Navigation(HOME, scene_radius=2.0)
    distance = navigation.distance
    navigation.zoom(2.0)
    assert navigation.distance == pytest.approx(distance * ZOOM_STEP**2)
    navigation.zoom(1000.0)
    assert navigation.distance == pytest.approx(2e-3)
    assert navigation.target == pytest.approx(HOME.target)


def test_key_scripts() -> None:
    presses = parse_key_script("right*3 ] wait*2 shift+w escape")
    assert [p.token for p in presses] == ["right*3"] * 3 + ["]"] + ["wait*2"] * 2 + ["shift+w", "escape"]
    assert presses[3].key == KEY_CODES["right_bracket"] and presses[4].key is None and presses[6].mods == 1
    for bad in ("ctl+a", "nosuchkey", "f12*x"):
        with pytest.raises(KeyScriptError, match="--keys: token 1"):
            parse_key_script(bad)


def test_every_binding_is_a_known_key_and_no_key_does_two_things() -> None:
    keys = [KEY_CODES[key] for binding in BINDINGS for key in binding.keys]
    assert len(keys) == len(set(keys))


def test_readme_lists_every_control() -> None:
    readme = (PROJECT_ROOT / "docs" / "guide.md").read_text(encoding="utf-8")
    assert controls_markdown() in readme, "docs/guide.md's controls table differs from viewer/keys.py: paste controls_markdown()"


def test_resolution_steps() -> None:
    assert next_resolution(256, up=True) == 512
    assert next_resolution(300, up=False) == 256
    assert next_resolution(4096, up=True) == 4096
    assert next_resolution(8, up=False) == 8


def test_numbered_screenshots_never_overwrite(tmp_path: Path) -> None:
    image = np.zeros((4, 6, 3), np.uint8)
    (tmp_path / "scene-0001.png").write_bytes(b"someone else's")
    assert save_numbered(image, tmp_path, "scene").name == "scene-0002.png"
    assert save_numbered(image, tmp_path, "scene").name == "scene-0003.png"
    assert (tmp_path / "scene-0001.png").read_bytes() == b"someone else's"
