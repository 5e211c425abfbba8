"""docs/viewer-panel.png: the viewer's window with its panel, the default scene's error against the
truth traced from the panel's button. Run under an X server (the viewer needs a window):

    xvfb-run -a -s "-screen 0 1024x768x24" python3 tools/panel_picture.py docs/viewer-panel.png

The frames are drawn one by one (Viewer.draw_frame) and this script times the intervals between
them for the overlay's fps, as the viewer's own loop does.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import glfw
from PIL import Image

from depthimpostor.gpu.context import create_window
from depthimpostor.scene import load_scene
from depthimpostor.viewer.app import Viewer, ViewerOptions

ROOT = Path(__file__).resolve().parent.parent
SIZE = (800, 450)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("output", type=Path)
    args = parser.parse_args()
    scene = load_scene(ROOT / "scenes" / "default.toml").with_overrides(size=SIZE)
    window = create_window("depthimpostor panel", scene.render.size)
    viewer = Viewer(window, ViewerOptions(scene, window_screenshot=Path("unused.png")))
    from depthimpostor.viewer.panel import ControlPanel  # imgui-bundle: Python 3.11 or later

    panel = viewer.panel
    assert isinstance(panel, ControlPanel)
    for _ in range(3):
        viewer.draw_frame()
    # A click on the button, through the viewer's glfw handlers into ImGui (as tests/test_viewer.py).
    x0, y0, x1, y1 = panel.rects["trace the truth now"]
    viewer.on_cursor((x0 + x1) / 2, (y0 + y1) / 2)
    viewer.draw_frame()
    for action in (glfw.PRESS, glfw.RELEASE):
        viewer.on_button(glfw.MOUSE_BUTTON_LEFT, action)
        viewer.draw_frame()
    while panel.truth is None or not panel.truth.done:
        viewer.draw_frame()
    viewer.on_cursor(5.0, SIZE[1] - 10.0)  # away from the widgets
    last = time.perf_counter()
    for _ in range(30):
        viewer.draw_frame()
        now = time.perf_counter()
        viewer.frame_intervals.append(now - last)
        last = now
    pixels = viewer.window_pixels
    assert pixels is not None
    Image.fromarray(pixels).save(args.output)
    print(" / ".join(viewer.panels()[0].lines))
    viewer.release()
    window.release()


if __name__ == "__main__":
    main()
