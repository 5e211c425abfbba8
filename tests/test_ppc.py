"""The planar pinhole camera: projection, frustum fitting, OpenGL depth, ray clipping, and the GL
matrices rasterizing exactly what `project` predicts.

The numpy PPC is the reference that the impostor baking and the GLSL intersection are checked against,
so every test here states an exact geometric fact with a tolerance that only float rounding explains.
"""

from __future__ import annotations

import moderngl
import numpy as np
import pytest

from conftest import assert_finite
from depthimpostor.gpu.context import bind_default_framebuffer
from depthimpostor.constants import CLIP_TOLERANCE_PIXELS
from depthimpostor.ppc import PPC, FrustumFitError

# (eye, target, up, fov, width, height): square, wide, tall, oblique and tilted up-vector cameras.
LOOK_AT_CASES = {
    "square": ((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), 60.0, 64, 64),
    "wide": ((3.6, 1.8, 4.6), (-0.2, 0.9, -0.6), (0.0, 1.0, 0.0), 45.0, 160, 90),
    "tall": ((-2.0, 0.5, -1.0), (1.0, 1.5, 2.0), (0.0, 1.0, 0.0), 30.0, 48, 96),
    "tilted_up": ((1.0, 2.0, 3.0), (0.0, 0.0, 0.0), (0.3, 1.0, -0.2), 75.0, 120, 80),
    "narrow_fov": ((10.0, -4.0, 2.0), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 8.0, 100, 50),
}
# Straight down with up = +Y: up is parallel to the view direction, so look_at picks its own frame.
STRAIGHT_DOWN = ((0.0, 5.0, 0.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), 50.0, 80, 60)
ALL_CASES = {**LOOK_AT_CASES, "straight_down": STRAIGHT_DOWN}


def make_camera(case: tuple, near: float = 0.05, far: float = 200.0) -> PPC:
    eye, target, up, fov, width, height = case
    return PPC.look_at(eye, target, up, fov, width, height, near=near, far=far)


def random_image_points(camera: PPC, rng: np.random.Generator, count: int, w_range: tuple[float, float]):
    """(u, v, w) spread over and around the image, at depths log-uniform in w_range."""
    u = rng.uniform(-0.5, 1.5, count) * camera.width
    v = rng.uniform(-0.5, 1.5, count) * camera.height
    w = np.exp(rng.uniform(np.log(w_range[0]), np.log(w_range[1]), count))
    return u, v, w


def fitted_camera() -> PPC:
    """A fitted camera on an elongated, off-centre cloud: asymmetric frustum, non-square pixels."""
    rng = np.random.default_rng(7)
    cloud = rng.normal(size=(500, 3)) * (1.5, 0.3, 0.6) + (0.4, 0.2, -0.3)
    # Looking at a point beside the cloud's centre makes the frustum asymmetric about the axis.
    return PPC.fitted((0.5, 1.0, 6.0), cloud, (1.0, 0.5, 0.0), 80, 40)


# --- construction and projection ------------------------------------------------------------------


