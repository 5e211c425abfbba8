"""The eye camera's depth: reversed-Z into a 32-bit float depth buffer, with no far plane.

The usual OpenGL projection into a 24-bit depth buffer resolves about w^2 / (near 2^24), so the
eye's near plane had to be kept within 1e-3 of its far plane: one box 1e4 units away pushed the
near plane past a mirror 5 units from the eye, and the near scene vanished. Reversed-Z, as
current renderers draw, writes window depth = near / w (clip depth in [0, 1] through
glClipControl, GL 4.5 or ARB_clip_control) into a float buffer, tested GREATER against a clear
of 0: a float's relative precision then matches 1/w's spread, about 2^-24 of w at every
distance, so the near plane can sit just short of the nearest object and the far plane can go
(one scene may span 1e-3 to 1e7 units).

Only the passes that draw what the eye sees run under it (`eye_depth`, a scope): depth images,
shadow maps and glass interiors keep their own fitted projections and OpenGL's [-1, 1] depth,
which their GLSL reads back (lib/depth_image.glsl). moderngl wraps neither glClipControl nor a
float depth renderbuffer, so both come from GL through the context's loader (context.gl_function).
Where GL has no clip control the eye keeps the OpenGL projection, its near plane fitted to 1e-3
of the far one, and `reversed_z` warns once per context that far objects can hide near ones.
"""

from __future__ import annotations

import ctypes
import warnings
import weakref
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import moderngl
import numpy as np

from .gpu.context import gl_function
from .ppc import PPC, Array
from .scene.model import Camera

_GL_LOWER_LEFT = 0x8CA1
_GL_NEGATIVE_ONE_TO_ONE = 0x935E
_GL_ZERO_TO_ONE = 0x935F
_GL_DEPTH_COMPONENT32F = 0x8CAC
_GL_READ_FRAMEBUFFER = 0x8CA8
_GL_DRAW_FRAMEBUFFER = 0x8CA9
_GL_DEPTH_BUFFER_BIT = 0x100
_GL_NEAREST = 0x2600

#: Without clip control: the near plane is at least this share of the far plane, so that a 24-bit
#: depth buffer resolves w^2 / (near 2^24), about 1e-3 of the scene's size at its far end.
NEAR_FAR_RATIO = 1e-3

#: With reversed-Z: the near plane is this share of the nearest any object's bounding sphere
#: comes to the eye (0.9) and, for an eye inside a sphere (a floor's), at least this share of
#: that sphere's radius (1e-4). A float depth resolves w to 2^-24 of itself wherever near is, so
#: a small near plane costs nothing; it only has to stay short of every surface.
NEAR_MARGIN = 0.9
NEAR_INSIDE_SHARE = 1e-4


class EyeCamera(PPC):
    """The frame's camera: the pinhole model of PPC with the reversed-Z, infinite-far projection
    (window depth = w_near / w). Depth images and shadow maps stay plain PPCs."""

    @classmethod
    def of(cls, camera: PPC) -> EyeCamera:
        return cls(camera.C, camera.a, camera.b, camera.c, camera.width, camera.height, camera.near, camera.far)

    @property
    def projection_matrix(self) -> Array:
        """Eye space -> clip space: x and y as PPC's, clip z = w_near and clip w = w, so that NDC
        depth (glClipControl's [0, 1]) is w_near / w: 1 on the near plane, 0 at infinity."""
        projection = super().projection_matrix
        projection[2] = (0.0, 0.0, 0.0, self.w_near)
        return projection


@dataclass(frozen=True)
class ReversedZ:
    """The two GL calls reversed-Z needs that moderngl does not make."""

    clip_control: Callable[[int, int], None]
    renderbuffer_storage: Callable[[int, int, int, int], None]  # glNamedRenderbufferStorage


_support: weakref.WeakKeyDictionary[moderngl.Context, ReversedZ | None] = weakref.WeakKeyDictionary()
_reversed_now: weakref.WeakKeyDictionary[moderngl.Context, bool] = weakref.WeakKeyDictionary()


def reversed_z(ctx: moderngl.Context) -> ReversedZ | None:
    """The context's clip control (looked up once per context), or None, with a warning, where GL
    has none (before 4.5 without ARB_clip_control)."""
    if ctx in _support:
        return _support[ctx]
    support: ReversedZ | None = None
    if ctx.version_code >= 450 or "GL_ARB_clip_control" in ctx.extensions:
        clip_control = gl_function(ctx, "glClipControl")
        storage = gl_function(ctx, "glNamedRenderbufferStorage")
        if clip_control and storage:
            support = ReversedZ(
                ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_uint)(clip_control),
                ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_uint, ctypes.c_int, ctypes.c_int)(storage),
            )
    if support is None:
        warnings.warn(
            f"{ctx.info['GL_RENDERER']} (GL {ctx.version_code // 100}.{ctx.version_code % 100 // 10}) has no "
            "glClipControl (GL 4.5 or ARB_clip_control): the eye keeps a 24-bit depth buffer whose near plane "
            "is 1e-3 of its far one, so an object far beyond the rest can hide near ones; use a GL 4.5 driver "
            "(Mesa 20 or later, any current vendor driver)",
            RuntimeWarning, stacklevel=2,
        )
    _support[ctx] = support
    return support


