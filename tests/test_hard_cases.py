"""The catalogue of hard cases (docs/numerical_robustness.md), each on the GPU and in the numpy
reference, against answers known in closed form. Items 1-7 use hand-made depth images of planes
(tests/synthetic.py); items 8-10 render whole scenes (tests/test_hard_scenes.py)."""

from __future__ import annotations

from collections.abc import Iterator

import moderngl
import numpy as np
import pytest

import synthetic
from depthimpostor.constants import CONTACT_DEPTH_TOLERANCE, MAX_SURFACE_SLOPE, Algorithm
from depthimpostor.gpu.shaders import ProgramCache

ALGORITHMS = pytest.mark.parametrize("algorithm", list(Algorithm), ids=lambda a: a.name.lower())


@pytest.fixture(scope="module")
def programs(ctx: moderngl.Context) -> Iterator[ProgramCache]:
    cache = ProgramCache(ctx)
    yield cache
    cache.release()


def fronto_plane(w: float = 5.0, **kwargs: object) -> tuple:
    cam = synthetic.camera()
    return cam, synthetic.plane_image(cam, (0.0, 0.0, -w), (0.0, 0.0, 1.0), **kwargs)


def check(gpu, expected, hit: np.ndarray | bool, t: np.ndarray | float | None = None, rtol: float = 1e-5) -> None:
    """Both answers finite, both hit where `hit` says, both at parameter t."""
    for result, who in ((gpu, "GPU"), (expected, "reference")):
        synthetic.assert_finite_hits(result)
        wrong = result.hit != np.broadcast_to(hit, result.hit.shape)
        assert not wrong.any(), f"{who}: {int(wrong.sum())} of {len(wrong)} rays hit where they should not or missed"
        if t is not None:
            wanted = np.broadcast_to(t, result.t.shape)[result.hit]
            error = np.abs(result.t[result.hit] - wanted)
            assert np.all(error <= rtol * np.abs(wanted) + 1e-6), f"{who}: t off by up to {error.max():.3g}"


# ----------------------------------------------------------------------------- 1. through the eye
@ALGORITHMS
def test_ray_through_the_eye_hits_the_sample_under_it(ctx, programs, algorithm) -> None:
    """A ray along an eye ray projects to one point: ceil(0) steps would read nothing and miss.
    With one step the two ends are compared with that texel's depth: the exact answer."""
    cam, image = fronto_plane()
    rng = np.random.default_rng(1)
    u, v = rng.uniform(1, 63, 200), rng.uniform(1, 47, 200)
    directions = cam.ray_direction(u, v)
    starts = rng.uniform(0.0, 4.0, 200)  # from the eye itself (0) to just in front of the plane
    origins = directions * starts[:, None]
    gpu, expected = synthetic.both(ctx, programs, [image], origins, directions, algorithm)
    check(gpu, expected, True, 5.0 - starts)
    assert (expected.samples == 2).all() and (gpu.samples == 2).all(), "one step, two samples"


@ALGORITHMS
def test_ray_nearly_through_the_eye_stays_continuous(ctx, programs, algorithm) -> None:
    """Tilting the eye ray by 1e-9 to 1e-3 of a pixel changes the hit by no more than the tilt."""
    cam, image = fronto_plane()
    u, v = np.full(7, 20.3), np.full(7, 30.7)
    direction = cam.ray_direction(u, v)
    tilt = 10.0 ** -np.arange(3, 10)[:, None] * cam.a  # a is one pixel: moves the vanishing point 1e-k px
    origins = direction * 2.0
    gpu, expected = synthetic.both(ctx, programs, [image], origins, direction + tilt, algorithm)
    check(gpu, expected, True, 3.0, rtol=1e-3)
    assert np.allclose(gpu.image_position, [[20.3, 30.7]], atol=2e-3)


# ----------------------------------------------------------------------------- 2. behind the eye
@ALGORITHMS
def test_ray_from_behind_the_eye_is_clipped_not_mirrored(ctx, programs, algorithm) -> None:
    """w <= 0 at the origin: the part behind the eye is clipped away before any divide by w."""
    cam, image = fronto_plane()
    rng = np.random.default_rng(2)
    targets = cam.unproject(rng.uniform(4, 60, 100), rng.uniform(4, 44, 100), np.full(100, 5.0))
    origins = np.column_stack([rng.uniform(-0.5, 0.5, 100), rng.uniform(-0.5, 0.5, 100), rng.uniform(0.5, 3.0, 100)])
    directions = targets - origins  # origin.z > 0 is behind the eye (which looks down -Z)
    gpu, expected = synthetic.both(ctx, programs, [image], origins, directions, algorithm)
    check(gpu, expected, True, 1.0)
    # Turned around, they run from behind the eye further behind it (w < 0 all along). Divided by
    # w first, they would project onto the same image segment (a vanishing point does not depend
    # on the direction's sign) and could hit; clipped first, they never enter the frustum.
    gpu, expected = synthetic.both(ctx, programs, [image], origins, -directions, algorithm)
    check(gpu, expected, False)
    assert (gpu.samples == 0).all() and (expected.samples == 0).all()