@pytest.mark.parametrize("case", ALL_CASES.values(), ids=ALL_CASES.keys())
def test_unproject_then_project_is_the_identity(case: tuple) -> None:
    camera = make_camera(case)
    u, v, w = random_image_points(camera, np.random.default_rng(1), 200, (0.01, 500.0))
    uvw = camera.project(camera.unproject(u, v, w))
    np.testing.assert_allclose(uvw, np.stack([u, v, w], axis=-1), rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("case", ALL_CASES.values(), ids=ALL_CASES.keys())
def test_project_then_unproject_is_the_identity(case: tuple) -> None:
    camera = make_camera(case)
    rng = np.random.default_rng(2)
    points = camera.C + rng.uniform(-20.0, 20.0, size=(300, 3))
    points = points[camera.project(points)[:, 2] > 0.05]  # in front of the camera only
    assert len(points) > 100
    uvw = camera.project(points)
    np.testing.assert_allclose(camera.unproject(uvw[:, 0], uvw[:, 1], uvw[:, 2]), points, rtol=0, atol=1e-9)


def test_straight_down_camera_is_a_proper_frame() -> None:
    camera = make_camera(STRAIGHT_DOWN)
    assert np.isfinite(camera.matrix).all()
    np.testing.assert_allclose(camera.forward, (0.0, -1.0, 0.0), atol=1e-12)
    assert abs(np.dot(camera.a, camera.b)) < 1e-12
    np.testing.assert_allclose(np.linalg.norm(camera.a), np.linalg.norm(camera.b), rtol=1e-12)
    np.testing.assert_allclose(camera.project((0.0, 0.0, 0.0))[:2], (40.0, 30.0), atol=1e-9)


@pytest.mark.parametrize("case", ALL_CASES.values(), ids=ALL_CASES.keys())
def test_ray_direction_passes_through_the_unprojected_points(case: tuple) -> None:
    camera = make_camera(case)
    u, v, w = random_image_points(camera, np.random.default_rng(3), 100, (0.1, 50.0))
    direction = camera.ray_direction(u, v)
    np.testing.assert_allclose(camera.C + direction * w[:, None], camera.unproject(u, v, w), atol=1e-12)
    # Along the ray, (u, v) stay put and w is the ray parameter.
    t = np.linspace(0.5, 30.0, len(u))
    uvw = camera.project(camera.C + direction * t[:, None])
    np.testing.assert_allclose(uvw, np.stack([u, v, t], axis=-1), rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("case", LOOK_AT_CASES.values(), ids=LOOK_AT_CASES.keys())
def test_look_at_centres_the_target_and_keeps_up_upwards(case: tuple) -> None:
    eye, target, up, fov, width, height = case
    camera = make_camera(case)
    distance = np.linalg.norm(np.subtract(target, eye))
    np.testing.assert_allclose(camera.project(target), (width / 2, height / 2, distance), rtol=1e-12)
    # A point above the target (along `up`) lands straight above the image centre.
    u, v, _ = camera.project(np.add(target, 0.1 * distance * np.asarray(up) / np.linalg.norm(up)))
    assert v < height / 2 - 1.0
    assert u == pytest.approx(width / 2, abs=1e-9)


@pytest.mark.parametrize("case", LOOK_AT_CASES.values(), ids=LOOK_AT_CASES.keys())
def test_look_at_fov_is_vertical_and_pixels_are_square(case: tuple) -> None:
    _, _, _, fov, width, height = case
    camera = make_camera(case)
    np.testing.assert_allclose(np.linalg.norm(camera.a), np.linalg.norm(camera.b), rtol=1e-12)
    assert camera.focal == pytest.approx(1.0, rel=1e-12)
    top = camera.ray_direction(width / 2, 0.0)
    bottom = camera.ray_direction(width / 2, float(height))
    angle = np.degrees(np.arccos(np.dot(top, bottom) / (np.linalg.norm(top) * np.linalg.norm(bottom))))
    assert angle == pytest.approx(fov, rel=1e-9)


# --- fitted frustums -------------------------------------------------------------------------------


def view_depth(camera: PPC, points: np.ndarray) -> np.ndarray:
    return (np.asarray(points) - camera.C) @ camera.forward


@pytest.mark.parametrize("seed", range(4))
def test_fitted_frustum_contains_every_point(seed: int) -> None:
    rng = np.random.default_rng(seed)
    points = rng.normal(size=(400, 3)) * rng.uniform(0.2, 2.0, 3) + rng.uniform(-1.0, 1.0, 3)
    eye = rng.uniform(-1.0, 1.0, 3) + (0.0, 0.0, 8.0)
    centre = points.mean(axis=0) + rng.uniform(-0.5, 0.5, 3)
    width, height = int(rng.integers(16, 200)), int(rng.integers(16, 200))
    camera = PPC.fitted(eye, points, centre, width, height)
    u, v, _ = camera.project(points).T
    assert (u >= 0).all() and (u <= width).all()
    assert (v >= 0).all() and (v <= height).all()
    depth = view_depth(camera, points)
    assert (camera.near <= depth).all() and (depth <= camera.far).all()
    # Tight: the points reach to within about two pixels of every edge.
    assert u.min() < 2.0 and u.max() > width - 2.0
    assert v.min() < 2.0 and v.max() > height - 2.0


def test_fitted_camera_has_an_asymmetric_frustum_and_non_square_pixels() -> None:
    camera = fitted_camera()
    assert abs(np.linalg.norm(camera.a) / np.linalg.norm(camera.b) - 1.0) > 0.05
    principal = camera.project(camera.C + camera.forward)[:2]
    assert np.abs(principal - (camera.width / 2, camera.height / 2)).max() > 2.0


@pytest.mark.parametrize(
    "points",
    [
        np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),  # on both sides of the eye
        np.random.default_rng(5).normal(size=(100, 3)),  # a cloud all around it
        np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -2.0]]),  # touching it
        np.zeros((3, 3)),  # nothing but the eye
    ],
    ids=["both_sides", "surrounding_cloud", "touching", "only_the_eye"],
)
def test_fitted_refuses_points_around_the_eye(points: np.ndarray) -> None:
    with pytest.raises(FrustumFitError, match="eye"):
        PPC.fitted((0.0, 0.0, 0.0), points, (0.0, 0.0, -1.0), 32, 32)


