"""GL contexts: the headless context is GL 3.3+ and says what it runs on; a bad backend name, or a
backend whose library is missing, is a ContextError that names what was tried and what to install.

The forced-OSMesa context is made in a child process: an OSMesa context made current in this process
would leave the session's EGL context without a current context once it is released (both go through
Mesa's one GL dispatch table), and every later test using `ctx` would fail.
"""

from __future__ import annotations

import ctypes.util
import json
import os
import subprocess
import sys

import moderngl
import pytest

from conftest import PROJECT_ROOT
from depthimpostor.gpu.context import REQUESTED_GL_VERSIONS, REQUIRED_GL_VERSION, create_context, describe
from depthimpostor.errors import ContextError, DepthImpostorError

MISSING_LIBRARY = "/nonexistent/libOSMesa.so.8"


def running_in_ci() -> bool:
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


def test_default_context_is_gl_33_core_and_described(ctx: moderngl.Context) -> None:
    assert REQUIRED_GL_VERSION == 330
    assert ctx.version_code >= REQUIRED_GL_VERSION
    backend = ctx.extra["backend"]
    assert backend in ("egl", "osmesa")
    line = describe(ctx)
    renderer = ctx.info["GL_RENDERER"]
    assert renderer and renderer in line
    assert ctx.info["GL_VERSION"] in line and backend in line
    assert "\n" not in line


@pytest.mark.parametrize("name", ["vulkan", "glx"])
def test_unknown_backend_lists_the_valid_ones(name: str) -> None:
    with pytest.raises(ContextError) as caught:
        create_context(name)
    message = str(caught.value)
    assert f"unknown GL backend {name!r}" in message
    for valid in ("auto", "egl", "osmesa"):
        assert valid in message
    assert isinstance(caught.value, DepthImpostorError) and caught.value.exit_code == 3


def test_unknown_backend_from_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("DEPTHIMPOSTOR_GL_BACKEND", "metal")
    with pytest.raises(ContextError, match=r"unknown GL backend 'metal'; expected one of: auto, egl, osmesa"):
        create_context()


def test_missing_osmesa_library_says_what_to_install(monkeypatch: pytest.MonkeyPatch) -> None:
    """Simulated everywhere (the real library may be installed): the loader gets a path that does
    not exist, as it would on a machine without libOSMesa."""
    monkeypatch.setattr(ctypes.util, "find_library", lambda name: MISSING_LIBRARY)
    with pytest.raises(ContextError) as caught:
        create_context("osmesa")
    message = str(caught.value)
    assert "osmesa" in message and MISSING_LIBRARY in message
    assert "libosmesa6" in message
    assert "egl:" not in message, "a forced backend tries that backend only"


def test_auto_names_every_backend_tried(monkeypatch: pytest.MonkeyPatch) -> None:
    def no_egl(*args: object, **kwargs: object) -> moderngl.Context:
        raise moderngl.Error("eglGetDisplay failed")

    monkeypatch.setattr(moderngl, "create_standalone_context", no_egl)
    monkeypatch.setattr(ctypes.util, "find_library", lambda name: MISSING_LIBRARY)
    with pytest.raises(ContextError) as caught:
        create_context("auto")
    message = str(caught.value)
    assert "OpenGL 3.3 core" in message
    assert "egl: eglGetDisplay failed" in message and "osmesa: " in message
    assert "libegl1" in message and "libosmesa6" in message
    assert "\n" not in message



@pytest.mark.parametrize("newest", [460, 450, 430, 330])
def test_egl_asks_for_the_newest_version_first(monkeypatch: pytest.MonkeyPatch, newest: int) -> None:
    """A driver that gives exactly the version asked for (NVIDIA's EGL, asked for 3.3, gave 3.3 and
    the compute-shader methods refused to run on an H100): the context is the newest version asked
    for that the driver has, never 3.3 where it has 4.3 or more."""
    asked: list[int] = []

    class Given:
        def __init__(self, version: int) -> None:
            self.version_code = version
            self.extra: dict[str, object] | None = None

    def exact_driver(*args: object, require: int, **kwargs: object) -> Given:
        asked.append(require)
        if require > newest:
            raise moderngl.Error("eglCreateContext failed (0x3009)")
        return Given(require)

    monkeypatch.setattr(moderngl, "create_standalone_context", exact_driver)
    context = create_context("egl")
    assert asked[0] == REQUESTED_GL_VERSIONS[0] == 450 and asked[-1] == context.version_code
    assert context.version_code == max(v for v in REQUESTED_GL_VERSIONS if v <= newest)
    assert context.version_code >= min(newest, 430)


OSMESA_PROBE = """
import json
from depthimpostor.gpu.context import create_context, describe
from depthimpostor.errors import ContextError
try:
    ctx = create_context("osmesa")
except ContextError as error:
    print(json.dumps({"error": str(error)}))
    raise SystemExit(0)
texture = ctx.texture((4, 3), 4)
fbo = ctx.framebuffer(texture)
fbo.use()
fbo.clear(0.25, 0.5, 0.75, 1.0)
pixels = list(fbo.read(components=4))
result = {"version": ctx.version_code, "describe": describe(ctx), "backend": ctx.extra["backend"],
          "pixels": pixels, "gl_error": ctx.error}
ctx.detect_framebuffer(0).use()
fbo.release()
texture.release()
ctx.release()
print(json.dumps(result))
"""


def run_osmesa_probe() -> dict:
    env = {key: value for key, value in os.environ.items() if key != "DEPTHIMPOSTOR_GL_BACKEND"}
    env["PYTHONPATH"] = str(PROJECT_ROOT)
    done = subprocess.run([sys.executable, "-c", OSMESA_PROBE], cwd=PROJECT_ROOT, env=env,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_forced_osmesa_works_or_says_what_to_install() -> None:
    installed = ctypes.util.find_library("OSMesa") is not None
    if not installed and running_in_ci():
        pytest.fail("CI installs libosmesa6, but ctypes.util.find_library('OSMesa') finds no libOSMesa")
    result = run_osmesa_probe()
    if installed:
        assert "error" not in result, result.get("error")
        assert result["backend"] == "osmesa" and "osmesa" in result["describe"]
        assert result["version"] >= REQUIRED_GL_VERSION
        assert result["gl_error"] == "GL_NO_ERROR"
        assert len(result["pixels"]) == 4 * 3 * 4
        for index in range(0, len(result["pixels"]), 4):
            red, green, blue, alpha = result["pixels"][index:index + 4]
            assert abs(red - 64) <= 1 and abs(green - 128) <= 1 and abs(blue - 191) <= 1 and alpha == 255
    else:
        assert "error" in result, "OSMesa made a context although find_library finds no libOSMesa"
        assert "osmesa" in result["error"] and "libosmesa6" in result["error"]
