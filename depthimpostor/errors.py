"""The package's one exception hierarchy.

Every error a user can cause (a bad scene file, a missing model, no usable OpenGL) is a
`DepthImpostorError`; the CLI prints its message on one line and exits with `exit_code`.
Anything else escaping is a bug in depthimpostor, not in the input.
"""

from __future__ import annotations


class DepthImpostorError(Exception):
    """Base class: an error with a message meant for the user, and the CLI exit code."""

    exit_code: int = 1


class SceneError(DepthImpostorError):
    """A scene file (or a value in it) is not what the format expects.

    The message reads `FILE: dotted.path: expected ..., got ...`.
    """

    exit_code = 2

    def __init__(self, source: str, path: str, message: str) -> None:
        self.source = source
        self.path = path
        self.detail = message
        location = f"{source}: {path}" if path else source
        super().__init__(f"{location}: {message}")


class ContextError(DepthImpostorError):
    """No OpenGL context could be created; the message names what was tried and what to install."""

    exit_code = 3


class ShaderError(DepthImpostorError):
    """A GLSL program failed to preprocess, compile or link."""

    exit_code = 4


class OutputError(DepthImpostorError):
    """An output cannot be written where it was asked for (a folder named as a file, an unknown
    image format, a read-only or full disk); the message names the path and the option."""

    exit_code = 2


class GpuLimitError(DepthImpostorError):
    """The settings ask for more than this GL context can hold (a texture over its size limit, an
    allocation over its memory budget); the message names the setting to change."""

    exit_code = 2


class SceneWarning(UserWarning):
    """Something in a scene is read but not drawn as the file means it (a texture drawn as its mean
    colour, primitives that are not triangles left out). The CLI prints it as one line; a program
    embedding the renderer can filter it with the `warnings` module."""
