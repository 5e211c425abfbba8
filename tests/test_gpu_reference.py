"""The GPU ray query (the mirror shader's own GLSL) against the numpy reference, ray by ray."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import moderngl
import numpy as np
import pytest

from conftest import SCENES
from depthimpostor.oracles import reference
from depthimpostor.constants import Algorithm
from depthimpostor.oracles.ray_query import RayQuery
from depthimpostor.methods.atlas import DepthImage
from depthimpostor.renderer import Renderer
from depthimpostor.scene import load_scene

RAYS = 6000


@pytest.fixture(scope="module")
def baked(ctx: moderngl.Context) -> Iterator[Renderer]:
    """The default scene's depth images, baked once (the frame itself is tiny)."""
    scene = load_scene(SCENES / "default.toml").with_overrides(size=(32, 18), impostor_resolution=128)
    renderer = Renderer(ctx, scene)
    renderer.render()
    yield renderer
    renderer.release()


#: The reference's answers to an image's random rays (random_rays of image i, seed i): the image's
#: index and whether the basic algorithm is asked (every other algorithm's hits are the optimized
#: march's, whose margins every test takes too).
Marched = Callable[[int, bool], tuple[np.ndarray, np.ndarray, reference.RayHits]]


@pytest.fixture(scope="module")
def marched(baked: Renderer) -> Marched:
    """Each answer computed once for the module: the numpy march, not the GPU, took the time."""
    assert baked.graph.impostors is not None
    images = baked.graph.impostors.depth_images
    answers: dict[tuple[int, bool], tuple[np.ndarray, np.ndarray, reference.RayHits]] = {}

    def answer(index: int, basic: bool) -> tuple[np.ndarray, np.ndarray, reference.RayHits]:
        if (index, basic) not in answers:
            origins, directions = random_rays(images[index], index)
            march = reference.intersect_basic if basic else reference.intersect_optimized
            answers[index, basic] = origins, directions, march(image_data(baked, images[index]), origins, directions)
        return answers[index, basic]

    return answer


def image_data(renderer: Renderer, image: DepthImage) -> reference.DepthImageData:
    assert renderer.graph.impostors is not None
    return renderer.graph.impostors.atlas.read(image)


