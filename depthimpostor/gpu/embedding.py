"""Living in someone else's GL context: the renderer leaves the GL state as it found it, and can
put its frame, upright, into a framebuffer the caller gives.

The contract (docs/python_api.md): every public `Renderer` method restores, on return or on an
error, the bound framebuffer and its viewport, the enable flags (blend, depth test, face culling,
rasterizer discard, program point size) and the culled and front faces. moderngl's scope keeps
the first two as moderngl records them (an application that binds framebuffers with raw GL calls
must bind its own again); texture units, the bound program and vertex array are not kept, since
moderngl binds those at every draw call.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar, cast

import moderngl

from .context import bind_default_framebuffer
from ..passes.present import PresentPass
from ..scene.model import RenderSettings
from .shaders import ProgramCache

Method = TypeVar("Method", bound=Callable[..., Any])


@contextmanager
def kept_state(ctx: moderngl.Context, enable_only: int | None = None) -> Iterator[None]:
    """Within the block, change any GL state; after it, the framebuffer, viewport, enable flags and
    face culling are as they were. `enable_only`: the flags to start the block with."""
    cull_face, front_face = ctx.cull_face, ctx.front_face
    # A scope binds its framebuffer on entry: the one bound now (detected), so nothing changes.
    scope = ctx.scope(ctx.detect_framebuffer(), enable_only=enable_only)
    try:
        with scope:
            try:
                yield
            finally:
                ctx.cull_face, ctx.front_face = cull_face, front_face
    finally:
        scope.release()


def keeps_gl_state(method: Method) -> Method:
    """A method of an object with a `ctx` that leaves the GL state as it found it (kept_state)."""
    @functools.wraps(method)
    def kept(self: Any, *args: Any, **kwargs: Any) -> Any:
        with kept_state(self.ctx):
            return method(self, *args, **kwargs)
    return cast(Method, kept)


class FramePresenter:
    """The renderer's frame copied into a caller's framebuffer, row 0 at the bottom as GL has it
    (the renderer's frames keep row 0 at the top, as images do)."""

    def __init__(self, ctx: moderngl.Context, programs: ProgramCache, size: tuple[int, int]) -> None:
        self.ctx = ctx
        self.size = size
        # Float, as the frame is: the display transform reads the linear values, not 8-bit ones.
        self.texture = ctx.texture(size, 4, dtype="f4")
        self.framebuffer = ctx.framebuffer([self.texture])
        self.present = PresentPass(ctx, programs, encode=True)

    def draw(self, frame: moderngl.Framebuffer, target: moderngl.Framebuffer,
             viewport: tuple[int, int, int, int] | None = None, display: RenderSettings | None = None) -> None:
        """Put `frame` (the renderer's colour framebuffer) into `viewport` of `target` (default: all
        of it) through `display`'s display transform, as `read_color` gives it; the viewport must
        be the frame's size."""
        x, y, width, height = viewport if viewport is not None else (0, 0, *target.size)
        if (width, height) != self.size:
            raise ValueError(f"the target's viewport is {width}x{height}, the frame {self.size[0]}x{self.size[1]}: "
                             "resize the renderer to the viewport first (Renderer.resize)")
        self.ctx.copy_framebuffer(self.framebuffer, frame)
        kept = target.viewport  # moderngl keeps a viewport per framebuffer: the caller's is put back
        target.use()
        self.ctx.viewport = (x, y, width, height)
        try:
            self.present.draw(self.texture, (x, y), display)
        finally:
            target.viewport = kept

    def release(self) -> None:
        bind_default_framebuffer(self.ctx)
        self.present.release()
        self.framebuffer.release()
        self.texture.release()
