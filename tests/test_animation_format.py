"""Animated objects and lights, and `impostor_resolution = "auto"`: what the scene format reads and what
the model does with it at a given time. The refusals are in test_scene.py's table of bad scenes."""

from __future__ import annotations

import math
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from test_scene import OK, an_object, write

from depthimpostor.errors import SceneError
from depthimpostor.scene import (
    AUTO_RESOLUTION,
    Animation,
    GlassMaterial,
    Light,
    MirrorMaterial,
    PlaneShape,
    RenderSettings,
    SceneObject,
    SphereShape,
    load_scene,
)
from depthimpostor.scene.model import axis_rotation

ANIMATED = """
[[lights]]
type = "point"
position = [3, 2, 0]
animation = { type = "orbit", centre = [1, 2, 0], axis = [0, 1, 0], degrees_per_second = -20 }
[[lights]]
type = "directional"
direction = [1, -1, 0]
animation = { type = "rotate", axis = [0, 2, 0], degrees_per_second = 90 }
[[lights]]
type = "directional"
direction = [0, -1, 0]
[[objects]]
name = "spinner"
shape = { type = "sphere", radius = 0.5 }
position = [1, 0.5, 0]
animation = { type = "rotate", axis = [0, 1, 0], degrees_per_second = 30 }
[[objects]]
name = "moon"
shape = { type = "box", size = [1, 1, 1] }
position = [2, 1, 0]
animation = { type = "orbit", centre = [0, 0, 0], axis = [0, 0, 3], degrees_per_second = -20 }
[[objects]]
name = "swinging mirror"
shape = { type = "plane", size = [2, 1] }
material = { type = "mirror" }
animation = { type = "rotate", axis = [1, 0, 0], degrees_per_second = 5 }
[[objects]]
name = "glass"
shape = { type = "sphere", radius = 0.3 }
material = { type = "glass" }
animation = { type = "orbit", centre = [0, 1, 0], axis = [0, 1, 0], degrees_per_second = 45 }
[[objects]]
name = "floor"
shape = { type = "plane", size = [10, 10] }
"""

Y_AXIS = (0.0, 1.0, 0.0)


def homogeneous(point: tuple[float, ...]) -> np.ndarray:
    return np.array([*point, 1.0])


# --- Reading ------------------------------------------------------------------------------------


def test_animations_of_objects_and_lights_are_read(tmp_path: Path) -> None:
    scene = load_scene(write(tmp_path, ANIMATED))
    orbiting, turning, still = scene.lights
    assert orbiting.animation == Animation("orbit", Y_AXIS, -20.0, (1.0, 2.0, 0.0))
    assert turning.animation == Animation("rotate", Y_AXIS, 90.0)  # the axis comes back at unit length
    assert still.animation is None and not still.moves and orbiting.moves and turning.moves
    spinner, moon, mirror, glass, floor = scene.objects
    assert spinner.animation == Animation("rotate", Y_AXIS, 30.0) and spinner.animation.centre is None
    assert moon.animation == Animation("orbit", (0.0, 0.0, 1.0), -20.0, (0.0, 0.0, 0.0))
    assert isinstance(mirror.shape, PlaneShape) and isinstance(mirror.material, MirrorMaterial) and mirror.moves
    assert isinstance(glass.material, GlassMaterial) and glass.moves
    assert floor.animation is None and not floor.moves
    assert scene.animated


def test_a_scene_without_animations_is_not_animated(tmp_path: Path) -> None:
    scene = load_scene(write(tmp_path, '[[lights]]\ntype = "point"\nposition = [0, 3, 0]\n' + OK))
    assert not scene.animated and scene.lights_at(12.5) == scene.lights


@pytest.mark.parametrize("moving", ["light", "object"])
def test_one_moving_thing_animates_the_scene(tmp_path: Path, moving: str) -> None:
    animation = 'animation = { type = "rotate", axis = [0, 1, 0], degrees_per_second = 1 }'
    light = '[[lights]]\ntype = "directional"\ndirection = [0, -1, 0]\n'
    text = (light + animation + "\n" + OK) if moving == "light" else (light + an_object(extra=animation))
    assert load_scene(write(tmp_path, text)).animated


def test_axis_is_normalized_even_when_tiny() -> None:
    assert Animation("rotate", (0.0, 0.0, 1e-200), 1.0).axis == (0.0, 0.0, 1.0)
    axis = Animation("rotate", (3.0, 0.0, 4.0), 1.0).axis
    assert axis == pytest.approx((0.6, 0.0, 0.8)) and math.hypot(*axis) == pytest.approx(1.0)
    with pytest.raises(ValueError, match="not all zero"):
        Animation("rotate", (0.0, 0.0, 0.0), 1.0)


# --- The transform ------------------------------------------------------------------------------


