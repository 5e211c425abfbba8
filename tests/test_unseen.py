"""What a depth image does not hold (constants.Unseen): each kind on hand-made images, GPU and
reference alike, and the promise the hybrid method rests on, measured on baked images of real
objects against their exact triangles: an answer the march calls certain is the exact one, up to
what the image's sampling explains."""

from __future__ import annotations

from collections.abc import Iterator

import moderngl
import numpy as np
import pytest
import synthetic
from conftest import SCENES
from embreex import rtcore_scene
from embreex.mesh_construction import TriangleMesh

from depthimpostor.oracles import reference
from depthimpostor.constants import Algorithm, Method, Unseen
from depthimpostor.geometry import ObjectGeometry
from depthimpostor.oracles.ray_query import query_depth_images
from depthimpostor.renderer import Renderer
from depthimpostor.scene import load_scene
from depthimpostor.gpu.shaders import ProgramCache


@pytest.fixture(scope="module")
def programs(ctx: moderngl.Context) -> Iterator[ProgramCache]:
    cache = ProgramCache(ctx)
    yield cache
    cache.release()


# A slab 0.3 deep whose face, 5 units in front of the eye, covers the image left of u = 30: its
# right side face (at u = 30) is edge-on to the eye and unseen.
CAMERA = synthetic.camera()
SLAB = synthetic.plane_image(CAMERA, (0.0, 0.0, -5.0), (0.0, 0.0, 1.0), thickness=0.3, mask=lambda u, v: u < 30)


def _across(w: float, start: float = 50.0) -> tuple[np.ndarray, np.ndarray]:
    """A ray at constant depth w, from u = `start` (right of the slab) toward u = 10 (over it), row 24."""
    origin = CAMERA.unproject(start, 24.0, w)
    return origin, CAMERA.unproject(10.0, 24.0, w) - origin


CASES = {
    # The face, head on: a hit through the visible surface with seen empty space before it.
    "hit": (CAMERA.unproject(20.0, 24.0, 2.0), CAMERA.unproject(20.0, 24.0, 8.0) - CAMERA.unproject(20.0, 24.0, 2.0),
            True, Unseen.NONE),
    # Well in front of everything: a certain miss, the slab's silhouette crossed far from it.
    "clear miss": (*_across(2.0), False, Unseen.NONE),
    # Inside the slab's depth: it enters through the side face, which the image does not hold. (Its
    # samples fall 0.6 texel past the texel edges: the one before the entry is more than a texel
    # from the covered centres, so that the coverage band around the edge flags nothing earlier;
    # from u = 50 it is a silhouette a step before.)
    "hidden entry": (*_across(5.15, 45.6), True, Unseen.HIDDEN_ENTRY),
    "within a texel of the edge": (*_across(5.15), True, Unseen.SILHOUETTE),
    # Behind the slab: space the slab hides, where more of the object could be (samples placed as
    # for the hidden entry).
    "occluded": (*_across(7.0, 45.6), False, Unseen.OCCLUDED),
    # Just in front of the face: whether it grazes the slab's edge the samples cannot say.
    "silhouette": (*_across(4.99), False, Unseen.SILHOUETTE),
}


@pytest.mark.parametrize("algorithm", list(Algorithm))
@pytest.mark.parametrize("case", list(CASES))
def test_each_kind_of_unseen(ctx, programs, case: str, algorithm: Algorithm) -> None:
    origin, direction, hit, kind = CASES[case]
    gpu = query_depth_images(ctx, programs, [SLAB], origin[None], direction[None], algorithm)
    expected = reference.intersect_depth_image(SLAB, origin[None], direction[None], algorithm)
    for answer, who in ((gpu, "GPU"), (expected, "reference")):
        assert bool(answer.hit[0]) is hit, f"{who}: hit {answer.hit[0]}"
        assert Unseen(int(answer.unseen[0])) is kind, f"{who}: {Unseen(int(answer.unseen[0])).name}"
        assert bool(answer.certain[0]) is (kind is Unseen.NONE), who
    if kind is not Unseen.NONE:
        assert gpu.unseen_t[0] == pytest.approx(expected.unseen_t[0], rel=1e-3, abs=1e-3)
        assert expected.unseen_t[0] <= (expected.t[0] if hit else np.inf)


