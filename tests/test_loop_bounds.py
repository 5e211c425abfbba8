"""The light and plane loops (lib/shading.glsl, lib/reflected_scene.glsl) run to constants of the
program, LIGHT_COUNT and PLANE_COUNT, which llvmpipe unrolls (a loop to a uniform cost the floor
5 of its 7.5 ms: tools/shading_cost.py). The uniform arrays they read are then shortened by the
compiler to the elements read, and a program with PLANE_COUNT has no u_plane_count: the frame
must be the one the uniform-bounded fallback draws."""

from __future__ import annotations

from pathlib import Path

import moderngl
import numpy as np
import pytest

from conftest import assert_finite
from depthimpostor.gpu.uniforms import write
from depthimpostor.oracles.truth import MIRROR_BACKING_ALBEDO
from depthimpostor.renderer import Renderer
from depthimpostor.scene import load_scene

SCENES = Path(__file__).resolve().parent.parent / "scenes"
BOUNDS = ("LIGHT_COUNT", "PLANE_COUNT")


@pytest.mark.parametrize("name", ["default.toml", "shadows.toml"])
def test_constant_loop_bounds_draw_the_frame_the_uniform_bounds_draw(ctx: moderngl.Context, name: str) -> None:
    scene = load_scene(SCENES / name).with_overrides(size=(160, 90), impostor_resolution=64)
    with Renderer(ctx, scene) as renderer:
        diffuse, reflectors = renderer.graph.diffuse, renderer.graph.reflector_pass
        assert diffuse is not None and diffuse.instanced is not None and reflectors is not None
        mirror = reflectors.programs[False]
        assert mirror is not None
        defines = {stages[1]: dict(found) for stages, found in renderer.programs.keys if len(stages) == 2}
        assert defines["diffuse.frag"]["LIGHT_COUNT"] == str(len(scene.lights))
        assert defines["reflector.frag"]["PLANE_COUNT"] == str(len(scene.analytic_planes)) != "0"
        renderer.render()
        constant = renderer.read_color_float()
        diffuse.instanced = renderer.programs.without_defines(diffuse.instanced, BOUNDS)
        fallback = renderer.programs.without_defines(mirror, BOUNDS)
        write(fallback, "u_backing_albedo", MIRROR_BACKING_ALBEDO)
        reflectors.programs[False] = fallback
        renderer.render()
        uniform = renderer.read_color_float()
    assert_finite(constant)
    assert np.abs(constant - uniform).max() < 1e-6
