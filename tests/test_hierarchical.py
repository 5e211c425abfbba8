"""The hierarchical traversal: its depth pyramid, built on the GPU, against a numpy one made from
the definition; its hits against the optimized march's on hundreds of thousands of rays; and the
texels it reads, which must grow with the logarithm of the resolution, not with the resolution.

The hard cases (tests/test_hard_cases.py) and the fuzzer (tests/test_fuzz.py) run it too, against
the numpy reference, since every algorithm is parametrized there."""

from __future__ import annotations

from collections.abc import Iterator
from types import SimpleNamespace

import moderngl
import numpy as np
import pytest

import synthetic
from conftest import SCENES
from depthimpostor.constants import BACKGROUND_DEPTH, EMPTY_SPAN_MAX, EMPTY_SPAN_MIN, Algorithm
from depthimpostor.errors import ContextError
from depthimpostor.oracles.ray_query import RayQuery, query_depth_images
from depthimpostor.methods.atlas import ImpostorAtlas
from depthimpostor.methods.pyramid import DepthPyramid, PyramidLayout, coarse_levels, level_size
from depthimpostor.renderer import Renderer
from depthimpostor.scene import load_scene
from depthimpostor.gpu.shaders import ProgramCache


@pytest.fixture(scope="module")
def programs(ctx: moderngl.Context) -> Iterator[ProgramCache]:
    cache = ProgramCache(ctx)
    yield cache
    cache.release()


def numpy_pyramid_level(layers: np.ndarray, level: int) -> np.ndarray:
    """Level `level` of an image's pyramid from the definition (methods/pyramid.py): per texel c,
    (min front, max back of the solid run) over the image texels [c 2^L - 1, (c + 1) 2^L] of each
    axis, background left out."""
    front, back = layers[..., 0].astype(np.float64), layers[..., 1].astype(np.float64)
    solid_back = np.where(back >= BACKGROUND_DEPTH, front, np.maximum(front, back))
    empty = front >= BACKGROUND_DEPTH
    low = np.where(empty, EMPTY_SPAN_MIN, front)
    high = np.where(empty, EMPTY_SPAN_MAX, solid_back)
    height, width = front.shape
    columns, rows = level_size(width, height, level)
    block = 2**level
    result = np.empty((rows, columns, 2))
    for row in range(rows):
        for column in range(columns):
            ys = slice(max(0, row * block - 1), min(height, (row + 1) * block + 1))
            xs = slice(max(0, column * block - 1), min(width, (column + 1) * block + 1))
            result[row, column] = low[ys, xs].min(), high[ys, xs].max()
    return result


def random_layers(rng: np.random.Generator, height: int, width: int) -> np.ndarray:
    """Depths with background patches, and back layers that are missing in places."""
    front = rng.uniform(0.2, 0.9, (height, width))
    front[rng.random((height, width)) < 0.3] = BACKGROUND_DEPTH
    back = np.where(rng.random((height, width)) < 0.5, front + rng.uniform(0, 0.1, (height, width)), BACKGROUND_DEPTH)
    back[front >= BACKGROUND_DEPTH] = BACKGROUND_DEPTH
    return np.stack([front, back], axis=2).astype(np.float32)


