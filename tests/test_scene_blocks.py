"""The lights and analytic planes are uniform blocks (gpu/scene_blocks.py): one std140 description
(gpu/std140.py, constants.LIGHTING and PLANES) gives both the GLSL struct and the numpy layout, the
GL reads each field where numpy put it, and no program holds its own copy of a light or a plane."""

from __future__ import annotations

import dataclasses
import itertools
from pathlib import Path

import moderngl
import numpy as np
import pytest

from conftest import SCENES, assert_finite
from depthimpostor.constants import LIGHTING, MATERIAL, MAX_ANALYTIC_PLANES, MAX_LIGHTS, PLANES
from depthimpostor.gpu.bindings import UniformBlock
from depthimpostor.gpu.context import bind_default_framebuffer
from depthimpostor.gpu.shaders import ProgramCache, ShaderLibrary
from depthimpostor.gpu.std140 import Struct
from depthimpostor.gpu.uniforms import bind_uniform_block
from depthimpostor.renderer import Renderer
from depthimpostor.resources import shaders_dir
from depthimpostor.scene import Animation, load_scene


def test_std140_offsets_follow_the_rules() -> None:
    inner = Struct("Inner", (("a", "float"), ("b", "vec3")))
    outer = Struct("Outer", (("x", "float"), ("v", "vec3"), ("w", "float"), ("uv", "vec2"),
                             ("inner", inner, 2), ("m", "mat4"), ("i", "int")))
    offsets = {name: offset for name, (_, offset) in outer.dtype.fields.items()}
    # vec3 aligns to 16 and a float fills its fourth slot; a struct aligns to 16 and its size
    # (4 + pad + 12 = 28) rounds up to 32; the struct ends padded to its alignment.
    assert offsets == {"x": 0, "v": 16, "w": 28, "uv": 32, "inner": 48, "m": 112, "i": 176}
    assert inner.dtype.itemsize == 32 and outer.dtype.itemsize == 192
    assert "Inner inner[2];" in outer.glsl() and "vec3 v;" in outer.glsl()
    with pytest.raises(ValueError, match="padding after each element"):
        _ = Struct("Bad", (("values", "float", 4),)).dtype


def _numbered(struct: Struct) -> np.ndarray:
    """A record of `struct` with every scalar in it a different small number (exact in float32)."""
    record = np.zeros((), struct.dtype)
    counter = itertools.count(1)

    def fill(view: np.ndarray) -> None:
        if view.dtype.names is None:
            view[...] = np.array([next(counter) for _ in range(view.size)]).reshape(view.shape)
            return
        for name in view.dtype.names:
            fill(view[name])

    fill(record)
    return record


# Each row one vec4 of what the GL read from the blocks, for the last light, the last plane and the
# last material (the farthest offsets); main writes row x into pixel x.
READER = """#version 330 core
#define MATERIAL_COUNT 3
#include "lib/common.glsl"
#include "lib/shading.glsl"
#include "lib/analytic_planes.glsl"
out vec4 out_color;
void main() {
    Light light = u_lighting.lights[MAX_LIGHTS - 1];
    AnalyticPlane plane = u_planes.planes[MAX_ANALYTIC_PLANES - 1];
    Material material = u_materials[MATERIAL_COUNT - 1];
    vec4 rows[17] = vec4[](
        vec4(u_lighting.ambient, float(u_lighting.light_count), u_lighting.env_rotation),
        vec4(u_lighting.env_zenith, u_lighting.env_intensity),
        vec4(u_lighting.env_horizon, 0.0), vec4(u_lighting.env_ground, 0.0),
        vec4(float(light.kind), float(light.shadows), light.radius, 0.0),
        vec4(light.vector, 0.0), vec4(light.radiance, 0.0),
        vec4(float(u_planes.count), float(plane.object_id), plane.half_size),
        plane.world_to_local[0], plane.world_to_local[3],
        vec4(float(material.kind), float(material.texture), material.metallic, material.roughness),
        vec4(material.color_a, material.scale), vec4(material.color_b, 0.0),
        vec4(float(material.metallic_roughness_texture), float(material.occlusion_texture),
             float(material.emissive_texture), material.occlusion_strength),
        vec4(material.alpha_cutoff, material.alpha, 0.0, 0.0), vec4(material.emissive, 0.0),
        vec4(plane.normal, float(plane.material)));
    out_color = rows[int(gl_FragCoord.x)];
}
"""
VERTEX = """#version 330 core
void main() { gl_Position = vec4(vec2(gl_VertexID & 1, gl_VertexID >> 1) * 4.0 - 1.0, 0.0, 1.0); }
"""


