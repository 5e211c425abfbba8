"""Jupyter: a notebook executed on a real kernel (nbclient, ipykernel) shows `depthimpostor.show`'s
frame as a PNG and makes the interactive view; the view's remote framebuffer (jupyter_rfb) draws
the renderer's frames and answers the browser's events (orbit, pan, zoom, reset, resize); its
controls change the renderer's settings, and a refused one is put back."""

from __future__ import annotations

import base64
import io
from collections.abc import Iterator
from pathlib import Path

import moderngl
import nbformat
import numpy as np
import pytest
from nbclient import NotebookClient
from PIL import Image

from conftest import PROJECT_ROOT, SCENES, assert_finite
from depthimpostor.constants import Method
from depthimpostor.errors import GpuLimitError
from depthimpostor.notebook.widgets import Interactive, SceneView
from depthimpostor.renderer import Renderer
from depthimpostor.scene import load_scene

SIZE = (64, 48)

NOTEBOOK_CELLS = [
    "import depthimpostor\nprint(depthimpostor.__file__)",
    f"depthimpostor.show('scenes/default.toml', size={SIZE})",
    f"view = depthimpostor.interactive('scenes/carousel.toml', size={SIZE}, time=1.0)\nview",
    "from PIL import Image\nview.view.handle_event({'event_type': 'wheel', 'dx': 0, 'dy': -100, 'x': 0, 'y': 0})\n"
    "Image.fromarray(view.view.get_frame())",
]


def png_of(output: nbformat.NotebookNode) -> np.ndarray:
    assert "image/png" in output.get("data", {}), output
    with Image.open(io.BytesIO(base64.b64decode(output["data"]["image/png"]))) as image:
        return np.asarray(image.convert("RGB"))


def test_a_notebook_shows_a_frame_and_the_interactive_view() -> None:
    notebook = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(code) for code in NOTEBOOK_CELLS])
    NotebookClient(notebook, timeout=120, kernel_name="python3",
                   resources={"metadata": {"path": str(PROJECT_ROOT)}}).execute()
    # (An error in a cell raises CellExecutionError: every cell ran.)
    imported, shown, interactive, zoomed = (cell.outputs for cell in notebook.cells)
    assert str(PROJECT_ROOT) in imported[0]["text"], "the kernel imported another depthimpostor"
    frame = png_of(shown[-1])
    assert frame.shape == (SIZE[1], SIZE[0], 3) and frame.std() > 10.0
    # The cell's value is the controls' box, holding the remote framebuffer (an anywidget model).
    models = notebook.metadata.widgets["application/vnd.jupyter.widget-state+json"]["state"]
    value = interactive[-1]
    assert value["output_type"] == "execute_result"
    box = models[value["data"]["application/vnd.jupyter.widget-view+json"]["model_id"]]
    assert box["model_name"] == "VBoxModel"
    children = [models[child.removeprefix("IPY_MODEL_")] for child in box["state"]["children"]]
    assert [child["model_name"] for child in children] == ["HBoxModel", "AnyModel", "LabelModel"]
    assert children[1]["state"]["css_width"] == f"{SIZE[0]}px"
    closer = png_of(zoomed[-1])
    assert closer.shape == frame.shape and closer.std() > 10.0


@pytest.fixture
def view(ctx: moderngl.Context) -> Iterator[SceneView]:
    scene = load_scene(SCENES / "default.toml").with_overrides(size=SIZE)
    widget = SceneView(Renderer(ctx, scene))
    widget.requested = 0
    widget.request_draw = lambda: setattr(widget, "requested", widget.requested + 1)
    yield widget
    widget.close()
    widget.close()  # harmless


def changed(before: np.ndarray, after: np.ndarray) -> float:
    return float(np.abs(before.astype(np.float64) - after).mean())


def test_the_view_draws_the_renderers_frame(view: SceneView) -> None:
    frame = view.get_frame()
    assert frame.shape == (SIZE[1], SIZE[0], 3) and frame.dtype == np.uint8
    assert_finite(view.renderer.read_color_float())
    assert frame.std() > 10.0
    assert view.frames == 2  # the first when it was made


