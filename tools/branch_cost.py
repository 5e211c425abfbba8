"""What code under a condition costs on this GL driver: a fragment shader over a 960x540 frame with
a block of work placed (a) always run, (b) under an `if` no pixel takes, (c) in a loop no pixel
needs, and (d) a loop of 64 iterations under an `if` no pixel takes. On llvmpipe (Mesa 22.3) the
`if` costs as much as running the block, and the loop runs its body once: a software rasterizer
runs a group of pixels in lock-step and executes both sides of a branch with masks, but leaves
a loop when no pixel of the group needs another iteration. The mirror shader is laid out for it
(docs/methods_and_results.md, "`--method hybrid`").

    python3 tools/branch_cost.py
"""

from __future__ import annotations

import statistics
import time

import moderngl
import numpy as np

from depthimpostor.gpu.context import create_context, describe

SIZE = (960, 540)
STEP = "a = sin(a * 1.01 + a.yzx) * 0.9 + cos(a.zxy);"
BLOCK = "{ vec3 a = vec3(gl_FragCoord.xy, 1.0); " + STEP * 64 + " acc += a; }"
LOOP = "{ vec3 a = vec3(gl_FragCoord.xy, 1.0); for (int k = 0; k < 64; ++k) { " + STEP + " } acc += a; }"
NOBODY = "gl_FragCoord.x < -1.0"  # false at every pixel, not known to the compiler
CASES = {
    "nothing": "",
    "the block, always": BLOCK,
    "the block under an if no pixel takes": f"if ({NOBODY}) {BLOCK}",
    "the block in a loop no pixel needs": f"for (int j = 0; j < ({NOBODY} ? 1 : 0); ++j) {BLOCK}",
    "64 iterations, always": LOOP,
    "64 iterations under an if no pixel takes": f"if ({NOBODY}) {LOOP}",
}


def frame_ms(ctx: moderngl.Context, body: str, frames: int = 7) -> float:
    program = ctx.program(
        vertex_shader="#version 330 core\nin vec2 p;\nvoid main() { gl_Position = vec4(p, 0.0, 1.0); }",
        fragment_shader="#version 330 core\nout vec4 color;\nvoid main() {\n vec3 acc = vec3(0.0);\n"
        + body + "\n color = vec4(acc, 1.0);\n}",
    )
    triangle = ctx.buffer(np.array([-1, -1, 3, -1, -1, 3], "f4"))
    vao = ctx.vertex_array(program, [(triangle, "2f", "p")])
    target = ctx.simple_framebuffer(SIZE, components=4, dtype="f4")
    target.use()
    times = []
    for frame in range(frames + 2):
        start = time.perf_counter()
        vao.render()
        ctx.finish()
        if frame >= 2:
            times.append(1000.0 * (time.perf_counter() - start))
    for resource in (vao, triangle, program, target):
        resource.release()
    return statistics.median(times)


def main() -> None:
    ctx = create_context()
    print(describe(ctx))
    for name, body in CASES.items():
        print(f"{name:44s} {frame_ms(ctx, body):8.2f} ms")
    ctx.release()


if __name__ == "__main__":
    main()
