"""The light and plane loops (lib/shading.glsl, lib/reflected_scene.glsl) run to constants of the
program, LIGHT_COUNT and PLANE_COUNT, which llvmpipe unrolls (a loop to a uniform cost the floor
5 of its 7.5 ms: tools/shading_cost.py). The uniform arrays they read are then shortened by the
compiler to the elements read, and a program with PLANE_COUNT has no u_plane_count: the frame
must be the one the uniform-bounded fallback draws."""

from __future__ import annotations

import dataclasses
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


def test_the_bound_without_objects_is_a_variant_of_the_mirror_program(ctx: moderngl.Context) -> None:
    """tools/interactive_frame.py's bound (OBJECTS_LEFT_OUT: the mirror pass without any reflected
    object) is the frame's own program with one define more, and draws the mirror with no object
    in it: each pixel is the frame's (an object seen directly) or that of the same scene without
    its reflected objects (the mirror then shows the floor and the sky alone)."""
    scene = load_scene(SCENES / "default.toml").with_overrides(size=(160, 90), impostor_resolution=64)
    bare = dataclasses.replace(scene, objects=tuple(o for i, o in enumerate(scene.objects)
                                                      if o.is_reflector or i in scene.analytic_plane_indices))
    with Renderer(ctx, bare) as renderer:
        renderer.render()
        nothing_reflected = renderer.read_color_float()
    with Renderer(ctx, scene) as renderer:
        reflectors = renderer.graph.reflector_pass
        assert reflectors is not None and reflectors.programs[False] is not None
        mirror = reflectors.programs[False]
        renderer.render()
        full = renderer.read_color_float()
        bound = renderer.programs.with_defines(mirror, {"OBJECTS_LEFT_OUT": 1})
        assert renderer.programs.without_defines(bound, ("OBJECTS_LEFT_OUT",)) is mirror
        write(bound, "u_backing_albedo", MIRROR_BACKING_ALBEDO)
        reflectors.programs[False] = bound
        renderer.render()
        without = renderer.read_color_float()
    assert_finite(without)
    assert np.abs(full - without).max() > 0.1  # the reflections of the objects are gone
    seen_directly = np.abs(without - full).max(axis=2) < 1e-4
    as_if_absent = np.abs(without - nothing_reflected).max(axis=2) < 1e-4
    assert np.all(seen_directly | as_if_absent)