@pytest.mark.parametrize("resolution, sizes", [
    (100, [(100, 100), (61, 37), (1, 1), (3, 65 // 2)]),  # odd and non-power-of-two sizes
    (64, [(64, 64), (64, 48), (2, 1)]),
    (1, [(1, 1)]),  # a one-texel image has no coarse level
])
def test_gpu_pyramid_matches_its_definition(
    ctx: moderngl.Context, programs: ProgramCache, resolution: int, sizes: list[tuple[int, int]]
) -> None:
    rng = np.random.default_rng(resolution)
    atlas = ImpostorAtlas(ctx, len(sizes), resolution)
    tiles, images = [], []
    for slot, (width, height) in enumerate(sizes):
        layers = random_layers(rng, height, width)
        origin = atlas.tile_origin(slot)
        atlas.depth_layers().write(layers.tobytes(), viewport=(*origin, width, height))
        tiles.append((*origin, width, height))
        images.append(layers)
    pyramid = DepthPyramid(ctx, programs, atlas.pyramid_layout, tiles)
    try:
        pyramid.build(atlas.depth_layers())
        layout = atlas.pyramid_layout
        assert layout.levels == coarse_levels(resolution, resolution)
        for slot, ((width, height), layers) in enumerate(zip(sizes, images, strict=False)):
            x, y, levels = layout.entry(slot, width, height)
            assert levels == coarse_levels(width, height)
            # The top level is one texel over the whole image.
            assert levels == 0 or level_size(width, height, levels) == (1, 1)
            for level in range(1, levels + 1):
                columns, rows = level_size(width, height, level)
                texels = pyramid.read_level(level)
                origin = (x >> (level - 1), y >> (level - 1))
                built = texels[origin[1]:origin[1] + rows, origin[0]:origin[0] + columns]
                expected = numpy_pyramid_level(layers, level)
                assert np.array_equal(built, expected.astype(np.float32)), f"slot {slot}, level {level}"
    finally:
        pyramid.release()
        atlas.release()


def test_pyramid_slots_never_overlap() -> None:
    """Every image's texels at every level stay inside its own slot."""
    layout = PyramidLayout.of_grid(columns=3, rows=2, resolution=300)
    assert layout.pitch == 256  # 300 texels: 9 coarse levels, 150 level-1 texels padded to 256
    for slot in range(6):
        x, y, levels = layout.entry(slot, 300, 300)
        for level in range(1, levels + 1):
            columns, _ = level_size(300, 300, level)
            start = x >> (level - 1)
            assert start + columns <= ((slot % 3) + 1) * (layout.pitch >> (level - 1))


def test_the_pyramid_asks_for_compute_shaders(programs: ProgramCache) -> None:
    """A GL older than 4.3 gets an error that names what is missing and what to use instead."""
    old_gl = SimpleNamespace(version_code=330)
    with pytest.raises(ContextError, match="compute shaders, which need OpenGL 4.3.*optimized"):
        DepthPyramid(old_gl, programs, PyramidLayout(1, 1, 3), [(0, 0, 8, 8)])  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def baked(ctx: moderngl.Context) -> Iterator[Renderer]:
    """The default scene's depth images at a non-power-of-two resolution."""
    scene = load_scene(SCENES / "default.toml").with_overrides(size=(32, 18), impostor_resolution=200)
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        yield renderer


def test_hierarchical_and_linear_agree_on_random_rays(ctx: moderngl.Context, baked: Renderer) -> None:
    """200,000 rays from around each mirror toward each object: about half hit, many start behind
    the eye or outside the frustum, many graze the object's silhouette."""
    assert baked.graph.impostors is not None
    rng = np.random.default_rng(5)
    images = baked.graph.impostors.depth_images
    for image in images:
        centre, radius = image.target.bounding_sphere
        count = 200_000 // len(images)
        origins = image.camera.C + rng.normal(size=(count, 3)) * 0.5
        directions = centre + rng.normal(size=(count, 3)) * radius * 0.6 - origins
        answers = {}
        for algorithm in (Algorithm.OPTIMIZED, Algorithm.HIERARCHICAL):
            query = RayQuery(ctx, baked.programs, baked.graph.impostors.atlas, [image], algorithm)
            answers[algorithm] = query.run(origins, directions)
            query.release()
        assert 0.2 < answers[Algorithm.OPTIMIZED].hit.mean() < 0.8
        synthetic.assert_same_hits(answers[Algorithm.HIERARCHICAL], answers[Algorithm.OPTIMIZED])


def test_hierarchical_and_linear_agree_over_several_images(ctx: moderngl.Context, baked: Renderer) -> None:
    """The nearest hit over all of a mirror's depth images, from the pyramids of all of them."""
    assert baked.graph.impostors is not None
    images = baked.graph.impostors.images_by_reflector[baked.world.mirrors[0].index]
    rng = np.random.default_rng(13)
    origins = baked.world.mirrors[0].bounding_sphere[0] + rng.normal(size=(60_000, 3)) * 0.5
    directions = rng.normal(size=(60_000, 3))
    answers = {}
    for algorithm in (Algorithm.OPTIMIZED, Algorithm.HIERARCHICAL):
        query = RayQuery(ctx, baked.programs, baked.graph.impostors.atlas, images, algorithm)
        answers[algorithm] = query.run(origins, directions)
        query.release()
    assert answers[Algorithm.OPTIMIZED].hit.sum() > 3000
    synthetic.assert_same_hits(answers[Algorithm.HIERARCHICAL], answers[Algorithm.OPTIMIZED])


def test_texels_read_grow_with_the_logarithm_of_the_resolution(ctx: moderngl.Context, programs: ProgramCache) -> None:
    """Rays that cross a tilted plane's whole image well in front of it (misses) and rays that hit
    it at the far side: the linear march reads a texel per pixel crossed, the hierarchical one
    about two per level."""
    reads: dict[tuple[Algorithm, int], tuple[float, float]] = {}  # (misses, hits)
    for resolution in (64, 128, 256, 512, 1024):
        cam = synthetic.camera(width=resolution, height=resolution, near=1.0, far=10.0)
        image = synthetic.plane_image(cam, (0.0, 0.0, -6.0), (0.2, 0.0, 1.0))
        # From in front of the left edge to the right edge: in front of the plane all along
        # (w 1.5 to 3), or ending on it.
        v = np.linspace(0.1, 0.9, 256) * resolution
        starts = cam.unproject(np.zeros_like(v), v, np.full_like(v, 1.5))
        ends = np.concatenate([cam.unproject(np.full(128, float(resolution)), v[:128], np.full(128, 3.0)),
                               cam.unproject(np.full(128, resolution - 0.5), v[128:], np.full(128, 9.0))])
        for algorithm in (Algorithm.OPTIMIZED, Algorithm.HIERARCHICAL):
            hits = query_depth_images(ctx, programs, [image], starts, ends - starts, algorithm)
            assert not hits.hit[:128].any() and hits.hit[128:].all()
            reads[algorithm, resolution] = (float(hits.samples[:128].mean()), float(hits.samples[128:].mean()))
    print({f"{a.name.lower()} {r}": value for (a, r), value in reads.items()})
    for resolution in (64, 128, 256, 512, 1024):
        assert reads[Algorithm.OPTIMIZED, resolution][0] >= resolution  # a texel per pixel crossed
        levels = coarse_levels(resolution, resolution)
        assert max(reads[Algorithm.HIERARCHICAL, resolution]) <= 4 * levels + 8
    # Each doubling adds a bounded number of reads (about a level's), not a doubling of them.
    for kind in (0, 1):
        growth = [reads[Algorithm.HIERARCHICAL, 2 * r][kind] - reads[Algorithm.HIERARCHICAL, r][kind] for r in (64, 128, 256, 512)]
        assert max(growth) <= 6, growth
