"""The interactive viewer: the renderer's frames in a glfw window, with the overlay on top.

Each frame: the renderer draws the scene (the same passes and shaders as `render`) into its own
float framebuffer at the window's framebuffer size; the frame is copied into an 8-bit frame
texture, the overlay is blended over it, and the result is put in the window. Screenshots are the
renderer's frame (no overlay); `--window-screenshot` is the composed frame, as the window shows it.

Nothing is re-baked for a camera move, a resize or an algorithm switch; a resolution change
re-bakes the depth images, a shader reload re-bakes with the new programs (see Renderer).
"""

from __future__ import annotations

import itertools
import json
import statistics
import sys
import time
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import glfw
import numpy as np

from ..constants import INTERACTIVE_BAKE_BUDGET, Algorithm, Method
from ..methods.registry import METHODS
from ..gpu.context import Window, bind_default_framebuffer, create_window, describe
from ..errors import DepthImpostorError, OutputError, SceneError, ShaderError
from ..gpu.limits import limit_memory
from ..outputs import Outputs, write_image
from ..passes.overlay import OverlayPass, Panel
from ..passes.present import PresentPass
from ..renderer import Renderer
from ..scene.model import Scene
from ..gpu.shaders import ProgramCache, ShaderLibrary
from .keys import ACTIONS_BY_KEY, FLY_KEYS, KEY_CODES, TURN_STEP_DEGREES, Action, KeyPress, help_lines, key_name
from .navigation import Navigation, scene_radius

if TYPE_CHECKING:  # imported where it is made: imgui-bundle may be absent (make_panel)
    from .panel import ControlPanel

#: Frames the overlay's median frame time and fps are taken over.
TIMING_WINDOW = 60
#: Overlay text height in screen units (times the monitor's content scale, in pixels).
FONT_SIZE = 14
#: Mouse orbit: a drag across the whole window width turns the view all the way round.
ORBIT_DEGREES_PER_WINDOW_WIDTH = 360.0
#: Fly mode: degrees of look per screen unit the mouse moves.
LOOK_DEGREES_PER_UNIT = 0.15
#: A fly step never covers more than this many seconds of motion (a stalled frame must not fling
#: the camera across the scene).
MAX_FLY_SECONDS = 0.1
#: Seconds a status message stays in the overlay.
MESSAGE_SECONDS = 4.0
#: Depth-image resolutions the resolution keys step through.
RESOLUTION_STEPS = tuple(2**k for k in range(3, 13))  # 8 .. 4096
METHOD_LABELS = {method: spec.label for method, spec in METHODS.items()}


@dataclass(frozen=True)
class ViewerOptions:
    scene: Scene
    algorithm: Algorithm = Algorithm.OPTIMIZED
    method: Method = Method.DEPTH
    frames: int | None = None  # quit after this many frames
    keys: tuple[KeyPress, ...] = ()
    screenshot: Path | None = None  # the last frame, without the overlay, at exit
    window_screenshot: Path | None = None  # the last frame as the window showed it
    report: Path | None = None  # JSON: frames, bakes, key events, GL errors
    shaders: Path | None = None
    screenshot_dir: Path = Path(".")
    max_memory: int | None = None  # bytes the frame and its images may take (--max-memory)
    panel: bool = True  # the panel of controls shown at the start (F2 toggles it; --no-panel)


def next_resolution(current: int, up: bool) -> int:
    """The next step of RESOLUTION_STEPS above (or below) `current`; `current` at the end."""
    if up:
        return next((r for r in RESOLUTION_STEPS if r > current), current)
    return next((r for r in reversed(RESOLUTION_STEPS) if r < current), current)


def save_numbered(image: np.ndarray, directory: Path, stem: str) -> Path:
    """Save as STEM-0001.png, -0002, ...: the first number whose file does not exist; the file is
    put in place exclusively (and whole), so a screenshot never overwrites one, even from another
    viewer."""
    for number in itertools.count(1):
        path = directory / f"{stem}-{number:04d}.png"
        if path.exists():
            continue
        try:
            return write_image(path, image, exclusive=True)
        except FileExistsError:  # another viewer took the number meanwhile
            continue
    raise AssertionError("unreachable")


