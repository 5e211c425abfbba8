"""depthimpostor: specular reflections through depth-image impostors, intersected per pixel.

The Python API (docs/python_api.md): `render_image` renders a scene file or `Scene` to a numpy
array; `Renderer` draws frames in a moderngl context (one from `create_context`, or the
application's own, whose GL state it leaves as found) and can put them in a framebuffer the
caller gives. In Jupyter, `show` displays a frame and `interactive` a view to orbit with the mouse
(docs/notebooks_and_videos.md). Every error a user can cause is a `DepthImpostorError`.
"""

from __future__ import annotations

from .api import render_image
from .gpu.context import create_context
from .errors import DepthImpostorError
from .notebook import interactive, show
from .renderer import Renderer
from .scene import Scene, load_scene

__version__ = "0.1.0"

__all__ = ["DepthImpostorError", "Renderer", "Scene", "create_context", "interactive", "load_scene", "render_image",
           "show"]
