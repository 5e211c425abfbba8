"""The panel's diagnostic views: where a frame is wrong, and why.

- the error against the truth: `compare`'s own difference image (compare.heat_map), of a frame
  rendered when asked for, its truth traced in a background thread while the window goes on;
- the samples each reflected ray read, and which depth image (reflected object) each mirror pixel
  hit: from a probe renderer that draws the viewer's frame again with those outputs.

Each view is an 8-bit image of the frame's size, top row first, shown in place of the frame.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from enum import Enum

import moderngl
import numpy as np

from ..colour import quantize
from ..oracles.compare import Comparison, compare, heat_map
from ..constants import NO_OBJECT, Algorithm, Method
from ..errors import DepthImpostorError
from ..renderer import Renderer
from ..supersampling import SubFrame
from ..scene.model import Camera, Scene
from ..gpu.shaders import ShaderLibrary


class View(Enum):
    FRAME = "frame"
    ERROR = "error against the truth"
    SAMPLES = "samples each ray read"
    IMAGE = "depth image each pixel hit"


#: Samples per ray shown white in the samples view (more are clipped): the optimized algorithm's
#: typical counts sit well below it, a basic march's long tails above.
SAMPLES_SCALE = 64.0
#: The image view's colours, one per reflected object (by index, in a ring); the environment black.
PALETTE = np.array([
    (0.90, 0.10, 0.29), (0.24, 0.71, 0.29), (1.00, 0.88, 0.10), (0.26, 0.39, 0.85), (0.96, 0.51, 0.19),
    (0.57, 0.12, 0.71), (0.27, 0.94, 0.94), (0.94, 0.20, 0.90), (0.74, 0.96, 0.05), (0.98, 0.75, 0.83),
])


@dataclass(frozen=True, eq=False)
class Settings:
    """What a view's image depends on: a change makes the image stale. Scenes are told apart by
    identity (the renderer replaces its scene on every change; a textured one holds arrays)."""

    scene: Scene
    method: Method
    algorithm: Algorithm
    view: Camera
    time: float

    @staticmethod
    def of(renderer: Renderer) -> Settings:
        return Settings(renderer.scene, renderer.method, renderer.algorithm, renderer.view, renderer.time)

    def same(self, other: Settings | None) -> bool:
        return other is not None and self.scene is other.scene and (
            (self.method, self.algorithm, self.view, self.time) == (other.method, other.algorithm, other.view, other.time))


def _twin(ctx: moderngl.Context, settings: Settings, shaders: ShaderLibrary | None, *,
          reflection_data: bool = False, count_samples: bool = False) -> Renderer:
    """A renderer drawing the frame of `settings`, with the outputs a view reads."""
    renderer = Renderer(ctx, settings.scene, settings.algorithm, reflection_data=reflection_data, shaders=shaders,
                        method=settings.method, count_samples=count_samples)
    renderer.set_time(settings.time)
    renderer.look_at(settings.view)
    return renderer


class TruthJob:
    """One error view being made: the frame rendered now (on the GL thread) with its reflection
    data, then compared with its truth in a background thread: `compare` itself, given the frame's
    sub-frames read beforehand, touches no GL. `progress` is the share traced."""

    def __init__(self, ctx: moderngl.Context, settings: Settings, shaders: ShaderLibrary | None) -> None:
        self.settings = settings
        self.started = time.perf_counter()
        self.progress = 0.0
        self.seconds: float | None = None
        self.comparison: Comparison | None = None
        self.failure: str | None = None
        self._image: np.ndarray | None = None
        self._renderer: Renderer | None = _twin(ctx, settings, shaders, reflection_data=True)
        self._renderer.render()
        frames = self._renderer.sub_frames()
        self._thread = threading.Thread(target=self._compare, args=(self._renderer, frames), daemon=True)
        self._thread.start()

    def _compare(self, renderer: Renderer, frames: list[SubFrame]) -> None:
        try:
            self.comparison = compare(renderer, frames=frames, progress=self._report)
        except Exception as error:  # noqa: BLE001 -- shown in the panel; the window goes on
            self.failure = f"{type(error).__name__}: {error}"
        self.seconds = time.perf_counter() - self.started

    def _report(self, done: float) -> None:
        self.progress = done

    @property
    def done(self) -> bool:
        return not self._thread.is_alive()

    def wait(self, timeout: float | None = None) -> None:
        self._thread.join(timeout)

    def image(self) -> np.ndarray | None:
        """`compare`'s difference image (as `compare` writes difference.png), once traced."""
        if self._image is None and self.comparison is not None:
            self._image = quantize(heat_map(self.comparison))
        return self._image

    def release(self) -> None:
        """Free the frame's renderer (GL thread); a trace still running is waited for first."""
        self._thread.join()
        if self._renderer is not None:
            self._renderer.release()
            self._renderer = None


