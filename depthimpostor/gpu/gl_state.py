"""GL raster state, set in scopes: a pass says the whole state it draws with, and the state before
it comes back when it ends (three.js's WebGLState, moderngl's ctx.scope). No pass enables or
disables a capability by hand, and none relies on another having left one set.

The state between scopes is BASE: the depth test on, no face culling, counter-clockwise front
faces, no blending. Renderer's public methods keep the caller's own state around all of it
(embedding.kept_state).
"""

from __future__ import annotations

import weakref
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Literal

import moderngl


Face = Literal["front", "back"]
Winding = Literal["ccw", "cw"]


def other_face(face: Face) -> Face:
    return "front" if face == "back" else "back"


@dataclass(frozen=True)
class RasterState:
    depth_test: bool = True
    cull: Face | None = None  # the faces culled, or none
    front_face: Winding = "ccw"
    blend: bool = False  # source-alpha blending (the overlay's text)
    point_size: bool = False  # gl_PointSize from the vertex shader (the sample view's splats)


BASE = RasterState()
NO_DEPTH_TEST = RasterState(depth_test=False)  # full-screen passes: the environment, the window copy

# The scopes open on each context, innermost last (a WeakKeyDictionary: a released context's
# entry goes with it).
_open: weakref.WeakKeyDictionary[moderngl.Context, list[RasterState]] = weakref.WeakKeyDictionary()


def _apply(ctx: moderngl.Context, state: RasterState) -> None:
    flags = ((moderngl.DEPTH_TEST if state.depth_test else 0) | (moderngl.CULL_FACE if state.cull else 0)
             | (moderngl.BLEND if state.blend else 0) | (moderngl.PROGRAM_POINT_SIZE if state.point_size else 0))
    ctx.enable_only(flags)
    if state.cull:
        ctx.cull_face = state.cull
    ctx.front_face = state.front_face
    if state.blend:
        ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA


def current_state(ctx: moderngl.Context) -> RasterState:
    """The state of the innermost scope open on `ctx` (BASE outside any)."""
    scopes = _open.get(ctx)
    return scopes[-1] if scopes else BASE


@contextmanager
def raster_state(ctx: moderngl.Context, state: RasterState = BASE) -> Iterator[None]:
    """Draw with `state` within the block; the enclosing scope's state (BASE outside any) after it."""
    scopes = _open.setdefault(ctx, [])
    scopes.append(state)
    _apply(ctx, state)
    try:
        yield
    finally:
        scopes.pop()
        _apply(ctx, scopes[-1] if scopes else BASE)