# --- OpenGL depth ----------------------------------------------------------------------------------


def scaled_camera() -> PPC:
    """A camera whose image plane is 2.5 units from the eye (focal != 1), so w != view depth."""
    base = make_camera(LOOK_AT_CASES["wide"], near=0.3, far=40.0)
    return PPC(base.C, base.a * 2.5, base.b * 2.5, base.c * 2.5, base.width, base.height, base.near, base.far)


@pytest.mark.parametrize("camera", [make_camera(LOOK_AT_CASES["wide"]), fitted_camera(), scaled_camera()],
                         ids=["look_at", "fitted", "focal_2.5"])
def test_opengl_depth_is_0_at_near_1_at_far_and_inverts(camera: PPC) -> None:
    assert camera.opengl_depth(camera.w_near) == pytest.approx(0.0, abs=1e-12)
    assert camera.opengl_depth(camera.w_far) == pytest.approx(1.0, abs=1e-12)
    # near and far are distances along the optical axis: the points there have depth 0 and 1.
    w_at_near = camera.project(camera.C + camera.forward * camera.near)[2]
    w_at_far = camera.project(camera.C + camera.forward * camera.far)[2]
    assert camera.opengl_depth(w_at_near) == pytest.approx(0.0, abs=1e-12)
    assert camera.opengl_depth(w_at_far) == pytest.approx(1.0, abs=1e-12)
    w = np.geomspace(camera.w_near, camera.w_far, 200)
    depth = camera.opengl_depth(w)
    assert (np.diff(depth) > 0).all()
    np.testing.assert_allclose(camera.w_from_opengl_depth(depth), w, rtol=1e-9)
    d = np.linspace(0.0, 1.0, 101)
    np.testing.assert_allclose(camera.opengl_depth(camera.w_from_opengl_depth(d)), d, atol=1e-9)


def test_projection_matrix_gives_pixel_ndc_and_opengl_depth() -> None:
    """The numpy side of the GL agreement: NDC = (2u/W - 1, 2v/H - 1, 2d(w) - 1), clip w = w."""
    for camera in (make_camera(LOOK_AT_CASES["wide"]), fitted_camera(), scaled_camera()):
        rotation = camera.view_matrix[:3, :3]
        np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(rotation) == pytest.approx(1.0)
        np.testing.assert_allclose(camera.view_projection, camera.projection_matrix @ camera.view_matrix)
        u, v, w = random_image_points(camera, np.random.default_rng(6), 50, (camera.w_near, camera.w_far))
        points = camera.unproject(u, v, w)
        clip = np.c_[points, np.ones(len(points))] @ camera.view_projection.T
        np.testing.assert_allclose(clip[:, 3], w, rtol=1e-9)
        ndc = clip[:, :3] / clip[:, 3:]
        expected = np.stack([2 * u / camera.width - 1, 2 * v / camera.height - 1, 2 * camera.opengl_depth(w) - 1], -1)
        np.testing.assert_allclose(ndc, expected, atol=1e-9)


