"""The one place where OpenGL contexts are made.

Headless rendering uses EGL (Mesa's llvmpipe on a machine without a GPU, the vendor driver on one
with); where EGL cannot give a context, OSMesa can, through a small ctypes loader that moderngl
accepts as `create_context(context=...)`. The interactive viewer's glfw window makes its context
here too (`create_window`), so that every context is made, checked and described in one module.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import os
from dataclasses import dataclass
from typing import Any, Literal

import moderngl

from ..errors import ContextError

Backend = Literal["auto", "egl", "osmesa"]

#: GL 3.3 core is what the shaders are written against (`#version 330 core`).
REQUIRED_GL_VERSION = 330
#: The versions asked for, in order, down to REQUIRED_GL_VERSION. Asked for 3.3 core, Mesa gives its
#: newest core version but NVIDIA's EGL gives 3.3 exactly, and the methods that need compute shaders
#: (4.3: the hierarchical march's pyramid, screen-space reflections) would refuse to run. 4.5 is the
#: newest llvmpipe has: asking it 4.6 first would cost a refused context (60 ms) on every start.
REQUESTED_GL_VERSIONS = (450, 430, REQUIRED_GL_VERSION)

_INSTALL_HINT = (
    "install Mesa's EGL (Debian/Ubuntu: apt-get install -y libegl1 libegl-mesa0) "
    "or OSMesa (apt-get install -y libosmesa6)"
)

# OSMesa attribute names from GL/osmesa.h.
_OSMESA_FORMAT = 0x22
_OSMESA_DEPTH_BITS = 0x30
_OSMESA_STENCIL_BITS = 0x31
_OSMESA_PROFILE = 0x33
_OSMESA_CORE_PROFILE = 0x34
_OSMESA_CONTEXT_MAJOR_VERSION = 0x36
_OSMESA_CONTEXT_MINOR_VERSION = 0x37
_GL_RGBA = 0x1908
_GL_UNSIGNED_BYTE = 0x1401


class OSMesaLoader:
    """A moderngl context loader backed by OSMesa (Mesa's off-screen software renderer).

    moderngl asks a loader for `load_opengl_function(name)` and calls `release()`; the context
    renders into a tiny client-memory buffer that we never read, since all our drawing goes into
    framebuffer objects.
    """

    def __init__(self, major: int = 3, minor: int = 3) -> None:
        path = ctypes.util.find_library("OSMesa") or "libOSMesa.so.8"
        self._lib = ctypes.CDLL(path)
        self._lib.OSMesaCreateContextAttribs.restype = ctypes.c_void_p
        self._lib.OSMesaCreateContextAttribs.argtypes = [ctypes.POINTER(ctypes.c_int), ctypes.c_void_p]
        self._lib.OSMesaMakeCurrent.argtypes = [
            ctypes.c_void_p, ctypes.c_void_p, ctypes.c_uint, ctypes.c_int, ctypes.c_int,
        ]
        self._lib.OSMesaGetProcAddress.restype = ctypes.c_void_p
        self._lib.OSMesaGetProcAddress.argtypes = [ctypes.c_char_p]
        self._lib.OSMesaDestroyContext.argtypes = [ctypes.c_void_p]
        attributes = [
            _OSMESA_FORMAT, _GL_RGBA,
            _OSMESA_DEPTH_BITS, 24,
            _OSMESA_STENCIL_BITS, 8,
            _OSMESA_PROFILE, _OSMESA_CORE_PROFILE,
            _OSMESA_CONTEXT_MAJOR_VERSION, major,
            _OSMESA_CONTEXT_MINOR_VERSION, minor,
            0,
        ]
        self._context = self._lib.OSMesaCreateContextAttribs((ctypes.c_int * len(attributes))(*attributes), None)
        if not self._context:
            raise ContextError(f"OSMesa ({path}) could not create a GL {major}.{minor} core context")
        self._buffer = (ctypes.c_ubyte * 4)()
        if not self._lib.OSMesaMakeCurrent(self._context, self._buffer, _GL_UNSIGNED_BYTE, 1, 1):
            raise ContextError("OSMesaMakeCurrent failed")

    def load_opengl_function(self, name: str) -> int:
        return self._lib.OSMesaGetProcAddress(name.encode()) or 0

    def __enter__(self) -> None:
        self._lib.OSMesaMakeCurrent(self._context, self._buffer, _GL_UNSIGNED_BYTE, 1, 1)

    def __exit__(self, *args: object) -> None:
        pass

    def release(self) -> None:
        if self._context:
            self._lib.OSMesaDestroyContext(self._context)
            self._context = None


def _egl_context(device: int | None = None) -> moderngl.Context:
    """`device`: the index among EGL's devices (EGL_EXT_device_enumeration, as glcontext enumerates
    them); None: EGL's default display."""
    settings: dict[str, Any] = {} if device is None else {"device_index": device}
    for version in REQUESTED_GL_VERSIONS:
        try:
            # moderngl's stub types each **settings value as a dict; glcontext takes strings and ints.
            return moderngl.create_standalone_context(backend="egl", require=version, **settings)  # type: ignore[arg-type]
        except Exception:  # eglCreateContext refused this version: ask for the next one down
            if version == REQUIRED_GL_VERSION:
                raise
    raise AssertionError("REQUESTED_GL_VERSIONS ends with REQUIRED_GL_VERSION")