Choice = TypeVar("Choice", bound=Enum)


def _skipped(refused: Iterable[tuple[str, str]]) -> str:
    """The overlay's note of the settings a key passed over, and why: one line, naming them all
    and the first reason (the terminal has every reason: `say` prints the message there)."""
    refused = list(refused)
    if not refused:
        return ""
    names = ", ".join(name for name, _ in refused)
    others = len({why.replace(name, "") for name, why in refused}) - 1  # reasons that name their setting alike
    return f" ({names} skipped: {refused[0][1]}" + (f"; and {others} other reasons" if others else "") + ")"


def _reason(error: DepthImpostorError) -> str:
    """Why a setting was refused, without the scene's file name (the overlay names the scene)."""
    return f"{error.path}: {error.detail}" if isinstance(error, SceneError) and error.path else str(error)


class NoPanel:
    """The viewer without its panel, where imgui-bundle is not installed (it has wheels for Python
    3.11 and later): the keys and the overlay do everything but the panel's views."""

    WHY = "the panel needs imgui-bundle (Python 3.11 or later: pip install imgui-bundle PyOpenGL)"
    visible = False
    wants_mouse = False

    def on_button(self, button: int, pressed: bool) -> None: ...
    def on_scroll(self, dx: float, dy: float) -> None: ...
    def on_cursor(self, x: float, y: float) -> None: ...
    def build(self, window_size: tuple[int, int], frame_size: tuple[int, int], seconds: float) -> None: ...
    def advance(self, seconds: float) -> None: ...
    def view_image(self) -> np.ndarray | None:
        return None
    def draw(self) -> None: ...
    def release(self) -> None: ...


def make_panel(viewer: Viewer, visible: bool) -> ControlPanel | NoPanel:
    """The panel of controls (viewer/panel.py), or, without imgui-bundle (or the PyOpenGL its
    renderer needs), none. Any other import error is the panel's own, and is raised."""
    try:
        from .panel import ControlPanel  # imgui-bundle: imported only where it is installed
    except ImportError as error:  # missing, or installed but failing to load its native library
        if (error.name or "").split(".")[0] in PANEL_PACKAGES:
            return NoPanel()
        raise
    return ControlPanel(viewer, visible=visible)


#: The packages the panel is optional for: the viewer runs without them (NoPanel).
PANEL_PACKAGES = ("imgui_bundle", "OpenGL")


@dataclass
class SessionLog:
    """What happened, for `--report` and the closing summary."""

    baked_after_frame: list[int] = field(default_factory=list)  # depth images baked so far, per frame
    events: list[dict[str, Any]] = field(default_factory=list)
    gl_errors: list[dict[str, Any]] = field(default_factory=list)
    screenshots: list[str] = field(default_factory=list)