def samples_image(counts: np.ndarray, mirror: np.ndarray, frame: np.ndarray) -> np.ndarray:
    """Samples per ray, black to white at SAMPLES_SCALE, inside the mirrors; the frame dimmed elsewhere."""
    level = np.clip(counts / SAMPLES_SCALE, 0.0, 1.0)[..., None]
    heat = np.concatenate([np.clip(3 * level, 0, 1), np.clip(3 * level - 1, 0, 1), np.clip(3 * level - 2, 0, 1)], 2)
    return quantize(np.where(mirror[..., None], heat, frame.mean(axis=2, keepdims=True) * 0.35))


def image_hit_image(object_id: np.ndarray, mirror: np.ndarray, frame: np.ndarray) -> np.ndarray:
    """Each mirror pixel coloured by the object whose depth image its ray hit (one image per
    reflected object and mirror), black for the environment; the frame dimmed elsewhere."""
    colour = PALETTE[np.maximum(object_id, 0) % len(PALETTE)]
    colour = np.where((object_id == NO_OBJECT)[..., None], 0.0, colour)
    return quantize(np.where(mirror[..., None], colour, frame.mean(axis=2, keepdims=True) * 0.35))


class Probe:
    """A second renderer, with reflection data and sample counts, that draws the viewer's frame
    once more while a per-pixel view is shown, whenever the settings change (else its last images
    are shown again). It has outputs of its own: the viewer's renderer draws without them."""

    def __init__(self, ctx: moderngl.Context, shaders: ShaderLibrary | None) -> None:
        self.ctx = ctx
        self.shaders = shaders
        self.settings: Settings | None = None
        self.renderer: Renderer | None = None
        self.failure: str | None = None
        self._images: dict[View, np.ndarray] = {}

    def image(self, view: View, settings: Settings) -> np.ndarray | None:
        if settings.same(self.settings) and view in self._images:
            return self._images[view]
        try:
            renderer = self._follow(settings)
        except DepthImpostorError as error:  # this view cannot be had here; the frame goes on
            self.release()
            self.failure = str(error)
            return None
        self.failure = None
        self.settings = settings
        renderer.render()
        data = renderer.read_reflection_data()
        frame = np.clip(renderer.read_color_float(), 0.0, 1.0)
        self._images = {
            View.SAMPLES: samples_image(renderer.read_sample_counts(), data.mirror_mask, frame),
            View.IMAGE: image_hit_image(data.object_id, data.mirror_mask, frame),
        }
        return self._images[view]

    def _follow(self, settings: Settings) -> Renderer:
        """Made on first use; then told only what changed (a camera move re-bakes nothing)."""
        if self.renderer is None:
            self.renderer = _twin(self.ctx, settings, self.shaders, reflection_data=True, count_samples=True)
            return self.renderer
        renderer = self.renderer
        if renderer.scene is not settings.scene:
            renderer.resize(settings.scene.render.size)
            renderer.set_scene(settings.scene)
        if renderer.method != settings.method:
            renderer.set_method(settings.method)
        if renderer.algorithm != settings.algorithm:
            renderer.set_algorithm(settings.algorithm)
        renderer.set_time(settings.time)
        renderer.look_at(settings.view)
        return renderer

    def release(self) -> None:
        if self.renderer is not None:
            self.renderer.release()
            self.renderer = None
        self.settings = None
        self._images = {}
