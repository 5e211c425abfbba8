"""The Python entry point: a scene in, an image out (docs/python_api.md).

    import depthimpostor
    image = depthimpostor.render_image("scenes/default.toml", size=(640, 360))  # (360, 640, 3) uint8

For more than one frame, or frames drawn into an application's own framebuffer, use `Renderer`
with a context (`create_context`, or the application's own): see docs/python_api.md.
"""

from __future__ import annotations

from os import PathLike
from typing import Literal

import moderngl
import numpy as np

from .constants import Algorithm, Method
from .gpu.context import Backend, create_context
from .gpu.limits import checked_memory, limit_memory
from .colour import display_encode
from .renderer import Renderer, checked_time
from .scene import Scene, load_scene


def render_image(
    scene: str | PathLike[str] | Scene,
    size: tuple[int, int] | None = None,
    method: str = "depth",
    algorithm: str = "optimized",
    impostor_resolution: int | Literal["auto"] | None = None,
    time: float = 0.0,
    dtype: Literal["uint8", "float32"] = "uint8",
    ctx: moderngl.Context | None = None,
    backend: Backend | None = None,
    max_memory: int | None = None,
) -> np.ndarray:
    """Render one frame of `scene` (a TOML file's path, or a `Scene`) and return it as a
    (height, width, 3) array, row 0 at the top (as images and PIL have it): uint8, through the
    scene's display transform (render.exposure, render.tone_mapping, sRGB encoding: docs/colour.md),
    or float32 linear colour, unclamped.

    `size` (width, height) and `impostor_resolution` override the scene's; `method` is one of
    depth, cubemap, cubemap-parallax, billboard, simplified, raytrace, hybrid and `algorithm` one of
    basic, optimized, hierarchical (as on the command line); `time` is the scene time in seconds of
    an animated scene. With `ctx` the frame is rendered in that context (which is left as it was
    found, and open); otherwise a headless one is made (`backend`: auto, egl, osmesa) and released.
    `max_memory` (bytes) is the budget of what the frame and its images may take.

    Raises a `DepthImpostorError` for a scene, setting or GL that cannot give the frame.
    """
    # Every argument is checked before the scene is read or a context is made.
    chosen_method, chosen_algorithm = _method(method), _algorithm(algorithm)
    if dtype not in ("uint8", "float32"):
        raise ValueError(f'dtype: expected "uint8" or "float32", got {dtype!r}')
    seconds = checked_time(time)
    if max_memory is not None:
        if ctx is not None:
            raise ValueError("max_memory: give it with limits.limit_memory(ctx, ...) when you pass your own ctx")
        max_memory = checked_memory(max_memory)
    loaded = scene if isinstance(scene, Scene) else load_scene(scene)
    loaded = loaded.with_overrides(size=size, impostor_resolution=impostor_resolution, source="render_image")
    own = ctx is None
    context = create_context(backend) if ctx is None else ctx
    try:
        if own:
            limit_memory(context, max_memory)
        with Renderer(context, loaded, chosen_algorithm, method=chosen_method) as renderer:
            renderer.set_time(seconds)
            renderer.render()
            color = renderer.read_color_float()
    finally:
        if own:
            context.release()
    render = loaded.render
    return display_encode(color, render.tone_mapping, render.exposure) if dtype == "uint8" else color


def _method(name: object) -> Method:
    if isinstance(name, str) and name.upper().replace("-", "_") in Method.__members__:
        return Method.from_option(name)
    raise ValueError(f"method: expected one of {[m.option for m in Method]}, got {name!r}")


def _algorithm(name: object) -> Algorithm:
    if isinstance(name, str) and name.upper() in Algorithm.__members__:
        return Algorithm[name.upper()]
    raise ValueError(f"algorithm: expected one of {[a.name.lower() for a in Algorithm]}, got {name!r}")
