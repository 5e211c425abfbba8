"""Putting a finished frame in the window: rows flipped (frames here keep row 0 at the top, a
window's row 0 is its bottom), pixels copied one to one; with `encode`, a linear frame through
the display transform on the way (lib/display.glsl, colour.py: what `read_color` gives)."""

from __future__ import annotations

import moderngl

from ..gpu.bindings import TextureUnit
from ..constants import ToneMapping
from ..gpu.gl_state import NO_DEPTH_TEST, raster_state
from ..scene.model import RenderSettings
from ..gpu.shaders import ProgramCache
from ..gpu.uniforms import write



class PresentPass:
    def __init__(self, ctx: moderngl.Context, programs: ProgramCache, encode: bool = False,
                 flip: bool = True) -> None:
        """`encode`: the frame is linear, shown through the display transform of the settings
        `draw` is given; `flip` False: into another frame (row 0 at the top too)."""
        self.ctx = ctx
        self.encode = encode
        defines = {**({"DISPLAY_ENCODE": 1} if encode else {}), **({} if flip else {"KEEP_ROWS": 1})}
        self.program = programs.get("fullscreen.vert", "present.frag", defines)
        self.vertex_array = ctx.vertex_array(self.program, [])

    def draw(self, frame: moderngl.Texture, origin: tuple[int, int] = (0, 0),
             display: RenderSettings | None = None) -> None:
        """Draw `frame` over the bound framebuffer's viewport (which must be the frame's size),
        whose lower-left corner is `origin`; an encoding pass through `display`'s exposure and
        tone mapping (the defaults' without it)."""
        frame.use(TextureUnit.FRAME)
        write(self.program, "u_frame", TextureUnit.FRAME)
        write(self.program, "u_origin", origin)
        if self.encode:
            settings = display if display is not None else RenderSettings()
            write(self.program, "u_exposure_scale", 2.0 ** settings.exposure)
            write(self.program, "u_tone_mapping", int(ToneMapping[settings.tone_mapping.upper()]))
        with raster_state(self.ctx, NO_DEPTH_TEST):
            self.vertex_array.render(moderngl.TRIANGLES, vertices=3)

    def release(self) -> None:
        self.vertex_array.release()