def _osmesa_context(device: int | None = None) -> moderngl.Context:
    if device is not None:
        raise ContextError(f"OSMesa renders on the CPU: it has no device {device} (EGL's devices are GPUs)")
    loader = OSMesaLoader()
    # moderngl's stub types each **settings value as a dict; `context` takes any loader object.
    ctx = moderngl.create_context(context=loader, require=REQUIRED_GL_VERSION)  # type: ignore[arg-type]
    ctx.extra = {"loader": loader}  # what gl_function asks for entry points moderngl does not wrap
    return ctx


_BACKENDS = {"egl": _egl_context, "osmesa": _osmesa_context}

# EGL_EXT_device_query's and EGL_NV_device_cuda's names (EGL/eglext.h).
_EGL_EXTENSIONS = 0x3055
_EGL_CUDA_DEVICE_NV = 0x323A


@dataclass(frozen=True)
class EglDevice:
    """One of EGL's devices, at `index` in EGL_EXT_device_enumeration's order (create_context's `device`)."""

    index: int
    cuda: int | None  # its CUDA device number (EGL_CUDA_DEVICE_NV) where the driver says, else None
    extensions: str = ""


def egl_devices() -> list[EglDevice]:
    """EGL's devices, in the order glcontext indexes them, each with its CUDA device number where
    the device has EGL_NV_device_cuda (NVIDIA's driver; Mesa's have none). Raises ContextError
    where EGL or its device enumeration is missing."""
    path = ctypes.util.find_library("EGL")
    if path is None:
        raise ContextError(f"no EGL library to enumerate devices with; {_INSTALL_HINT}")
    lib = ctypes.CDLL(path)
    lib.eglGetProcAddress.restype = ctypes.c_void_p
    lib.eglGetProcAddress.argtypes = [ctypes.c_char_p]

    def function(name: str, result: Any, *arguments: Any) -> Any:
        address = lib.eglGetProcAddress(name.encode())
        return ctypes.CFUNCTYPE(result, *arguments)(address) if address else None

    query_devices = function("eglQueryDevicesEXT", ctypes.c_uint, ctypes.c_int, ctypes.POINTER(ctypes.c_void_p),
                             ctypes.POINTER(ctypes.c_int))
    query_string = function("eglQueryDeviceStringEXT", ctypes.c_char_p, ctypes.c_void_p, ctypes.c_int)
    # EGLAttrib is intptr_t: a 32-bit int here would let the driver write past it.
    query_attribute = function("eglQueryDeviceAttribEXT", ctypes.c_uint, ctypes.c_void_p, ctypes.c_int,
                               ctypes.POINTER(ctypes.c_ssize_t))
    count = ctypes.c_int(0)
    if query_devices is None or not query_devices(0, None, ctypes.byref(count)):
        raise ContextError(f"{path} cannot enumerate EGL devices (EGL_EXT_device_enumeration)")
    handles = (ctypes.c_void_p * max(count.value, 1))()
    if not query_devices(count.value, handles, ctypes.byref(count)):
        raise ContextError(f"{path} cannot enumerate EGL devices (EGL_EXT_device_enumeration)")
    devices = []
    for index, handle in enumerate(handles[:count.value]):
        text = query_string(handle, _EGL_EXTENSIONS) if query_string is not None else None
        extensions = text.decode(errors="replace") if text else ""
        cuda = None
        value = ctypes.c_ssize_t(-1)
        if ("EGL_NV_device_cuda" in extensions.split() and query_attribute is not None
                and query_attribute(handle, _EGL_CUDA_DEVICE_NV, ctypes.byref(value))):
            cuda = int(value.value)
        devices.append(EglDevice(index, cuda, extensions))
    return devices


