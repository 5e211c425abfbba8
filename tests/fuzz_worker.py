"""The file fuzzer's worker (tests/test_fuzz_files.py): a process apart from the tests' own, which
renders each scene file it is sent and says how that went, one JSON line per file.

Apart, so that a hostile file can neither take the tests' memory nor hang them: its data segment
is capped (RLIMIT_DATA, a bound far past any budget, so that a runaway allocation fails here
instead of on the machine), the tests wait for each answer a bounded time and kill it past that,
and its peak memory is measured per file (VmHWM, reset before each). What the C libraries write
to file descriptors 1 and 2 goes to its stderr, a file whose growth is counted: the CLI's one line
must be the only line.

Protocol: a path a line on stdin; a JSON object a line on the descriptor stdout was at the start:
{"outcome": "rendered" | "refused" | "bug", "message": ..., "growth": bytes, "stray": bytes}: growth
is the peak resident memory while the file was rendered, over what it was before.
"""

from __future__ import annotations

import json
import os
import resource
import sys
import traceback
import warnings

import numpy as np

from depthimpostor.api import render_image
from depthimpostor.errors import DepthImpostorError
from depthimpostor.gpu.context import create_context


def resident(field: str) -> int:
    """VmRSS (resident bytes now) or VmHWM (their peak) from /proc/self/status."""
    with open("/proc/self/status", encoding="ascii") as status:
        for line in status:
            if line.startswith(field + ":"):
                return int(line.split()[1]) * 1024
    return 0


def reset_peak() -> None:
    with open("/proc/self/clear_refs", "w", encoding="ascii") as refs:
        refs.write("5")  # Linux: the peak resident size starts again from the current one


def outcome(path: str, ctx: object) -> tuple[str, str]:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # SceneWarnings: the CLI prints each on one line
            frame = render_image(path, size=(16, 9), impostor_resolution=32, dtype="float32", ctx=ctx)  # type: ignore[arg-type]
    except DepthImpostorError as error:
        if error.exit_code != 2:
            return "bug", f"{type(error).__name__} (exit {error.exit_code}): {error}"
        return "refused", str(error)
    except Exception:  # what the fuzzer looks for
        return "bug", traceback.format_exc()
    if not np.isfinite(frame).all():
        return "bug", "a frame holding NaN or Inf"
    error = getattr(ctx, "error", "GL_NO_ERROR")
    return ("rendered", "") if error == "GL_NO_ERROR" else ("bug", f"a GL error left behind: {error}")


def main() -> None:
    limit = int(sys.argv[1])
    answers = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)  # what a library prints to stdout is stray output too
    ctx = create_context()
    resource.setrlimit(resource.RLIMIT_DATA, (limit, limit))
    for line in sys.stdin:
        before = os.fstat(2).st_size
        reset_peak()
        start = resident("VmRSS")  # what earlier cases left (freed memory malloc keeps) is not this one's
        kind, message = outcome(line.rstrip("\n"), ctx)
        sys.stdout.flush(), sys.stderr.flush()
        answers.write(json.dumps({"outcome": kind, "message": message, "growth": resident("VmHWM") - start,
                                  "stray": os.fstat(2).st_size - before}) + "\n")


if __name__ == "__main__":
    main()
