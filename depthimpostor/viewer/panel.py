"""The viewer's panel of controls, in Dear ImGui (imgui-bundle), drawn over the window.

The panel changes the renderer through its public setters, as the keys do: the method, the
algorithm, the depth images' resolution, the bounces, each object's material and each light
(Renderer.set_scene), the animation's time. It graphs the frame time split by pass, and shows the
diagnostic views of views.py in place of the frame.

ImGui is fed the window's mouse by the viewer's own glfw callbacks (the keys stay the viewer's:
none is given to ImGui), and drawn by imgui-bundle's OpenGL 3 renderer (PyOpenGL) into the
window's framebuffer, after the frame: it saves and restores the GL state it touches. Each widget's
rectangle is kept in `rects` by its label, so that a script (the tests) can click it.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np
from imgui_bundle import imgui
from imgui_bundle.python_backends.opengl_backend_programmable import ProgrammablePipelineRenderer

from ..constants import MAX_BOUNCES, MAX_IOR, Algorithm, Method
from ..errors import DepthImpostorError
from ..scene import AUTO_RESOLUTION
from ..scene.model import CheckerMaterial, DiffuseMaterial, GlassMaterial, Light, MirrorMaterial, SceneObject
from .views import Probe, Settings, TruthJob, View

if TYPE_CHECKING:
    from .app import Viewer

#: Frames the frame-time graph shows.
GRAPH_FRAMES = 120
#: The choices of the resolution combo: "auto" (per image, from its footprint), then fixed sides.
RESOLUTIONS: tuple[int | str, ...] = (AUTO_RESOLUTION, *(2**k for k in range(3, 13)))
#: The animation slider's range, in seconds.
TIME_RANGE = 60.0
#: Panel width in screen units (times the window's content scale).
PANEL_WIDTH = 300
Rect = tuple[float, float, float, float]
Value = TypeVar("Value")


def _vector(edit: tuple[bool, list[float]]) -> tuple[bool, tuple[float, ...]]:
    return edit[0], tuple(edit[1])


class ControlPanel:
    def __init__(self, viewer: Viewer, visible: bool = True) -> None:
        self.viewer = viewer
        self.visible = visible
        self.rects: dict[str, Rect] = {}  # widget label -> (x0, y0, x1, y1) in screen units, last drawn
        self.view = View.FRAME
        self.playing = False
        self._pending: dict[str, Any] = {}  # label -> the value a widget is being dragged to
        self.truth: TruthJob | None = None
        self.probe = Probe(viewer.ctx, viewer.library)
        self._context = imgui.create_context()
        io = imgui.get_io()
        io.set_ini_filename("")  # no imgui.ini written into the user's folder
        self._backend = ProgrammablePipelineRenderer()  # type: ignore[no-untyped-call]

    # ------------------------------------------------------------------ input, from the viewer's callbacks
    @property
    def wants_mouse(self) -> bool:
        """Is the mouse over (or dragging) the panel? Then it does not orbit, pan or zoom."""
        return self.visible and bool(imgui.get_io().want_capture_mouse)

    def on_cursor(self, x: float, y: float) -> None:
        imgui.get_io().add_mouse_pos_event(x, y)

    def on_button(self, button: int, down: bool) -> None:
        if button < imgui.MouseButton_.count:
            imgui.get_io().add_mouse_button_event(button, down)

    def on_scroll(self, dx: float, dy: float) -> None:
        imgui.get_io().add_mouse_wheel_event(dx, dy)

    # ------------------------------------------------------------------ actions (what the widgets do)
    def _apply(self, what: str, change: Callable[[], None]) -> bool:
        try:
            change()
        except DepthImpostorError as error:  # refused: the last state kept, as for a key
            self.viewer.say(f"{what} refused: {error}")
            return False
        self.viewer.say(what)
        return True

    def set_method(self, method: Method) -> bool:
        return self._apply(f"method: {method.option}", lambda: self.viewer.renderer.set_method(method))

    def set_algorithm(self, algorithm: Algorithm) -> bool:
        return self._apply(f"algorithm: {algorithm.name.lower()}", lambda: self.viewer.renderer.set_algorithm(algorithm))

    def set_resolution(self, resolution: int | str) -> bool:
        return self._apply(f"image resolution: {resolution}",
                           lambda: self.viewer.renderer.set_impostor_resolution(resolution))

    def set_bounces(self, bounces: int) -> bool:
        scene = self.viewer.renderer.scene
        edited = dataclasses.replace(scene, render=dataclasses.replace(scene.render, max_bounces=bounces))
        return self._apply(f"bounces: {bounces}", lambda: self.viewer.renderer.set_scene(edited))

    def set_object(self, index: int, obj: SceneObject) -> bool:
        scene = self.viewer.renderer.scene
        objects = scene.objects[:index] + (obj,) + scene.objects[index + 1:]
        return self._apply(f"{obj.name}: material edited",
                           lambda: self.viewer.renderer.set_scene(dataclasses.replace(scene, objects=objects)))

    def set_light(self, index: int, light: Light) -> bool:
        scene = self.viewer.renderer.scene
        lights = scene.lights[:index] + (light,) + scene.lights[index + 1:]
        return self._apply(f"light {index} edited",
                           lambda: self.viewer.renderer.set_scene(dataclasses.replace(scene, lights=lights)))

    def set_time(self, seconds: float) -> None:
        self.viewer.renderer.set_time(seconds)

    def trace_truth(self) -> None:
        """Start the error view's trace of the frame as it is now (a running one is waited out first)."""
        self._drop_truth()
        try:
            self.truth = TruthJob(self.viewer.ctx, Settings.of(self.viewer.renderer), self.viewer.library)
        except DepthImpostorError as error:
            self.viewer.say(f"no error view: {error}")
        self.view = View.ERROR

    def _drop_truth(self) -> None:
        if self.truth is not None:
            self.truth.release()
            self.truth = None

    # ------------------------------------------------------------------ each frame
    def advance(self, seconds: float) -> None:
        """Before the frame: the animation's clock, when playing."""
        renderer = self.viewer.renderer
        if self.playing and renderer.scene.animated:
            renderer.set_time((renderer.time + seconds) % TIME_RANGE)

    def view_image(self) -> np.ndarray | None:
        """The diagnostic view to show in place of the frame (8-bit, top row first), if any."""
        renderer = self.viewer.renderer
        if self.view == View.ERROR and self.truth is not None and self.truth.done:
            image = self.truth.image()
            width, height = renderer.scene.render.size
            return image if image is not None and image.shape[:2] == (height, width) else None
        if self.view in (View.SAMPLES, View.IMAGE):
            return self.probe.image(self.view, Settings.of(renderer))
        return None

    def build(self, window_size: tuple[int, int], framebuffer_size: tuple[int, int], seconds: float) -> None:
        """A new ImGui frame with the panel's widgets; their actions apply at once."""
        io = imgui.get_io()
        io.display_size = imgui.ImVec2(*window_size)
        io.display_framebuffer_scale = imgui.ImVec2(framebuffer_size[0] / max(window_size[0], 1),
                                                    framebuffer_size[1] / max(window_size[1], 1))
        io.delta_time = max(seconds, 1e-4)
        imgui.new_frame()
        if not self.visible:
            return
        imgui.set_next_window_pos(imgui.ImVec2(window_size[0] - PANEL_WIDTH - 4, 4), imgui.Cond_.first_use_ever)
        imgui.set_next_window_size(imgui.ImVec2(PANEL_WIDTH, window_size[1] - 8), imgui.Cond_.first_use_ever)
        imgui.begin("depthimpostor (F2 hides)")
        imgui.push_item_width(PANEL_WIDTH * 0.55)
        self._settings()
        if imgui.collapsing_header("where is it wrong, and why", imgui.TreeNodeFlags_.default_open):
            self._views()
        if imgui.collapsing_header("frame time by pass", imgui.TreeNodeFlags_.default_open):
            self._timing()
        if imgui.collapsing_header("materials"):
            self._materials()
        if imgui.collapsing_header("lights"):
            self._lights()
        imgui.pop_item_width()
        imgui.end()

    def _remember(self, label: str) -> None:
        low, high = imgui.get_item_rect_min(), imgui.get_item_rect_max()
        self.rects[label] = (low.x, low.y, high.x, high.y)

    def _choose(self, label: str, names: list[str], current: int) -> int | None:
        """A combo whose options are remembered as 'label/option': the index chosen this frame."""
        chosen = None
        opened = imgui.begin_combo(label, names[current])
        self._remember(label)
        if opened:
            for index, name in enumerate(names):
                if imgui.selectable(name, index == current)[0] and index != current:
                    chosen = index
                self._remember(f"{label}/{name}")
            imgui.end_combo()
        return chosen

    def _settings(self) -> None:
        renderer = self.viewer.renderer
        methods = list(Method)
        chosen = self._choose("method", [m.option for m in methods], methods.index(renderer.method))
        if chosen is not None:
            self.set_method(methods[chosen])
        algorithms = list(Algorithm)
        chosen = self._choose("algorithm", [a.name.lower() for a in algorithms], algorithms.index(renderer.algorithm))
        if chosen is not None:
            self.set_algorithm(algorithms[chosen])
        setting = renderer.scene.render.impostor_resolution
        current = RESOLUTIONS.index(setting) if setting in RESOLUTIONS else 0
        chosen = self._choose("resolution", [str(r) for r in RESOLUTIONS], current)
        if chosen is not None:
            self.set_resolution(RESOLUTIONS[chosen])
        bounces = self._edited("bounces", renderer.scene.render.max_bounces,
                               lambda label, v: imgui.slider_int(label, v, 1, MAX_BOUNCES))
        if bounces is not None:
            self.set_bounces(bounces)
        if renderer.scene.animated:
            self.playing = imgui.checkbox("play", self.playing)[1]
            self._remember("play")
            imgui.same_line()
            changed, seconds = imgui.slider_float("time", renderer.time, 0.0, TIME_RANGE, "%.1f s")
            if changed:
                self.set_time(seconds)
        else:
            imgui.text_disabled("nothing moves in this scene")

    def _edited(self, label: str, value: Value, widget: Callable[[str, Value], tuple[bool, Value]]) -> Value | None:
        """A slider or colour that applies its value when let go (each edit re-bakes): the value
        being dragged is kept meanwhile, since the scene keeps the old one until then."""
        changed, shown = widget(label, self._pending.get(label, value))
        self._remember(label)
        if changed:
            self._pending[label] = shown
        if imgui.is_item_deactivated_after_edit():
            final = self._pending.pop(label, None)
            return None if final is None or final == value else final
        return None

    def _colour(self, label: str, colour: tuple[float, ...]) -> tuple[float, ...] | None:
        def edit(name: str, value: tuple[float, ...]) -> tuple[bool, tuple[float, ...]]:
            changed, rgb = imgui.color_edit3(name, list(value), imgui.ColorEditFlags_.no_picker)
            return changed, tuple(rgb)
        return self._edited(label, colour, edit)

    def _materials(self) -> None:
        for index, obj in enumerate(self.viewer.renderer.scene.objects):
            material = obj.material
            name = f"{obj.name}##{index}"
            edits: dict[str, Any] = {}
            if isinstance(material, DiffuseMaterial) and material.texture is None:
                edits["color"] = self._colour(f"{name} colour", material.color)
            elif isinstance(material, CheckerMaterial):
                edits["color_a"] = self._colour(f"{name} colour a", material.color_a)
                edits["color_b"] = self._colour(f"{name} colour b", material.color_b)
            elif isinstance(material, MirrorMaterial):
                edits["tint"] = self._colour(f"{name} mirror tint", material.tint)
            elif isinstance(material, GlassMaterial):
                edits["ior"] = self._edited(f"{name} ior", material.ior,
                                            lambda label, v: imgui.slider_float(label, v, 1.0, MAX_IOR))
                edits["tint"] = self._colour(f"{name} glass tint", material.tint)
            else:
                imgui.text_disabled(f"{obj.name}: {type(material).__name__} (not editable here)")
            edits = {key: value for key, value in edits.items() if value is not None}
            if edits:
                self.set_object(index, dataclasses.replace(obj, material=dataclasses.replace(material, **edits)))

    def _lights(self) -> None:
        for index, light in enumerate(self.viewer.renderer.scene.lights):
            name = f"{light.type} {index}"
            where = "direction" if light.type == "directional" else "position"
            edits: dict[str, Any] = {
                "color": self._colour(f"{name} colour", light.color),
                "intensity": self._edited(f"{name} intensity", light.intensity,
                                          lambda label, v: imgui.slider_float(label, v, 0.0, 4.0)),
                where: self._edited(f"{name} {where}", getattr(light, where),
                                    lambda label, v: _vector(imgui.drag_float3(label, list(v), 0.02))),
            }
            edits = {key: value for key, value in edits.items() if value is not None}
            if edits:
                self.set_light(index, dataclasses.replace(light, **edits))

    def _timing(self) -> None:
        """Frame time split by pass: the mirror pass (timed apart, Renderer.time_mirror_pass) and
        everything else the frame drew; bakes as they happen."""
        stats = self.viewer.renderer.stats
        frames = np.array(list(itertools.islice(reversed(stats.draw_seconds), GRAPH_FRAMES))[::-1], np.float32)
        mirrors = np.array(list(itertools.islice(reversed(stats.mirror_seconds), GRAPH_FRAMES))[::-1], np.float32)
        if not len(frames):
            return
        mirrors = mirrors[-len(frames):] if len(mirrors) >= len(frames) else np.zeros_like(frames)
        top = float(frames.max()) * 1000.0
        size = imgui.ImVec2(0, 40)
        for label, series in (("frame", frames), ("mirror pass", mirrors), ("other passes", frames - mirrors)):
            milliseconds = np.ascontiguousarray(series * 1000.0, np.float32)
            imgui.plot_lines(label, milliseconds, overlay_text=f"{milliseconds[-1]:.1f} ms",
                             scale_min=0.0, scale_max=top, graph_size=size)
        if stats.bake_seconds:
            imgui.text(f"last bake {1000.0 * stats.bake_seconds[-1]:.0f} ms ({len(stats.bake_seconds)} bakes)")

    def _views(self) -> None:
        renderer = self.viewer.renderer
        for view in View:
            if imgui.radio_button(view.value, self.view == view):
                self.view = view
            self._remember(f"view/{view.value}")
        if imgui.button("trace the truth now"):
            self.trace_truth()
        self._remember("trace the truth now")
        truth = self.truth
        if truth is not None:
            if not truth.done:
                imgui.progress_bar(truth.progress, imgui.ImVec2(-1, 0), f"tracing {100 * truth.progress:.0f} %")
            elif truth.failure is not None:
                imgui.text_wrapped(f"the trace failed: {truth.failure}")
            elif truth.comparison is not None:
                figures = truth.comparison.figures
                imgui.text(f"PSNR {figures.psnr_db:.1f} dB, wrong object {100 * figures.wrong_object_share:.2f} %")
                imgui.text(f"traced in {truth.seconds:.1f} s")
                if not truth.settings.same(Settings.of(renderer)):
                    imgui.text_colored(imgui.ImVec4(1, 0.7, 0.2, 1), "stale: the frame changed since")
        if self.probe.failure is not None and self.view in (View.SAMPLES, View.IMAGE):
            imgui.text_wrapped(self.probe.failure)
        if self.view == View.IMAGE:
            imgui.text_wrapped("colour: the reflected object whose depth image the ray hit (the mirror shader "
                               "outputs the object, one image per object and mirror); black: the sky")
        renderer.graph.tint_retraced = imgui.checkbox("tint re-traced rays (hybrid)", renderer.graph.tint_retraced)[1]
        self._remember("tint re-traced rays (hybrid)")

    def draw(self) -> None:
        """ImGui's frame, into the framebuffer in use (the window's)."""
        imgui.render()
        self._backend.render(imgui.get_draw_data())

    def release(self) -> None:
        self._drop_truth()
        self.probe.release()
        self._backend.shutdown()
        imgui.destroy_context(self._context)