# --- frustum clipping ------------------------------------------------------------------------------


def frustum_slack(camera: PPC, points: np.ndarray) -> np.ndarray:
    """Each point's smallest distance inside the six frustum bounds (u, v in pixels; w in units of
    the depth range): >= 0 inside, 0 on the boundary, < 0 outside. Only meaningful for w > 0."""
    u, v, w = np.moveaxis(camera.project(points), -1, 0)
    span = camera.w_far - camera.w_near
    bounds = [u, camera.width - u, v, camera.height - v, (w - camera.w_near) / span, (camera.w_far - w) / span]
    return np.min(bounds, axis=0)


def clip_camera() -> PPC:
    return make_camera(LOOK_AT_CASES["wide"], near=0.5, far=12.0)


def assert_clipped_segment(camera: PPC, origins: np.ndarray, directions: np.ndarray) -> None:
    """Every ray reported inside has entry and exit on the frustum boundary and is inside in between."""
    inside, t_enter, t_exit = camera.clip_ray(origins, directions)
    assert inside.all()
    assert np.isfinite(t_enter).all() and np.isfinite(t_exit).all()
    assert (t_enter >= 0.0).all() and (t_enter < t_exit).all()
    entry = origins + directions * t_enter[:, None]
    exit_ = origins + directions * t_exit[:, None]
    entry_slack, exit_slack = frustum_slack(camera, entry), frustum_slack(camera, exit_)
    starts_inside = t_enter == 0.0
    np.testing.assert_allclose(entry_slack[~starts_inside], 0.0, atol=1e-7)
    assert (entry_slack[starts_inside] > 0.0).all()
    np.testing.assert_allclose(exit_slack, 0.0, atol=1e-7)
    s = np.linspace(0.01, 0.99, 33)
    between = origins[:, None] + directions[:, None] * (t_enter[:, None] + s * (t_exit - t_enter)[:, None])[..., None]
    assert (frustum_slack(camera, between) > 0.0).all()


def test_rays_through_the_frustum_enter_and_exit_on_its_boundary() -> None:
    camera = clip_camera()
    rng = np.random.default_rng(11)
    # Aim from points all around the frustum at random points inside it.
    u = rng.uniform(0.05, 0.95, 200) * camera.width
    v = rng.uniform(0.05, 0.95, 200) * camera.height
    w = rng.uniform(camera.w_near * 1.2, camera.w_far * 0.9, 200)
    targets = camera.unproject(u, v, w)
    origins = camera.C + rng.uniform(-15.0, 15.0, size=(200, 3))
    directions = (targets - origins) * rng.uniform(0.1, 3.0, (200, 1))
    assert_clipped_segment(camera, origins, directions)


def test_clipping_agrees_with_dense_sampling_along_random_rays() -> None:
    camera = clip_camera()
    rng = np.random.default_rng(12)
    origins = camera.C + rng.uniform(-15.0, 15.0, size=(400, 3))
    directions = rng.normal(size=(400, 3))
    inside, t_enter, t_exit = camera.clip_ray(origins, directions)
    assert 20 < inside.sum() < 380, "the sample should have both hits and misses"
    t = np.linspace(0.0, 40.0, 4001)
    samples = origins[:, None] + directions[:, None] * t[:, None]
    in_front = np.moveaxis(camera.project(samples), -1, 0)[2] > 0
    sampled_inside = (frustum_slack(camera, samples) > 1e-6) & in_front
    # Every sample strictly inside the frustum lies within [t_enter, t_exit] of a ray reported inside.
    within = (t >= t_enter[:, None] - 1e-9) & (t <= t_exit[:, None] + 1e-9) & inside[:, None]
    assert not (sampled_inside & ~within).any()
    assert sampled_inside[inside].any(axis=1).sum() >= 0.9 * inside.sum()


