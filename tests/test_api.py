"""The Python API: `render_image`, and the renderer embedded in an application's own moderngl
context and framebuffer (the contract in docs/python_api.md)."""

from __future__ import annotations

import ctypes
import ctypes.util
import threading
from collections.abc import Iterator
from typing import Any

import moderngl
import numpy as np
import pytest

import depthimpostor
from conftest import SCENES, assert_finite
from depthimpostor.colour import display_encode
from depthimpostor.errors import ContextError
from depthimpostor.scene import load_scene

SIZE = (64, 36)
SCENE = SCENES / "default.toml"


def test_render_image_is_the_frame_the_renderer_draws(ctx: moderngl.Context) -> None:
    image = depthimpostor.render_image(SCENE, size=SIZE, impostor_resolution=64)
    assert image.dtype == np.uint8 and image.shape == (SIZE[1], SIZE[0], 3)
    scene = load_scene(SCENE).with_overrides(size=SIZE, impostor_resolution=64)
    with depthimpostor.Renderer(ctx, scene) as renderer:
        renderer.render()
        expected = renderer.read_color()
    assert np.abs(image.astype(int) - expected).max() <= 1
    # A Scene in, float out, in the caller's context, which stays open.
    color = depthimpostor.render_image(scene, dtype="float32", ctx=ctx)
    assert color.dtype == np.float32 and color.shape == image.shape
    assert_finite(color)
    # uint8 is the float frame, linear, through the display transform (sRGB-encoded: docs/colour.md).
    assert np.abs(display_encode(color).astype(int) - expected).max() <= 1
    assert ctx.error == "GL_NO_ERROR"


@pytest.mark.parametrize(("argument", "value", "message"), [
    ("method", "mirror", "method: expected one of"), ("algorithm", "fast", "algorithm: expected one of"),
    ("dtype", "float16", "dtype: expected"),
    ("method", None, "method: expected one of"), ("method", 3, "method: expected one of"),
    ("algorithm", None, "algorithm: expected one of"),
    ("time", float("nan"), "time: expected a finite number"), ("time", float("inf"), "time: expected a finite"),
    ("time", "1", "time: expected a finite number"),
    ("max_memory", "1G", "max_memory: expected a positive integer"),
    ("max_memory", float("nan"), "max_memory: expected a positive integer"),
    ("max_memory", -1, r"max_memory: expected a positive integer number of bytes .*, got -1$"),
    ("max_memory", 0, "max_memory: expected a positive integer"),
])
def test_render_image_names_a_bad_argument(argument: str, value: object, message: str) -> None:
    """Each bad argument is a ValueError naming it (not an AttributeError, TypeError, a budget of
    "-0.00 MiB", or a frame at time NaN), before any context is made."""
    with pytest.raises(ValueError, match=message):
        depthimpostor.render_image(SCENE, size=SIZE, **{argument: value})  # type: ignore[arg-type]


def test_render_image_refuses_a_bad_scene_setting() -> None:
    with pytest.raises(depthimpostor.DepthImpostorError) as raised:
        depthimpostor.render_image(SCENE, size=(0, 10))
    # Named as the function's argument: this is not the command line's --size.
    assert str(raised.value) == "render_image: size: expected 2 integers in [1, 16384], got [0, 10]"


@pytest.mark.parametrize("size", [(np.int64(64), np.int32(36)), np.array([64, 36]), [64, 36]])
def test_render_image_takes_numpy_integers(ctx: moderngl.Context, size: object) -> None:
    image = depthimpostor.render_image(SCENE, size=size, impostor_resolution=np.int64(32), ctx=ctx,  # type: ignore[arg-type]
                                       time=np.float32(0.5))  # type: ignore[arg-type]
    assert image.shape == (36, 64, 3)


def test_a_released_renderer_or_context_is_named(ctx: moderngl.Context) -> None:
    scene = load_scene(SCENE).with_overrides(size=SIZE, impostor_resolution=32)
    renderer = depthimpostor.Renderer(ctx, scene)
    renderer.release()
    renderer.release()  # a second release does nothing
    for use in (renderer.render, renderer.read_color, lambda: renderer.set_time(1.0), lambda: renderer.resize((8, 8))):
        with pytest.raises(ValueError, match="the renderer was released"):
            use()
    own = depthimpostor.create_context()
    try:
        renderer = depthimpostor.Renderer(own, scene)
        own.release()
        with pytest.raises(ContextError, match=r"the GL context was released \(ctx.release\(\)\)"):
            renderer.render()
        renderer.release()  # the context freed what it held: nothing to do
        with pytest.raises(ContextError, match="the GL context was released"):
            depthimpostor.Renderer(own, scene)
    finally:
        ctx.__enter__()  # EGL leaves the released context current: the session's is made current again