@ALGORITHMS
def test_ray_crossing_the_near_plane_starts_at_it(ctx, programs, algorithm) -> None:
    """From between the eye and the near plane (0 < w < w_near), the march starts on the near plane."""
    cam, image = fronto_plane()
    u, v = np.linspace(5, 59, 50), np.linspace(40, 8, 50)
    target = cam.unproject(u, v, np.full(50, 5.0))
    origins = cam.unproject(np.full(50, 32.0), np.full(50, 24.0), np.full(50, 0.5))
    gpu, expected = synthetic.both(ctx, programs, [image], origins, target - origins, algorithm)
    check(gpu, expected, True, 1.0)


# ----------------------------------------------------------------------------- 3. frustum edges
@ALGORITHMS
def test_rays_outside_touching_or_along_the_frustum(ctx, programs, algorithm) -> None:
    """Misses read no sample; rays in a side plane or along an edge (u or v exactly 0 or width)
    hit the plane in the image's own border texels, never a neighbour tile of the atlas."""
    cam, image = fronto_plane()
    far_plane = synthetic.plane_image(cam, (0.0, 0.0, -9.0), (0.0, 0.0, 1.0), object_id=1)
    # Along eye rays one pixel outside each side: outside the frustum all the way.
    outside_u = np.array([-1.0, 65.0, 32.0, 32.0])
    outside_v = np.array([24.0, 24.0, -1.0, 49.0])
    outside = cam.ray_direction(outside_u, outside_v)
    gpu, expected = synthetic.both(ctx, programs, [image, far_plane], outside * 2.0, outside, algorithm)
    check(gpu, expected, False)
    assert (gpu.samples == 0).all() and (expected.samples == 0).all()

    # In the side planes u = 0 and u = width, v = 0 and v = height, and along the four corner edges.
    u = np.array([0.0, 64.0, 10.0, 10.0, 0.0, 64.0, 0.0, 64.0])
    v = np.array([20.0, 20.0, 0.0, 48.0, 0.0, 0.0, 48.0, 48.0])
    directions = cam.ray_direction(u, v)
    for start in (0.0, 2.0):  # from the eye (the edge of every side plane) and from inside
        gpu, expected = synthetic.both(ctx, programs, [image, far_plane], directions * start, directions, algorithm)
        check(gpu, expected, True, 5.0 - start)
        assert (gpu.object_id == 0).all(), "read the neighbour tile's depth"


# ----------------------------------------------------------------------------- 4. grazing
@ALGORITHMS
def test_ray_lying_in_the_surface_hits_where_it_enters(ctx, programs, algorithm) -> None:
    """A ray in the plane w = 5 has ray depth = surface depth up to float32 rounding at every pixel:
    without a contact band the first sign change lands anywhere along it (flicker)."""
    cam, image = fronto_plane()
    rng = np.random.default_rng(4)
    starts = cam.unproject(rng.uniform(2, 30, 300), rng.uniform(2, 46, 300), np.full(300, 5.0))
    ends = cam.unproject(rng.uniform(34, 62, 300), rng.uniform(2, 46, 300), np.full(300, 5.0))
    gpu, expected = synthetic.both(ctx, programs, [image], starts, ends - starts, algorithm)
    check(gpu, expected, True, 0.0)
    # Lifted off the surface by far less than the band, it still touches; by far more, it misses.
    w_lift = CONTACT_DEPTH_TOLERANCE * 5.0**2 / cam.w_near * 0.1  # dw = dd * w^2 / w_near (w_far >> w)
    gpu, expected = synthetic.both(ctx, programs, [image], starts + [0, 0, w_lift], ends - starts, algorithm)
    check(gpu, expected, True, 0.0)
    gpu, expected = synthetic.both(ctx, programs, [image], starts + [0, 0, 0.01], ends - starts, algorithm)
    check(gpu, expected, False)


