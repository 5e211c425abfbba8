"""The planar pinhole camera (PPC) of a depth image, in the lecture's notation.

    C  the eye;
    a  the vector along an image row, one pixel long;
    b  the vector along an image column (downwards), one pixel long;
    c  the vector from the eye to the top-left corner of the image.

A pixel (u, v) is the point P = C + a*u + b*v + c; pixel (i, j) covers [i, i+1] x [j, j+1] and its
centre is (i + 0.5, j + 0.5). The surface point sampled there is Q = C + (a*u + b*v + c) * w, so
projecting a point Q is solving [a b c] (u w, v w, w)^T = Q - C, and w is the point's depth in
units of the image plane's distance (w = 1 on the image plane).

OpenGL depth (the [0, 1] window depth of a standard perspective projection) is, in terms of w,
d(w) = (1/w_near - 1/w) / (1/w_near - 1/w_far): affine in 1/w and therefore affine in screen
space along the projection of any 3-D segment, which is what makes the optimized intersection
(2-D segments in (screen parameter, d)) exact.

The GL matrices rasterize exactly what `project` predicts: window x = u, window y = v (so image
row 0, the top row, is GL framebuffer row 0, and `fbo.read()` returns rows top to bottom), and
window depth = d(w).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .constants import (
    BOUND_MARGIN,
    CLIP_TOLERANCE_PIXELS,
    CONTACT_DEPTH_TOLERANCE,
    DEPTH_IMAGE_DTYPE,
    MAX_SURFACE_SLOPE,
    Algorithm,
    image_algorithm,
)

Array = NDArray[np.float64]


class FrustumFitError(ValueError):
    """No pinhole frustum from this eye can contain these points (they surround or touch the eye)."""


def _unit(vector: Array) -> Array:
    return vector / np.linalg.norm(vector)


def orthonormal_frame(forward: Array, up_hint: Array) -> tuple[Array, Array, Array]:
    """(right, down, forward) with `down` as close to -up_hint as forward allows."""
    forward = _unit(forward)
    if abs(float(np.dot(_unit(up_hint), forward))) > 0.999:
        # Looking straight up or down: any perpendicular will do, pick one that is stable.
        up_hint = np.array([0.0, 0.0, -1.0]) if abs(forward[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    right = _unit(np.cross(forward, up_hint))
    down = np.cross(forward, right)
    return right, down, forward


def orthonormal_frames(forward: Array, up_hint: Array) -> tuple[Array, Array, Array]:
    """orthonormal_frame of each row of `forward` ((n, 3)) with `up_hint` ((3,) or (n, 3)): (n, 3)
    rights, downs and forwards, by its steps."""
    forward = _unit_rows(forward)
    up = np.array(np.broadcast_to(up_hint, forward.shape), dtype=np.float64)
    steep = np.abs(np.add.reduce(_unit_rows(up) * forward, axis=1)) > 0.999
    up[steep] = np.where((np.abs(forward[steep, 2]) < 0.9)[:, None], (0.0, 0.0, -1.0), (1.0, 0.0, 0.0))
    right = _unit_rows(np.cross(forward, up))
    return right, np.cross(forward, right), forward


@dataclass(frozen=True, eq=False)
class FrustumFit:
    """The tightest frustum from `eye` around some points, before a resolution is chosen: its
    frame, the extent of the points' tangents along `right` and `down`, and their depths along
    `forward` (PPC.fitted; fit_frusta finds many at once). `camera` makes the PPC of any size."""

    eye: Array
    right: Array
    down: Array
    forward: Array
    tan_x: tuple[float, float]  # (least, greatest)
    tan_y: tuple[float, float]
    depth: tuple[float, float]  # (nearest, farthest) along forward

    def camera(self, width: int, height: int) -> PPC:
        """The PPC of this frustum at `width` x `height` (fitted_cameras, of one)."""
        return fitted_cameras([self], width, height)[0]


def fitted_cameras(fits: Sequence[FrustumFit], width: int, height: int) -> list[PPC]:
    """The PPC of each of `fits` at `width` x `height` (FrustumFit.camera), all at once: numpy's
    float64 arithmetic, element by element, rounds as Python's floats do, so each camera is the
    one alone (a thousand objects' two thousand one by one took 30 ms of a start)."""
    if not fits:
        return []
    # (x0, x1, y0, y1, nearest, farthest) of each fit, and its frame's vectors.
    bounds = np.array([(*fit.tan_x, *fit.tan_y, *fit.depth) for fit in fits], np.float64)
    right, down, forward = (np.array([getattr(fit, name) for fit in fits], np.float64) for name in ("right", "down", "forward"))
    # One pixel of margin on each side so that silhouette samples are rasterized in full.
    span_x = np.maximum(bounds[:, 1] - bounds[:, 0], 1e-9) * (1.0 + 2.0 / width)
    span_y = np.maximum(bounds[:, 3] - bounds[:, 2], 1e-9) * (1.0 + 2.0 / height)
    x0 = bounds[:, 0] - span_x / width
    y0 = bounds[:, 2] - span_y / height
    a = right * (span_x / width)[:, None]
    b = down * (span_y / height)[:, None]
    c = forward + right * x0[:, None] + down * y0[:, None]
    # The near/far margins keep the closest and farthest vertices off the clip planes.
    near, far = (bounds[:, 4] * 0.995).tolist(), (bounds[:, 5] * 1.005).tolist()
    return [PPC(fit.eye, a[i], b[i], c[i], int(width), int(height), near[i], far[i]) for i, fit in enumerate(fits)]


#: The points fit_frusta works through at once: its arrays (a few hundred kB) stay in cache and are
#: reused from one batch of sets to the next (a thousand objects' 4.5 million vertices in arrays
#: made anew for each set of 260,000 spent most of their 0.3 s faulting fresh pages in).
FIT_CHUNK_POINTS = 2**16


def fit_frusta(eye: ArrayLike, points: NDArray[np.floating], centres: ArrayLike) -> list[FrustumFit | None]:
    """The FrustumFit from `eye` around each of n point sets ((n, V, 3): sets of one size, as the
    objects of one mesh), looking at its centre ((n, 3)); None for a set at or behind the eye's
    plane (it surrounds or touches the eye: no pinhole frustum contains it). The same arithmetic
    as one set alone, to the bit: numpy's stacked matmul makes each set's BLAS call as one set's
    `@` does, and the largest of the norms is the root of the largest square (the rounded
    square root is monotonic)."""
    eye_point = np.asarray(eye, dtype=np.float64)
    frames = orthonormal_frames(np.asarray(centres, dtype=np.float64).reshape(-1, 3) - eye_point, np.array([0.0, 1.0, 0.0]))
    # (z_min, z_max, tan_x least, greatest, tan_y least, greatest) of each set.
    extremes = _frustum_extremes(eye_point, points, frames)
    z_min, z_max = extremes[:, 0], extremes[:, 1]
    # Below this the tangent bounds explode (the object wraps around the eye): no image
    # plane can hold the projection, so refuse instead of producing a degenerate camera. The
    # extent (the farthest point's distance) is measured only where the test is close: in front
    # of the eye a point's distance is z sqrt(1 + tan_x^2 + tan_y^2), at most the bound below.
    with np.errstate(invalid="ignore", over="ignore"):  # (NaN where a point is at the eye's plane: not clear)
        steepest = np.abs(extremes[:, 2:4]).max(axis=1) ** 2 + np.abs(extremes[:, 4:6]).max(axis=1) ** 2
        clear = (z_min > 0.0) & (z_min > 2e-3 * z_max * np.sqrt(1.0 + steepest))
    refused = np.zeros(len(extremes), bool)
    close = np.flatnonzero(~clear)
    if len(close):
        pts = np.asarray(points, dtype=np.float64)[close] - eye_point
        extent = np.sqrt(np.add.reduce(pts * pts, axis=2).max(axis=1))
        refused[close] = (extent == 0.0) | (z_min[close] <= 1e-3 * extent)
    rows = extremes.tolist()
    return [None if refused[i] else FrustumFit(eye_point, frames[0][i], frames[1][i], frames[2][i], (row[2], row[3]),
                                               (row[4], row[5]), (row[0], row[1]))
            for i, row in enumerate(rows)]


def _frustum_extremes(eye: Array, points: NDArray[np.floating], frames: tuple[Array, Array, Array]) -> Array:
    """fit_frusta's bounds of each set ((n, 6): z's least and greatest along `forward`, then
    tan_x's and tan_y's), FIT_CHUNK_POINTS points at a time in arrays made once."""
    count, size = points.shape[:2]
    step = max(1, FIT_CHUNK_POINTS // max(size, 1))
    right, down, forward = (frame[:, :, None] for frame in frames)
    eyes = np.tile(eye, size)  # the eye beside each point of a set: the subtraction runs along whole rows
    shifted = np.empty((min(step, count), size, 3))
    z_buffer, tan_buffer = np.empty((2, min(step, count), size, 1))
    extremes = np.empty((count, 6))
    for first in range(0, count, step):
        sets = slice(first, min(first + step, count))
        n = sets.stop - first
        pts = shifted[:n]
        np.subtract(points[sets].reshape(n, size * 3), eyes, out=pts.reshape(n, size * 3), dtype=np.float64)
        z = np.matmul(pts, forward[sets], out=z_buffer[:n])[..., 0]
        extremes[sets, 0], extremes[sets, 1] = z.min(axis=1), z.max(axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):  # the refused sets' tangents are not used
            for column, axis in ((2, right), (4, down)):
                tan = np.matmul(pts, axis[sets], out=tan_buffer[:n])[..., 0]
                tan /= z
                extremes[sets, column], extremes[sets, column + 1] = tan.min(axis=1), tan.max(axis=1)
    return extremes


@dataclass(frozen=True, eq=False)
class PPC:
    C: Array
    a: Array
    b: Array
    c: Array
    width: int
    height: int
    near: float  # distance of the near plane from C along the optical axis, > 0
    far: float

    # ----------------------------------------------------------------- construction
    @classmethod
    def look_at(
        cls,
        eye: ArrayLike,
        target: ArrayLike,
        up: ArrayLike,
        fov: float,
        width: int,
        height: int,
        near: float = 0.05,
        far: float = 200.0,
    ) -> PPC:
        """A camera at `eye` looking at `target`; `fov` is the vertical field of view in degrees."""
        eye_point = np.asarray(eye, dtype=np.float64)
        right, down, forward = orthonormal_frame(np.asarray(target, float) - eye_point, np.asarray(up, float))
        pixel = 2.0 * np.tan(np.radians(fov) / 2.0) / height  # image plane at distance 1
        a = right * pixel
        b = down * pixel
        c = forward - a * (width / 2.0) - b * (height / 2.0)
        return cls(eye_point, a, b, c, int(width), int(height), float(near), float(far))

    @classmethod
    def fitted(cls, eye: ArrayLike, points: ArrayLike, center: ArrayLike, width: int, height: int) -> PPC:
        """The tightest frustum from `eye`, looking at `center`, that contains every point.

        Tight bounds spend every pixel on the object and keep the near/far ratio small, which is
        what keeps a 32-bit float OpenGL depth precise. Raises FrustumFitError when a point lies
        at or behind the eye's plane (the object surrounds or touches the eye).
        """
        fit = fit_frusta(eye, np.asarray(points, dtype=np.float64).reshape(1, -1, 3), np.asarray(center, float)[None])[0]
        if fit is None:
            raise FrustumFitError("the points surround or touch the eye; no pinhole frustum contains them")
        return fit.camera(width, height)

    # ----------------------------------------------------------------- derived quantities
    @cached_property
    def matrix(self) -> Array:
        """[a b c] as columns: maps (u w, v w, w) to Q - C."""
        return np.column_stack([self.a, self.b, self.c])

    @cached_property
    def inverse(self) -> Array:
        return np.asarray(np.linalg.inv(self.matrix), dtype=np.float64)

    @cached_property
    def forward(self) -> Array:
        """Unit optical axis (a x b points away from the eye, since a goes right and b down)."""
        return _unit(np.cross(self.a, self.b))

    @cached_property
    def focal(self) -> float:
        """Distance from the eye to the image plane along the optical axis."""
        return float(np.dot(self.c, self.forward))

    @cached_property
    def max_relative_depth_step(self) -> float:
        """The largest |w1 - w0| / min(w0, w1) between samples one texel apart that still belong to
        one surface: a surface at angle theta to the line of sight changes w by about
        tan(theta) * (pixel size / focal) per pixel, and MAX_SURFACE_SLOPE bounds tan(theta)."""
        pixel_angle = max(float(np.linalg.norm(self.a)), float(np.linalg.norm(self.b))) / self.focal
        return MAX_SURFACE_SLOPE * pixel_angle

    @property
    def w_near(self) -> float:
        return self.near / self.focal

    @property
    def w_far(self) -> float:
        return self.far / self.focal

    # ----------------------------------------------------------------- projection
    def camera_coordinates(self, points: ArrayLike) -> Array:
        """(u w, v w, w) of world points, shape (..., 3)."""
        return (np.asarray(points, dtype=np.float64) - self.C) @ self.inverse.T

    def project(self, points: ArrayLike) -> Array:
        """(u, v, w) of world points; u and v in pixels, w the depth (1 on the image plane)."""
        xyz = self.camera_coordinates(points)
        w = xyz[..., 2]
        return np.stack([xyz[..., 0] / w, xyz[..., 1] / w, w], axis=-1)

    def unproject(self, u: ArrayLike, v: ArrayLike, w: ArrayLike) -> Array:
        """Q = C + (a u + b v + c) w."""
        u, v, w = (np.asarray(x, dtype=np.float64) for x in (u, v, w))
        return self.C + (u[..., None] * self.a + v[..., None] * self.b + self.c) * w[..., None]

    def ray_direction(self, u: ArrayLike, v: ArrayLike) -> Array:
        """a u + b v + c: the (unnormalized) direction of the ray through image point (u, v)."""
        u, v = np.asarray(u, dtype=np.float64), np.asarray(v, dtype=np.float64)
        return u[..., None] * self.a + v[..., None] * self.b + self.c

    def opengl_depth(self, w: ArrayLike) -> Array:
        """OpenGL window depth in [0, 1] of a point at depth w (0 on the near plane, 1 on the far)."""
        w = np.asarray(w, dtype=np.float64)
        return self.w_far * (w - self.w_near) / (w * (self.w_far - self.w_near))

    def inverse_w_from_opengl_depth(self, depth: ArrayLike) -> Array:
        """1/w of an OpenGL depth: affine in it, 1/w_near - d (1/w_near - 1/w_far)."""
        d = np.asarray(depth, dtype=np.float64)
        return 1.0 / self.w_near - d * (1.0 / self.w_near - 1.0 / self.w_far)

    def w_from_opengl_depth(self, depth: ArrayLike) -> Array:
        return 1.0 / self.inverse_w_from_opengl_depth(depth)

    # ----------------------------------------------------------------- frustum clipping
    def clip_ray(self, origins: ArrayLike, directions: ArrayLike) -> tuple[NDArray[np.bool_], Array, Array]:
        """Clip rays origin + t * direction, t >= 0, to the frustum (near and far planes included).

        Works in camera coordinates (x, y, w) = [a b c]^-1 (Q - C), where the frustum is the
        intersection of six half-spaces linear in (x, y, w): w >= w_near, w <= w_far, x >= 0,
        x <= width * w, y >= 0, y <= height * w. Clipping each is a Liang-Barsky step that never
        divides by w, so rays that start behind the eye or cross its plane are handled before any
        perspective divide. Returns (inside, t_enter, t_exit).
        """
        return self.clip_ray_grown(origins, directions, 0.0)

    def clip_ray_grown(
        self, origins: ArrayLike, directions: ArrayLike, pixels: float
    ) -> tuple[NDArray[np.bool_], Array, Array]:
        """clip_ray against the frustum grown by `pixels` on every side (and by the same share of
        w_near and w_far at its ends)."""
        p0 = self.camera_coordinates(origins)
        dp = np.asarray(directions, dtype=np.float64) @ self.inverse.T
        return self._clip(p0, dp, self._half_spaces(p0, dp, pixels))

    @staticmethod
    def _clip(p0: Array, dp: Array, half_spaces: list[tuple[Array, Array]]) -> tuple[NDArray[np.bool_], Array, Array]:
        t_enter = np.zeros(p0.shape[:-1])
        t_exit = np.full(p0.shape[:-1], np.inf)
        # A zero direction is no ray (and inf * 0 below would be NaN).
        inside = np.any(dp != 0.0, axis=-1)
        for value, rate in half_spaces:
            parallel = rate == 0.0
            inside &= ~(parallel & (value < 0.0))
            with np.errstate(divide="ignore", invalid="ignore"):
                t = -value / rate
            t_enter = np.where(~parallel & (rate > 0.0), np.maximum(t_enter, t), t_enter)
            t_exit = np.where(~parallel & (rate < 0.0), np.minimum(t_exit, t), t_exit)
        inside &= t_enter <= t_exit
        return inside, t_enter, t_exit

    def _half_spaces(self, p0: Array, dp: Array, pixels: float = 0.0) -> list[tuple[Array, Array]]:
        """Each half-space of the frustum grown by `pixels` as f(t) = value + rate * t >= 0 along
        the ray: u >= -pixels is x + pixels * w >= 0, and likewise for the other sides; the near
        and far planes move out by the same share of the image's size."""
        x, y, w = p0[..., 0], p0[..., 1], p0[..., 2]
        dx, dy, dw = dp[..., 0], dp[..., 1], dp[..., 2]
        grow = pixels / max(self.width, self.height)
        return [
            (w - self.w_near * (1.0 - grow), dw),
            (self.w_far * (1.0 + grow) - w, -dw),
            (x + pixels * w, dx + pixels * dw),
            ((self.width + pixels) * w - x, (self.width + pixels) * dw - dx),
            (y + pixels * w, dy + pixels * dw),
            ((self.height + pixels) * w - y, (self.height + pixels) * dw - dy),
        ]

    # ----------------------------------------------------------------- OpenGL
    @cached_property
    def view_matrix(self) -> Array:
        """World -> eye space (rigid; GL convention: x right, y up, looking down -z)."""
        right, down, forward = orthonormal_frame(self.forward, -self.b)
        rotation = np.stack([right, -down, -forward])
        view = np.eye(4)
        view[:3, :3] = rotation
        view[:3, 3] = -rotation @ self.C
        return view

    @cached_property
    def projection_matrix(self) -> Array:
        """Eye space -> clip space, such that NDC x = 2u/width - 1, y = 2v/height - 1, z = 2d - 1."""
        # Camera coordinates (x, y, w) from eye-space coordinates: [a b c]^-1 R^T.
        to_camera = self.inverse @ self.view_matrix[:3, :3].T
        wn, wf = self.w_near, self.w_far
        depth_scale = (wf + wn) / (wf - wn)
        depth_offset = -2.0 * wn * wf / (wf - wn)
        x_row, y_row, w_row = to_camera
        projection = np.zeros((4, 4))
        projection[0, :3] = 2.0 * x_row / self.width - w_row
        projection[1, :3] = 2.0 * y_row / self.height - w_row
        projection[2, :3] = depth_scale * w_row
        projection[2, 3] = depth_offset
        projection[3, :3] = w_row
        return projection

    @property
    def view_projection(self) -> Array:
        return self.projection_matrix @ self.view_matrix

    def gl_bytes(self, matrix: Array) -> bytes:
        """A matrix as GL wants it: float32, column-major."""
        return np.ascontiguousarray(matrix.T, dtype=np.float32).tobytes()

    def bound(self, pixels: float = CLIP_TOLERANCE_PIXELS) -> tuple[Array, float]:
        """(centre, radius) of a sphere around the frustum grown by `pixels` as clip_ray_grown
        grows it: every point a ray clipped to it can hit lies inside. The radius has a margin of
        BOUND_MARGIN for the rounding of float32 clipping in the shaders."""
        cached: dict[float, tuple[Array, float]] = self.__dict__.setdefault("_bounds", {})
        if pixels not in cached:  # a camera never changes: every record of its image asks again
            grow = pixels / max(self.width, self.height)
            # The eight corners at once (u slowest, w fastest), each as unproject makes it.
            u, v, w = (np.array(axis).reshape(-1) for axis in np.meshgrid(
                (-pixels, self.width + pixels), (-pixels, self.height + pixels),
                (self.w_near * (1.0 - grow), self.w_far * (1.0 + grow)), indexing="ij"))
            corners = self.unproject(u, v, w)
            centre = corners.mean(axis=0)
            radius = float(np.max(np.linalg.norm(corners - centre, axis=1)))
            cached[pixels] = (centre, radius * (1.0 + BOUND_MARGIN))
        centre, radius = cached[pixels]
        return centre.copy(), radius

    def hit_bound(self, around: tuple[Array, float] | None, pixels: float = CLIP_TOLERANCE_PIXELS) -> tuple[Array, float]:
        """(centre, radius) of a sphere around every hit a march of this image can give, when the
        image shows what lies in the sphere `around` (its object's bounding sphere): that sphere
        grown by a texel's width at the far plane (a hit lies on the segment between two samples,
        each read at its position on the ray, up to half a texel from the texel centre where the
        surface was rasterized) and by CONTACT_DEPTH_TOLERANCE along a pixel's ray at the far plane
        (a hit's depth is the surface's within it), with BOUND_MARGIN. The frustum's bound where
        that is smaller, or where the image shows no one object (`around` None)."""
        frustum = self.bound(pixels)
        if around is None:
            return frustum
        grow = pixels / max(self.width, self.height)
        w_far = self.w_far * (1.0 + grow)
        texel = (float(np.linalg.norm(self.a)) + float(np.linalg.norm(self.b))) * w_far
        corner_rays = self.ray_direction(np.array([0.0, 0.0, self.width, self.width]),
                                         np.array([0.0, self.height, 0.0, self.height]))
        longest_ray = max(float(np.linalg.norm(ray)) for ray in corner_rays)
        depth = CONTACT_DEPTH_TOLERANCE * w_far * w_far * (1.0 / self.w_near - 1.0 / self.w_far) * longest_ray
        radius = (around[1] + texel + depth) * (1.0 + BOUND_MARGIN)
        return (np.asarray(around[0], dtype=np.float64), radius) if radius < frustum[1] else frustum

    def depth_image_record(
        self, object_id: int, tile_origin: tuple[int, int], pyramid: tuple[int, int, int] = (0, 0, 0),
        around: tuple[Array, float] | None = None
    ) -> NDArray[np.void]:
        """This camera packed as one `DepthImage` std140 record, a 0-d structured array (see
        constants.DEPTH_IMAGE_FIELDS); `pyramid` is (x, y, coarse levels) of its depth pyramid, where it has one."""
        return depth_image_records([self], [object_id], [tile_origin], [pyramid], [around])[0].copy()


def view_projections(cameras: Sequence[PPC]) -> Array:
    """PPC.view_projection of each camera, (n, 4, 4): view_matrix and projection_matrix worked out
    for all at once by the same steps (a thousand objects' depth images spent 0.6 s a bake in
    them one by one)."""
    a, b, c, eye = (np.array([getattr(camera, name) for camera in cameras], np.float64).reshape(-1, 3)
                    for name in "abcC")  # (np.array of a list of vectors: three times quicker than np.stack)
    n = len(a)
    width, height, near, far = (np.array([getattr(camera, name) for camera in cameras], np.float64)
                                for name in ("width", "height", "near", "far"))
    inverse = np.linalg.inv(np.stack([a, b, c], axis=2))
    forward = _unit_rows(np.cross(a, b))  # PPC.forward
    focal = np.add.reduce(c * forward, axis=1)
    right, down, forward = orthonormal_frames(forward, -b)  # view_matrix's
    rotation = np.stack([right, -down, -forward], axis=1)
    view = np.tile(np.eye(4), (n, 1, 1))
    view[:, :3, :3] = rotation
    view[:, :3, 3] = np.matmul(-rotation, eye[:, :, None])[..., 0]
    # projection_matrix.
    to_camera = np.matmul(inverse, rotation.transpose(0, 2, 1))
    wn, wf = near / focal, far / focal
    depth_scale = (wf + wn) / (wf - wn)
    depth_offset = -2.0 * wn * wf / (wf - wn)
    x_row, y_row, w_row = to_camera[:, 0], to_camera[:, 1], to_camera[:, 2]
    projection = np.zeros((n, 4, 4))
    projection[:, 0, :3] = 2.0 * x_row / width[:, None] - w_row
    projection[:, 1, :3] = 2.0 * y_row / height[:, None] - w_row
    projection[:, 2, :3] = depth_scale[:, None] * w_row
    projection[:, 2, 3] = depth_offset
    projection[:, 3, :3] = w_row
    return np.matmul(projection, view)


def _unit_rows(vectors: Array) -> Array:
    """(n, 3) vectors scaled to unit length."""
    return vectors / _norms(vectors)[:, None]


def _norms(vectors: Array) -> Array:
    """The lengths of (..., 3) vectors."""
    return np.sqrt(np.add.reduce(vectors * vectors, axis=-1))


def depth_image_records(cameras: Sequence[PPC], object_ids: Sequence[int], tile_origins: Sequence[tuple[int, int]],
                        pyramids: Sequence[tuple[int, int, int]], arounds: Sequence[tuple[Array, float] | None]
                        ) -> NDArray[np.void]:
    """PPC.depth_image_record of each camera, in one (n,) array: the same quantities (focal, w_near,
    max_relative_depth_step, bound, hit_bound) worked out for all cameras at once, each as the
    property of its name does, in float64 (a vector's length summed as norm(axis=-1) sums it, so
    it may differ from the property's in the last bit of a float64, far below the float32 record)."""
    n = len(cameras)
    records = np.zeros(n, dtype=DEPTH_IMAGE_DTYPE)
    if n == 0:
        return records
    eye, a, b, c = (np.array([getattr(camera, name) for camera in cameras], np.float64) for name in "Cabc")
    width = np.array([camera.width for camera in cameras], np.float64)
    height = np.array([camera.height for camera in cameras], np.float64)
    near = np.array([camera.near for camera in cameras], np.float64)
    far = np.array([camera.far for camera in cameras], np.float64)
    inverse = np.linalg.inv(np.stack([a, b, c], axis=2))
    normal = np.cross(a, b)
    forward = normal / _norms(normal)[:, None]
    focal = np.add.reduce(c * forward, axis=1)
    w_near, w_far = near / focal, far / focal
    length_a, length_b = _norms(a), _norms(b)
    records["eye"] = np.column_stack([eye, np.asarray(object_ids, np.float64)])
    for name, vector in (("a", a), ("b", b), ("c", c)):
        records[name][:, :3] = vector
    for row in range(3):
        records[f"inverse_row{row}"][:, :3] = inverse[:, row]
    records["depth_range"] = np.column_stack([w_near, w_far, width, height])
    records["tile"] = np.column_stack([np.asarray(tile_origins, np.int64).reshape(n, 2), width, height])
    # (max relative depth step, 1/w_near, 1/w_near - 1/w_far): 1/w = y - OpenGL depth * z.
    inverse_near, inverse_far = 1.0 / w_near, 1.0 / w_far
    step = MAX_SURFACE_SLOPE * (np.maximum(length_a, length_b) / focal)
    records["surface"] = np.column_stack([step, inverse_near, inverse_near - inverse_far, np.zeros(n)])
    # w: `--algorithm auto` traverses this image hierarchically (constants.image_algorithm).
    sizes = {(camera.width, camera.height) for camera in cameras}  # (a plan's images share a few sizes)
    traversal = {size: int(image_algorithm(Algorithm.AUTO, *size) == Algorithm.HIERARCHICAL) for size in sizes}
    hierarchical = [traversal[camera.width, camera.height] for camera in cameras]
    records["pyramid"] = np.column_stack([np.asarray(pyramids, np.int64).reshape(n, 3), hierarchical])
    bound_centre, bound_radius = _frustum_bounds(eye, a, b, c, width, height, w_near, w_far)
    bound = np.column_stack([bound_centre, bound_radius])
    records["bound"] = bound
    records["hit_bound"] = bound
    objects = {i: around for i, around in enumerate(arounds) if around is not None}
    if objects:
        shown = list(objects)
        records["hit_bound"][shown] = _hit_bounds(
            a[shown], b[shown], c[shown], width[shown], height[shown], w_near[shown], w_far[shown],
            length_a[shown] + length_b[shown], bound[shown], list(objects.values()))
    return records


def _frustum_bounds(eye: Array, a: Array, b: Array, c: Array, width: Array, height: Array, w_near: Array,
                    w_far: Array, pixels: float = CLIP_TOLERANCE_PIXELS) -> tuple[Array, Array]:
    """PPC.bound of n cameras: ((n, 3) centres, (n,) radii)."""
    grow = pixels / np.maximum(width, height)
    # The eight corners (u slowest, w fastest), each as unproject makes it.
    u = np.stack([np.full_like(width, -pixels), width + pixels], axis=1)[:, [0, 0, 0, 0, 1, 1, 1, 1]]
    v = np.stack([np.full_like(height, -pixels), height + pixels], axis=1)[:, [0, 0, 1, 1, 0, 0, 1, 1]]
    w = np.stack([w_near * (1.0 - grow), w_far * (1.0 + grow)], axis=1)[:, [0, 1, 0, 1, 0, 1, 0, 1]]
    corners = eye[:, None] + (u[..., None] * a[:, None] + v[..., None] * b[:, None] + c[:, None]) * w[..., None]
    centre = corners.mean(axis=1)
    radius = _norms(corners - centre[:, None]).max(axis=1)
    return centre, radius * (1.0 + BOUND_MARGIN)


def _hit_bounds(a: Array, b: Array, c: Array, width: Array, height: Array, w_near: Array, w_far: Array,
                texel_lengths: Array, frustum: Array, arounds: list[tuple[Array, float]],
                pixels: float = CLIP_TOLERANCE_PIXELS) -> Array:
    """PPC.hit_bound of n cameras whose images show one object each (in `arounds`), given their
    frusta's bounds ((n, 4) spheres, where that is smaller): (n, 4) spheres."""
    grow = pixels / np.maximum(width, height)
    grown_far = w_far * (1.0 + grow)
    texel = texel_lengths * grown_far
    u = np.stack([np.zeros_like(width), np.zeros_like(width), width, width], axis=1)
    v = np.stack([np.zeros_like(height), height, np.zeros_like(height), height], axis=1)
    corner_rays = u[..., None] * a[:, None] + v[..., None] * b[:, None] + c[:, None]
    longest_ray = _norms(corner_rays).max(axis=1)
    depth = CONTACT_DEPTH_TOLERANCE * grown_far * grown_far * (1.0 / w_near - 1.0 / w_far) * longest_ray
    around_centre = np.array([centre for centre, _ in arounds], np.float64)
    radius = (np.array([radius for _, radius in arounds], np.float64) + texel + depth) * (1.0 + BOUND_MARGIN)
    return np.where((radius < frustum[:, 3])[:, None], np.column_stack([around_centre, radius]), frustum)