@dataclass(frozen=True)
class EglChoice:
    """The EGL device a GPU's worker draws on, and how it was chosen (the batch manifest's `worker`)."""

    index: int
    how: str


def choose_egl_device(devices: list[EglDevice], gpu: str, visible: str | None) -> EglChoice:
    """The EGL device of the GPU that Ray (or a scheduler like it) gave this process: `gpu` its id
    (ray.get_gpu_ids()), `visible` the process's CUDA_VISIBLE_DEVICES.

    EGL lists its devices in the driver's order, which need not be CUDA's (nor hold GPUs alone:
    Mesa adds a software device), so a GPU's id is not its EGL index. Where the devices say their
    CUDA device (EGL_NV_device_cuda, as nvdiffrast and MapD choose theirs), the one that reports
    this GPU's CUDA device number is taken. That number counts the devices the process sees:
    the GPU's place in CUDA_VISIBLE_DEVICES (0 for a Ray worker of one GPU), its id where that is
    unset. Elsewhere (other vendors, or a mapping that does not name exactly one device), EGL's
    index order: the GPU's id as its index, right where the two orders agree."""
    ordinals = [entry.strip() for entry in visible.split(",")] if visible else None
    if ordinals is None:
        ordinal = int(gpu) if gpu.isdigit() else None
    else:
        ordinal = ordinals.index(gpu) if gpu in ordinals else None
    reported = [device for device in devices if device.cuda is not None]
    matches = [device for device in reported if device.cuda == ordinal]
    if reported and len(matches) == 1:
        return EglChoice(matches[0].index, f"EGL_CUDA_DEVICE_NV {ordinal} (CUDA_VISIBLE_DEVICES={visible})")
    if not reported:
        why = "no EGL device has EGL_NV_device_cuda"
    elif ordinal is None:
        why = f"GPU {gpu} is not among CUDA_VISIBLE_DEVICES={visible}"
    else:
        why = f"{len(matches)} EGL devices report CUDA device {ordinal}"
    if not gpu.isdigit():
        raise ContextError(f"no EGL device for GPU {gpu}: {why}, and its id is no EGL index")
    return EglChoice(int(gpu), f"index {gpu}: {why}")


def egl_device_for_gpu(gpu: str) -> EglChoice:
    """choose_egl_device for this process's devices and CUDA_VISIBLE_DEVICES; EGL's index order
    where its devices cannot be enumerated here (create_context then says why)."""
    try:
        devices = egl_devices()
    except (ContextError, OSError) as error:
        if not gpu.isdigit():
            raise ContextError(f"no EGL device for GPU {gpu}: {error}") from None
        return EglChoice(int(gpu), f"index {gpu}: {error}")
    return choose_egl_device(devices, gpu, os.environ.get("CUDA_VISIBLE_DEVICES"))