def random_rays(image: DepthImage, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Rays from around the mirror (the depth image's eye) toward the object's bounding sphere:
    about half hit, and many start behind the eye or outside the frustum."""
    rng = np.random.default_rng(seed)
    centre, radius = image.target.bounding_sphere
    origins = image.camera.C + rng.normal(size=(RAYS, 3)) * 0.5
    targets = centre + rng.normal(size=(RAYS, 3)) * radius * 0.6
    return origins, targets - origins


def away_from_decision_boundaries(hits: reference.RayHits) -> np.ndarray:
    """Rays whose march never came within 1e-3 pixel of a texel edge or of a change in step count,
    nor within 1e-6 of a depth crossing: there float32 and float64 must agree; closer than that,
    either answer is right."""
    return (hits.texel_margin > 1e-3) & (hits.depth_margin > 1e-6)


@pytest.mark.parametrize("algorithm", list(Algorithm), ids=lambda a: a.name.lower())
def test_gpu_query_agrees_with_numpy_reference(ctx: moderngl.Context, baked: Renderer, marched: Marched,
                                               algorithm: Algorithm) -> None:
    assert baked.graph.impostors is not None
    for index, image in enumerate(baked.graph.impostors.depth_images):
        origins, directions, expected = marched(index, algorithm == Algorithm.BASIC)  # intersect_depth_image's
        query = RayQuery(ctx, baked.programs, baked.graph.impostors.atlas, [image], algorithm)
        gpu = query.run(origins, directions)
        query.release()
        margins = marched(index, False)[2]
        clear = away_from_decision_boundaries(margins)

        name = image.target.object.name
        assert 0.2 < expected.hit.mean() < 0.8, f"{name}: the ray sample should mix hits and misses"
        assert clear.mean() > 0.5, f"{name}: too few rays away from decision boundaries to judge"
        assert (gpu.hit == expected.hit)[clear].mean() >= 0.999, name
        both = clear & gpu.hit & expected.hit
        error = np.abs(gpu.image_position[both] - expected.image_position[both]).max(axis=1)
        assert error.max() < 0.01, f"{name}: worst {error.max():.4f} px"
        assert np.all(gpu.object_id[gpu.hit] == image.target.index)
        assert np.allclose(gpu.color[both], expected.color[both], atol=1.5 / 255)
        for field in (gpu.t, gpu.image_position, gpu.color):
            assert np.isfinite(field).all()


def test_basic_and_optimized_find_the_same_hits(marched: Marched) -> None:
    """The 3-D segment between unprojected samples projects to the 2-D segment in OpenGL depth
    (depth is affine along a line's projection), so both algorithms find the same point."""
    basic, optimized = marched(1, True)[2], marched(1, False)[2]
    clear = away_from_decision_boundaries(optimized)
    assert (basic.hit == optimized.hit)[clear].mean() >= 0.999
    both = clear & basic.hit & optimized.hit
    assert np.allclose(basic.t[both], optimized.t[both], rtol=1e-6, atol=1e-9)


def test_nearest_hit_over_several_depth_images(ctx: moderngl.Context, baked: Renderer) -> None:
    """A mirror's rays see the nearest of its objects: the GPU and the reference agree on which."""
    assert baked.graph.impostors is not None
    images = baked.graph.impostors.images_by_reflector[baked.world.mirrors[0].index]
    rng = np.random.default_rng(11)
    origins = baked.world.mirrors[0].bounding_sphere[0] + rng.normal(size=(RAYS, 3)) * 0.5
    directions = rng.normal(size=(RAYS, 3))
    query = RayQuery(ctx, baked.programs, baked.graph.impostors.atlas, images)
    gpu = query.run(origins, directions)
    query.release()
    expected = reference.nearest_depth_image_hit([image_data(baked, i) for i in images], origins, directions)
    clear = away_from_decision_boundaries(expected)
    assert expected.hit.sum() > 300
    assert (gpu.hit == expected.hit)[clear].mean() >= 0.999
    both = clear & gpu.hit & expected.hit
    assert (gpu.object_id[both] == expected.object_id[both]).mean() >= 0.999
    assert np.allclose(gpu.t[both], expected.t[both], rtol=1e-3, atol=1e-4)


def test_rays_that_miss_every_frustum_read_no_samples(ctx: moderngl.Context, baked: Renderer) -> None:
    assert baked.graph.impostors is not None
    image = baked.graph.impostors.depth_images[0]
    centre, _ = image.target.bounding_sphere
    away = image.camera.C - centre  # straight away from the object
    origins = np.repeat(image.camera.C[None, :], 64, axis=0)
    directions = np.repeat(away[None, :], 64, axis=0)
    query = RayQuery(ctx, baked.programs, baked.graph.impostors.atlas, [image])
    gpu = query.run(origins, directions)
    query.release()
    assert not gpu.hit.any()
    assert (gpu.samples == 0).all()


@pytest.mark.parametrize("algorithm", [Algorithm.BASIC, Algorithm.OPTIMIZED], ids=lambda a: a.name.lower())
def test_every_hit_lies_in_its_images_hit_bound(baked: Renderer, marched: Marched, algorithm: Algorithm) -> None:
    """The mirror shader skips an image whose hit bound a ray enters after its nearest hit
    (lib/reflected_scene.glsl): every hit a march of the image finds must lie inside it
    (PPC.hit_bound), and for one object's image it is tighter than the frustum's bound."""
    assert baked.graph.impostors is not None
    for index, image in enumerate(baked.graph.impostors.depth_images):
        origins, directions, hits = marched(index, algorithm == Algorithm.BASIC)
        record = image.record()
        centre, radius = record["hit_bound"][:3], float(record["hit_bound"][3])
        assert radius < float(record["bound"][3])
        points = origins[hits.hit] + directions[hits.hit] * hits.t[hits.hit, None]
        assert len(points) > 500
        distance = np.linalg.norm(points - centre, axis=1)
        assert np.all(distance <= radius), f"{image.label}: a hit {distance.max() - radius:.3g} outside"
