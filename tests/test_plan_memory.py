"""The plan's memory is what the renderer allocates: every texture, renderbuffer and buffer it makes
for its first frame, counted as GL holds them, equals the plan's figure (plan.plan_memory)."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import moderngl
import numpy as np
import pytest
from conftest import SCENES, scene_from_toml

from depthimpostor.constants import DEPTH_IMAGE_DTYPE, Algorithm, Method, depth_image_capacity, lists_images
from depthimpostor.methods.registry import METHODS
from depthimpostor.plan import plan_render
from depthimpostor.renderer import Renderer
from depthimpostor.scene import load_scene

_MAKERS = ("texture", "texture_array", "texture_cube", "texture3d", "depth_texture", "renderbuffer",
           "depth_renderbuffer", "buffer")


def _bytes(item: Any, mip_levels: int) -> int:
    """GPU bytes of a texture or renderbuffer (with its mips 1..mip_levels) or a buffer."""
    if isinstance(item, moderngl.Buffer):
        return item.size
    texel = item.components * int(item.dtype[1]) * getattr(item, "layers", 1)  # an array's level holds every layer
    # GL's chain ends at 1x1: a larger max_level (build_mipmaps' default) makes no more levels.
    last = min(mip_levels, max(item.width, item.height).bit_length() - 1)
    return sum(max(1, item.width >> m) * max(1, item.height >> m) * texel for m in range(last + 1))


@pytest.fixture
def allocations(ctx: moderngl.Context, monkeypatch: pytest.MonkeyPatch) -> Iterator[list[tuple[Any, list[int]]]]:
    """Every GL object made through the context while the test runs, with its mip levels."""
    made: list[tuple[Any, list[int]]] = []
    levels: dict[int, list[int]] = {}
    making = [False]  # a maker that calls another counts once

    def recording(name: str) -> Any:
        original = getattr(moderngl.Context, name)

        def make(self: moderngl.Context, *args: Any, **kwargs: Any) -> Any:
            outer = not making[0]
            making[0] = True
            try:
                item = original(self, *args, **kwargs)
            finally:
                making[0] = not outer
            if outer:
                levels[id(item)] = [0]
                made.append((item, levels[id(item)]))
            return item
        return make

    def build_mipmaps(self: moderngl.Texture, base: int = 0, max_level: int = 1000) -> None:
        levels.setdefault(id(self), [0])[0] = max_level  # GL clamps to the chain's length; _bytes stops at 1x1 anyway
        original_mipmaps(self, base, max_level)

    def build_array_mipmaps(self: moderngl.TextureArray, base: int = 0, max_level: int = 1000) -> None:
        levels.setdefault(id(self), [0])[0] = max_level
        original_array_mipmaps(self, base, max_level)

    original_mipmaps = moderngl.Texture.build_mipmaps
    original_array_mipmaps = moderngl.TextureArray.build_mipmaps
    for name in _MAKERS:
        monkeypatch.setattr(moderngl.Context, name, recording(name))
    monkeypatch.setattr(moderngl.Texture, "build_mipmaps", build_mipmaps)
    monkeypatch.setattr(moderngl.TextureArray, "build_mipmaps", build_array_mipmaps)
    yield made


def _alive_bytes(made: list[tuple[Any, list[int]]]) -> int:
    return sum(_bytes(item, level[0]) for item, level in made if type(item.mglo).__name__ != "InvalidObject")


CASES = [
    ("default.toml", Method.DEPTH, Algorithm.OPTIMIZED, {}),
    ("default.toml", Method.DEPTH, Algorithm.HIERARCHICAL, {}),  # the pyramid the plan left out
    ("glass_and_mirrors.toml", Method.DEPTH, Algorithm.HIERARCHICAL, {}),  # bounces, glass in mirrors
    ("shadows.toml", Method.DEPTH, Algorithm.OPTIMIZED, {"reflection_data": True}),
    ("grid_3x3.toml", Method.CUBEMAP, Algorithm.OPTIMIZED, {}),
    ("planar_mirror.toml", Method.BILLBOARD, Algorithm.OPTIMIZED, {}),
    ("carousel.toml", Method.RAYTRACE, Algorithm.OPTIMIZED, {}),
    ("carousel.toml", Method.SIMPLIFIED, Algorithm.OPTIMIZED, {}),
    ("default.toml", Method.HYBRID, Algorithm.HIERARCHICAL, {"count_samples": True}),
    ("default.toml", Method.DEPTH, Algorithm.OPTIMIZED, {"roughness": 0.15}),  # a glossy mirror's colour mips
    ("grid_3x3.toml", Method.CUBEMAP, Algorithm.OPTIMIZED, {"roughness": 0.3}),
    ("planar_mirror.toml", Method.PLANAR, Algorithm.OPTIMIZED, {}),  # made in the frame (methods/seen_from_eye.py)
    ("default.toml", Method.SSR, Algorithm.OPTIMIZED, {"reflection_data": True}),
    ("default.toml", Method.SSR, Algorithm.OPTIMIZED, {"roughness": 0.15}),  # the frame copy's mips
    ("textured_near_mirror.toml", Method.DEPTH, Algorithm.OPTIMIZED, {}),  # texture arrays, atlas, records
    ("showcase.toml", Method.RAYTRACE, Algorithm.OPTIMIZED, {}),  # three images in one array
]


@pytest.mark.parametrize(("name", "method", "algorithm", "options"), CASES,
                         ids=[f"{n}-{m.option}-{a.name.lower()}{'-rough' * ('roughness' in o)}" for n, m, a, o in CASES])
def test_plan_memory_is_what_the_renderer_allocates(ctx: moderngl.Context, allocations: list[tuple[Any, list[int]]],
                                                    name: str, method: Method, algorithm: Algorithm,
                                                    options: dict[str, float]) -> None:
    options = dict(options)
    scene = load_scene(SCENES / name).with_overrides(size=(96, 54), impostor_resolution=32)
    scene = scene.with_roughness(options.pop("roughness", 0.0))
    with Renderer(ctx, scene, algorithm, method=method, **options) as renderer:
        renderer.render()
        allocated = _alive_bytes(allocations)
        planned = renderer.plan.memory
    assert sum(planned.values()) == allocated, planned
    if not options:  # the `plan` command's figure is the renderer's
        assert plan_render(scene, method, algorithm).memory == planned


def many_around_a_mirror(count: int) -> str:
    """A mirror sphere among `count` small spheres and boxes: past 128 objects, each mirror's table
    holds lists of candidate images by ray past its records (methods/image_cells.py)."""
    text = ('[render]\nsize = [96, 54]\nimpostor_resolution = 16\n[camera]\neye = [0.0, 2.0, 7.0]\ntarget = [0.0, 0.8, 0.0]\n'
            '[[lights]]\ntype = "directional"\ndirection = [-0.4, -1.0, -0.3]\n'
            '[[objects]]\nname = "mirror"\nshape = { type = "sphere", radius = 0.8 }\nmaterial = { type = "mirror" }\n'
            'position = [0.0, 0.8, 0.0]\n')
    for k in range(count):
        angle, ring = 2.39996 * k, 1.6 + 2.0 * k / count
        shape = '{ type = "sphere", radius = 0.1 }' if k % 2 else '{ type = "box", size = [0.15, 0.15, 0.15] }'
        text += (f'[[objects]]\nname = "o{k}"\nshape = {shape}\nmaterial = {{ type = "diffuse", color = [0.8, 0.4, 0.2] }}\n'
                 f"position = [{ring * np.cos(angle):.4f}, {0.2 + 1.2 * (k % 7) / 7:.4f}, {ring * np.sin(angle):.4f}]\n")
    return text


@pytest.mark.parametrize("method", [Method.DEPTH, Method.BILLBOARD, Method.CUBEMAP])
def test_plan_memory_counts_the_lists_of_candidate_images(ctx: moderngl.Context, allocations: list[tuple[Any, list[int]]],
                                                          method: Method) -> None:
    scene = scene_from_toml(many_around_a_mirror(140))
    assert lists_images(depth_image_capacity(len(scene.objects)))
    with Renderer(ctx, scene, method=method) as renderer:
        renderer.render()
        first_frame = _alive_bytes(allocations)
        baked = renderer.graph.baked_images
        assert baked is not None
        # Baked lazily (depth images, billboards), the first frame's images fill the atlas's first
        # rows alone; once every image is baked, the renderer holds what the plan states.
        assert (first_frame < sum(renderer.plan.memory.values())) == baked.lazily
        baked.bake_again()
        renderer.render()
        allocated = _alive_bytes(allocations)
        planned = renderer.plan.memory
    records = depth_image_capacity(len(scene.objects)) * DEPTH_IMAGE_DTYPE.itemsize
    noun = METHODS[method].stand_in.image_noun  # type: ignore[attr-defined]
    assert planned[f"{noun} records"] > records  # the lists past the one mirror's records
    assert sum(planned.values()) == allocated, planned
    assert plan_render(scene, method).memory == planned
