"""Any number of distinct materials (issue 32, item 1): past a uniform block's records
(MATERIAL_BLOCK_RECORDS) the MaterialRecords table is a storage buffer, read by every pass (the
eye's batch, the bakes, the mirror's reflected rays) with the records a uniform block would give."""

from __future__ import annotations

import moderngl
import numpy as np
from conftest import assert_finite, scene_from_toml

from depthimpostor.constants import MATERIAL, MATERIAL_BLOCK_RECORDS
from depthimpostor.plan import plan_render
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene
from depthimpostor.gpu.uniforms import materials_in_storage

HEAD = """
[render]
size = [160, 90]
impostor_resolution = 16
[camera]
eye = [0.0, 2.2, 5.5]
target = [0.0, 0.4, 0.0]
[[lights]]
type = "directional"
direction = [-0.4, -1.0, -0.3]
[[objects]]
name = "mirror"
shape = { type = "sphere", radius = 0.6 }
material = { type = "mirror" }
position = [0.0, 0.7, 0.0]
"""
#: More than a 64 KiB uniform block holds (682 records of 96 bytes): main refused such a scene.
COUNT = 700


def boxes(distinct: bool) -> Scene:
    """COUNT small boxes in a ring about the mirror, red and blue in turn (a record read from the
    wrong place shows the other colour, or black); `distinct`: each box's colour off by a
    millionth of its own, so that every box has a material of its own."""
    objects = []
    for k in range(COUNT):
        angle, ring = 2.0 * np.pi * k / 100, 1.4 + 0.25 * (k // 100)
        red, blue = (0.85, 0.2) if k % 2 else (0.15, 0.8)
        off = 1e-6 * k if distinct else 0.0
        objects.append(f'[[objects]]\nname = "box {k}"\nshape = {{ type = "box", size = [0.1, 0.1, 0.1] }}\n'
                       f"material = {{ type = \"diffuse\", color = [{red + off:.7f}, 0.3, {blue:.7f}] }}\n"
                       f"position = [{ring * np.cos(angle):.4f}, 0.05, {ring * np.sin(angle):.4f}]\n")
    return scene_from_toml(HEAD + "\n".join(objects))


def test_a_table_past_a_uniform_blocks_records_is_read_as_one_would_be(ctx: moderngl.Context) -> None:
    many, two = boxes(distinct=True), boxes(distinct=False)
    assert len(many.materials) == COUNT > MATERIAL_BLOCK_RECORDS and len(two.materials) == 2
    assert COUNT * MATERIAL.dtype.itemsize > 65536  # past llvmpipe's GL_MAX_UNIFORM_BLOCK_SIZE too
    assert materials_in_storage(many) and not materials_in_storage(two)
    frames = []
    for scene in (many, two):
        with Renderer(ctx, scene) as renderer:  # the depth method: bakes and the eye's batch read it
            renderer.render()
            frames.append(renderer.read_color_float())
            assert_finite(frames[-1])
    # Colours apart by at most 7e-4 (the millionths): one 8-bit step of the output at most.
    assert np.abs(frames[0] - frames[1]).max() <= 1.0 / 255.0 + 1e-6
    assert (frames[1][..., 0] > 0.5).any() and (frames[1][..., 2] > 0.5).any()  # both colours are in view


def test_the_plan_says_where_the_materials_are() -> None:
    many, two = (next(line for line in plan_render(boxes(distinct)).limits if line.startswith("materials:"))
                 for distinct in (True, False))
    assert f"materials: {COUNT} " in many and "in a storage buffer" in many
    assert "materials: 2 " in two and "in a uniform block" in two