# A ridge toward the eye (two planes 40 degrees either side of the line of sight meeting along the
# column u = 30.2, 5 units away): between the samples at u = 29.5 and 30.5 the surface comes in
# front of their join, up to the ridge.
RIDGE_POINT = CAMERA.unproject(30.2, 24.0, 5.0)
_RIDGE_U, _RIDGE_V = synthetic.pixel_centres(CAMERA)
RIDGE = synthetic.image_from_w(CAMERA, np.maximum(
    synthetic.plane_w(CAMERA, RIDGE_POINT, np.array([np.sin(0.7), 0.0, np.cos(0.7)]), _RIDGE_U, _RIDGE_V),
    synthetic.plane_w(CAMERA, RIDGE_POINT, np.array([-np.sin(0.7), 0.0, np.cos(0.7)]), _RIDGE_U, _RIDGE_V)), None)


@pytest.mark.parametrize("algorithm", list(Algorithm))
@pytest.mark.parametrize(("w", "kind"), [(5.01, Unseen.SILHOUETTE), (4.95, Unseen.NONE)])
def test_a_ridge_between_samples_is_unseen(ctx, programs, w: float, kind: Unseen, algorithm: Algorithm) -> None:
    """A ray across the ridge at w = 5.01 passes in front of both samples next to it and their
    join, and behind the ridge itself: the truth hits it, the samples cannot tell, and the march's
    miss must not be called certain (it was, before the joins' extensions bounded the surface
    between samples). At w = 4.95 it passes in front of the extensions too: a certain miss."""
    origin, direction = _across(w, 45.6)
    gpu = query_depth_images(ctx, programs, [RIDGE], origin[None], direction[None], algorithm)
    expected = reference.intersect_depth_image(RIDGE, origin[None], direction[None], algorithm)
    for answer, who in ((gpu, "GPU"), (expected, "reference")):
        assert not answer.hit[0], who
        assert Unseen(int(answer.unseen[0])) is kind, f"{who}: {Unseen(int(answer.unseen[0])).name}"


# ---------------------------------------------------------------- real objects against their triangles

RAYS_PER_IMAGE = 4000
#: Offsets of a ray, in texel footprints at its hit, within which the image's sampling explains an
#: answer: a sample stands for its texel's centre, and the march reads any point of the texel.
FOOTPRINT_TEXELS = 1.5


def _embree(item: ObjectGeometry) -> rtcore_scene.EmbreeScene:
    scene = rtcore_scene.EmbreeScene()
    mesh = item.world_mesh
    TriangleMesh(scene, np.ascontiguousarray(mesh.positions[mesh.indices], dtype=np.float32))
    return scene


def _trace(scene: rtcore_scene.EmbreeScene, origins: np.ndarray, directions: np.ndarray):
    out = scene.run(origins.astype(np.float32), directions.astype(np.float32), output=1)
    hit = out["geomID"] >= 0
    normal = np.asarray(out["Ng"], float)
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-30)
    return hit, np.where(hit, out["tfar"].astype(float), np.inf), normal


def explained_by_sampling(image: reference.DepthImageData, target: ObjectGeometry, origins: np.ndarray,
                          directions: np.ndarray, answer: reference.RayHits) -> np.ndarray:
    """Is each answer the exact one of the ray, or of a ray moved by at most FOOTPRINT_TEXELS
    texels' footprint across itself (8 directions)? A hit must then lie at the exact hit's t, give
    or take the footprint divided by the cosine of the angle of incidence (a grazing ray's hit
    moves far along it for a small move across; the cosine is bounded by MAX_SURFACE_SLOPE's 1/16)."""
    scene = _embree(target)
    camera = image.camera
    pixel_angle = max(np.linalg.norm(camera.a), np.linalg.norm(camera.b)) / camera.focal
    exact_hit, exact_t, _ = _trace(scene, origins, directions)
    at = np.where(answer.hit, answer.t, np.where(exact_hit, exact_t, 0.0))
    footprint = FOOTPRINT_TEXELS * pixel_angle * np.linalg.norm(origins + directions * at[:, None] - camera.C, axis=1)
    across = np.cross(directions, [0.31, 0.94, 0.13])
    across /= np.linalg.norm(across, axis=1, keepdims=True)
    other = np.cross(directions, across)
    explained = np.zeros(len(origins), bool)
    for a, b in [(0, 0), (1, 0), (-1, 0), (0, 1), (0, -1), (0.7, 0.7), (0.7, -0.7), (-0.7, 0.7), (-0.7, -0.7)]:
        moved = origins + (across * a + other * b) * footprint[:, None]
        hit, t, normal = _trace(scene, moved, directions)
        cosine = np.maximum(np.abs(np.einsum("ij,ij->i", normal, directions)), 1.0 / 16.0)
        explained |= (answer.hit == hit) & (~hit | (np.abs(answer.t - t) <= footprint / cosine))
    return explained