def test_rays_that_miss_the_frustum_are_not_inside() -> None:
    camera = clip_camera()
    forward, right = camera.forward, camera.a / np.linalg.norm(camera.a)
    rays = {
        # Parallel to the optical axis, so far to the side that the frustum widens to it only past far.
        "beside": (camera.C + right * 30.0, forward),
        # From beyond the far plane, heading further away.
        "away_beyond_far": (camera.C + forward * (camera.far + 5.0), forward),
        # From behind the eye, heading backwards.
        "away_behind_eye": (camera.C - forward * 2.0, -forward),
        # Along the left side plane's direction (u = 0), but outside it.
        "parallel_left": (camera.C - camera.a * 5.0, camera.ray_direction(0.0, camera.height / 2)),
        # Along the top side plane's direction (v = 0), but above it.
        "parallel_top": (camera.C - camera.b * 5.0, camera.ray_direction(camera.width / 3, 0.0)),
        # Parallel to the near plane, just in front of the eye (between the eye and near).
        "parallel_near": (camera.C + forward * camera.near * 0.5 - camera.a * 200, camera.a),
        # Crossing the image plane's line of sight beside the frustum.
        "across_beside": (camera.unproject(-40.0, 10.0, 2.0), camera.unproject(-40.0, 80.0, 9.0)
                          - camera.unproject(-40.0, 10.0, 2.0)),
    }
    origins = np.array([origin for origin, _ in rays.values()])
    directions = np.array([direction for _, direction in rays.values()])
    inside, _, _ = camera.clip_ray(origins, directions)
    missed = dict(zip(rays, inside, strict=False))
    assert not any(missed.values()), missed


def binary_exact_camera() -> PPC:
    """Looking down -Z from the origin with power-of-two entries, so that [a b c]^-1 is exact and a ray
    parallel to a frustum plane has a rate of exactly 0 (the Liang-Barsky parallel case)."""
    return PPC(np.zeros(3), np.array([1 / 64, 0.0, 0.0]), np.array([0.0, -1 / 64, 0.0]),
               np.array([-0.5, 0.5, -1.0]), 64, 64, 0.5, 8.0)


@pytest.mark.parametrize(
    ("origin", "direction", "expected"),
    [
        ((-2.0, 0.0, -3.0), (-0.5, 0.5, -1.0), None),  # along the left plane (u = 0), outside it
        ((2.0, 0.0, -3.0), (0.5, 0.0, -1.0), None),  # along the right plane (u = width), outside it
        ((0.0, 0.0, -0.25), (1.0, 0.0, 0.0), None),  # along the near plane, between it and the eye
        ((0.0, 0.0, -9.0), (0.0, 1.0, 0.0), None),  # along the far plane, beyond it
        ((0.6, 0.0, -3.0), (0.5, 0.0, -1.0), (0.0, 5.0)),  # along the right plane, inside it: out at far
        ((0.0, 0.0, -5.0), (1.0, 0.0, 0.0), (0.0, 2.5)),  # across, from the axis: out at u = width
        ((-5.0, 0.0, -2.0), (1.0, 0.0, 0.0), (4.0, 6.0)),  # across, from beside: in at u = 0, out at u = width
    ],
)
def test_rays_exactly_parallel_to_a_frustum_plane(origin: tuple, direction: tuple, expected: tuple | None) -> None:
    camera = binary_exact_camera()
    inside, t_enter, t_exit = camera.clip_ray(np.array(origin), np.array(direction))
    if expected is None:
        assert not inside
    else:
        assert inside
        assert (float(t_enter), float(t_exit)) == pytest.approx(expected, abs=1e-12)


def test_ray_from_behind_the_eye_along_the_axis_enters_through_the_near_plane() -> None:
    camera = clip_camera()
    origin = camera.C - camera.forward * 2.0
    inside, t_enter, t_exit = camera.clip_ray(origin, camera.forward)
    assert inside
    assert t_enter == pytest.approx(2.0 + camera.near, rel=1e-12)
    assert t_exit == pytest.approx(2.0 + camera.far, rel=1e-12)
    u, v, w = camera.project(origin + camera.forward * t_enter)
    assert (u, v, w) == pytest.approx((camera.width / 2, camera.height / 2, camera.w_near), rel=1e-9)


