"""What the driver said when it compiled and linked a program, warnings included: moderngl shows a
log only when a compile fails, and a GPU driver's warnings on a program that compiled (an
unrolled loop given up, a precision lowered) are what a first run on that GPU wants kept
(tools/gpu_results.py writes them beside its results).

Read through the GL entry points moderngl does not wrap (gl_function): the program's own link log,
and the log of each shader still attached to it (moderngl deletes its shaders once the program is
linked; GL keeps a shader marked for deletion while a program holds it)."""

from __future__ import annotations

import ctypes

import moderngl

from .context import gl_function

GL_INFO_LOG_LENGTH = 0x8B84
GL_ATTACHED_SHADERS = 0x8B85
#: At most this many shaders are asked for per program (a compute shader has one, ours two).
MAX_SHADERS = 8

_GET_IV = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_uint, ctypes.POINTER(ctypes.c_int))
_GET_LOG = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_int, ctypes.POINTER(ctypes.c_int), ctypes.c_char_p)
_GET_ATTACHED = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_int, ctypes.POINTER(ctypes.c_int),
                                 ctypes.POINTER(ctypes.c_uint))


def _function(ctx: moderngl.Context, name: str, prototype: type) -> object:
    address = gl_function(ctx, name)
    if not address:
        raise LookupError(f"{name} is not available through this context's loader")
    return prototype(address)


def _log(get_iv: object, get_log: object, name: int) -> str:
    length = ctypes.c_int(0)
    get_iv(name, GL_INFO_LOG_LENGTH, ctypes.byref(length))  # type: ignore[operator]
    if length.value <= 1:  # the length counts the terminating zero
        return ""
    text = ctypes.create_string_buffer(length.value)
    get_log(name, length.value, None, text)  # type: ignore[operator]
    return text.value.decode(errors="replace").strip()


def program_logs(ctx: moderngl.Context, program: moderngl.Program | moderngl.ComputeShader) -> str:
    """The link log of `program` and the compile log of each of its shaders, one after another
    (empty where the driver said nothing). Raises LookupError where the context's loader cannot
    give the GL entry points."""
    get_program_iv = _function(ctx, "glGetProgramiv", _GET_IV)
    get_program_log = _function(ctx, "glGetProgramInfoLog", _GET_LOG)
    get_shader_iv = _function(ctx, "glGetShaderiv", _GET_IV)
    get_shader_log = _function(ctx, "glGetShaderInfoLog", _GET_LOG)
    get_attached = _function(ctx, "glGetAttachedShaders", _GET_ATTACHED)
    count, shaders = ctypes.c_int(0), (ctypes.c_uint * MAX_SHADERS)()
    get_attached(program.glo, MAX_SHADERS, ctypes.byref(count), shaders)  # type: ignore[operator]
    parts = [_log(get_shader_iv, get_shader_log, shaders[i]) for i in range(count.value)]
    parts.append(_log(get_program_iv, get_program_log, program.glo))
    return "\n".join(part for part in parts if part)