def _expected_rows(lighting: np.ndarray, planes: np.ndarray, materials: np.ndarray) -> np.ndarray:
    light = lighting["lights"][MAX_LIGHTS - 1]
    plane = planes["planes"][MAX_ANALYTIC_PLANES - 1]
    material = materials[-1]
    rows = [
        [lighting["ambient"], lighting["light_count"], *lighting["env_rotation"]],
        [*lighting["env_zenith"], lighting["env_intensity"]],
        [*lighting["env_horizon"], 0], [*lighting["env_ground"], 0],
        [light["kind"], light["shadows"], light["radius"], 0], [*light["vector"], 0], [*light["radiance"], 0],
        [planes["count"], plane["object_id"], *plane["half_size"]],
        plane["world_to_local"][0], plane["world_to_local"][3],
        [material["kind"], material["texture"], material["metallic"], material["roughness"]],
        [*material["color_a"], material["scale"]], [*material["color_b"], 0],
        [material["metallic_roughness_texture"], material["occlusion_texture"], material["emissive_texture"],
         material["occlusion_strength"]],
        [material["alpha_cutoff"], material["alpha"], 0, 0], [*material["emissive"], 0], [*plane["normal"], plane["material"]],
    ]
    return np.array([np.asarray(row, np.float64) for row in rows], np.float32)


def test_the_gl_reads_every_field_where_numpy_put_it(ctx: moderngl.Context, tmp_path: Path) -> None:
    (tmp_path / "lib").symlink_to(shaders_dir() / "lib")
    (tmp_path / "reader.frag").write_text(READER)
    (tmp_path / "quad.vert").write_text(VERTEX)
    programs = ProgramCache(ctx, ShaderLibrary(tmp_path))
    lighting, planes = _numbered(LIGHTING), _numbered(PLANES)
    materials = np.zeros(3, MATERIAL.dtype)  # (np.stack would pack the fields: no std140 padding)
    materials[:] = _numbered(MATERIAL)
    materials["kind"][-1] += 100  # the last record, not the first, is read
    buffers = [ctx.buffer(lighting.tobytes()), ctx.buffer(planes.tobytes()), ctx.buffer(materials.tobytes())]
    target = ctx.renderbuffer((17, 1), 4, dtype="f4")
    framebuffer = ctx.framebuffer([target])
    try:
        program = programs.get("quad.vert", "reader.frag")
        assert program["Lights"].size == LIGHTING.dtype.itemsize
        assert program["AnalyticPlanes"].size == PLANES.dtype.itemsize
        assert program["MaterialRecords"].size == 3 * MATERIAL.dtype.itemsize
        bind_uniform_block(program, "Lights", UniformBlock.LIGHTS)
        bind_uniform_block(program, "AnalyticPlanes", UniformBlock.ANALYTIC_PLANES)
        bind_uniform_block(program, "MaterialRecords", UniformBlock.MATERIALS)
        buffers[0].bind_to_uniform_block(UniformBlock.LIGHTS)
        buffers[1].bind_to_uniform_block(UniformBlock.ANALYTIC_PLANES)
        buffers[2].bind_to_uniform_block(UniformBlock.MATERIALS)
        vertex_array = ctx.vertex_array(program, [])
        framebuffer.use()
        vertex_array.render(moderngl.TRIANGLES, vertices=3)
        vertex_array.release()
        rows = np.frombuffer(framebuffer.read(components=4, dtype="f4"), np.float32).reshape(17, 4)
    finally:
        bind_default_framebuffer(ctx)
        for item in (framebuffer, target, *buffers):
            item.release()
        programs.release()
    np.testing.assert_array_equal(rows, _expected_rows(lighting, planes, materials))


def test_no_program_holds_a_light_or_a_plane(ctx: moderngl.Context) -> None:
    """Every program the shadowed scene makes reads the lights (and the mirror shader the planes)
    from the blocks on the table's bindings, and has no uniform of its own for them."""
    scene = load_scene(SCENES / "shadows.toml").with_overrides(size=(64, 48), impostor_resolution=32)
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        programs = renderer.programs.programs()
        members = [set(program) for program in programs]
        assert any("AnalyticPlanes" in names for names in members)
        for program, names in zip(programs, members, strict=True):
            stray = {name for name in names if name.startswith(("u_light", "u_ambient", "u_plane", "u_env_"))}
            assert stray <= {"u_env_map"}, stray
            for block, binding in (("Lights", UniformBlock.LIGHTS), ("AnalyticPlanes", UniformBlock.ANALYTIC_PLANES)):
                if block in names:
                    assert program[block].binding == binding
        assert sum("Lights" in names for names in members) >= 2  # the bake and the eye's passes


def test_a_moved_light_reaches_every_program_through_the_block(ctx: moderngl.Context) -> None:
    """set_time writes the moved light into the block: the frame is that of a scene whose light
    stands where the turning one has got to (the floor, an analytic plane in the mirror shader, and
    the baked images all lit by it), and not the frame before the move."""
    scene = load_scene(SCENES / "default.toml").with_overrides(size=(96, 54), impostor_resolution=32)
    turning = dataclasses.replace(scene.lights[0], animation=Animation("rotate", (1.0, 0.0, 0.0), 20.0))
    with Renderer(ctx, dataclasses.replace(scene, lights=[turning])) as renderer:
        renderer.render()
        before = renderer.read_color_float()
        renderer.set_time(1.0)
        renderer.render()
        frame = renderer.read_color_float()
    standing = dataclasses.replace(turning.at(1.0), animation=None)
    with Renderer(ctx, dataclasses.replace(scene, lights=[standing])) as fresh:
        fresh.render()
        expected = fresh.read_color_float()
    assert_finite(frame)
    assert np.abs(frame - before).max() > 0.05
    np.testing.assert_allclose(frame, expected, atol=1e-5)
