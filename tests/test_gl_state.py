"""GL raster state is set in scopes (depthimpostor/gpu/gl_state.py): a scope sets the whole state and the
enclosing one comes back after it, and no module outside the state modules toggles a capability."""

from __future__ import annotations

import ctypes
import re
from pathlib import Path

import moderngl

from depthimpostor.gpu.context import gl_function
from depthimpostor.gpu.gl_state import BASE, NO_DEPTH_TEST, RasterState, raster_state

PACKAGE = Path(__file__).resolve().parent.parent / "depthimpostor"
# The modules that own GL state: the scopes, and the renderer's boundary with a caller's context.
STATE_MODULES = {"gpu/gl_state.py", "gpu/embedding.py"}  # relative to the package
TOGGLE = re.compile(r"\.(enable|disable|enable_only)\(|\.(cull_face|front_face|blend_func)\s*=[^=]")

GL_DEPTH_TEST, GL_CULL_FACE, GL_BLEND = 0x0B71, 0x0B44, 0x0BE2
GL_CULL_FACE_MODE, GL_FRONT_FACE = 0x0B45, 0x0B46
GL_FRONT, GL_BACK, GL_CW, GL_CCW = 0x0404, 0x0405, 0x0900, 0x0901


def test_no_module_toggles_gl_state_by_hand() -> None:
    offenders = [f"{path.relative_to(PACKAGE)}:{number}: {line.strip()}"
                 for path in PACKAGE.rglob("*.py") if path.relative_to(PACKAGE).as_posix() not in STATE_MODULES
                 for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
                 if TOGGLE.search(line)]
    assert not offenders, offenders


def _state(ctx: moderngl.Context) -> tuple[bool, bool, bool, int, int]:
    is_enabled = ctypes.CFUNCTYPE(ctypes.c_ubyte, ctypes.c_uint)(gl_function(ctx, "glIsEnabled"))
    get_integer = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.POINTER(ctypes.c_int))(gl_function(ctx, "glGetIntegerv"))
    values = []
    for name in (GL_CULL_FACE_MODE, GL_FRONT_FACE):
        value = ctypes.c_int()
        get_integer(name, ctypes.byref(value))
        values.append(value.value)
    return (bool(is_enabled(GL_DEPTH_TEST)), bool(is_enabled(GL_CULL_FACE)), bool(is_enabled(GL_BLEND)),
            values[0], values[1])


def test_nested_scopes_set_the_whole_state_and_give_back_the_enclosing_one(ctx: moderngl.Context) -> None:
    culled = RasterState(cull="front", front_face="cw")
    with raster_state(ctx, culled):
        assert _state(ctx) == (True, True, False, GL_FRONT, GL_CW)
        with raster_state(ctx, RasterState(depth_test=False, blend=True)):
            depth, cull, blend, _, winding = _state(ctx)
            assert (depth, cull, blend, winding) == (False, False, True, GL_CCW)
        assert _state(ctx) == (True, True, False, GL_FRONT, GL_CW)
        with raster_state(ctx, NO_DEPTH_TEST):
            assert _state(ctx)[:3] == (False, False, False)
        assert _state(ctx) == (True, True, False, GL_FRONT, GL_CW)
    depth, cull, blend, _, winding = _state(ctx)
    assert (depth, cull, blend, winding) == (BASE.depth_test, False, False, GL_CCW)