def create_context(backend: Backend | None = None, device: int | None = None) -> moderngl.Context:
    """Create a headless GL 3.3+ core context.

    `backend` "auto" (the default, or the DEPTHIMPOSTOR_GL_BACKEND environment variable) tries EGL
    first and OSMesa second. `device` picks one of EGL's devices by its index in EGL's device
    enumeration (a batch worker on a machine with several GPUs: batch/worker.py); with a device,
    "auto" is EGL alone. Raises `ContextError` naming every backend tried, why each failed,
    and what to install.
    """
    choice = backend or os.environ.get("DEPTHIMPOSTOR_GL_BACKEND", "auto")
    if choice not in ("auto", *_BACKENDS):
        raise ContextError(f"unknown GL backend {choice!r}; expected one of: auto, {', '.join(_BACKENDS)}")
    order = (["egl"] if device is not None else list(_BACKENDS)) if choice == "auto" else [choice]
    failures: list[str] = []
    for name in order:
        try:
            ctx = _BACKENDS[name](device)
        except Exception as error:  # each backend fails in its own way (OSError, moderngl.Error, ...)
            failures.append(f"{name}: {error}".strip())
            continue
        ctx.extra = {**(ctx.extra or {}), "backend": name, **({"device": device} if device is not None else {})}
        return ctx
    raise ContextError(
        f"no OpenGL {REQUIRED_GL_VERSION // 100}.{REQUIRED_GL_VERSION % 100 // 10} core context could be created "
        f"(tried {'; '.join(failures)}); {_INSTALL_HINT}"
    )


_WINDOW_HINT = (
    "a window needs an X server: set DISPLAY, or run under Xvfb "
    "(apt-get install -y xvfb; xvfb-run -a depthimpostor view ...)"
)


@dataclass
class Window:
    """A glfw window and the moderngl context of its GL core context (3.3 or newer)."""

    handle: Any  # glfw's window pointer
    ctx: moderngl.Context

    def release(self) -> None:
        import glfw

        self.ctx.release()
        glfw.destroy_window(self.handle)
        glfw.terminate()


def create_window(title: str, size: tuple[int, int]) -> Window:
    """Open a window of `size` screen units (its framebuffer may have more pixels on a HiDPI
    screen) with a current GL 3.3+ core context. Raises ContextError saying what is missing."""
    import glfw  # only the viewer needs it; headless rendering must not depend on a display

    glfw.ERROR_REPORTING = "raise"
    try:
        if not glfw.init():
            raise glfw.GLFWError("glfwInit failed")
        glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
        glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
        glfw.window_hint(glfw.SCALE_TO_MONITOR, True)
        for version in REQUESTED_GL_VERSIONS:  # the newest first, as for EGL
            glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, version // 100)
            glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, version % 100 // 10)
            try:
                handle = glfw.create_window(size[0], size[1], title, None, None)
                break
            except glfw.GLFWError:  # this version is unavailable: ask for the next one down
                if version == REQUIRED_GL_VERSION:
                    raise
        glfw.make_context_current(handle)
    except glfw.GLFWError as error:
        glfw.terminate()
        display = os.environ.get("DISPLAY")
        raise ContextError(f"no window could be opened (DISPLAY={display!r}: {error}); {_WINDOW_HINT}") from None
    # From here on a glfw error is reported, not raised: a failed cursor or title change is no
    # reason to lose the window.
    glfw.ERROR_REPORTING = "warn"
    try:
        ctx = moderngl.create_context(require=REQUIRED_GL_VERSION)
    except Exception as error:  # moderngl.Error, or a GL too old for `require`
        glfw.destroy_window(handle)
        glfw.terminate()
        raise ContextError(f"the window's OpenGL context is not usable: {error}") from None
    ctx.extra = {"backend": "glfw"}
    return Window(handle, ctx)


@functools.cache
def _library(name: str) -> ctypes.CDLL | None:
    """The shared library `name` (EGL, GL), or None: looked up once (find_library runs ldconfig,
    15 ms a call)."""
    path = ctypes.util.find_library(name)
    return None if path is None else ctypes.CDLL(path)


