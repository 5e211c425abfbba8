"""Putting a finished frame in the window: rows flipped (frames here keep row 0 at the top, a
window's row 0 is its bottom), pixels copied one to one."""

from __future__ import annotations

import moderngl

from ..gl_state import NO_DEPTH_TEST, raster_state
from ..bindings import TextureUnit
from ..shaders import ProgramCache
from .uniforms import write



class PresentPass:
    def __init__(self, ctx: moderngl.Context, programs: ProgramCache) -> None:
        self.ctx = ctx
        self.program = programs.get("fullscreen.vert", "present.frag")
        self.vertex_array = ctx.vertex_array(self.program, [])

    def draw(self, frame: moderngl.Texture, origin: tuple[int, int] = (0, 0)) -> None:
        """Draw `frame` over the bound framebuffer's viewport (which must be the frame's size),
        whose lower-left corner is `origin`."""
        frame.use(TextureUnit.FRAME)
        write(self.program, "u_frame", TextureUnit.FRAME)
        write(self.program, "u_origin", origin)
        with raster_state(self.ctx, NO_DEPTH_TEST):
            self.vertex_array.render(moderngl.TRIANGLES, vertices=3)

    def release(self) -> None:
        self.vertex_array.release()
