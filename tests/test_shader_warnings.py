"""The driver says nothing compiling the programs a frame uses: a warning such as "used
uninitialized" is undefined behaviour that llvmpipe happens to forgive (it zeroes) and a GPU may not.
Compiled in a child process with Mesa's on-disk shader cache off: a program it compiled before comes
back from the cache with no log at all, which would let a warning through unseen."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from conftest import PROJECT_ROOT, SCENES

PROBE = """
import json, sys
from depthimpostor.constants import Method
from depthimpostor.gpu.compile_logs import program_logs
from depthimpostor.gpu.context import create_context
from depthimpostor.renderer import Renderer
from depthimpostor.scene import load_scene

ctx = create_context()
scene = load_scene(sys.argv[1]).with_overrides(size=(96, 54), impostor_resolution=32)
said = {}
for method in sys.argv[2:]:
    with Renderer(ctx, scene, reflection_data=True, method=Method[method]) as renderer:
        renderer.render()
        for (stages, defines), program in renderer.programs.compiled():
            text = program_logs(ctx, program)
            if text:
                said[" + ".join(stages) + "".join(f" {k}={v}" for k, v in defines)] = text
print(json.dumps(said))
"""


@pytest.mark.parametrize("methods", [("PLANAR", "HYBRID"), ("DEPTH", "RAYTRACE", "SSR")])
def test_the_programs_of_a_textured_mirror_scene_compile_without_a_word(methods: tuple[str, ...]) -> None:
    env = {**os.environ, "PYTHONPATH": str(PROJECT_ROOT), "MESA_SHADER_CACHE_DISABLE": "true"}
    done = subprocess.run([sys.executable, "-c", PROBE, str(SCENES / "textured_near_mirror.toml"), *methods],
                          env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    said = json.loads(done.stdout.strip().splitlines()[-1])
    assert said == {}, "\n".join(f"{name}:\n{text}" for name, text in said.items())
