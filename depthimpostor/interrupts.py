"""Ctrl-C and `kill` that land in a finalizer are not lost.

The CLI turns SIGINT into KeyboardInterrupt (Python's own) and SIGTERM into `Terminated`, raised
wherever the main thread is, so that every `finally` on the way out runs. Where that is a
finalizer (a generator context manager closed by the garbage collector, a `__del__`), Python
cannot raise it: it prints "Exception ignored in ..." with a traceback and goes on as if no
signal had come (`render --video` then rendered its thousand frames). Within `deferred_interrupts`
such an interrupt is kept instead, silently, and `raise_pending` raises it at the next safe point:
the video's frame loop, and the CLI when the command returns.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any


class Terminated(BaseException):
    """SIGTERM, raised where the command is (as SIGINT raises KeyboardInterrupt), so that every
    `finally` and `with` block on the way out runs."""


_pending: list[BaseException] = []


def _keep_interrupts(unraisable: Any) -> None:
    if isinstance(unraisable.exc_value, (KeyboardInterrupt, Terminated)):
        _pending.append(unraisable.exc_value)
    else:
        sys.__unraisablehook__(unraisable)


@contextmanager
def deferred_interrupts() -> Iterator[None]:
    """Keep the interrupts that land in finalizers (see the module's docstring) until `raise_pending`."""
    previous = sys.unraisablehook
    sys.unraisablehook = _keep_interrupts
    try:
        yield
    finally:
        sys.unraisablehook = previous
        _pending.clear()


def raise_pending() -> None:
    """Raise the first interrupt a finalizer swallowed, if one did."""
    if _pending:
        interrupt = _pending[0]
        _pending.clear()
        raise interrupt