def test_rays_from_behind_the_eye_are_clipped_without_nan() -> None:
    camera = clip_camera()
    rng = np.random.default_rng(13)
    # Start behind the eye's plane (w < 0) and aim through random points inside the frustum: the
    # ray crosses the eye's plane beside the eye and enters through the near plane or a side plane.
    u, v = rng.uniform(0.1, 0.9, 100) * camera.width, rng.uniform(0.1, 0.9, 100) * camera.height
    targets = camera.unproject(u, v, rng.uniform(1.0, 10.0, 100))
    origins = camera.C - camera.forward * rng.uniform(0.5, 5.0, (100, 1)) + rng.uniform(-1.0, 1.0, (100, 3))
    assert (camera.project(origins)[:, 2] < 0).all()
    directions = targets - origins
    assert_clipped_segment(camera, origins, directions)
    _, t_enter, _ = camera.clip_ray(origins, directions)
    entry_uvw = camera.project(origins + directions * t_enter[:, None])
    on_near = np.isclose(entry_uvw[:, 2], camera.w_near, rtol=1e-9)
    on_side = (np.isclose(entry_uvw[:, 0], 0.0, atol=1e-7) | np.isclose(entry_uvw[:, 0], camera.width)
               | np.isclose(entry_uvw[:, 1], 0.0, atol=1e-7) | np.isclose(entry_uvw[:, 1], camera.height))
    assert (on_near | on_side).all()
    assert on_near.any() and on_side.any(), "the sample should cover both kinds of entry"


def test_ray_starting_inside_enters_at_zero() -> None:
    camera = clip_camera()
    rng = np.random.default_rng(14)
    origins = camera.unproject(rng.uniform(1, camera.width - 1, 50), rng.uniform(1, camera.height - 1, 50),
                               rng.uniform(camera.w_near * 1.1, camera.w_far * 0.9, 50))
    directions = rng.normal(size=(50, 3))
    inside, t_enter, t_exit = camera.clip_ray(origins, directions)
    assert inside.all()
    assert (t_enter == 0.0).all()
    assert_clipped_segment(camera, origins, directions)


# --- GL rasterizes what `project` predicts ---------------------------------------------------------

VERTEX_SHADER = """
#version 330 core
uniform mat4 u_view_projection;
in vec3 in_position;
flat out float v_id;
void main() {
    gl_Position = u_view_projection * vec4(in_position, 1.0);
    v_id = float(gl_VertexID);
}
"""

FRAGMENT_SHADER = """
#version 330 core
flat in float v_id;
out vec4 out_id_depth;
void main() {
    out_id_depth = vec4(v_id, gl_FragCoord.z, 0.0, 1.0);
}
"""


def rasterize_points(ctx: moderngl.Context, camera: PPC, positions: np.ndarray) -> np.ndarray:
    """Draw each position as a 1-pixel GL point; returns (height, width, 4) rows of (id, depth, 0, 1),
    id -1 where no point landed. Row index = v: window y = v, so image row 0 is framebuffer row 0."""
    size = (camera.width, camera.height)
    color = ctx.texture(size, 4, dtype="f4")
    depth = ctx.depth_renderbuffer(size)
    fbo = ctx.framebuffer(color, depth)
    program = ctx.program(vertex_shader=VERTEX_SHADER, fragment_shader=FRAGMENT_SHADER)
    vbo = ctx.buffer(np.ascontiguousarray(positions, dtype=np.float32).tobytes())
    vao = ctx.vertex_array(program, [(vbo, "3f", "in_position")])
    # A scope so that blending, depth testing or program point size left on by other tests cannot
    # change what lands in the target; it restores the previous state on exit.
    scope = ctx.scope(fbo, enable_only=moderngl.NOTHING)
    try:
        program["u_view_projection"].write(np.ascontiguousarray(camera.view_projection.T, dtype=np.float32).tobytes())
        with scope:
            ctx.point_size = 1.0
            fbo.clear(-1.0, 0.0, 0.0, 0.0, depth=1.0)
            vao.render(moderngl.POINTS)
            image = np.frombuffer(fbo.read(components=4, dtype="f4"), dtype=np.float32)
        return image.reshape(camera.height, camera.width, 4).copy()
    finally:
        bind_default_framebuffer(ctx)
        for obj in (scope, vao, vbo, program, fbo, depth, color):
            obj.release()


