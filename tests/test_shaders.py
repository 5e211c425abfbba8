"""The GLSL preprocessor: includes inside #if branches, include cycles, and error locations; and
probes of the mirror shader's functions where NaN could creep in."""

from __future__ import annotations

from pathlib import Path

import moderngl
import numpy as np
import pytest

from depthimpostor.constants import Method
from depthimpostor.gpu.context import bind_default_framebuffer
from depthimpostor.errors import ShaderError
from depthimpostor.gpu.shaders import ProgramCache, ShaderLibrary
from depthimpostor.gpu.uniforms import write

VERTEX = """#version 330 core
void main() { gl_Position = vec4(vec2(gl_VertexID & 1, gl_VertexID >> 1) * 4.0 - 1.0, 0.0, 1.0); }
"""
# value.glsl is met first inside the branch that BRANCH=1 drops: merged once blindly, it would be
# missing from the other branch.
FRAGMENT = """#version 330 core
out vec4 out_color;
#if BRANCH == 0
#include "lib/value.glsl"
float pick() { return value() + 0.25; }
#else
#include "lib/value.glsl"
#include "lib/value.glsl"
float pick() { return value() + 0.5; }
#endif
void main() { out_color = vec4(pick()); }
"""


def _library(tmp_path: Path, files: dict[str, str]) -> ShaderLibrary:
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    return ShaderLibrary(tmp_path)


def _draw(ctx: moderngl.Context, program: moderngl.Program) -> float:
    target = ctx.renderbuffer((1, 1), 4, dtype="f4")
    framebuffer = ctx.framebuffer([target])
    vertex_array = ctx.vertex_array(program, [])
    try:
        framebuffer.use()
        vertex_array.render(moderngl.TRIANGLES, vertices=3)
        return float(np.frombuffer(framebuffer.read(components=1, dtype="f4"), np.float32)[0])
    finally:
        bind_default_framebuffer(ctx)
        for item in (vertex_array, framebuffer, target):
            item.release()


def test_an_include_works_in_whichever_branch_is_compiled(ctx: moderngl.Context, tmp_path: Path) -> None:
    library = _library(tmp_path, {
        "quad.vert": VERTEX, "pick.frag": FRAGMENT, "lib/value.glsl": "float value() { return 0.125; }\n",
    })
    programs = ProgramCache(ctx, library)
    try:
        assert _draw(ctx, programs.get("quad.vert", "pick.frag", {"BRANCH": 0})) == 0.375
        assert _draw(ctx, programs.get("quad.vert", "pick.frag", {"BRANCH": 1})) == 0.625
    finally:
        programs.release()


def test_an_include_cycle_is_named(tmp_path: Path) -> None:
    library = _library(tmp_path, {
        "loop.frag": '#version 330 core\n#include "lib/a.glsl"\n',
        "lib/a.glsl": '#include "b.glsl"\n', "lib/b.glsl": '#include "a.glsl"\n',
    })
    with pytest.raises(ShaderError, match=r"cycle: loop\.frag -> lib/a\.glsl -> lib/b\.glsl -> lib/a\.glsl"):
        library.preprocess("loop.frag", {})


def test_a_compile_error_names_the_included_file_and_line(ctx: moderngl.Context, tmp_path: Path) -> None:
    library = _library(tmp_path, {
        "quad.vert": VERTEX, "pick.frag": FRAGMENT,
        "lib/value.glsl": "// line 1\nfloat value() { return undeclared; }\n",
    })
    programs = ProgramCache(ctx, library)
    try:
        with pytest.raises(ShaderError, match=r"lib/value\.glsl:2:"):
            programs.get("quad.vert", "pick.frag", {"BRANCH": 1})
    finally:
        programs.release()


#: Probes of the mirror shader's own GLSL functions (the shipped library, one extra file).
PROBES = {
    "probe.vert": VERTEX,
    "box_exit_probe.frag": """#version 330 core
#include "lib/common.glsl"
#include "lib/reflected_scene.glsl"
uniform vec3 u_origin;
uniform vec3 u_direction;
out vec4 out_color;
void main() { out_color = vec4(box_exit(u_origin, u_direction, vec3(-1.0), vec3(1.0))); }
""",
    "slab_probe.frag": """#version 330 core
#include "lib/common.glsl"
#include "lib/reflected_scene.glsl"
uniform vec3 u_origin;
uniform vec3 u_direction;
out vec4 out_color;
void main() {
    float t_near;
    bool met = ray_meets_box(u_origin, 1.0 / u_direction, vec3(-1.0), vec3(1.0), 1e30, t_near);
    out_color = vec4(met ? t_near : -1.0);
}
""",
}


@pytest.mark.parametrize(("fragment", "method", "origin", "direction", "expected"), [
    # The parallax cube map's exit from its proxy box: from a point on the box's top face, along it.
    ("box_exit_probe.frag", Method.CUBEMAP_PARALLAX, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0), 1.0),
    ("box_exit_probe.frag", Method.CUBEMAP_PARALLAX, (0.5, 1.0, -1.0), (0.0, 0.0, 1.0), 2.0),
    ("box_exit_probe.frag", Method.CUBEMAP_PARALLAX, (0.0, 0.5, 0.0), (1.0, 0.0, 0.0), 1.0),
    # The BVH's slab test: a ray lying in a face of the box meets it, one beside the box does not.
    ("slab_probe.frag", Method.RAYTRACE, (-3.0, 1.0, 0.0), (1.0, 0.0, 0.0), 2.0),
    ("slab_probe.frag", Method.RAYTRACE, (-3.0, 1.0, 1.0), (1.0, 0.0, 0.0), 2.0),
    ("slab_probe.frag", Method.RAYTRACE, (-3.0, 0.5, 0.0), (1.0, 0.0, 0.0), 2.0),
    ("slab_probe.frag", Method.RAYTRACE, (-3.0, 1.5, 0.0), (1.0, 0.0, 0.0), -1.0),
])
def test_rays_along_a_box_face_are_not_lost_to_nan(ctx: moderngl.Context, fragment: str, method: Method,
                                                   origin: tuple[float, ...], direction: tuple[float, ...],
                                                   expected: float) -> None:
    """A ray parallel to an axis, starting on a face of a box: 0 * (1/0) is NaN, which GLSL's min
    and max may pass on. llvmpipe did: the cube map's parallax lookup went to the ray's own origin,
    and the BVH missed the box the ray lies on."""
    library = ShaderLibrary()
    library.generated.update(PROBES)
    programs = ProgramCache(ctx, library)
    try:
        program = programs.get("probe.vert", fragment, {"METHOD": int(method)})
        write(program, "u_origin", origin)
        write(program, "u_direction", direction)
        assert _draw(ctx, program) == expected
    finally:
        programs.release()