@ALGORITHMS
def test_grazing_rays_hit_within_one_texel_of_the_surface(ctx, programs, algorithm) -> None:
    """Rays at 0.05 to 2 degrees to a tilted plane: a hit on each (no hole), within the depth the
    plane spans over one texel (no false surface), GPU and reference alike."""
    cam = synthetic.camera()
    normal = np.array([0.0, np.sin(np.radians(60)), np.cos(np.radians(60))])
    point = np.array([0.0, 0.0, -5.0])
    image = synthetic.plane_image(cam, tuple(point), tuple(normal))
    along = np.cross(normal, [1.0, 0.0, 0.0])  # in the plane, across the image's rows
    angles = np.radians(np.geomspace(0.05, 2.0, 40))
    directions = np.cos(angles)[:, None] * along + np.sin(angles)[:, None] * -normal
    hits_at = point + along * 0.1
    origins = hits_at - directions * 0.6
    gpu, expected = synthetic.both(ctx, programs, [image], origins, directions, algorithm)
    check(gpu, expected, True)
    pixel_angle = cam.max_relative_depth_step / MAX_SURFACE_SLOPE
    texel_depth = 5.0 * pixel_angle * np.tan(np.radians(60)) * 2.0  # what the plane spans over two texels
    for result in (gpu, expected):
        points = origins + directions * result.t[:, None]
        assert np.abs((points - point) @ normal).max() < texel_depth


# ----------------------------------------------------------------------------- 5. silhouettes
def two_slabs(near_thickness: float, far_thickness: float = 2.0) -> tuple:
    """A near slab (w = 4) over the image's left half, in front of a far one (w = 7) over the right
    half: one object, so their samples meet across a depth discontinuity at u = 32."""
    cam = synthetic.camera()
    u, v = synthetic.pixel_centres(cam)
    front = np.where(u < 32, 4.0, 7.0)
    back = np.where(u < 32, 4.0 + near_thickness, 7.0 + far_thickness)
    return cam, synthetic.image_from_w(cam, front, back)


@ALGORITHMS
def test_no_rubber_sheet_across_a_silhouette(ctx, programs, algorithm) -> None:
    """A ray going right to left, in front of the far slab and then behind the thin near one,
    crosses the segment joining their samples but no surface: it must miss."""
    cam, image = two_slabs(near_thickness=0.2)
    v = np.linspace(4, 44, 30)
    start = cam.unproject(np.full(30, 50.0), v, np.full(30, 5.0))
    end = cam.unproject(np.full(30, 10.0), v, np.full(30, 5.0))  # w = 5: behind the near slab's back
    gpu, expected = synthetic.both(ctx, programs, [image], start, end - start, algorithm)
    check(gpu, expected, False)


@ALGORITHMS
def test_ray_behind_a_thin_foreground_reaches_what_is_behind(ctx, programs, algorithm) -> None:
    """Left to right: behind the thin near slab, then onto the far one, which it crosses at w = 7."""
    cam, image = two_slabs(near_thickness=0.2)
    v = np.linspace(4, 44, 30)
    start = cam.unproject(np.full(30, 10.0), v, np.full(30, 5.0))
    on_far = cam.unproject(np.full(30, 44.0), v, np.full(30, 7.0))
    gpu, expected = synthetic.both(ctx, programs, [image], start, on_far - start, algorithm)
    check(gpu, expected, True, 1.0, rtol=1e-4)


@ALGORITHMS
def test_ray_into_the_hidden_side_of_a_thick_foreground_hits_it(ctx, programs, algorithm) -> None:
    """Right to left at w = 5 behind a near slab 2 deep: it enters the slab through the side the
    eye cannot see, at the discontinuity; the hit is at most one step past it."""
    cam, image = two_slabs(near_thickness=2.0)
    v = np.linspace(4, 44, 30)
    start = cam.unproject(np.full(30, 50.0), v, np.full(30, 5.0))
    end = cam.unproject(np.full(30, 10.0), v, np.full(30, 5.0))
    gpu, expected = synthetic.both(ctx, programs, [image], start, end - start, algorithm)
    check(gpu, expected, True)
    for result in (gpu, expected):
        assert np.all((result.image_position[:, 0] > 30.9) & (result.image_position[:, 0] <= 32.0))


# ----------------------------------------------------------------------------- 6. background
@ALGORITHMS
def test_background_ends_the_surface(ctx, programs, algorithm) -> None:
    """A plane with a 4-texel slot: a ray crossing its depth inside the slot goes through."""
    cam = synthetic.camera()
    image = synthetic.plane_image(cam, (0.0, 0.0, -5.0), (0.0, 0.0, 1.0), mask=lambda u, v: np.abs(u - 32) > 2)
    v = np.linspace(4, 44, 30)
    start = cam.unproject(np.full(30, 31.5), v, np.full(30, 4.0))
    end = cam.unproject(np.full(30, 32.5), v, np.full(30, 6.0))  # crosses w = 5 at u = 32
    gpu, expected = synthetic.both(ctx, programs, [image], start, end - start, algorithm)
    check(gpu, expected, False)


