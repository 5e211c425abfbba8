"""The viewer's camera: orbit around a target, pan, zoom, or fly; pure numpy, no window.

The state is an eye and a target (the view direction and the orbit distance follow from them)
under a fixed world up. Orbiting turns the eye about the target; flying turns the target about
the eye. Both keep the line of sight at least PITCH_MARGIN_DEGREES away from straight up or
down, where "right" and therefore the next turn would be undefined.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pyrr

from ..ppc import orthonormal_frame
from ..scene.model import Camera

PITCH_MARGIN_DEGREES = 1.0
#: Each wheel step moves the eye this share of the way to the target (or back).
ZOOM_STEP = 0.85
#: Fly speed in scene radii per second (Shift: FAST_FACTOR times that).
FLY_RADII_PER_SECOND = 0.5
FAST_FACTOR = 4.0


def scene_radius(bounds: Sequence[tuple[np.ndarray, float]]) -> float:
    """The radius about the middle of the objects' bounding spheres that holds them all (1 for none):
    the scale of zoom limits and fly speed (`Navigation.scene_radius`)."""
    if not bounds:
        return 1.0
    centres = np.array([centre for centre, _ in bounds])
    middle = centres.mean(axis=0)
    return max(float(np.linalg.norm(centre - middle)) + radius for centre, radius in bounds)


def _unit(vector: np.ndarray) -> np.ndarray:
    return vector / np.linalg.norm(vector)


def _rotate(vector: np.ndarray, axis: np.ndarray, degrees: float) -> np.ndarray:
    """`vector` turned `degrees` about the unit `axis`, right-handed (a pyrr quaternion)."""
    turn = pyrr.quaternion.create_from_axis_rotation(axis, math.radians(degrees), dtype=np.float64)
    return np.asarray(pyrr.quaternion.apply_to_vector(turn, vector), dtype=np.float64)


@dataclass
class Navigation:
    home: Camera
    scene_radius: float
    eye: np.ndarray = field(init=False)
    target: np.ndarray = field(init=False)
    flying: bool = False

    def __post_init__(self) -> None:
        self.up = _unit(np.asarray(self.home.up, float))
        self.reset()

    def reset(self) -> None:
        """Back to the scene's own camera, orbiting."""
        self.eye = np.asarray(self.home.eye, float).copy()
        self.target = np.asarray(self.home.target, float).copy()
        self.flying = False

    def view(self) -> Camera:
        return Camera(tuple(self.eye), tuple(self.target), tuple(self.up), self.home.fov_y)

    @property
    def distance(self) -> float:
        return float(np.linalg.norm(self.target - self.eye))

    def frame(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(right, screen up, forward) of the current view, as the camera itself builds them."""
        right, down, forward = orthonormal_frame(self.target - self.eye, self.up)
        return right, -down, forward

    def _turned(self, direction: np.ndarray, yaw: float, pitch: float) -> np.ndarray:
        """`direction` turned `yaw` degrees about up and raised `pitch` degrees toward up, its
        elevation kept within the margin of the poles."""
        turned = _rotate(direction, self.up, yaw)
        length = float(np.linalg.norm(turned))
        height = float(np.dot(turned, self.up))
        horizontal = turned - height * self.up
        if np.linalg.norm(horizontal) < 1e-9 * length:
            # Straight up or down (a top-down scene camera): the side the image's top is on
            # decides which way is "forward", as the camera itself decided it.
            horizontal = -math.copysign(1.0, height) * self.frame()[1]
        elevation = math.asin(float(np.clip(height / length, -1.0, 1.0)))
        limit = math.radians(90.0 - PITCH_MARGIN_DEGREES)
        wanted = float(np.clip(elevation + math.radians(pitch), -limit, limit))
        return length * (math.cos(wanted) * _unit(horizontal) + math.sin(wanted) * self.up)

    def turn(self, yaw: float, pitch: float) -> None:
        """Orbiting: the eye goes `yaw` degrees around the target (positive: to its right) and
        `pitch` degrees up. Flying: the eye looks `yaw` degrees to the left and `pitch` up."""
        if self.flying:
            self.target = self.eye + self._turned(self.target - self.eye, yaw, pitch)
        else:
            self.eye = self.target + self._turned(self.eye - self.target, yaw, pitch)

    def pan(self, dx: float, dy: float, window_height: float) -> None:
        """Slide eye and target so that the point at the target's depth follows a cursor that
        moved (dx, dy) window pixels (y down)."""
        right, screen_up, _ = self.frame()
        world_per_pixel = 2.0 * self.distance * math.tan(math.radians(self.home.fov_y) / 2.0) / window_height
        shift = (-dx * right + dy * screen_up) * world_per_pixel
        self.eye = self.eye + shift
        self.target = self.target + shift

    def zoom(self, steps: float) -> None:
        """Positive steps move the eye toward the target, never through it or past the scene's
        reach (1e-3 to 1e3 scene radii away)."""
        distance = float(np.clip(self.distance * ZOOM_STEP**steps, 1e-3 * self.scene_radius, 1e3 * self.scene_radius))
        self.eye = self.target - distance * _unit(self.target - self.eye)

    def toggle_fly(self) -> None:
        self.flying = not self.flying

    def fly(self, forward: float, right: float, lift: float, seconds: float, fast: bool = False) -> None:
        """Move eye and target along the view (forward), sideways and along up; each of
        forward, right and lift is -1, 0 or 1 (keys held)."""
        right_axis, _, forward_axis = self.frame()
        speed = FLY_RADII_PER_SECOND * self.scene_radius * (FAST_FACTOR if fast else 1.0)
        shift = (forward * forward_axis + right * right_axis + lift * self.up) * speed * seconds
        self.eye = self.eye + shift
        self.target = self.target + shift
