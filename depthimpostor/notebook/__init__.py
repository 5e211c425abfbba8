"""Jupyter: one frame as an image (`show`), and a view to orbit with the mouse (`interactive`).

    import depthimpostor
    depthimpostor.show("scenes/default.toml", size=(640, 360))         # a PIL image: the cell shows it
    depthimpostor.interactive("scenes/carousel.toml", size=(640, 360))  # drag to orbit, wheel to zoom

The interactive view is a jupyter_rfb remote framebuffer: the kernel renders each frame with the
same `Renderer` as `render` (in a headless EGL context of its own, so no display is needed where
the kernel runs) and sends it to the browser as an image; the browser sends back the mouse's
events. Method, algorithm, image resolution and (in an animated scene) time are ipywidgets
controls above it (widgets.py). `show` needs nothing more than the package; `interactive` needs
the [notebook] extra (`pip install "depthimpostor[notebook]"`), imported only when it is called.
"""

from __future__ import annotations

from os import PathLike
from typing import TYPE_CHECKING, Any, Literal

from PIL import Image

from ..api import _algorithm, _method, render_image
from ..gpu.context import Backend, create_context
from ..renderer import Renderer
from ..scene import Scene, load_scene

if TYPE_CHECKING:
    from .widgets import Interactive


def show(scene: str | PathLike[str] | Scene, size: tuple[int, int] | None = None, **options: Any) -> Image.Image:
    """One frame of `scene` as a PIL image, through the scene's display transform; Jupyter shows it
    as a PNG when it is a cell's value (in a loop: `display(depthimpostor.show(...))`). `options`
    are `render_image`'s: method, algorithm, impostor_resolution, time, backend, ctx, max_memory."""
    return Image.fromarray(render_image(scene, size=size, dtype="uint8", **options))


def interactive(
    scene: str | PathLike[str] | Scene,
    size: tuple[int, int] = (640, 360),
    method: str = "depth",
    algorithm: str = "optimized",
    impostor_resolution: int | Literal["auto"] | None = None,
    time: float = 0.0,
    backend: Backend | None = None,
) -> Interactive:
    """A view of `scene` to orbit with the mouse, with its settings as widgets (`Interactive`); the
    arguments are `render_image`'s. It renders in a headless GL context of its own, released when the view
    is closed (`.view.close()`)."""
    loaded = scene if isinstance(scene, Scene) else load_scene(scene)
    loaded = loaded.with_overrides(size=size, impostor_resolution=impostor_resolution)
    chosen_method, chosen_algorithm = _method(method), _algorithm(algorithm)
    try:
        from .widgets import Interactive
    except ModuleNotFoundError as error:
        raise ModuleNotFoundError(f'depthimpostor.interactive needs the [notebook] extra: pip install '
                                  f'"depthimpostor[notebook]" ({error})', name=error.name) from error
    ctx = create_context(backend)
    renderer: Renderer | None = None
    try:
        renderer = Renderer(ctx, loaded, chosen_algorithm, method=chosen_method)
        renderer.set_time(time)
        return Interactive(renderer, own_context=True)
    except BaseException:
        if renderer is not None:
            renderer.release()
        ctx.release()
        raise
