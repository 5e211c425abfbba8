"""The notebook's interactive view: a jupyter_rfb remote framebuffer drawn by a `Renderer` in the
kernel (`SceneView`), under ipywidgets controls (`Interactive`). `depthimpostor.interactive` makes
one; this module needs the [notebook] extra."""

from __future__ import annotations

from typing import Any

import ipywidgets
import numpy as np
from jupyter_rfb import RemoteFrameBuffer

from ..constants import Algorithm, Method
from ..errors import DepthImpostorError
from ..renderer import Renderer
from ..scene.model import AUTO_RESOLUTION
from ..viewer.navigation import Navigation, scene_radius

#: A drag across the whole view turns the eye once around the target, as in the viewer's window.
ORBIT_DEGREES_PER_VIEW_WIDTH = 360.0
#: Browsers report a wheel notch as about 100 pixels of scroll; the viewer zooms one step a notch.
WHEEL_PIXELS_PER_STEP = 100.0
#: jupyter_rfb's pointer buttons.
LEFT, RIGHT, MIDDLE = 1, 2, 3
#: The image resolutions offered (as the viewer's [ and ] keys step through them), and "auto".
RESOLUTIONS: tuple[int | str, ...] = (AUTO_RESOLUTION, 64, 128, 256, 512, 1024, 2048)


class SceneView(RemoteFrameBuffer):  # type: ignore[misc]  # jupyter_rfb ships no type hints
    """A renderer's frames in the notebook: drag with the left button to orbit the target, with the
    right or middle one to pan, the wheel to zoom; a double click goes back to the scene's camera.
    The frame follows the widget's size (in CSS pixels). `own_context`: closing the view releases
    the renderer's context too (one made for the view alone)."""

    def __init__(self, renderer: Renderer, own_context: bool = False, **kwargs: Any) -> None:
        width, height = renderer.scene.render.size
        super().__init__(css_width=f"{width}px", css_height=f"{height}px", **kwargs)
        self.renderer = renderer
        self.own_context = own_context
        self.closed = False
        self.navigation = Navigation(renderer.view, scene_radius(renderer.world.bounds))
        self._pointer: tuple[float, float] | None = None
        self.frames = 0
        # The first frame now: the widget's snapshot where no browser draws it (an exported
        # notebook), and a GL error or refusal raised here, in the cell that made the view.
        self.send_frame(self.get_frame())

    def get_frame(self) -> np.ndarray:
        self.renderer.look_at(self.navigation.view())
        self.renderer.render()
        self.frames += 1
        return self.renderer.read_color()

    def handle_event(self, event: dict[str, Any]) -> None:
        kind = event.get("event_type", event.get("type"))
        if kind == "resize":
            size = (max(round(event["width"]), 1), max(round(event["height"]), 1))
            if size == self.renderer.scene.render.size:
                return
            self.renderer.resize(size)
        elif kind == "pointer_down":
            self._pointer = (event["x"], event["y"])
            return
        elif kind == "pointer_up":
            self._pointer = None
            return
        elif kind == "pointer_move":
            if not self._drag(event):
                return
        elif kind == "wheel":
            self.navigation.zoom(-event["dy"] / WHEEL_PIXELS_PER_STEP)
        elif kind == "double_click":
            self.navigation.reset()
        else:
            return
        self.request_draw()

    def _drag(self, event: dict[str, Any]) -> bool:
        """Orbit or pan by the pointer's motion since the last event; False when no button is held."""
        previous, buttons = self._pointer, set(event.get("buttons", ()))
        if previous is None or not buttons:
            return False
        self._pointer = (event["x"], event["y"])
        dx, dy = event["x"] - previous[0], event["y"] - previous[1]
        width, height = self.renderer.scene.render.size
        if LEFT in buttons:
            degrees = ORBIT_DEGREES_PER_VIEW_WIDTH / width
            self.navigation.turn(-dx * degrees, dy * degrees)
        else:
            self.navigation.pan(dx, dy, height)
        return True

    def close(self) -> None:
        super().close()
        if self.closed:  # closing twice frees nothing twice
            return
        self.closed = True
        self.renderer.release()
        if self.own_context:
            self.renderer.ctx.release()


class Interactive(ipywidgets.VBox):  # type: ignore[misc]  # ipywidgets ships no type hints
    """A `SceneView` (`.view`) under its controls: method, algorithm, image resolution, time (for a
    scene that animates), and a line saying what was drawn or why a setting was refused."""

    def __init__(self, renderer: Renderer, own_context: bool = False) -> None:
        self.view = SceneView(renderer, own_context)
        self._reverting = False
        render = renderer.scene.render
        self.method = ipywidgets.Dropdown(options=[m.option for m in Method], value=renderer.method.option,
                                          description="method")
        self.algorithm = ipywidgets.Dropdown(options=[a.name.lower() for a in Algorithm],
                                             value=renderer.algorithm.name.lower(), description="algorithm")
        resolutions = list(dict.fromkeys((*RESOLUTIONS, render.impostor_resolution)))
        self.resolution = ipywidgets.Dropdown(options=resolutions, value=render.impostor_resolution,
                                              description="resolution")
        self.time = ipywidgets.FloatSlider(value=renderer.time, min=0.0, max=60.0, step=0.1, description="time (s)")
        self.status = ipywidgets.Label(value=self._describe())
        controls: list[ipywidgets.Widget] = [self.method, self.algorithm, self.resolution]
        if renderer.scene.animated:
            controls.append(self.time)
        for control, apply in ((self.method, lambda v: renderer.set_method(Method.from_option(v))),
                               (self.algorithm, lambda v: renderer.set_algorithm(Algorithm[v.upper()])),
                               (self.resolution, renderer.set_impostor_resolution),
                               (self.time, renderer.set_time)):
            control.observe(self._setter(control, apply), names="value")
        super().__init__([ipywidgets.HBox(controls), self.view, self.status])

    def _setter(self, control: ipywidgets.ValueWidget, apply: Any) -> Any:
        def changed(change: dict[str, Any]) -> None:
            if self._reverting or change["new"] == change["old"]:
                return
            try:
                apply(change["new"])
            except DepthImpostorError as error:
                # The renderer kept its setting; so does the control.
                self.status.value = f"{control.description} {change['new']} refused: {error}"
                self._reverting = True
                try:
                    control.value = change["old"]
                finally:
                    self._reverting = False
                return
            self.status.value = self._describe()
            self.view.request_draw()
        return changed

    def _describe(self) -> str:
        renderer = self.view.renderer
        stand_in = renderer.graph.stand_in
        return f"{renderer.method.option}: {stand_in.describe() if stand_in is not None else 'no mirror'}"
