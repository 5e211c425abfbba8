"""The real viewer window, driven by scripted keys under Xvfb.

Where Xvfb is not installed the window tests skip and say so; with CI=true they fail instead,
since CI (.ci/run) installs it. The viewer runs as `python -m depthimpostor view`, what a user
types, in its own process with its own X display.
"""

from __future__ import annotations

import importlib.util
import json
import os
import select
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any, cast

import moderngl
import numpy as np
import pytest
from PIL import Image

from conftest import PROJECT_ROOT, SCENES
from test_startup_bakes import textured_ring_toml
from depthimpostor.colour import quantize
from depthimpostor.oracles.compare import compare, heat_map
from depthimpostor.constants import NO_OBJECT, Method
from depthimpostor.passes.overlay import PANEL_PADDING
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene, load_scene
from depthimpostor.viewer.app import NoPanel, Viewer, make_panel
from depthimpostor.viewer.keys import ACTIONS_BY_KEY, parse_key_script

SIZE = (480, 270)
DEFAULT_SCENE = SCENES / "default.toml"


def _no_window(reason: str) -> None:
    if os.environ.get("CI") == "true":
        pytest.fail(f"{reason}; CI must be able to open the viewer's window (.ci/run installs xvfb)")
    pytest.skip(reason)


def _display_number(read_end: int, timeout: float = 20.0) -> str:
    """What Xvfb writes to -displayfd: the number, then a newline, possibly in two writes. The
    pipe must stay open until the newline: Xvfb treats a failed write as fatal."""
    text = ""
    deadline = time.monotonic() + timeout
    while not text.endswith("\n"):
        ready, _, _ = select.select([read_end], [], [], max(0.0, deadline - time.monotonic()))
        chunk = os.read(read_end, 64).decode() if ready else ""
        if not chunk:
            break  # timed out, or Xvfb exited
        text += chunk
    return text.strip()


@pytest.fixture(scope="module")
def display() -> Iterator[str]:
    """A private Xvfb server; its display name (":N", chosen by Xvfb itself)."""
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        _no_window("no X server for the viewer's window: Xvfb is not installed (apt-get install -y xvfb)")
    read_end, write_end = os.pipe()
    server = subprocess.Popen(
        [xvfb, "-displayfd", str(write_end), "-screen", "0", "1280x1024x24", "-nolisten", "tcp"],
        pass_fds=(write_end,), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
    )
    os.close(write_end)
    number = _display_number(read_end)
    os.close(read_end)
    if not number:
        server.kill()
        _no_window(f"Xvfb did not start: {server.communicate()[1].decode(errors='replace').strip()[-300:]}")
    yield f":{number}"
    server.terminate()
    server.wait(timeout=10)