def _current_context_function(name: str) -> int:
    """`name` from whichever of EGL and GLX has a context current in this thread (a context made
    outside this module, such as an application's that embeds the renderer); 0 if neither."""
    for library, current, get in (("EGL", "eglGetCurrentContext", "eglGetProcAddress"),
                                  ("GL", "glXGetCurrentContext", "glXGetProcAddressARB")):
        lib = _library(library)
        if lib is None:
            continue
        if not hasattr(lib, current) or not hasattr(lib, get):
            continue
        getattr(lib, current).restype = ctypes.c_void_p
        if not getattr(lib, current)():
            continue
        getattr(lib, get).restype = ctypes.c_void_p
        getattr(lib, get).argtypes = [ctypes.c_char_p]
        return int(getattr(lib, get)(name.encode()) or 0)
    return 0


def gl_function(ctx: moderngl.Context, name: str) -> int:
    """The address of the GL entry point `name` in `ctx` (current), for the few that moderngl
    does not wrap (glClipControl, see eye.py); 0 where the context's loader has none. A non-zero
    address says nothing of support: check the GL version or extension too."""
    extra = ctx.extra if isinstance(ctx.extra, dict) else {}
    backend = extra.get("backend")
    if backend == "osmesa":
        return int(extra["loader"].load_opengl_function(name))
    if backend == "glfw":
        import glfw

        return int(glfw.get_proc_address(name) or 0)
    return _current_context_function(name)  # EGL (ours) or a context made elsewhere


def describe(ctx: moderngl.Context) -> str:
    """One line naming the backend, renderer and GL version, for logs and benchmark headers."""
    backend = (ctx.extra or {}).get("backend", "window")
    return f"{ctx.info['GL_RENDERER']} ({ctx.info['GL_VERSION']}, {backend})"


def bind_default_framebuffer(ctx: moderngl.Context) -> None:
    """Bind framebuffer 0 before releasing framebuffers.

    moderngl re-binds the last framebuffer used whenever it creates a new one; if that one has
    been released, the re-bind raises GL_INVALID_OPERATION. Every release path calls this first.
    """
    ctx.detect_framebuffer(0).use()


@functools.cache
def _current_context_queries() -> tuple[Any, ...]:
    """EGL's and GLX's "which context is current in this thread" functions that this machine has
    (find_library runs a program: looked up once)."""
    found = []
    for library, name in (("EGL", "eglGetCurrentContext"), ("GL", "glXGetCurrentContext")):
        lib = _library(library)
        if lib is None:
            continue
        function = getattr(lib, name, None)
        if function is not None:
            function.restype = ctypes.c_void_p
            found.append(function)
    return tuple(found)


def _has_current_context(ctx: moderngl.Context) -> bool | None:
    """Whether this thread has a GL context current (`ctx`'s kind of it); None where that cannot be
    asked. GL calls without one do nothing and read 0 (a GL_MAX_RENDERBUFFER_SIZE of 0)."""
    extra = ctx.extra if isinstance(ctx.extra, dict) else {}
    backend = extra.get("backend")
    if backend == "osmesa":
        lib = extra["loader"]._lib
        lib.OSMesaGetCurrentContext.restype = ctypes.c_void_p
        return bool(lib.OSMesaGetCurrentContext())
    if backend == "glfw":
        import glfw

        return bool(glfw.get_current_context())
    queries = _current_context_queries()
    return any(query() for query in queries) if queries else None


def check_usable(ctx: moderngl.Context) -> None:
    """Raise ContextError if `ctx` was released, or if no GL context is current in this thread (a
    context made in one thread and used in another): GL would fail later, or silently draw nothing."""
    if isinstance(ctx.mglo, moderngl.InvalidObject):
        raise ContextError("the GL context was released (ctx.release()); make the renderer in a live context")
    if _has_current_context(ctx) is False:
        raise ContextError("the GL context is not current in this thread: a moderngl context is current in the "
                           "thread that made it; make it current here first (`with ctx:`), or make one context "
                           "per thread")