def pixel_centre_points(camera: PPC, rng: np.random.Generator, count: int) -> tuple[np.ndarray, np.ndarray]:
    """`count` distinct pixels, each with a point at its centre at a random depth well inside
    [near, far]; returns (pixel (i, j) per point, float32-exact world positions)."""
    flat = rng.choice(camera.width * camera.height, size=count, replace=False)
    i, j = flat % camera.width, flat // camera.width
    # Clear of the near and far planes by 5% of the range in 1/w, where GL depth is linear.
    d = rng.uniform(0.05, 0.95, count)
    w = camera.w_from_opengl_depth(d)
    positions = camera.unproject(i + 0.5, j + 0.5, w).astype(np.float32)
    return np.stack([i, j], axis=1), positions.astype(np.float64)


GL_CAMERAS = {"look_at": lambda: make_camera(LOOK_AT_CASES["wide"], near=0.5, far=50.0), "fitted": fitted_camera}


@pytest.mark.parametrize("make", GL_CAMERAS.values(), ids=GL_CAMERAS.keys())
def test_gl_points_land_where_project_says(ctx: moderngl.Context, make) -> None:
    camera = make()
    rng = np.random.default_rng(21)
    pixels, positions = pixel_centre_points(camera, rng, 300)
    # Expectations from the float32 positions actually drawn.
    u, v, w = camera.project(positions).T
    np.testing.assert_array_equal(np.floor(u).astype(int), pixels[:, 0])
    np.testing.assert_array_equal(np.floor(v).astype(int), pixels[:, 1])

    image = rasterize_points(ctx, camera, positions)
    assert_finite(image)

    ids = image[..., 0]
    assert (ids >= 0).sum() == len(positions), "every point covers exactly one pixel"
    landed = ids[pixels[:, 1], pixels[:, 0]]
    np.testing.assert_array_equal(landed, np.arange(len(positions), dtype=np.float32))
    window_depth = image[pixels[:, 1], pixels[:, 0], 1].astype(np.float64)
    np.testing.assert_allclose(window_depth, camera.opengl_depth(w), rtol=0, atol=1e-5)


def test_the_bound_holds_the_grown_frustum_and_is_entered_first() -> None:
    """PPC.bound, the sphere the mirror shader orders and skips a mirror's images by: the grown
    frustum's corners lie inside it, and a ray that enters the grown frustum enters the sphere no
    later (the shader's early stop rests on this)."""
    camera = fitted_camera()
    centre, radius = camera.bound()
    grow = CLIP_TOLERANCE_PIXELS / max(camera.width, camera.height)
    for u in (-CLIP_TOLERANCE_PIXELS, camera.width + CLIP_TOLERANCE_PIXELS):
        for v in (-CLIP_TOLERANCE_PIXELS, camera.height + CLIP_TOLERANCE_PIXELS):
            for w in (camera.w_near * (1.0 - grow), camera.w_far * (1.0 + grow)):
                assert np.linalg.norm(camera.unproject(u, v, w) - centre) < radius
    rng = np.random.default_rng(11)
    origins = centre + rng.normal(size=(4000, 3)) * 3.0 * radius
    # Aimed at points about the bound's middle: many of them cross the frustum, some near its edges.
    directions = centre + rng.normal(size=(4000, 3)) * 0.5 * radius - origins
    inside, t_enter, _ = camera.clip_ray_grown(origins, directions, CLIP_TOLERANCE_PIXELS)
    assert inside.sum() > 1000  # enough rays meet the frustum for the test to mean something
    a = np.einsum("ij,ij->i", directions, directions)
    closest = -np.einsum("ij,ij->i", origins - centre, directions) / a
    offset = origins - centre + directions * closest[:, None]
    half_chord_squared = (radius**2 - np.einsum("ij,ij->i", offset, offset)) / a
    assert np.all(half_chord_squared[inside] > 0.0)
    entry = np.maximum(closest - np.sqrt(np.maximum(half_chord_squared, 0.0)), 0.0)
    assert np.all(entry[inside] < t_enter[inside] + 1e-12)