def test_a_context_used_from_another_thread_is_named(ctx: moderngl.Context) -> None:
    """GL calls in a thread where the context is not current do nothing (GL_MAX_RENDERBUFFER_SIZE
    reads 0): the renderer says so instead."""
    scene = load_scene(SCENE).with_overrides(size=SIZE, impostor_resolution=32)
    errors: list[BaseException] = []
    with depthimpostor.Renderer(ctx, scene) as renderer:
        def other_thread() -> None:
            for use in (renderer.render, lambda: depthimpostor.Renderer(ctx, scene)):
                try:
                    use()
                except BaseException as error:  # noqa: BLE001 - the test reads it in the main thread
                    errors.append(error)
        thread = threading.Thread(target=other_thread)
        thread.start()
        thread.join()
        renderer.render()  # still fine in its own thread
    assert len(errors) == 2 and all(isinstance(error, ContextError) for error in errors), errors
    assert all("not current in this thread" in str(error) for error in errors)


class GlState:
    """What the application set, read back from GL itself (not from moderngl's records)."""

    DRAW_FRAMEBUFFER_BINDING, VIEWPORT = 0x8CA6, 0x0BA2
    CAPABILITIES = {"blend": 0x0BE2, "depth_test": 0x0B71, "cull_face": 0x0B44}

    def __init__(self) -> None:
        egl = ctypes.CDLL(ctypes.util.find_library("EGL") or "libEGL.so.1")
        egl.eglGetProcAddress.restype = ctypes.c_void_p
        egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]

        def function(name: str, restype: Any, *argtypes: Any) -> Any:
            address = egl.eglGetProcAddress(name.encode())
            assert address, name
            return ctypes.CFUNCTYPE(restype, *argtypes)(address)

        self._get = function("glGetIntegerv", None, ctypes.c_uint, ctypes.POINTER(ctypes.c_int))
        self._enabled = function("glIsEnabled", ctypes.c_ubyte, ctypes.c_uint)

    def read(self) -> dict[str, object]:
        values = (ctypes.c_int * 4)()
        self._get(self.DRAW_FRAMEBUFFER_BINDING, values)
        state: dict[str, object] = {"framebuffer": values[0]}
        self._get(self.VIEWPORT, values)
        state["viewport"] = tuple(values)
        state.update({name: bool(self._enabled(code)) for name, code in self.CAPABILITIES.items()})
        return state


@pytest.fixture
def app(ctx: moderngl.Context) -> Iterator[moderngl.Context]:
    """An application's own context: EGL, made without depthimpostor (and current while it lives)."""
    context = moderngl.create_standalone_context(backend="egl", require=330)  # type: ignore[arg-type]
    yield context
    context.release()
    ctx.__enter__()  # EGL leaves the released context current: the session's is made current again


def test_embedded_in_an_application_framebuffer(app: moderngl.Context) -> None:
    """The application has its framebuffer bound, a viewport, blending and culling on; the renderer
    draws a frame into a viewport of it, upright, and leaves all of that as it was."""
    color = app.texture((100, 60), 4)
    target = app.framebuffer([color])
    target.use()
    target.clear(0.0, 0.0, 1.0, 1.0)
    app.viewport = (3, 4, 50, 40)
    app.enable_only(moderngl.BLEND | moderngl.CULL_FACE)
    gl = GlState()
    before = gl.read()
    assert before == {"framebuffer": target.glo, "viewport": (3, 4, 50, 40), "blend": True, "depth_test": False,
                      "cull_face": True}

    scene = load_scene(SCENE).with_overrides(size=SIZE, impostor_resolution=64)
    with depthimpostor.Renderer(app, scene) as renderer:
        assert gl.read() == before, "making the renderer changed the application's GL state"
        renderer.render(target, viewport=(10, 20, *SIZE))
        assert gl.read() == before, "rendering changed the application's GL state"
        frame = renderer.read_color()  # row 0 at the top
        assert gl.read() == before

        # GL's rows start at the bottom: flipped, the viewport holds the frame as an image shows it.
        pixels = np.frombuffer(target.read(components=3), np.uint8).reshape(60, 100, 3)
        placed = pixels[20 : 20 + SIZE[1], 10 : 10 + SIZE[0]][::-1]
        assert np.abs(placed.astype(int) - frame).max() <= 1
        outside = np.ones((60, 100), bool)
        outside[20 : 20 + SIZE[1], 10 : 10 + SIZE[0]] = False
        assert (pixels[outside] == [0, 0, 255]).all(), "the frame went outside its viewport"

        # The application's next draw lands in its own framebuffer, without binding it again.
        app.clear(1.0, 0.0, 0.0, 1.0)
        assert (np.frombuffer(target.read(components=3), np.uint8).reshape(-1, 3) == [255, 0, 0]).all()
        assert np.array_equal(renderer.read_color(), frame), "the application drew into the renderer's frame"

        renderer.resize((32, 18))  # settings keep the state too
        assert gl.read() == before
    assert gl.read() == before, "releasing the renderer changed the application's GL state"
    assert app.error == "GL_NO_ERROR"


def test_a_viewport_of_another_size_is_refused(app: moderngl.Context) -> None:
    target = app.framebuffer([app.texture((100, 60), 4)])
    scene = load_scene(SCENE).with_overrides(size=SIZE, impostor_resolution=32)
    with depthimpostor.Renderer(app, scene) as renderer, pytest.raises(ValueError, match="resize the renderer"):
        renderer.render(target)