class Viewer:
    def __init__(self, window: Window, options: ViewerOptions) -> None:
        self.window = window
        self.ctx = window.ctx
        self.options = options
        self.frame_size: tuple[int, int] = glfw.get_framebuffer_size(window.handle)
        self.library = ShaderLibrary(options.shaders) if options.shaders else None
        scene = options.scene.with_overrides(size=self.frame_size)
        limit_memory(self.ctx, options.max_memory)
        # The mirror pass timed apart (a finish before it) for the panel's graph of the frame by pass.
        self.renderer = Renderer(self.ctx, scene, options.algorithm, shaders=self.library, method=options.method,
                                 time_mirror_pass=True, bake_budget=INTERACTIVE_BAKE_BUDGET)
        # The viewer's own programs (overlay, present): the renderer's are its to replace.
        self.programs = ProgramCache(self.ctx, self.library)
        self.font_pixels = round(FONT_SIZE * max(glfw.get_window_content_scale(window.handle)))
        self._make_viewer_passes()
        self._make_frame_target()
        self.navigation = Navigation(scene.camera, scene_radius(self.renderer.world.bounds))
        self.log = SessionLog()
        self.frames = 0
        self.held: set[int] = set()
        self.buttons: set[int] = set()
        self.cursor: tuple[float, float] | None = None
        self.show_help = False
        self.screenshot_requested = False
        self.message: tuple[str, float] | None = None
        self.frame_intervals: deque[float] = deque(maxlen=TIMING_WINDOW)
        self.window_pixels: np.ndarray | None = None  # the last frame as the window showed it (--window-screenshot)
        self._last_frame = time.perf_counter()
        self.panel = make_panel(self, options.panel)
        self._install_callbacks()

    # ------------------------------------------------------------------ GL objects
    def _make_viewer_passes(self) -> None:
        self.overlay = OverlayPass(self.ctx, self.programs, self.font_pixels)
        # The linear frame through the display transform (as a screenshot is written), then the
        # overlay over it, then the whole flipped into the window.
        self.display = PresentPass(self.ctx, self.programs, encode=True, flip=False)
        self.present = PresentPass(self.ctx, self.programs)

    def _make_frame_target(self) -> None:
        self.linear_texture = self.ctx.texture(self.frame_size, 4, dtype="f4")
        self.frame_texture = self.ctx.texture(self.frame_size, 4)
        self.frame_framebuffer = self.ctx.framebuffer([self.frame_texture])
        # The window's pixels, panel included, copied here to be read (--window-screenshot): GL reads
        # a window's framebuffer only through its back buffer, which moderngl's read does not name.
        self.window_texture = self.ctx.texture(self.frame_size, 3)
        self.window_copy = self.ctx.framebuffer([self.window_texture])

    def _release_frame_target(self) -> None:
        bind_default_framebuffer(self.ctx)
        self.frame_framebuffer.release()
        self.frame_texture.release()
        self.window_copy.release()
        self.window_texture.release()
        self.linear_texture.release()

    def release(self) -> None:
        self.panel.release()
        self._release_frame_target()
        self.overlay.release()
        self.display.release()
        self.present.release()
        self.programs.release()
        self.renderer.release()

    # ------------------------------------------------------------------ input
    def _install_callbacks(self) -> None:
        handle = self.window.handle
        glfw.set_key_callback(handle, lambda _w, key, _scancode, action, mods: self.on_key(key, action, mods))
        glfw.set_cursor_pos_callback(handle, lambda _w, x, y: self.on_cursor(x, y))
        glfw.set_mouse_button_callback(handle, lambda _w, button, action, _mods: self.on_button(button, action))
        glfw.set_scroll_callback(handle, lambda _w, dx, dy: self.on_scroll(dx, dy))
        glfw.set_framebuffer_size_callback(handle, lambda _w, width, height: self.on_resize((width, height)))

    def on_key(self, key: int, action: int, mods: int) -> None:
        if action == glfw.PRESS:
            self.held.add(key)
        elif action == glfw.RELEASE:
            self.held.discard(key)
            return
        binding = ACTIONS_BY_KEY.get(key)
        if binding is None or (action == glfw.REPEAT and not binding.repeats):
            return
        try:
            message = self.perform(binding.action)
        except DepthImpostorError as error:
            # A key never ends the session: what it asked for is refused, the last state kept.
            message = f"{key_name(key)} refused: {_reason(error)}"
        self.log.events.append(
            {"frame": self.frames, "key": key_name(key), "action": binding.action.name.lower(), "message": message}
        )
        if message:
            self.say(message)

    def on_button(self, button: int, action: int) -> None:
        self.panel.on_button(button, action == glfw.PRESS)
        if action == glfw.PRESS and not self.panel.wants_mouse:  # a click on the panel is the panel's
            self.buttons.add(button)
        elif action != glfw.PRESS:
            self.buttons.discard(button)

    def on_scroll(self, dx: float, dy: float) -> None:
        self.panel.on_scroll(dx, dy)
        if not self.panel.wants_mouse:
            self.navigation.zoom(dy)

    def on_cursor(self, x: float, y: float) -> None:
        self.panel.on_cursor(x, y)
        previous, self.cursor = self.cursor, (x, y)
        if previous is None:
            return
        dx, dy = x - previous[0], y - previous[1]
        # Mouse motion is in screen units (the window's size), not framebuffer pixels: the two
        # differ on HiDPI screens, and a drag must turn the view as far on either.
        width, height = glfw.get_window_size(self.window.handle)
        if self.navigation.flying:
            self.navigation.turn(-dx * LOOK_DEGREES_PER_UNIT, -dy * LOOK_DEGREES_PER_UNIT)
        elif glfw.MOUSE_BUTTON_LEFT in self.buttons:
            degrees = ORBIT_DEGREES_PER_WINDOW_WIDTH / max(width, 1)
            self.navigation.turn(-dx * degrees, dy * degrees)
        elif self.buttons & {glfw.MOUSE_BUTTON_RIGHT, glfw.MOUSE_BUTTON_MIDDLE}:
            self.navigation.pan(dx, dy, max(height, 1))

    def on_resize(self, size: tuple[int, int]) -> None:
        if size == self.frame_size or 0 in size:
            return  # a minimized window keeps its last frame target
        try:
            self.renderer.resize(size)
        except DepthImpostorError as error:  # a window larger than the GL can render: the old size stays
            self.say(f"frames stay {self.frame_size[0]}x{self.frame_size[1]}: {_reason(error)}")
            return
        self.frame_size = size
        self._release_frame_target()
        self._make_frame_target()

    def say(self, message: str) -> None:
        print(message, flush=True)
        self.message = (message, time.perf_counter())

    # ------------------------------------------------------------------ actions
    def perform(self, action: Action) -> str | None:
        """Carry out a bound action; returns what to tell the user, if anything."""
        navigation, renderer = self.navigation, self.renderer
        turns = {
            Action.TURN_LEFT: (TURN_STEP_DEGREES, 0.0), Action.TURN_RIGHT: (-TURN_STEP_DEGREES, 0.0),
            Action.TURN_UP: (0.0, TURN_STEP_DEGREES), Action.TURN_DOWN: (0.0, -TURN_STEP_DEGREES),
        }
        if action in turns:
            navigation.turn(*turns[action])
        elif action in (Action.ZOOM_IN, Action.ZOOM_OUT):
            navigation.zoom(1.0 if action == Action.ZOOM_IN else -1.0)
        elif action == Action.TOGGLE_FLY:
            navigation.toggle_fly()
            self._capture_cursor(navigation.flying)
            return "fly mode: W A S D move, Q E down/up, the mouse looks" if navigation.flying else "orbit mode"
        elif action == Action.HOME:
            navigation.reset()
            self._capture_cursor(False)
            return "back to the scene's camera"
        elif action == Action.NEXT_ALGORITHM:
            algorithms = list(Algorithm)
            # A GL without compute shaders has no depth pyramids (ContextError); a pyramid over the
            # memory budget is refused (GpuLimitError): the next algorithm is tried.
            chosen, skipped = self._next_setting(algorithms, renderer.algorithm, renderer.set_algorithm)
            return f"algorithm: {chosen.name.lower()}" + _skipped((a.name.lower(), why) for a, why in skipped)
        elif action == Action.NEXT_METHOD:
            method, passed = self._next_setting(list(Method), renderer.method, renderer.set_method)
            return f"method: {METHOD_LABELS[method]}" + _skipped((m.option, why) for m, why in passed)
        elif action in (Action.RESOLUTION_UP, Action.RESOLUTION_DOWN):
            return self._change_resolution(action == Action.RESOLUTION_UP)
        elif action == Action.TOGGLE_SAMPLES:
            if renderer.graph.sampled is None:
                return "no samples to show: " + ("no mirror" if renderer.graph.stand_in is None else
                                                 f"{METHOD_LABELS[renderer.method]} keep no depth")
            renderer.set_show_samples(not renderer.graph.show_samples)
            return "showing the baked images' samples" if renderer.graph.show_samples else "showing objects"
        elif action == Action.TOGGLE_RETRACED:
            renderer.graph.tint_retraced = not renderer.graph.tint_retraced
            shown = "tinted magenta" if renderer.graph.tint_retraced else "not tinted"
            if not METHODS[renderer.method].names_triangles:  # no other method re-traces rays
                return f"re-traced rays {shown} (only the hybrid method re-traces: M selects it)"
            return f"re-traced rays {shown}"
        elif action == Action.RELOAD_SHADERS:
            return self.reload_shaders()
        elif action == Action.SCREENSHOT:
            self.screenshot_requested = True  # taken from the next frame
        elif action == Action.TOGGLE_HELP:
            self.show_help = not self.show_help
        elif action == Action.TOGGLE_PANEL:
            if isinstance(self.panel, NoPanel):
                return NoPanel.WHY
            self.panel.visible = not self.panel.visible
        elif action == Action.QUIT:
            glfw.set_window_should_close(self.window.handle, True)
        return None

    @staticmethod
    def _next_setting(choices: list[Choice], current: Choice, use: Callable[[Choice], None]
                      ) -> tuple[Choice, list[tuple[Choice, str]]]:
        """Switch to the first choice after `current` (in a ring) that `use` accepts; the ones it
        refused, and why. `use` refuses by raising, leaving the renderer as it was; if every
        other choice is refused, `current` stays."""
        start = choices.index(current)
        skipped: list[tuple[Choice, str]] = []
        for step in range(1, len(choices)):
            wanted = choices[(start + step) % len(choices)]
            try:
                use(wanted)
            except DepthImpostorError as error:
                skipped.append((wanted, _reason(error)))
                continue
            return wanted, skipped
        return current, skipped

    def _capture_cursor(self, captured: bool) -> None:
        # Flying looks around with unbounded mouse motion: glfw hides the cursor and keeps it in
        # the window. The next motion is measured from wherever the cursor is then.
        mode = glfw.CURSOR_DISABLED if captured else glfw.CURSOR_NORMAL
        glfw.set_input_mode(self.window.handle, glfw.CURSOR, mode)
        self.cursor = None

    def _change_resolution(self, up: bool) -> str:
        setting = self.renderer.scene.render.impostor_resolution
        baked_before = self.renderer.graph.baked_images
        # From "auto", the keys step from the largest image's side.
        current = setting if isinstance(setting, int) else baked_before.atlas.resolution if baked_before else 256
        resolution = next_resolution(current, up)
        if resolution == current:
            return f"baked images stay at {current}x{current}: the end of the range"
        try:
            self.renderer.set_impostor_resolution(resolution)
        except DepthImpostorError as error:
            return f"baked images stay at {current}x{current}: {_reason(error)}"
        baked = self.renderer.graph.baked_images
        if baked is None:
            return f"image resolution {resolution}x{resolution}, for the methods that bake images"
        return f"{baked.image_noun}s {current}x{current} -> {resolution}x{resolution} (re-baking {len(baked.depth_images)})"

    def reload_shaders(self) -> str:
        try:
            fresh = self.programs.reloaded()
            try:
                self.renderer.reload_shaders()
            except ShaderError:
                fresh.release()
                raise
        except ShaderError as error:
            print(error, file=sys.stderr, flush=True)
            return "shader reload failed (the error is in the terminal); drawing with the last good shaders"
        self.overlay.release()
        self.display.release()
        self.present.release()
        self.programs.release()
        self.programs = fresh
        self._make_viewer_passes()
        return "shaders reloaded"

    def _fly(self, seconds: float) -> None:
        axes = {"forward": 0.0, "right": 0.0, "lift": 0.0}
        for key, axis, sign in FLY_KEYS:
            if KEY_CODES[key] in self.held:
                axes[axis] += sign
        fast = bool(self.held & {glfw.KEY_LEFT_SHIFT, glfw.KEY_RIGHT_SHIFT})
        if any(axes.values()):
            self.navigation.fly(axes["forward"], axes["right"], axes["lift"], min(seconds, MAX_FLY_SECONDS), fast)

    # ------------------------------------------------------------------ frames
    def panels(self) -> list[Panel]:
        renderer = self.renderer
        width, height = self.frame_size
        draws = list(itertools.islice(reversed(renderer.stats.draw_seconds), TIMING_WINDOW))
        # Before a frame is timed (the first, or frames drawn one by one by a caller, without the
        # loop that measures their intervals) there is no figure yet: the overlay says so.
        frame_ms = f"{1000.0 * statistics.median(draws):.1f} ms (median of {len(draws)})" if draws else "- ms"
        fps = f"{1.0 / statistics.median(self.frame_intervals):.1f} fps" if self.frame_intervals else "- fps"
        lines = [
            # The algorithm is the depth images' intersection; the other methods have none.
            METHOD_LABELS[renderer.method]
            + (f", {renderer.algorithm.name.lower()}" if renderer.method == Method.DEPTH else ""),
            f"{width}x{height} | {frame_ms} | {fps}",
        ]
        if renderer.graph.stand_in is not None:
            line = f"{renderer.graph.stand_in.describe()} | {renderer.graph.stand_in.bytes / 2**20:.1f} MiB"
            if renderer.graph.baked_images is not None:
                bake_ms = 1000.0 * renderer.stats.bake_seconds[-1] if renderer.stats.bake_seconds else 0.0
                line += f" | bake {bake_ms:.0f} ms"
            lines.append(line)
            waiting = renderer.graph.baked_images.deferred if renderer.graph.baked_images is not None else 0
            if waiting:  # a bake budget's (BakedImages.bake_budget): on a line of its own, which a long one hides
                lines.append(f"{waiting} images to bake, their rays traced meanwhile")
        else:
            lines.append("nothing to reflect (no mirror)")
        mode = "fly" if self.navigation.flying else "orbit"
        lines.append(f"{mode}{' | samples view' if renderer.graph.show_samples else ''} | H: help")
        if self.message and time.perf_counter() - self.message[1] < MESSAGE_SECONDS:
            lines.append(self.message[0])
        panels = [Panel(tuple(lines))]
        if self.show_help:
            panels.append(Panel(tuple(help_lines()), "top-right"))
        return panels

    def draw_frame(self) -> None:
        renderer = self.renderer
        now = time.perf_counter()
        seconds, self._last_frame = now - self._last_frame, now
        # The panel's widgets act first: the frame shows what they changed.
        self.panel.build(glfw.get_window_size(self.window.handle), self.frame_size, seconds)
        self.panel.advance(seconds)
        renderer.look_at(self.navigation.view())
        renderer.render()
        if self.screenshot_requested:
            self.screenshot_requested = False
            try:
                path = save_numbered(renderer.read_color(), self.options.screenshot_dir,
                                     Path(renderer.scene.source).stem)
            except OutputError as failure:  # a full disk loses the screenshot, not the session
                self.say(f"no screenshot: {failure}")
            else:
                self.log.screenshots.append(str(path))
                self.say(f"screenshot {path}")
        view = self.panel.view_image()
        if view is not None:  # a diagnostic view in place of the frame: a chart, written as it is
            self.frame_texture.write(np.ascontiguousarray(np.dstack([view, np.full(view.shape[:2], 255, np.uint8)])))
        else:
            self.ctx.copy_framebuffer(self.linear_texture, renderer.targets.color_framebuffer)
        self.frame_framebuffer.use()
        if view is None:
            self.display.draw(self.linear_texture, display=renderer.scene.render)
        self.overlay.draw(self.panels(), self.frame_size)
        self.ctx.screen.use()
        # The window's framebuffer was measured when the context was made; after a resize the
        # viewport must be set to its current size.
        self.ctx.viewport = (0, 0, *self.frame_size)
        self.present.draw(self.frame_texture)
        self.panel.draw()
        if self.options.window_screenshot is not None:  # copied before the swap leaves the back buffer undefined
            self.ctx.copy_framebuffer(self.window_copy, self.ctx.screen)
            width, height = self.frame_size
            pixels = np.frombuffer(self.window_copy.read(components=3), np.uint8).reshape(height, width, 3)
            self.window_pixels = pixels[::-1].copy()
        error = self.ctx.error
        if error != "GL_NO_ERROR":
            self.log.gl_errors.append({"frame": self.frames, "error": error})
            print(f"depthimpostor view: {error} in frame {self.frames}", file=sys.stderr, flush=True)
        glfw.swap_buffers(self.window.handle)

    def run(self) -> int:
        """The event loop; returns the exit status (1 if any GL error was raised)."""
        handle = self.window.handle
        script = deque(self.options.keys)
        last = time.perf_counter()
        while not glfw.window_should_close(handle):
            glfw.poll_events()
            now = time.perf_counter()
            if self.frames:
                self.frame_intervals.append(now - last)
            seconds, last = now - last, now
            # A scripted key is held for one frame: pressed before it is drawn, released after,
            # so that fly keys move the camera as a real press would.
            press = script.popleft() if script else None
            if press is not None and press.key is not None:
                self.on_key(press.key, glfw.PRESS, press.mods)
            if self.navigation.flying:
                self._fly(seconds)
            if not glfw.window_should_close(handle) and 0 not in self.frame_size:
                self.draw_frame()
                self.frames += 1
                self.log.baked_after_frame.append(self.renderer.stats.depth_images_baked)
            if press is not None and press.key is not None:
                self.on_key(press.key, glfw.RELEASE, press.mods)
            if self.options.frames is not None and self.frames >= self.options.frames:
                break
        if script:
            print(f"depthimpostor view: {len(script)} scripted keys were not pressed (--frames ended first)",
                  file=sys.stderr)
        self._finish()
        return 1 if self.log.gl_errors else 0

    def _finish(self) -> None:
        renderer = self.renderer
        draws = renderer.stats.draw_seconds
        summary = {
            "renderer": describe(self.ctx),
            "scene": renderer.scene.source,
            "frames": self.frames,
            "frame_ms_median": 1000.0 * statistics.median(draws) if draws else None,
            # The whole loop, copy, overlay, panel and present included, over the last TIMING_WINDOW frames.
            "fps_median": 1.0 / statistics.median(self.frame_intervals) if self.frame_intervals else None,
            "depth_images_baked": renderer.stats.depth_images_baked,
            "baked_after_frame": self.log.baked_after_frame,
            "events": self.log.events,
            "gl_errors": self.log.gl_errors,
            "screenshots": self.log.screenshots,
        }
        # The screenshots and the report go in place together (their paths were checked before the
        # window opened): a full disk leaves none of them, never half of one.
        with Outputs() as out:
            if self.options.screenshot is not None and self.frames:
                out.image(self.options.screenshot, renderer.read_color())
            if self.options.window_screenshot is not None and self.window_pixels is not None:
                out.image(self.options.window_screenshot, self.window_pixels)
            if self.options.report is not None:
                out.text(self.options.report, json.dumps(summary, indent=2))
        median = f"{summary['frame_ms_median']:.1f} ms" if draws else "-"
        print(
            f"{self.frames} frames, median frame {median}, {renderer.stats.depth_images_baked} depth images baked, "
            f"{len(self.log.gl_errors) or 'no'} GL errors, on {summary['renderer']}"
        )


def run_viewer(options: ViewerOptions) -> int:
    window = create_window(f"depthimpostor: {Path(options.scene.source).name}", options.scene.render.size)
    try:
        viewer = Viewer(window, options)
        try:
            return viewer.run()
        finally:
            viewer.release()
    finally:
        window.release()