def run_view(args: list[str], cwd: Path, display: str | None) -> subprocess.CompletedProcess[str]:
    env = {key: value for key, value in os.environ.items() if key not in ("DISPLAY", "WAYLAND_DISPLAY")}
    if display is not None:
        env["DISPLAY"] = display
    env["PYTHONPATH"] = str(PROJECT_ROOT)
    return subprocess.run([sys.executable, "-m", "depthimpostor", "view", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def run_views(sessions: list[tuple[Path, list[str]]], display: str) -> list[tuple[int, str]]:
    """(exit status, stderr) of each (working folder, `depthimpostor` arguments), run one after
    another in one process (VIEW_EACH), as run_view would run each in its own: one start-up
    (imports, no bytecode written here) for several sessions."""
    env = {key: value for key, value in os.environ.items() if key not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env.update(DISPLAY=display, PYTHONPATH=str(PROJECT_ROOT))
    done = subprocess.run([sys.executable, "-c", VIEW_EACH, json.dumps([(str(cwd), args) for cwd, args in sessions])],
                          cwd=sessions[0][0], env=env, capture_output=True, text=True, timeout=300 * len(sessions))
    assert done.returncode == 0, f"the viewer process failed ({done.returncode}):\n{done.stderr[-3000:]}"
    # What the process wrote past sys.stderr (the driver's own messages) counts as each session's.
    return [(result["code"], result["stderr"] + done.stderr) for result in json.loads(done.stdout.strip().splitlines()[-1])]


def session_args(keys: str, frames: int, *extra: str) -> list[str]:
    return [str(DEFAULT_SCENE), "--size", f"{SIZE[0]}x{SIZE[1]}", "--frames", str(frames), "--keys", keys,
            "--screenshot", "last.png", "--window-screenshot", "window.png", "--report", "report.json", *extra]


def session_report(folder: Path, code: int, stdout: str, stderr: str) -> dict[str, Any]:
    assert code == 0, f"viewer failed ({code}):\n{stdout}\n{stderr}"
    report = json.loads((folder / "report.json").read_text())
    assert report["gl_errors"] == []
    assert "GL_" not in stderr, stderr
    report["stdout"] = stdout
    return report


def view_session(display: str, tmp_path: Path, keys: str, frames: int, *extra: str) -> dict[str, Any]:
    done = run_view(session_args(keys, frames, *extra), tmp_path, display)
    return session_report(tmp_path, done.returncode, done.stdout, done.stderr)


def png(path: Path) -> np.ndarray:
    return np.asarray(Image.open(path).convert("RGB")).astype(np.int16)


def headless(ctx: moderngl.Context, scene: Scene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The frame `render` makes, its mirror mask, and the object each mirror pixel reflects."""
    with Renderer(ctx, scene, reflection_data=True) as renderer:
        renderer.render()
        data = renderer.read_reflection_data()
        return renderer.read_color().astype(np.int16), data.mirror_mask, data.object_id


def events_of(report: dict[str, Any], action: str) -> list[int]:
    return [event["frame"] for event in report["events"] if event["action"] == action]


def new_bakes(report: dict[str, Any], frame: int) -> int:
    baked = report["baked_after_frame"]
    return baked[frame] - (baked[frame - 1] if frame else 0)


def test_window_shows_the_scene_and_re_bakes_only_for_resolution(
    ctx: moderngl.Context, display: str, tmp_path: Path
) -> None:
    report = view_session(display, tmp_path, "wait right*4 ] up*2 down*2 left*4 p", 15, "--no-panel")
    assert report["frames"] == 15
    # The whole loop's rate beside the renderer's draw time (issue 24's viewer figure).
    assert 0 < report["fps_median"] < float("inf") and report["frame_ms_median"] > 0

    # Orbiting re-bakes nothing; the resolution key re-bakes the five depth images, once.
    assert new_bakes(report, 0) == 5
    for frame in events_of(report, "turn_right") + events_of(report, "turn_left") + events_of(report, "turn_up"):
        assert new_bakes(report, frame) == 0, f"an orbit step re-baked depth images (frame {frame})"
    [resolution_frame] = events_of(report, "resolution_up")
    assert new_bakes(report, resolution_frame) == 5
    assert report["depth_images_baked"] == 10

    # Back at the scene's camera, the screenshot is the frame `render` makes at that resolution.
    scene = load_scene(DEFAULT_SCENE).with_overrides(size=SIZE, impostor_resolution=512)
    expected, mirror, reflected = headless(ctx, scene)
    shot = png(tmp_path / "last.png")
    assert shot.shape == expected.shape
    close = np.abs(shot - expected).max(axis=2) <= 2
    assert close.mean() > 0.999, f"{(~close).mean():.2%} of the screenshot differs from the headless render"

    # The mirror shows the reflected objects: the pixels whose rays hit them show their colours.
    objects = scene.objects
    hits_objects = mirror & (reflected != NO_OBJECT)
    hits_objects &= np.isin(reflected, [i for i, o in enumerate(objects) if o.shape.__class__.__name__ != "PlaneShape"])
    assert hits_objects.sum() > 0.02 * mirror.sum()
    saturation = shot.max(axis=2) - shot.min(axis=2)
    assert np.median(saturation[hits_objects]) > 60, "reflected objects are coloured, not sky or floor grey"

    # The overlay is in the window, never in the screenshot; elsewhere the two are the same.
    window = png(tmp_path / "window.png")
    differs = np.abs(window - shot).max(axis=2) > 2
    rows, columns = np.nonzero(differs)
    top, bottom, left, right = rows.min(), rows.max(), columns.min(), columns.max()
    assert (top, left) == (PANEL_PADDING, PANEL_PADDING), "the overlay's panel starts at the top-left corner"
    assert differs[top : bottom + 1, left : right + 1].mean() > 0.5, "the overlay is one dark panel"
    assert bottom < SIZE[1] - 40 and right < SIZE[0] - 40, "the overlay leaves the rest of the frame alone"

    # P saved a numbered screenshot in the working folder.
    [numbered] = report["screenshots"]
    assert Path(numbered).name == "default-0001.png"
    assert png(tmp_path / numbered).shape == expected.shape


def test_the_hybrid_window_comes_before_its_images_and_bakes_them_over_frames(display: str, tmp_path: Path) -> None:
    """The viewer's frames bake no more than its budget of triangles (INTERACTIVE_BAKE_BUDGET) where
    the hybrid method traces the rays of the images not baked yet: 300 objects' images come in
    over several frames, each frame whole (BakedImages.bake_budget; tests/test_bake_budget.py)."""
    (tmp_path / "ring.toml").write_text(textured_ring_toml(tmp_path, 300))
    done = run_view(["ring.toml", "--size", "320x180", "--frames", "6", "--method", "hybrid", "--no-panel",
                     "--report", "report.json", "--screenshot", "last.png", "--keys", "p"], tmp_path, display)
    report = session_report(tmp_path, done.returncode, done.stdout, done.stderr)
    assert all(new_bakes(report, frame) > 0 for frame in range(6)), report["baked_after_frame"]
    assert report["baked_after_frame"][-1] < 300


def test_every_control_runs_without_gl_errors(ctx: moderngl.Context, display: str, tmp_path: Path) -> None:
    shaders = tmp_path / "shaders"
    shutil.copytree(PROJECT_ROOT / "shaders", shaders)
    keys = "tab v v m*6 f w*2 d e shift+w right up home page_up page_down [ r h f1 tab f12 wait"
    report = view_session(display, tmp_path, keys, len(keys.split()) + 5, "--shaders", str(shaders))
    done = {event["action"] for event in report["events"]}
    assert done == {
        "next_algorithm", "toggle_samples", "next_method", "toggle_fly", "turn_right", "turn_up", "home",
        "zoom_in", "zoom_out", "resolution_down", "reload_shaders", "toggle_help", "screenshot",
    }
    messages = {event["action"]: event["message"] for event in report["events"]}
    assert messages["reload_shaders"] == "shaders reloaded"
    # M goes through every method and back to depth images: the cube map bakes its six faces
    # once for both of its lookups, billboards bake one image per object, the triangle methods
    # bake nothing, and the depth images (released meanwhile) are baked again.
    method_bakes = [new_bakes(report, frame) for frame in events_of(report, "next_method")]
    assert method_bakes == [6, 0, 5, 0, 0, 5]
    # A reload re-bakes with the new programs; so did the halved resolution before it.
    assert new_bakes(report, events_of(report, "reload_shaders")[0]) == 5
    assert report["depth_images_baked"] == 5 + sum(method_bakes) + 5 + 5
    # Every setting toggled back, zoom undone, the camera home: the frame `render` makes.
    expected, _, _ = headless(ctx, load_scene(DEFAULT_SCENE).with_overrides(size=SIZE, impostor_resolution=128))
    close = np.abs(png(tmp_path / "last.png") - expected).max(axis=2) <= 2
    assert close.mean() > 0.999


def test_fly_keys_move_the_camera(display: str, tmp_path: Path) -> None:
    (tmp_path / "home").mkdir()
    (tmp_path / "flown").mkdir()
    sessions = [(tmp_path / "home", ["view", *session_args("wait", 2)]),
                (tmp_path / "flown", ["view", *session_args("f w*4", 5)])]
    for (folder, _), (code, stderr) in zip(sessions, run_views(sessions, display), strict=True):
        session_report(folder, code, "", stderr)
    home, flown = png(tmp_path / "home" / "last.png"), png(tmp_path / "flown" / "last.png")
    assert (np.abs(home - flown).max(axis=2) > 8).mean() > 0.2


def test_without_an_x_server_the_viewer_says_what_to_install(tmp_path: Path) -> None:
    done = run_view(["--frames", "1"], tmp_path, display=None)
    assert done.returncode == 3
    assert "xvfb" in done.stderr.lower() and "Traceback" not in done.stderr


def test_bad_key_scripts_and_scenes_are_refused_before_a_window_opens(tmp_path: Path) -> None:
    done = run_view(["--keys", "right nosuchkey"], tmp_path, display=None)
    assert done.returncode == 2 and "--keys: token 2" in done.stderr
    bad = tmp_path / "bad.toml"
    bad.write_text('[camera]\nfov_y = "wide"\n')
    done = run_view([str(bad)], tmp_path, display=None)
    assert done.returncode == 2 and "camera.fov_y" in done.stderr and "Traceback" not in done.stderr


MOUSE_AND_RESIZE = """
import json, sys, time
import glfw
import numpy as np
from depthimpostor.gpu.context import create_window
from depthimpostor.scene import load_scene
from depthimpostor.viewer.app import Viewer, ViewerOptions

scene = load_scene(sys.argv[1]).with_overrides(size=(320, 180))
window = create_window("test", scene.render.size)
viewer = Viewer(window, ViewerOptions(scene))
viewer.draw_frame()
nav = viewer.navigation
home_eye = nav.eye.copy()
out = {}
# A left drag across a quarter of the window's width orbits a quarter turn.
viewer.on_cursor(100.0, 90.0)
viewer.on_button(glfw.MOUSE_BUTTON_LEFT, glfw.PRESS)
viewer.on_cursor(180.0, 90.0)
viewer.on_button(glfw.MOUSE_BUTTON_LEFT, glfw.RELEASE)
offset0, offset1 = home_eye - nav.target, nav.eye - nav.target
out["orbit_degrees"] = float(np.degrees(np.arccos(np.dot(offset0[[0, 2]], offset1[[0, 2]])
                                                  / np.linalg.norm(offset0[[0, 2]]) / np.linalg.norm(offset1[[0, 2]]))))
# A right drag pans: eye and target move together.
target = nav.target.copy()
viewer.on_button(glfw.MOUSE_BUTTON_RIGHT, glfw.PRESS)
viewer.on_cursor(200.0, 90.0)
viewer.on_button(glfw.MOUSE_BUTTON_RIGHT, glfw.RELEASE)
out["panned"] = float(np.linalg.norm(nav.target - target))
glfw.set_window_size(window.handle, 400, 300)
deadline = time.time() + 10
while viewer.frame_size != (400, 300) and time.time() < deadline:
    glfw.poll_events()
viewer.draw_frame()
out["frame_size"] = list(viewer.frame_size)
out["renderer_size"] = list(viewer.renderer.scene.render.size)
out["frame_shape"] = list(viewer.renderer.read_color().shape)
out["baked"] = viewer.renderer.stats.depth_images_baked
out["gl_error"] = viewer.ctx.error
viewer.release()
window.release()
print(json.dumps(out))
"""


def test_mouse_drags_and_window_resizes(display: str, tmp_path: Path) -> None:
    """The glfw callbacks' handlers, driven in a real window: drags orbit and pan; a resize
    renders at the new framebuffer size and re-bakes nothing."""
    env = {**os.environ, "DISPLAY": display, "PYTHONPATH": str(PROJECT_ROOT)}
    done = subprocess.run([sys.executable, "-c", MOUSE_AND_RESIZE, str(DEFAULT_SCENE)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["orbit_degrees"] == pytest.approx(90.0, abs=1e-6)
    assert result["panned"] > 0.1
    assert result["frame_size"] == result["renderer_size"] == [400, 300]
    assert result["frame_shape"] == [300, 400, 3]
    assert result["baked"] == 5
    assert result["gl_error"] == "GL_NO_ERROR"


#: Every binding of the viewer, each pressed at least once: the methods in turn (M), with the
#: samples view (V) and the re-traced tint (T) toggled in several of them, the algorithms (Tab),
#: the resolution up and down, a shader reload, help, screenshots, every move, and Escape last.
EVERY_KEY = ("wait tab tab tab m v t m v m v t m v m m v t m v t m ] [ [ ] v r h f1 f2 f2 p f12 right left up down "
             "page_up page_down f w a s d q e shift+w f home wait escape")

#: Where the depth method cannot start: no depth-image frustum fits an object that surrounds the
#: mirror's centre (`render` refuses it too). The methods that bake are skipped by M there.
START_METHOD = {"surrounds.toml": "raytrace"}


#: The scenes with mirrors in mirrors (render.max_bounces = 2) skip every other method, saying why,
#: and so does the scene whose ring surrounds the mirror's centre, for the methods that bake.
SKIPS_METHODS = {"two_mirrors.toml", "glass_and_mirrors.toml", "surrounds.toml"}
PROJECT_SCENES = sorted(SCENES.glob("*.toml")) + sorted((SCENES / "hard").glob("*.toml"))


def test_the_key_script_presses_every_binding() -> None:
    assert {binding.action for binding in ACTIONS_BY_KEY.values()} == {
        ACTIONS_BY_KEY[press.key].action for press in parse_key_script(EVERY_KEY) if press.key in ACTIONS_BY_KEY}


#: The viewer as `python -m depthimpostor view` runs it (cli.main), once for each (working folder,
#: arguments) in argv[1] (JSON), in one process: each session its own window, GL context and
#: renderer. Its exit status (1 for an exception, with its traceback, as Python's would be) and
#: what it wrote to stderr are collected for each.
VIEW_EACH = """
import contextlib, io, json, os, sys, traceback
from depthimpostor.cli import main

results = []
for folder, args in json.loads(sys.argv[1]):
    os.chdir(folder)
    stderr = io.StringIO()
    with contextlib.redirect_stderr(stderr):
        try:
            code = main(args)
        except SystemExit as exit:
            code = exit.code if isinstance(exit.code, int) else 1
        except BaseException:
            traceback.print_exc()
            code = 1
    results.append({"code": code, "stderr": stderr.getvalue()})
print(json.dumps(results))
"""


def every_key_args(scene: Path) -> list[str]:
    # Small images: the keys are the point, not the images' detail (at the scenes' own 256^2,
    # 512^2 after "]", baking every method's images took most of the suite's time).
    return ["view", str(scene), "--size", "96x54", "--impostor-res", "32", "--keys", EVERY_KEY, "--report", "report.json",
            "--method", START_METHOD.get(scene.name, "depth")]


@pytest.fixture(scope="module")
def every_key_sessions(request: pytest.FixtureRequest, display: str,
                       tmp_path_factory: pytest.TempPathFactory) -> dict[Path, tuple[int, str, Path]]:
    """Each selected project scene's session of EVERY_KEY: (exit status, stderr, report path). The
    sessions run one after another in one viewer process (VIEW_EACH): a process each spent most of
    its time starting Python and importing what every session imports again."""
    scenes = [item.callspec.params["scene"] for item in request.session.items
              if getattr(item, "originalname", None) == "test_every_key_in_every_project_scene_keeps_the_session"]
    folders = [tmp_path_factory.mktemp("every_key") for _ in scenes]
    results = run_views([(folder, every_key_args(scene)) for scene, folder in zip(scenes, folders, strict=True)], display)
    return {scene: (code, stderr, folder / "report.json")
            for scene, (code, stderr), folder in zip(scenes, results, folders, strict=True)}


# All in one worker (pyproject's --dist loadgroup), which runs them in one process (the fixture
# above); xdist starts the groups with the most tests first, so this long one does not come last.
@pytest.mark.xdist_group("viewer_every_key")
@pytest.mark.parametrize("scene", PROJECT_SCENES, ids=lambda path: str(path.relative_to(SCENES).with_suffix("")))
def test_every_key_in_every_project_scene_keeps_the_session(
    every_key_sessions: dict[Path, tuple[int, str, Path]], scene: Path
) -> None:
    """No key ends the session, in any project scene: what a scene cannot do (another method with
    mirrors in mirrors, say) is skipped or refused in the overlay, and the session goes on to the
    scripted Escape."""
    pressed = len(EVERY_KEY.split())
    bound = sum(press.key in ACTIONS_BY_KEY for press in parse_key_script(EVERY_KEY))  # not waits, fly keys
    code, stderr, report_path = every_key_sessions[scene]
    assert code == 0, f"{scene.name}: exit {code}\n{stderr[-3000:]}"
    report = json.loads(report_path.read_text())
    assert report["gl_errors"] == [], scene.name
    # Every key acted, none ended the session early: Escape did, last (before its frame).
    assert report["frames"] == pressed - 1, scene.name
    assert len(report["events"]) == bound, scene.name
    assert report["events"][-1]["action"] == "quit"
    methods = [event["message"] for event in report["events"] if event["action"] == "next_method"]
    if scene.name in SKIPS_METHODS:
        assert any("skipped" in message for message in methods), methods


OVER_THE_LIMIT = """
import dataclasses, json, sys
import glfw
from depthimpostor.gpu.context import create_window
from depthimpostor.gpu.limits import context_limits, use_limits
from depthimpostor.scene import load_scene
from depthimpostor.viewer.app import Viewer, ViewerOptions

scene = load_scene(sys.argv[1]).with_overrides(size=(160, 90), impostor_resolution=512)
window = create_window("test", scene.render.size)
# A GL whose textures are 2048 a side at most: 5 images of 1024 need a 3072 x 2048 atlas.
use_limits(window.ctx, dataclasses.replace(context_limits(window.ctx), max_texture_size=2048))
viewer = Viewer(window, ViewerOptions(scene))
viewer.draw_frame()
viewer.on_key(glfw.KEY_RIGHT_BRACKET, glfw.PRESS, 0)
viewer.draw_frame()
out = {"message": viewer.message[0], "overlay": list(viewer.panels()[0].lines),
       "resolution": viewer.renderer.graph.baked_images.atlas.resolution, "gl_error": viewer.ctx.error}
viewer.release()
window.release()
print(json.dumps(out))
"""


def test_a_resolution_over_the_gl_limits_keeps_the_old_and_says_why(display: str, tmp_path: Path) -> None:
    env = {**os.environ, "DISPLAY": display, "PYTHONPATH": str(PROJECT_ROOT)}
    done = subprocess.run([sys.executable, "-c", OVER_THE_LIMIT, str(DEFAULT_SCENE)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["resolution"] == 512
    assert result["message"].startswith("baked images stay at 512x512: the atlas of 5 baked images of 1024x1024")
    assert "GL_MAX_TEXTURE_SIZE of 2048" in result["message"] and result["message"] in result["overlay"]
    assert result["gl_error"] == "GL_NO_ERROR"
    # Frames drawn one by one have no interval to time: the overlay says "-", not "nan".
    assert not any("nan" in line for line in result["overlay"]) and any("- fps" in line for line in result["overlay"])


def test_view_takes_a_memory_budget(display: str, tmp_path: Path) -> None:
    (refused, refusal), (fits, stderr) = run_views(
        [(tmp_path, ["view", str(DEFAULT_SCENE), "--size", "160x90", "--frames", "1", "--max-memory", budget])
         for budget in ("1M", "64M")], display)
    assert refused == 2 and "Traceback" not in refusal
    assert "over the 1.00 MiB of --max-memory (the most: depth images" in refusal
    assert refusal.strip().endswith("lower --impostor-res or raise --max-memory")
    assert fits == 0, stderr


#: The panel test's window: tall enough for the panel's views and graphs.
PANEL_SIZE = (640, 400)
PANEL = """
import json, sys
from pathlib import Path
import glfw
import numpy as np
from depthimpostor.gpu.context import create_window
from depthimpostor.scene import load_scene
from depthimpostor.viewer.app import Viewer, ViewerOptions

scene = load_scene(sys.argv[1]).with_overrides(size=(640, 400))
window = create_window("test", scene.render.size)
viewer = Viewer(window, ViewerOptions(scene, window_screenshot=Path("unused.png")))
panel = viewer.panel
out = {}

def click(label):
    # The real widget path: the window's mouse, through the viewer's glfw handlers, into ImGui.
    x0, y0, x1, y1 = panel.rects[label]
    viewer.on_cursor((x0 + x1) / 2, (y0 + y1) / 2)
    viewer.draw_frame()
    viewer.on_button(glfw.MOUSE_BUTTON_LEFT, glfw.PRESS)
    viewer.draw_frame()
    viewer.on_button(glfw.MOUSE_BUTTON_LEFT, glfw.RELEASE)
    viewer.draw_frame()
    viewer.draw_frame()  # a popup's first frame only measures it: its items are placed in the next

viewer.draw_frame()
viewer.draw_frame()
np.save("frame_depth.npy", viewer.renderer.read_color())
# The error view, traced in the background: frames go on while it traces.
click("trace the truth now")
frames_while_tracing = 0
while not panel.truth.done:
    viewer.draw_frame()
    frames_while_tracing += 1
viewer.draw_frame()
out["frames_while_tracing"] = frames_while_tracing
np.save("error_view.npy", panel.view_image())
np.save("error_window.npy", viewer.window_pixels)
out["error_rect"] = panel.rects["view/frame"]
click("view/frame")
out["view_after"] = panel.view.value
click("method")
click("method/cubemap")
out["method"] = viewer.renderer.method.option
np.save("frame_cubemap.npy", viewer.renderer.read_color())
click("resolution")
click("resolution/32")
out["resolution"] = viewer.renderer.scene.render.impostor_resolution
np.save("frame_cubemap_32.npy", viewer.renderer.read_color())
np.save("window.npy", viewer.window_pixels)
out["rects"] = {k: panel.rects[k] for k in ("method", "resolution")}
out["baked"] = viewer.renderer.stats.depth_images_baked
out["gl_error"] = viewer.ctx.error
viewer.release()
window.release()
print(json.dumps(out))
"""


def test_the_panel_changes_method_and_resolution_and_shows_the_error_against_the_truth(
    ctx: moderngl.Context, display: str, tmp_path: Path
) -> None:
    """Clicks on the panel's widgets (mouse events through the viewer's glfw handlers into ImGui)
    change the method and the resolution, and the frame is then the one `render` makes with them;
    the error view, traced in the background, is `compare`'s difference image."""
    if sys.version_info < (3, 11) and importlib.util.find_spec("imgui_bundle") is None:
        pytest.skip("imgui-bundle has wheels for Python 3.11 and later (pyproject.toml): the panel is tested there")
    env = {**os.environ, "DISPLAY": display, "PYTHONPATH": str(PROJECT_ROOT)}
    done = subprocess.run([sys.executable, "-c", PANEL, str(DEFAULT_SCENE)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["gl_error"] == "GL_NO_ERROR"
    assert result["method"] == "cubemap" and result["resolution"] == 32
    scene = load_scene(DEFAULT_SCENE).with_overrides(size=PANEL_SIZE)

    def frame_of(name: str) -> np.ndarray:
        frame = np.load(tmp_path / f"{name}.npy").astype(np.int16)
        assert frame.shape == (PANEL_SIZE[1], PANEL_SIZE[0], 3)
        return frame

    def close(a: np.ndarray, b: np.ndarray) -> float:
        return float((np.abs(a.astype(np.int16) - b.astype(np.int16)).max(axis=2) <= 2).mean())

    with Renderer(ctx, scene, method=Method.CUBEMAP) as renderer:
        renderer.render()
        cubemap = renderer.read_color().astype(np.int16)
        renderer.set_impostor_resolution(32)
        renderer.render()
        cubemap_32 = renderer.read_color().astype(np.int16)
    # Each change shows: the frame is what `render` makes with the new setting, and differs from before.
    assert close(frame_of("frame_cubemap"), cubemap) > 0.999
    assert close(frame_of("frame_cubemap_32"), cubemap_32) > 0.999
    # (The mirror is a small part of the frame: the cube map's lookup changes 1.2 % of the frame's
    # pixels, its faces at 32x32 0.26 %.)
    assert close(frame_of("frame_depth"), cubemap) < 0.995
    assert close(cubemap, cubemap_32) < 0.999
    # The window shows the panel (over the frame's right part), the frame elsewhere.
    window = np.load(tmp_path / "window.npy")
    x0, _, x1, _ = result["rects"]["method"]
    assert close(window[130:, : int(x0) - 20], cubemap_32[130:, : int(x0) - 20]) > 0.99
    assert close(window[:, int(x0) : int(x1)], cubemap_32[:, int(x0) : int(x1)]) < 0.5

    # The error view is compare's difference image of the same frame.
    with Renderer(ctx, scene, reflection_data=True) as renderer:
        renderer.render()
        expected = quantize(heat_map(compare(renderer)))
    view = np.load(tmp_path / "error_view.npy")
    assert view.shape == expected.shape and np.isfinite(view).all()
    assert close(view, expected) > 0.999
    assert (expected.max(axis=2) > 0).mean() > 0.01, "the difference image is not empty"
    error_window = np.load(tmp_path / "error_window.npy")
    left = int(result["error_rect"][0]) - 20
    assert close(error_window[130:, :left], expected[130:, :left]) > 0.99, "the window shows the error view"
    assert result["view_after"] == "frame"


def test_without_imgui_bundle_the_viewer_has_no_panel_and_says_why(monkeypatch: pytest.MonkeyPatch) -> None:
    """Where imgui-bundle is not installed (Python 3.10: no wheel), the viewer runs without its panel."""
    monkeypatch.setitem(sys.modules, "imgui_bundle", None)  # an import of it raises ImportError
    monkeypatch.delitem(sys.modules, "depthimpostor.viewer.panel", raising=False)
    panel = make_panel(cast(Viewer, None), visible=True)
    assert isinstance(panel, NoPanel) and not panel.visible and not panel.wants_mouse
    assert panel.view_image() is None and "imgui-bundle" in NoPanel.WHY


def test_an_import_error_of_the_panels_own_is_raised(monkeypatch: pytest.MonkeyPatch) -> None:
    """Only imgui-bundle or PyOpenGL missing means "no panel": a module of the panel's own that
    fails to import is a bug to see, not a panel quietly gone. (Where imgui-bundle is not
    installed the panel's import stops at it first: nothing of the panel's own is reached.)"""
    if importlib.util.find_spec("imgui_bundle") is None:
        pytest.skip("imgui-bundle is not installed here (Python 3.10: no wheel): the panel's import stops at it")
    monkeypatch.setitem(sys.modules, "depthimpostor.viewer.views", None)
    monkeypatch.delitem(sys.modules, "depthimpostor.viewer.panel", raising=False)
    with pytest.raises(ModuleNotFoundError, match="depthimpostor.viewer.views"):
        make_panel(cast(Viewer, None), visible=True)