def _rays_at(image_target: ObjectGeometry, mirror: ObjectGeometry, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Rays from points of the mirror toward points in and around the object's bounding sphere:
    hits, misses, grazing rays and rays behind the object, as a mirror sends them."""
    triangles = mirror.world_mesh.positions[mirror.world_mesh.indices]
    pick = rng.integers(0, len(triangles), RAYS_PER_IMAGE)
    a, b = rng.random(RAYS_PER_IMAGE), rng.random(RAYS_PER_IMAGE)
    flip = a + b > 1
    a[flip], b[flip] = 1 - a[flip], 1 - b[flip]
    corners = triangles[pick]
    origins = corners[:, 0] + a[:, None] * (corners[:, 1] - corners[:, 0]) + b[:, None] * (corners[:, 2] - corners[:, 0])
    centre, radius = image_target.bounding_sphere
    directions = centre + rng.normal(size=(RAYS_PER_IMAGE, 3)) * radius / np.sqrt(3) - origins
    return origins, directions / np.linalg.norm(directions, axis=1, keepdims=True)


@pytest.fixture(scope="module")
def baked(ctx: moderngl.Context) -> list[tuple[reference.DepthImageData, ObjectGeometry, np.ndarray, np.ndarray]]:
    """Every depth image of the default scene and of the checker scene (boxes, a plate edge-on
    from the mirror's centre, knots, spheres, a cylinder, a torus) at 128^2, with its rays; as
    the hybrid method bakes them (with where second solid runs begin)."""
    rng = np.random.default_rng(7)
    found = []
    for name in ("default.toml", "checker_near_mirror.toml"):
        scene = load_scene(SCENES / name).with_overrides(size=(32, 18), impostor_resolution=128)
        with Renderer(ctx, scene, method=Method.HYBRID) as renderer:
            renderer.render()
            assert renderer.graph.impostors is not None
            for image in renderer.graph.impostors.depth_images:
                origins, directions = _rays_at(image.target, image.mirror, rng)
                found.append((renderer.graph.impostors.atlas.read(image), image.target, origins, directions))
    return found


@pytest.fixture(scope="module")
def marched(baked) -> list[reference.RayHits]:
    """The reference's answers to each baked image's rays, marched once for the module's tests."""
    return [reference.intersect_optimized(image, origins, directions) for image, _, origins, directions in baked]


def test_certain_answers_are_the_exact_ones(baked, marched) -> None:
    """On 36,000 rays at 9 objects, the reference's certain answers (hit or miss) are the exact
    intersection with the triangles up to sampling. Not quite all: 2 or 3 in 100,000 (hits on a
    knot whose strands cross close in depth) are not, and the test holds that share, so that a
    change which makes the flag less sound fails here."""
    wrong_and_certain = wrong = flagged = total = 0
    for (image, target, origins, directions), answer in zip(baked, marched, strict=True):
        explained = explained_by_sampling(image, target, origins, directions, answer)
        wrong_and_certain += int((answer.certain & ~explained).sum())
        wrong += int((~explained).sum())
        flagged += int((~answer.certain).sum())
        total += len(origins)
    assert wrong > 100, "the rays should find the depth images' errors"
    assert flagged < 0.6 * total, f"{flagged} of {total} flagged: uncertainty should be the exception"
    assert wrong_and_certain <= 1e-4 * total, f"{wrong_and_certain} of {total} wrong answers called certain"


@pytest.mark.parametrize("algorithm", [Algorithm.OPTIMIZED, Algorithm.HIERARCHICAL])
def test_gpu_flags_what_the_reference_flags(ctx, programs, baked, marched, algorithm: Algorithm) -> None:
    """The GLSL's Unseen is the reference's, ray by ray, but where float32 and float64 decide a
    boundary case otherwise; the hierarchical traversal finds the same first unseen place."""
    agree = total = false_certain = 0
    for (image, target, origins, directions), expected in zip(baked[:5], marched[:5], strict=True):
        gpu = query_depth_images(ctx, programs, [image], origins, directions, algorithm)
        agree += int((gpu.certain == expected.certain).sum())
        total += len(origins)
        false_certain += int((gpu.certain & ~explained_by_sampling(image, target, origins, directions, gpu)).sum())
        bright = gpu.hit & (gpu.color >= 0.999).all(axis=1)
        assert not bright.any(), "a hit shows the white of a cleared texel (the default scene has no white object)"
    assert agree >= 0.995 * total, f"{total - agree} of {total} rays flagged otherwise on the GPU"
    assert false_certain <= 1e-4 * total, f"GPU: {false_certain} of {total} wrong answers called certain"