def make_depth_buffer(ctx: moderngl.Context, size: tuple[int, int]) -> moderngl.Renderbuffer:
    """The eye's depth buffer: 32-bit float under reversed-Z, moderngl's 24-bit one otherwise."""
    depth = ctx.depth_renderbuffer(size)
    support = reversed_z(ctx)
    if support is not None:
        # moderngl makes DEPTH_COMPONENT24 alone; the same renderbuffer is given float storage.
        support.renderbuffer_storage(depth.glo, _GL_DEPTH_COMPONENT32F, size[0], size[1])
    return depth


_blits: weakref.WeakKeyDictionary[moderngl.Context, tuple[Callable[..., None], Callable[..., None]]] = \
    weakref.WeakKeyDictionary()


def copy_depth(ctx: moderngl.Context, source: moderngl.Framebuffer, target: moderngl.Framebuffer) -> None:
    """Copy `source`'s depth buffer into `target`'s, texel for texel (both the eye's: the same size
    and format, as glBlitFramebuffer asks of depth), and leave `target` bound. moderngl's
    copy_framebuffer copies colour alone, so the blit comes from GL (GL 3.0) through the loader."""
    if ctx not in _blits:
        bind_address, blit_address = gl_function(ctx, "glBindFramebuffer"), gl_function(ctx, "glBlitFramebuffer")
        if not (bind_address and blit_address):
            raise RuntimeError(f"{ctx.info['GL_RENDERER']} has no glBlitFramebuffer")
        _blits[ctx] = (ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_uint)(bind_address),
                       ctypes.CFUNCTYPE(None, *[ctypes.c_int] * 8, ctypes.c_uint, ctypes.c_uint)(blit_address))
    bind, blit = _blits[ctx]
    if source.size != target.size:
        raise ValueError(f"copy_depth: sizes differ ({source.size} and {target.size})")
    width, height = source.size
    bind(_GL_READ_FRAMEBUFFER, source.glo)
    bind(_GL_DRAW_FRAMEBUFFER, target.glo)
    blit(0, 0, width, height, 0, 0, width, height, _GL_DEPTH_BUFFER_BIT, _GL_NEAREST)
    target.use()  # both of GL's bindings again, as moderngl believes them


def clear_depth(ctx: moderngl.Context) -> float:
    """The depth the eye's buffer is cleared to: the farthest there is (0 reversed, 1 otherwise)."""
    return 0.0 if reversed_z(ctx) is not None else 1.0


@contextmanager
def eye_depth(ctx: moderngl.Context, reversed_: bool = True) -> Iterator[None]:
    """Draw with the eye's depth convention (`reversed_`) or OpenGL's (False: a bake inside an
    eye pass, such as a glass interior's), restoring the one before on leaving."""
    support = reversed_z(ctx)
    before = _reversed_now.get(ctx, False)
    wanted = reversed_ and support is not None
    if support is None or wanted == before:
        yield
        return
    _set(ctx, support, wanted)
    try:
        yield
    finally:
        _set(ctx, support, before)


def _set(ctx: moderngl.Context, support: ReversedZ, on: bool) -> None:
    support.clip_control(_GL_LOWER_LEFT, _GL_ZERO_TO_ONE if on else _GL_NEGATIVE_ONE_TO_ONE)
    ctx.depth_func = ">" if on else "<"
    _reversed_now[ctx] = on


Sphere = tuple[np.ndarray, float]


def fitted_camera(view: Camera, size: tuple[int, int], bounds: list[Sphere], reversed_: bool) -> PPC:
    """The camera of `view` (where it stands and looks), its near (and, without reversed-Z, far)
    plane fitted to the scene's bounding spheres: fixed planes would clip a scene a thousand times
    smaller (or larger) than the one they were picked for, and a moving eye changes what is near
    and far. `reversed_`: an EyeCamera (see `reversed_z`), else a PPC for OpenGL's depth."""
    eye = np.asarray(view.eye, float)
    reaches = [(float(np.linalg.norm(centre - eye)), radius) for centre, radius in bounds]
    far = max((distance + radius for distance, radius in reaches), default=1.0) * 1.01
    if not reversed_:
        nearest = min((distance - radius for distance, radius in reaches), default=far)
        near = max(far * NEAR_FAR_RATIO, nearest * NEAR_MARGIN)
        return PPC.look_at(view.eye, view.target, view.up, view.fov_y, size[0], size[1], near, far)
    nearest = min((max(distance - radius, NEAR_INSIDE_SHARE * radius) for distance, radius in reaches), default=1.0)
    # Only a sphere of radius 0 at the eye gives 0 (the loader refuses such sizes).
    near = nearest * NEAR_MARGIN if nearest > 0.0 else far * NEAR_INSIDE_SHARE
    return EyeCamera.look_at(view.eye, view.target, view.up, view.fov_y, size[0], size[1], near, far)