@ALGORITHMS
def test_ray_ending_on_the_far_plane(ctx, programs, algorithm) -> None:
    """The clipped end at OpenGL depth 1 (the far plane): a surface just in front of it is hit,
    and with nothing there the ray misses without reading past the image."""
    cam = synthetic.camera(far=10.0)
    image = synthetic.plane_image(cam, (0.0, 0.0, -9.99), (0.0, 0.0, 1.0))
    rng = np.random.default_rng(6)
    origins = cam.unproject(rng.uniform(8, 56, 100), rng.uniform(8, 40, 100), np.full(100, 2.0))
    targets = cam.unproject(rng.uniform(8, 56, 100), rng.uniform(8, 40, 100), np.full(100, 10.0))
    gpu, expected = synthetic.both(ctx, programs, [image], origins, targets - origins, algorithm)
    check(gpu, expected, True, (9.99 - 2.0) / 8.0, rtol=1e-3)
    empty = synthetic.plane_image(cam, (0.0, 0.0, -9.99), (0.0, 0.0, 1.0), mask=lambda u, v: u < 0)
    gpu, expected = synthetic.both(ctx, programs, [empty], origins, targets - origins, algorithm)
    check(gpu, expected, False)


# ----------------------------------------------------------------------------- 7. exact positions
@ALGORITHMS
@pytest.mark.parametrize("offset", [0.5, 0.0, 1e-6], ids=["pixel-centre", "pixel-edge", "just-past-edge"])
def test_hits_on_pixel_centres_and_edges(ctx, programs, algorithm, offset) -> None:
    cam, image = fronto_plane()
    u = np.arange(4, 60, 2) + offset
    v = np.full(len(u), 24.0) + offset
    on_plane = cam.unproject(u, v, np.full(len(u), 5.0))
    origins = on_plane + np.array([0.3, -0.2, 2.0])  # w = 3, off the eye ray
    gpu, expected = synthetic.both(ctx, programs, [image], origins, on_plane - origins, algorithm)
    check(gpu, expected, True, 1.0)
    assert np.allclose(gpu.image_position, np.column_stack([u, v]), atol=1e-3)


@ALGORITHMS
def test_hit_on_the_last_sample(ctx, programs, algorithm) -> None:
    """The ray leaves the frustum through its side exactly where it meets the plane: k = 1 on the
    last step, at u = width (the border texel, clamped)."""
    cam, image = fronto_plane()
    v = np.linspace(3, 45, 20)
    exits = cam.unproject(np.full(20, 64.0), v, np.full(20, 5.0))
    origins = cam.unproject(np.full(20, 20.0), v, np.full(20, 3.0))
    gpu, expected = synthetic.both(ctx, programs, [image], origins, exits - origins, algorithm)
    check(gpu, expected, True, 1.0, rtol=1e-4)
    assert np.allclose(gpu.image_position[:, 0], 64.0, atol=1e-3)


# ----------------------------------------------------------------------------- 8. near/far ratio
@ALGORITHMS
def test_the_widest_depth_range_a_fit_allows(ctx, programs, algorithm) -> None:
    """PPC.fitted refuses an object nearer than 1e-3 of its extent, so w_far / w_near <= ~1e3.
    At that ratio float32 OpenGL depth still places hits on a receding plane within 1e-3 of w."""
    cam = synthetic.camera(near=0.01, far=10.0)
    normal = np.array([0.0, 1.0, 0.0])  # a floor under the eye: w from near to far across the image
    # A slab 0.05 thick: near its horizon the floor is steeper than MAX_SURFACE_SLOPE from the eye,
    # and a closed object's back layer is what lets rays in there (an open one would be a hole).
    image = synthetic.plane_image(cam, (0.0, -0.3, 0.0), tuple(normal), thickness=0.05)
    rng = np.random.default_rng(8)
    u, v = rng.uniform(2, 62, 300), rng.uniform(26, 47, 300)
    w = synthetic.plane_w(cam, np.array([0.0, -0.3, 0.0]), normal, np.floor(u) + 0.5, np.floor(v) + 0.5)
    keep = (w > 0.02) & (w < 5.0)  # below the horizon's row, where the floor's silhouette is
    targets = cam.unproject(np.floor(u) + 0.5, np.floor(v) + 0.5, w)[keep]
    origins = targets + np.array([0.0, 0.2, 0.1])
    gpu, expected = synthetic.both(ctx, programs, [image], origins, targets - origins, algorithm)
    for result in (gpu, expected):
        synthetic.assert_finite_hits(result)
        assert result.hit.all()
        points = origins + (targets - origins) * result.t[:, None]
        assert np.abs(points[:, 2] - targets[:, 2]).max() < 1e-3 * np.abs(targets[:, 2]).max() + 0.02