@pytest.mark.parametrize("animation", [Animation("rotate", (1.0, 2.0, 3.0), 17.0),
                                       Animation("orbit", Y_AXIS, -20.0, (4.0, 5.0, 6.0))])
def test_time_zero_is_exactly_the_identity(animation: Animation) -> None:
    assert animation.angle(0.0) == 0.0
    matrix = animation.matrix(0.0, (0.1, 0.2, 0.3))
    assert matrix.dtype == np.float64 and np.array_equal(matrix, np.eye(4))


def test_angle_grows_with_time_modulo_a_full_turn() -> None:
    assert Animation("rotate", Y_AXIS, -20.0).angle(1.5) == pytest.approx(330.0)
    assert Animation("rotate", Y_AXIS, 100.0).angle(4.0) == pytest.approx(40.0)


def test_a_far_time_turns_by_its_true_angle() -> None:
    """rate * time overflows to Inf at 1e308 s (and cos(Inf) is a domain error): the angle is
    taken exactly, modulo 360, and the turn stays a rotation."""
    animation = Animation("rotate", Y_AXIS, 30.0)
    angle = animation.angle(1e308)
    assert 0.0 <= angle < 360.0 and angle == float(Fraction(30) * Fraction(1e308) % 360)
    rotation = animation.rotation(1e308)
    assert np.allclose(rotation @ rotation.T, np.eye(3))


@pytest.mark.parametrize("axis", [0, 1, 2])
@pytest.mark.parametrize("degrees", [90.0, -37.0, 200.0])
def test_turns_about_principal_axes_agree_with_axis_rotation(axis: int, degrees: float) -> None:
    unit = tuple(float(i == axis) for i in range(3))
    matrix = Animation("rotate", unit, degrees).matrix(1.0, (0.0, 0.0, 0.0))  # type: ignore[arg-type]
    np.testing.assert_allclose(matrix[:3, :3], axis_rotation(axis, degrees), atol=1e-12)
    np.testing.assert_array_equal(matrix[3], (0.0, 0.0, 0.0, 1.0))


def test_a_turn_about_any_axis_is_right_handed() -> None:
    # In a right-handed basis (u, v, k) the turn about k by an angle is the one about Z by it.
    k = np.array([1.0, -2.0, 0.5]) / np.linalg.norm([1.0, -2.0, 0.5])
    u = np.cross(k, (1.0, 0.0, 0.0))
    u /= np.linalg.norm(u)
    basis = np.column_stack([u, np.cross(k, u), k])
    animation = Animation("rotate", (1.0, -2.0, 0.5), 25.0)
    expected = basis @ axis_rotation(2, 50.0) @ basis.T
    np.testing.assert_allclose(animation.matrix(2.0, (0.0, 0.0, 0.0))[:3, :3], expected, atol=1e-12)


def test_the_pivot_stays_put_and_the_turn_is_rigid() -> None:
    pivot = (1.0, -2.0, 3.0)
    matrix = Animation("rotate", (1.0, 1.0, 0.0), 33.0).matrix(0.7, pivot)
    np.testing.assert_allclose(matrix @ homogeneous(pivot), homogeneous(pivot), atol=1e-12)
    np.testing.assert_allclose(matrix[:3, :3] @ matrix[:3, :3].T, np.eye(3), atol=1e-12)
    assert np.linalg.det(matrix[:3, :3]) == pytest.approx(1.0)


def test_pivot_is_the_centre_of_an_orbit_and_the_position_of_a_rotation() -> None:
    assert Animation("orbit", Y_AXIS, 1.0, (1.0, 2.0, 3.0)).pivot_of((7.0, 8.0, 9.0)) == (1.0, 2.0, 3.0)
    assert Animation("rotate", Y_AXIS, 1.0).pivot_of((7, 8, 9)) == (7.0, 8.0, 9.0)


# --- Objects ------------------------------------------------------------------------------------


def test_rotating_90_per_second_about_y_takes_plus_x_to_minus_z_after_a_second() -> None:
    obj = SceneObject("a", SphereShape(1.0), position=(1.0, 2.0, 3.0), animation=Animation("rotate", Y_AXIS, 90.0))
    moved = obj.model_matrix(1.0) @ (1.0, 0.0, 0.0, 1.0)  # the object's local +X, one unit off its position
    np.testing.assert_allclose(moved, (1.0, 2.0, 2.0, 1.0), atol=1e-12)
    np.testing.assert_allclose(axis_rotation(1, 90.0) @ (1.0, 0.0, 0.0), (0.0, 0.0, -1.0), atol=1e-12)