def test_a_left_drag_orbits_and_a_double_click_goes_home(view: SceneView) -> None:
    home = view.get_frame()
    eye, target = view.navigation.eye.copy(), view.navigation.target.copy()
    view.handle_event({"event_type": "pointer_down", "x": 10.0, "y": 20.0, "button": 1, "buttons": (1,)})
    view.handle_event({"event_type": "pointer_move", "x": 26.0, "y": 20.0, "button": 0, "buttons": (1,)})
    view.handle_event({"event_type": "pointer_up", "x": 26.0, "y": 20.0, "button": 1, "buttons": ()})
    assert view.requested == 1
    # 16 of 64 pixels across: a quarter turn about the target, at the same distance and height.
    turned = view.navigation.eye
    assert np.linalg.norm(turned - target) == pytest.approx(np.linalg.norm(eye - target))
    assert turned[1] == pytest.approx(eye[1])
    cosine = np.dot((eye - target)[[0, 2]], (turned - target)[[0, 2]])
    assert cosine == pytest.approx(0.0, abs=1e-9)
    orbited = view.get_frame()
    assert changed(home, orbited) > 10.0
    # Moving with no button held does nothing, and asks for no frame.
    view.handle_event({"event_type": "pointer_move", "x": 50.0, "y": 5.0, "button": 0, "buttons": ()})
    assert view.requested == 1 and np.allclose(view.navigation.eye, turned)
    view.handle_event({"event_type": "double_click", "x": 5.0, "y": 5.0, "button": 1, "buttons": ()})
    assert np.allclose(view.navigation.eye, eye) and view.requested == 2
    assert changed(home, view.get_frame()) == 0.0


def test_a_right_drag_pans_and_the_wheel_zooms(view: SceneView) -> None:
    eye, target = view.navigation.eye.copy(), view.navigation.target.copy()
    view.handle_event({"event_type": "pointer_down", "x": 10.0, "y": 10.0, "button": 2, "buttons": (2,)})
    view.handle_event({"event_type": "pointer_move", "x": 20.0, "y": 10.0, "button": 0, "buttons": (2,)})
    assert np.allclose(view.navigation.eye - eye, view.navigation.target - target)  # both slid alike
    assert not np.allclose(view.navigation.target, target)
    distance = view.navigation.distance
    view.handle_event({"event_type": "wheel", "dx": 0.0, "dy": -100.0, "x": 0.0, "y": 0.0})
    assert view.navigation.distance == pytest.approx(0.85 * distance)
    assert view.requested == 2


def test_a_resize_changes_the_frame_size(view: SceneView) -> None:
    view.handle_event({"event_type": "resize", "width": 80.0, "height": 40.0, "pixel_ratio": 1.0})
    assert view.get_frame().shape == (40, 80, 3) and view.requested == 1
    view.handle_event({"event_type": "resize", "width": 80.0, "height": 40.0, "pixel_ratio": 1.0})
    assert view.requested == 1  # the same size: nothing to draw again


def test_the_controls_change_the_renderer(ctx: moderngl.Context, monkeypatch: pytest.MonkeyPatch) -> None:
    scene = load_scene(SCENES / "carousel.toml").with_overrides(size=SIZE)

    def refuse(self: Renderer, resolution: int | str) -> None:
        raise GpuLimitError(f"--impostor-res: {resolution} is too large for this test")

    monkeypatch.setattr(Renderer, "set_impostor_resolution", refuse)
    controls = Interactive(Renderer(ctx, scene))
    try:
        renderer = controls.view.renderer
        before = controls.view.get_frame()
        controls.method.value = "cubemap"
        assert renderer.method is Method.CUBEMAP and controls.status.value.startswith("cubemap: ")
        controls.time.value = 3.0
        assert renderer.time == 3.0
        assert changed(before, controls.view.get_frame()) > 0.1
        controls.resolution.value = 512
        assert controls.resolution.value == 256 and renderer.scene.render.impostor_resolution == 256
        assert "resolution 512 refused: --impostor-res: 512 is too large" in controls.status.value
    finally:
        controls.view.close()


def test_the_controls_include_time_only_for_an_animated_scene(ctx: moderngl.Context) -> None:
    scene = load_scene(SCENES / "default.toml").with_overrides(size=SIZE)
    controls = Interactive(Renderer(ctx, scene))
    try:
        assert controls.time not in controls.children[0].children
        controls.resolution.value = "auto"
        assert controls.view.renderer.scene.render.impostor_resolution == "auto"
    finally:
        controls.view.close()


def test_show_is_a_png_in_a_notebook() -> None:
    import depthimpostor

    image = depthimpostor.show(Path(SCENES / "default.toml"), size=SIZE)
    assert image.size == SIZE and image.mode == "RGB"
    assert image._repr_png_()[:8] == b"\x89PNG\r\n\x1a\n"