def test_model_matrix_turns_the_static_transform_about_the_pivot() -> None:
    animation = Animation("rotate", (0.0, 1.0, 1.0), 40.0)
    obj = SceneObject("a", SphereShape(1.0), position=(1.0, 2.0, 3.0), rotation=(10.0, 20.0, 30.0),
                      scale=(1.0, 2.0, 3.0), animation=animation)
    static = SceneObject("a", SphereShape(1.0), position=obj.position, rotation=obj.rotation,
                         scale=obj.scale).model_matrix()
    assert np.array_equal(obj.model_matrix(), static) and np.array_equal(obj.model_matrix(0.0), static)
    for time in (0.3, 1.0, 7.5):
        np.testing.assert_allclose(obj.model_matrix(time), animation.matrix(time, obj.position) @ static,
                                   atol=1e-12)
        # A rotating object stays where it is.
        np.testing.assert_allclose(obj.model_matrix(time)[:3, 3], obj.position, atol=1e-12)


def test_an_orbiting_object_keeps_its_distance_to_the_centre() -> None:
    centre = (0.0, 1.0, 0.0)
    obj = SceneObject("a", SphereShape(0.3), position=(2.0, 1.0, 0.0), rotation=(0.0, 45.0, 0.0),
                      animation=Animation("orbit", Y_AXIS, 45.0, centre))
    at_two_seconds = obj.model_matrix(2.0)  # 90 degrees round +Y: +X goes to -Z
    np.testing.assert_allclose(at_two_seconds[:3, 3], (0.0, 1.0, -2.0), atol=1e-12)
    for time in (0.5, 1.3, 4.0):
        position = obj.model_matrix(time)[:3, 3]
        assert math.dist(position, centre) == pytest.approx(2.0)
    # The object turns with its orbit (as the moon does), so it shows the centre the same face.
    np.testing.assert_allclose(at_two_seconds[:3, :3], axis_rotation(1, 90.0) @ axis_rotation(1, 45.0), atol=1e-12)


# --- Lights -------------------------------------------------------------------------------------


def test_an_orbiting_point_light_moves_on_its_circle(tmp_path: Path) -> None:
    light = load_scene(write(tmp_path, ANIMATED)).lights[0]
    centre = np.array((1.0, 2.0, 0.0))
    assert light.at(0.0) == light
    for time in (0.5, 1.5, 9.0):
        moved = light.at(time)
        offset, start = np.subtract(moved.position, centre), np.subtract(light.position, centre)
        assert np.linalg.norm(offset) == pytest.approx(np.linalg.norm(start))
        assert offset[1] == pytest.approx(start[1], abs=1e-12)  # the circle is square to the axis
        np.testing.assert_allclose(offset, axis_rotation(1, -20.0 * time) @ start, atol=1e-12)
        assert moved.direction == light.direction == (0.0, 0.0, 0.0) and moved.animation == light.animation
    # -20 degrees a second for 4.5 seconds: -90 about +Y takes the +X offset to +Z.
    np.testing.assert_allclose(light.at(4.5).position, (1.0, 2.0, 2.0), atol=1e-12)


def test_a_rotating_directional_light_turns_its_direction(tmp_path: Path) -> None:
    scene = load_scene(write(tmp_path, ANIMATED))
    light = scene.lights[1]
    np.testing.assert_allclose(light.at(1.0).direction, (0.0, -1.0, -1.0), atol=1e-12)
    assert light.at(1.0).position == (0.0, 0.0, 0.0)
    at_half = scene.lights_at(0.5)
    assert len(at_half) == 3 and at_half[2] == scene.lights[2]
    np.testing.assert_allclose(at_half[1].direction, axis_rotation(1, 45.0) @ (1.0, -1.0, 0.0), atol=1e-12)
    np.testing.assert_allclose(at_half[0].position, scene.lights[0].at(0.5).position)


def test_a_light_without_animation_is_itself_at_any_time() -> None:
    light = Light("point", position=(1.0, 2.0, 3.0))
    assert light.at(3.0) is light and not light.moves


# --- impostor_resolution = "auto" ---------------------------------------------------------------


def test_auto_resolution_is_read(tmp_path: Path) -> None:
    render = load_scene(write(tmp_path, '[render]\nimpostor_resolution = "auto"\n' + OK)).render
    assert render.impostor_resolution == AUTO_RESOLUTION == "auto" and render.auto_resolution
    assert not load_scene(write(tmp_path, OK)).render.auto_resolution
    assert not RenderSettings(impostor_resolution=128).auto_resolution


def test_with_overrides_accepts_auto_and_back(tmp_path: Path) -> None:
    scene = load_scene(write(tmp_path, OK))
    auto = scene.with_overrides(impostor_resolution="auto")
    assert auto.render.auto_resolution and auto.render.size == scene.render.size
    assert auto.with_overrides(impostor_resolution=64).render.impostor_resolution == 64
    with pytest.raises(SceneError, match=r'^command line: --impostor-res: expected an integer in \[4, 4096\] '
                                         r'or "auto", got "Auto"$'):
        scene.with_overrides(impostor_resolution="Auto")
