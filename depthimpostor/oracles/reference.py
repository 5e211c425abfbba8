"""The numpy reference of the ray / depth-image intersection.

The lecture's two algorithms of shaders/lib/depth_image.glsl, with the same function names,
vectorized over rays and computed in float64, so that the GLSL can be checked against it ray by
ray and a reader can hold the two side by side. A ray is origin + t * direction, t >= 0. The
hierarchical traversal has no reference of its own: it must find the optimized march's hits, so
the optimized march is its reference (its samples per ray differ).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, fields
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from ..constants import (
    BACKGROUND_DEPTH, CLIP_TOLERANCE_PIXELS, CONTACT_DEPTH_TOLERANCE, MIN_LINES_SINE_SQUARED, NO_OBJECT,
    SILHOUETTE_BAND_TEXELS, STEEP_JOIN_SHARE, Algorithm, Unseen,
)
from ..ppc import PPC

Array = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class DepthImageData:
    """A depth image read back from the GPU: its camera, colours and OpenGL depths (row v, column u)."""

    camera: PPC
    color: Array  # (height, width, 3) in [0, 1]
    depth: NDArray[np.float32]  # (height, width), BACKGROUND_DEPTH where nothing was rasterized
    object_id: int
    # The nearest back face behind each sample (BACKGROUND_DEPTH where there is none); None for
    # a surface with nothing behind it (as thin as it looks).
    back_depth: NDArray[np.float32] | None = None
    # The back face's colour (height, width, 3), NaN where none was drawn; None: no back colours
    # (a ray coming in through the back layer is then a hidden entry, as without the layer).
    back_color: Array | None = None
    # Where a second solid run begins behind the first (OpenGL depth; BACKGROUND_DEPTH: none);
    # None: not known, and everything behind the first run is unseen.
    beyond_depth: NDArray[np.float32] | None = None

    @property
    def back_layer(self) -> NDArray[np.float32]:
        return self.depth if self.back_depth is None else self.back_depth


@dataclass(frozen=True, eq=False)
class RayHits:
    """Per-ray results, the fields the GPU ray query returns."""

    hit: NDArray[np.bool_]
    t: Array
    image_position: Array  # (n, 2) u, v in the depth image that was hit
    color: Array  # (n, 3)
    object_id: NDArray[np.int64]
    samples: NDArray[np.int64]  # depth-image samples read, summed over images
    # |f0 - f1| of the step that was hit (inf for a miss): how far the ray's depth changes
    # against the surface's over the step. k = f0 / (f0 - f1) loses digits in proportion to
    # 1 / |f0 - f1|, so grazing hits (small values) are where float32 and float64 part ways.
    conditioning: Array
    # How close the march came to a decision boundary, over the steps it visited: the smallest
    # distance of a sample position to a texel edge, of the projected length to an integer, or
    # of the ray to the frustum it missed (pixels: all pick samples), and the smallest distance
    # of |ray depth - surface depth| to the contact tolerance or of a depth step to the largest
    # that joins two samples (OpenGL depth). Where these are tiny, float32 and float64 may decide
    # otherwise, and the GPU and the reference can legitimately disagree.
    texel_margin: Array
    depth_margin: Array
    # The ray parameter from which the answer rests on what the images do not hold, and why (an
    # Unseen kind): inf and Unseen.NONE where it rests on nothing unseen (see "What the image
    # does not hold" in the GLSL).
    unseen_t: Array
    unseen: NDArray[np.int64]

    @classmethod
    def misses(cls, count: int) -> RayHits:
        return cls(
            np.zeros(count, bool), np.zeros(count), np.zeros((count, 2)), np.zeros((count, 3)),
            np.full(count, NO_OBJECT), np.zeros(count, np.int64), np.full(count, np.inf),
            np.full(count, np.inf), np.full(count, np.inf), np.full(count, np.inf),
            np.full(count, int(Unseen.NONE), np.int64),
        )

    def rows(self, keep: NDArray[np.int64]) -> RayHits:
        return RayHits(*(getattr(self, field.name)[keep] for field in fields(self)))

    def put(self, rows: NDArray[np.int64], part: RayHits) -> None:
        for field in fields(self):
            getattr(self, field.name)[rows] = getattr(part, field.name)

    @property
    def certain(self) -> NDArray[np.bool_]:
        """Does the answer rest on nothing unseen before it (a hit's t; a miss: anywhere)?"""
        return (self.unseen == Unseen.NONE) | (self.hit & (self.unseen_t > self.t))


def texel_of(image: DepthImageData, s: Array) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """(row, column) of the sample under image points s (..., 2), clamped to the image."""
    height, width = image.depth.shape
    column = np.clip(np.floor(s[..., 0]), 0, width - 1).astype(np.int64)
    row = np.clip(np.floor(s[..., 1]), 0, height - 1).astype(np.int64)
    return row, column


def sample_layers(image: DepthImageData, s: Array) -> Array:
    """(visible surface, back of its solid run) under s, (..., 2): see the GLSL."""
    row, column = texel_of(image, s)
    front = image.depth[row, column].astype(np.float64)
    back = image.back_layer[row, column].astype(np.float64)
    return np.stack([front, np.where(back >= BACKGROUND_DEPTH, front, np.maximum(front, back))], axis=-1)


def inside_solid(r: Array, layers: Array) -> NDArray[np.bool_]:
    front, back = layers[..., 0], layers[..., 1]
    return (front < BACKGROUND_DEPTH) & (r >= front - CONTACT_DEPTH_TOLERANCE) & (r <= back + CONTACT_DEPTH_TOLERANCE)


def sample_color(image: DepthImageData, s: Array) -> Array:
    row, column = texel_of(image, s)
    return image.color[row, column]


def sample_back_color(image: DepthImageData, s: Array) -> Array:
    """The back layer's colour under s (NaN where none was drawn, or the image keeps none)."""
    if image.back_color is None:
        return np.full(s.shape[:-1] + (3,), np.nan)
    row, column = texel_of(image, s)
    return image.back_color[row, column]


def back_crossing(image: DepthImageData, s0: Array, s1: Array, r0: Array, r1: Array, z0: Array, z1: Array
                  ) -> tuple[NDArray[np.bool_], Array]:
    """Does a step come in through the back layer (see the GLSL), and where along it (k)?"""
    real_back = (z0[:, 1] > z0[:, 0]) & (z1[:, 1] > z1[:, 0])  # sample_layers: back = front where none
    cross, k = segments_cross(z0[:, 1] - r0, z1[:, 1] - r1)
    colored = np.isfinite(sample_back_color(image, nearer_sample(k, s0, s1))).all(axis=-1)
    return real_back & samples_connected(image, s0, s1, z0[:, 1], z1[:, 1]) & cross & colored, k


def nearer_sample(k: Array, s0: Array, s1: Array) -> Array:
    """The sample (of a step's two) nearer the crossing at k, whose texel's colour a hit shows:
    both are surface, while the point between them can lie over a third, background texel."""
    return np.where((k < 0.5)[:, None], s0, s1)


def step_count(image: DepthImageData, sa: Array, sb: Array) -> NDArray[np.int64]:
    height, width = image.depth.shape
    pixels = np.ceil(np.maximum(np.abs(sb[:, 0] - sa[:, 0]), np.abs(sb[:, 1] - sa[:, 1])))
    return np.clip(pixels, 1, max(width, height) + 1).astype(np.int64)


def segments_cross(f0: Array, f1: Array) -> tuple[NDArray[np.bool_], Array]:
    """Does the ray go from in front of the surface to behind it, touching within
    CONTACT_DEPTH_TOLERANCE counting as both? And where along the step (k, clamped to [0, 1])."""
    with np.errstate(divide="ignore", invalid="ignore"):
        k = np.where(f0 == f1, 0.0, np.clip(f0 / (f0 - f1), 0.0, 1.0))
    return (f0 <= CONTACT_DEPTH_TOLERANCE) & (f1 >= -CONTACT_DEPTH_TOLERANCE), k


def allowed_step(image: DepthImageData, s0: Array, s1: Array, z0: Array, z1: Array) -> Array:
    """The largest depth step (OpenGL depth) that joins the two samples."""
    row0, column0 = texel_of(image, s0)
    row1, column1 = texel_of(image, s1)
    texels = np.hypot(row1 - row0, column1 - column0)
    inverse_w0 = image.camera.inverse_w_from_opengl_depth(z0)
    inverse_w1 = image.camera.inverse_w_from_opengl_depth(z1)
    allowed = image.camera.max_relative_depth_step * texels * np.minimum(inverse_w0, inverse_w1)
    return allowed / (1.0 / image.camera.w_near - 1.0 / image.camera.w_far)


def connection_slack(image: DepthImageData, s0: Array, s1: Array, z0: Array, z1: Array) -> Array:
    """How far the depth step between two samples is under the largest one surface may make, in
    OpenGL depth: >= 0 joins them (see samples_connected in the GLSL), < 0 is a discontinuity."""
    step = np.abs(image.camera.inverse_w_from_opengl_depth(z1) - image.camera.inverse_w_from_opengl_depth(z0))
    depth_per_inverse_w = 1.0 / (1.0 / image.camera.w_near - 1.0 / image.camera.w_far)
    return allowed_step(image, s0, s1, z0, z1) - step * depth_per_inverse_w


def samples_connected(image: DepthImageData, s0: Array, s1: Array, z0: Array, z1: Array) -> NDArray[np.bool_]:
    """Are two neighbouring samples one surface (neither background, no depth discontinuity)?"""
    background = (z0 >= BACKGROUND_DEPTH) | (z1 >= BACKGROUND_DEPTH)
    return ~background & (connection_slack(image, s0, s1, z0, z1) >= 0.0)


def behind_solid(r: Array, layers: Array) -> NDArray[np.bool_]:
    """Is the ray, at OpenGL depth r, behind the solid run: in space the object hides?"""
    front, back = layers[..., 0], layers[..., 1]
    return (front < BACKGROUND_DEPTH) & (r > back + CONTACT_DEPTH_TOLERANCE)


def occluded(image: DepthImageData, s: Array, r: Array, layers: Array) -> NDArray[np.bool_]:
    """Is the ray, at OpenGL depth r over image point s, in space the object hides from the eye:
    behind the first solid run, and at or behind where a second one begins (see the GLSL)?"""
    if image.beyond_depth is None:
        return behind_solid(r, layers)
    row, column = texel_of(image, s)
    return behind_solid(r, layers) & (r >= image.beyond_depth[row, column] - CONTACT_DEPTH_TOLERANCE)


def silhouette_clear_depth(image: DepthImageData, z: Array, side: float) -> Array:
    """The OpenGL depth a ray must stay in front of (side 1) or behind (side -1) to be clear of a
    silhouette at a sample of depth z: 1/w larger (smaller) by SILHOUETTE_BAND_TEXELS texels of
    the steepest joined slope."""
    camera = image.camera
    inverse_w = camera.inverse_w_from_opengl_depth(z)
    clear = inverse_w * (1.0 + side * SILHOUETTE_BAND_TEXELS * camera.max_relative_depth_step)
    return (1.0 / camera.w_near - clear) / (1.0 / camera.w_near - 1.0 / camera.w_far)


class TexelBlock(NamedTuple):
    """Over the texels whose centres lie within one texel of an image point in u and in v (the
    2 x 2 block a bilinear lookup reads): the nearest visible surface, the farthest back of a solid
    run (0 where none is covered), and whether the block is one surface (see the GLSL)."""

    nearest: Array
    farthest_back: Array
    one_surface: NDArray[np.bool_]

    def rows(self, keep: NDArray[np.int64]) -> TexelBlock:
        return TexelBlock(self.nearest[keep], self.farthest_back[keep], self.one_surface[keep])


def texel_block(image: DepthImageData, s: Array) -> TexelBlock:
    """The block of image points s (..., 2). A march reads each sample's once, as the GLSL does:
    sample 1's block of one step is sample 0's of the next."""
    corner = np.floor(s[..., :2] - 0.5)
    centres = [corner + [du + 0.5, dv + 0.5] for dv in (0.0, 1.0) for du in (0.0, 1.0)]
    layers = [sample_layers(image, centre) for centre in centres]
    nearest = np.minimum.reduce([z[..., 0] for z in layers])
    farthest_back = np.maximum.reduce([np.where(z[..., 0] < BACKGROUND_DEPTH, z[..., 1], 0.0) for z in layers])
    one_surface = np.logical_and.reduce([z[..., 0] < BACKGROUND_DEPTH for z in layers])
    for a, b in ((0, 1), (2, 3), (0, 2), (1, 3)):
        one_surface &= samples_connected(image, centres[a], centres[b], layers[a][..., 0], layers[b][..., 0])
    return TexelBlock(nearest, farthest_back, one_surface)


def clip_half_space(value: Array, rate: Array, low: Array, high: Array) -> tuple[Array, Array]:
    """One Liang-Barsky step: keep the part of [low, high] where value + rate * k >= 0 (empty: low > high)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = -value / rate
    low = np.where(rate > 0.0, np.maximum(low, bound), low)
    high = np.where(rate < 0.0, np.minimum(high, bound), high)
    return low, np.where((rate == 0.0) & (value < 0.0), -np.inf, high)


def outer_join(image: DepthImageData, texel: Array, outward: Array, z: Array) -> tuple[Array, NDArray[np.bool_]]:
    """The visible surface one step `outward` (texels) beyond a sample at texel centre `texel` of
    depth z, and whether it is joined to it (inside the image and one surface with it)."""
    height, width = image.depth.shape
    beyond = texel + outward
    inside = (beyond[:, 0] >= 0) & (beyond[:, 0] < width) & (beyond[:, 1] >= 0) & (beyond[:, 1] < height)
    z_beyond = sample_layers(image, beyond)[:, 0]
    return z_beyond, inside & np.any(outward != 0.0, axis=1) & samples_connected(image, texel, beyond, z, z_beyond)


def crease_unseen(image: DepthImageData, s0: Array, s1: Array, r0: Array, r1: Array, z0: Array, z1: Array
                  ) -> NDArray[np.bool_]:
    """Does the ray pass between the join of two samples of one surface and the nearest that surface
    can come between them (see the GLSL)?"""
    row0, column0 = texel_of(image, s0)
    row1, column1 = texel_of(image, s1)
    texel0 = np.stack([column0, row0], axis=1).astype(np.float64) + 0.5  # the samples' texel centres
    texel1 = np.stack([column1, row1], axis=1).astype(np.float64) + 0.5
    z_before, left = outer_join(image, texel0, texel0 - texel1, z0)
    z_after, right = outer_join(image, texel1, texel1 - texel0, z1)
    low, high = np.zeros(len(r0)), np.ones(len(r0))
    low, high = clip_half_space(z0 - CONTACT_DEPTH_TOLERANCE - r0, (z1 - z0) - (r1 - r0), low, high)
    clear = silhouette_clear_depth(image, np.minimum(z0, z1), 1.0)
    low, high = clip_half_space(r0 - clear, r1 - r0, low, high)
    left_low, left_high = clip_half_space(r0 - z0, (r1 - r0) - (z0 - z_before), low, high)
    right_low, right_high = clip_half_space(r0 - (2.0 * z1 - z_after), (r1 - r0) - (z_after - z1), low, high)
    beyond_left = left & (left_low <= left_high)
    beyond_right = right & (right_low <= right_high)
    return np.any(texel0 != texel1, axis=1) & (beyond_left | beyond_right)


def step_unseen(image: DepthImageData, s0: Array, s1: Array, r0: Array, r1: Array, z0: Array, z1: Array,
                block0: TexelBlock, block1: TexelBlock) -> Array:
    """What a step that did not hit through the visible surface relies on that the image does
    not hold (an Unseen kind per ray; see the GLSL). `block0`, `block1`: the samples' texel blocks."""
    nearest0, back0, one_surface0 = block0
    nearest1, back1, one_surface1 = block1
    nearer = np.minimum(nearest0, nearest1)
    farther_back = np.maximum(back0, back1)
    one_surface = one_surface0 & one_surface1 & samples_connected(image, s0, s1, z0[:, 0], z1[:, 0])
    in_front = np.maximum(r0, r1) < silhouette_clear_depth(image, nearer, 1.0)
    behind = np.minimum(r0, r1) > silhouette_clear_depth(image, farther_back, -1.0)
    silhouette = (nearer < BACKGROUND_DEPTH) & np.where(
        one_surface, crease_unseen(image, s0, s1, r0, r1, z0[:, 0], z1[:, 0]), ~in_front & ~behind)
    kind = np.where(silhouette, int(Unseen.SILHOUETTE), int(Unseen.NONE))
    kind = np.where(occluded(image, s1, r1, z1), int(Unseen.OCCLUDED), kind)
    return np.where(inside_solid(r1, z1), int(Unseen.HIDDEN_ENTRY), kind)


def hit_unseen(image: DepthImageData, s0: Array, s1: Array, z0: Array, z1: Array, block0: TexelBlock,
               block1: TexelBlock) -> NDArray[np.bool_]:
    """Is a hit through a step between joined samples (depths z0, z1 of the layer crossed) on a
    silhouette's: a join steeper than STEEP_JOIN_SHARE of the steepest, or within a texel of
    where the image is not one surface (the samples' texel blocks; see the GLSL)?"""
    return steep_join(image, s0, s1, z0, z1) | ~block0.one_surface | ~block1.one_surface


def steep_join(image: DepthImageData, s0: Array, s1: Array, z0: Array, z1: Array) -> NDArray[np.bool_]:
    """Is a step between joined samples steeper than STEEP_JOIN_SHARE of the steepest join? Two
    surfaces close in depth (strands of a knot, one behind the other) are joined across the gap
    between them, and a ray through the gap hits the join: such a hit is a silhouette's."""
    return connection_slack(image, s0, s1, z0, z1) < (1.0 - STEEP_JOIN_SHARE) * allowed_step(image, s0, s1, z0, z1)


def note_unseen(result: RayHits, active: NDArray[np.bool_], kind: Array, sigma0: Array, rays: ClippedRays) -> None:
    """Record the step from screen parameter sigma0's kind where nothing unseen came before it."""
    first = active & (kind != Unseen.NONE) & (result.unseen == Unseen.NONE)
    if first.any():
        result.unseen[first] = kind[first]
        t = ray_parameter(np.broadcast_to(sigma0, first.shape), rays.pa[:, 2], rays.pb[:, 2], rays.t_enter, rays.t_exit)
        result.unseen_t[first] = t[first]


def start_unseen(image: DepthImageData, s: Array, r: Array, layers: Array) -> Array:
    """What sample 0 relies on that the image does not hold: the ray enters the frustum inside
    the run or behind it (the object reaches the frustum's side there, edge-on to the eye)."""
    kind = np.where(occluded(image, s, r, layers), int(Unseen.OCCLUDED), int(Unseen.NONE))
    return np.where(inside_solid(r, layers), int(Unseen.HIDDEN_ENTRY), kind)


def ray_parameter(sigma: Array, w_a: Array, w_b: Array, t_enter: Array, t_exit: Array) -> Array:
    """t at screen parameter sigma: 1/w is affine in screen space (see the GLSL)."""
    lam = sigma * w_a / ((1.0 - sigma) * w_b + sigma * w_a)
    return t_enter + lam * (t_exit - t_enter)


@dataclass(frozen=True, eq=False)
class ClippedRays:
    inside: NDArray[np.bool_]
    t_enter: Array
    t_exit: Array
    pa: Array  # camera coordinates (x, y, w) of the clipped ends
    pb: Array
    sa: Array  # (u, v, OpenGL depth) of the clipped ends: a' and b'
    sb: Array

    def rows(self, keep: NDArray[np.int64]) -> ClippedRays:
        return ClippedRays(*(getattr(self, field.name)[keep] for field in fields(self)))


def clip_and_project(image: DepthImageData, origins: Array, directions: Array) -> ClippedRays:
    camera = image.camera
    # Grown as the GLSL grows it: rays along a side are inside whatever the rounding.
    inside, t_enter, t_exit = camera.clip_ray_grown(origins, directions, CLIP_TOLERANCE_PIXELS)
    t_exit = np.where(inside, t_exit, 0.0)
    t_enter = np.where(inside, t_enter, 0.0)
    p0 = camera.camera_coordinates(origins)
    dp = directions @ camera.inverse.T
    # Rays outside the frustum get harmless ends so that nothing below divides by zero.
    pa = np.where(inside[:, None], p0 + dp * t_enter[:, None], [0.0, 0.0, 1.0])
    pb = np.where(inside[:, None], p0 + dp * t_exit[:, None], [0.0, 0.0, 1.0])
    sa = np.stack([pa[:, 0] / pa[:, 2], pa[:, 1] / pa[:, 2], camera.opengl_depth(pa[:, 2])], axis=1)
    sb = np.stack([pb[:, 0] / pb[:, 2], pb[:, 1] / pb[:, 2], camera.opengl_depth(pb[:, 2])], axis=1)
    return ClippedRays(inside, t_enter, t_exit, pa, pb, sa, sb)


#: How far float32 rounding may put a clipped end across the side that sets it, as a share of the
#: image's larger side: the GPU clips in 3-D and divides, some tens of units in the last place of
#: the screen coordinate (a ray along the last column of a 64-texel image, whose end this puts
#: 0.3 px along the segment, moved its float32 hit half a texel: tests/test_fuzz.py).
SIDE_ROUNDING = 2.0**-19


def clipped_end_drift(image: DepthImageData, sa: Array, sb: Array) -> Array:
    """How far (pixels along the segment) float32 rounding may move an end of the clipped segment
    that a side of the frustum sets: a ray running nearly along a side (its projection nearly along
    the image's edge) meets it where a small error across the side moves the end far along the
    ray, and the march's uniform steps with it. 0 where neither end is on a side."""
    height, width = image.depth.shape
    delta = np.abs(sb[:, :2] - sa[:, :2])
    length = np.maximum(delta.max(axis=1), 1e-300)
    drift = np.zeros(len(sa))
    for axis, size in ((0, width), (1, height)):
        rate = delta[:, axis] / length  # the coordinate's change per pixel along the segment
        for end in (sa, sb):
            on_side = np.minimum(np.abs(end[:, axis] + CLIP_TOLERANCE_PIXELS),
                                 np.abs(end[:, axis] - size - CLIP_TOLERANCE_PIXELS)) < 1e-6
            with np.errstate(divide="ignore"):
                moved = np.where(on_side, SIDE_ROUNDING * max(width, height) / rate, 0.0)
            drift = np.maximum(drift, moved)
    return drift


def intersect_optimized(image: DepthImageData, origins: Array, directions: Array) -> RayHits:
    """The lecture's optimized algorithm: 2-D segments in (screen parameter, OpenGL depth)."""
    origins, directions = np.asarray(origins, float), np.asarray(directions, float)
    rays = clip_and_project(image, origins, directions)
    result = RayHits.misses(len(origins))
    steps = np.where(rays.inside, step_count(image, rays.sa, rays.sb), 0)
    result.samples[:] = np.where(rays.inside, steps + 1, 0)
    active = rays.inside.copy()
    # The step count is a decision too: ceil() of a length within rounding of an integer.
    length = np.maximum(np.abs(rays.sb[:, 0] - rays.sa[:, 0]), np.abs(rays.sb[:, 1] - rays.sa[:, 1]))
    result.texel_margin[active] = np.abs(length - np.round(length))[active]
    # A ray that passes within rounding of the frustum may be clipped in by float32.
    near_miss = ~rays.inside & image.camera.clip_ray_grown(origins, directions, 1e-3)[0]
    result.texel_margin[near_miss] = 0.0
    # An end that a side of the frustum sets is a decision too: where float32 may move it along the
    # segment by more than the margins' 1e-3 px, the steps sample other texels.
    result.texel_margin[active & (clipped_end_drift(image, rays.sa, rays.sb) > 1e-3)] = 0.0
    s0 = rays.sa.copy()
    z0 = sample_layers(image, s0[:, :2])
    block0 = texel_block(image, s0[:, :2])
    _track_margins(result, active, s0, z0)
    note_unseen(result, active, start_unseen(image, s0[:, :2], s0[:, 2], z0), np.zeros(len(origins)), rays)
    starts_inside = active & inside_solid(s0[:, 2], z0)
    _record(result, starts_inside, rays.t_enter, s0[:, :2], sample_color(image, s0[:, :2]), image.object_id, 1)
    active &= ~starts_inside
    # Once fewer than half of the rows march on, the others' answers are final and the steps go on
    # over the marching rows alone (`rows`: the caller's ray of each row of `rays`, `steps`, `s0`,
    # `z0` and `marching`, whose answers are put into `result`). Each step is computed ray by ray:
    # the same answers. (Every ray stepped to the batch's longest march took several times as long
    # where most rays end early or miss the frustum: a mirror's rays over each of its images.)
    rows, marching = np.arange(len(origins)), result
    for i in range(int(steps.max(initial=0))):
        active &= i < steps
        if not active.any():
            break
        if 2 * np.count_nonzero(active) < len(active):
            result.put(rows, marching)
            keep = np.flatnonzero(active)
            rows, rays, marching, active = rows[keep], rays.rows(keep), marching.rows(keep), active[keep]
            steps, s0, z0, block0 = steps[keep], s0[keep], z0[keep], block0.rows(keep)
        s1 = rays.sa + (rays.sb - rays.sa) * ((i + 1) / np.maximum(steps, 1))[:, None]
        z1 = sample_layers(image, s1[:, :2])
        block1 = texel_block(image, s1[:, :2])
        _track_margins(marching, active, s1, z1)
        slack = connection_slack(image, s0[:, :2], s1[:, :2], z0[:, 0], z1[:, 0])
        _track_connection(marching, active, slack, z0[:, 0], z1[:, 0])
        cross, k = segments_cross(s0[:, 2] - z0[:, 0], s1[:, 2] - z1[:, 0])
        through_surface = samples_connected(image, s0[:, :2], s1[:, :2], z0[:, 0], z1[:, 0]) & cross
        through_back, k_back = back_crossing(image, s0[:, :2], s1[:, :2], s0[:, 2], s1[:, 2], z0, z1)
        through_back &= ~through_surface
        k = np.where(through_back, k_back, k)
        crossed = np.where(through_back[:, None], z0[:, [1]] * [1, 0] + z1[:, [1]] * [0, 1],
                           z0[:, [0]] * [1, 0] + z1[:, [0]] * [0, 1])
        kind = step_unseen(image, s0[:, :2], s1[:, :2], s0[:, 2], s1[:, 2], z0, z1, block0, block1)
        unseen_hit = hit_unseen(image, s0[:, :2], s1[:, :2], crossed[:, 0], crossed[:, 1], block0, block1)
        kind = np.where(through_surface | through_back, np.where(unseen_hit, int(Unseen.SILHOUETTE), int(Unseen.NONE)), kind)
        note_unseen(marching, active, kind, i / np.maximum(steps, 1), rays)
        through = through_surface | through_back
        k = np.where(through, k, 1.0)
        new_hit = active & (through | inside_solid(s1[:, 2], z1))
        if new_hit.any():
            s = s0[:, :2] + (s1[:, :2] - s0[:, :2]) * k[:, None]
            sigma = (i + k) / np.maximum(steps, 1)
            t = ray_parameter(sigma, rays.pa[:, 2], rays.pb[:, 2], rays.t_enter, rays.t_exit)
            nearer = nearer_sample(k, s0[:, :2], s1[:, :2])
            color = np.where(through_back[:, None], sample_back_color(image, nearer), sample_color(image, nearer))
            _record(marching, new_hit, t, s, color, image.object_id, i + 2)
            surface_hit = new_hit & through_surface
            marching.conditioning[surface_hit] = np.abs((s0[:, 2] - z0[:, 0]) - (s1[:, 2] - z1[:, 0]))[surface_hit]
            active &= ~new_hit
        s0, z0, block0 = s1, z1, block1
    if marching is not result:
        result.put(rows, marching)
    return result


def intersect_basic(image: DepthImageData, origins: Array, directions: Array) -> RayHits:
    """The lecture's basic algorithm: unproject each step and intersect 3-D segments with the ray."""
    origins, directions = np.asarray(origins, float), np.asarray(directions, float)
    camera = image.camera
    rays = clip_and_project(image, origins, directions)
    result = RayHits.misses(len(origins))
    steps = np.where(rays.inside, step_count(image, rays.sa, rays.sb), 0)
    result.samples[:] = np.where(rays.inside, steps + 1, 0)
    ray_a = origins + directions * rays.t_enter[:, None]
    ray_ab = directions * (rays.t_exit - rays.t_enter)[:, None]
    wa = np.where(rays.inside, rays.pa[:, 2], 1.0)
    wb = np.where(rays.inside, rays.pb[:, 2], 1.0)
    active = rays.inside.copy()
    s0 = rays.sa[:, :2].copy()
    z0 = sample_layers(image, s0)
    block0 = texel_block(image, s0)
    note_unseen(result, active, start_unseen(image, s0, rays.sa[:, 2], z0), np.zeros(len(origins)), rays)
    starts_inside = active & inside_solid(rays.sa[:, 2], z0)
    _record(result, starts_inside, rays.t_enter, s0, sample_color(image, s0), image.object_id, 1)
    active &= ~starts_inside
    q0 = camera.unproject(s0[:, 0], s0[:, 1], camera.w_from_opengl_depth(z0[:, 0]))
    # Once fewer than half of the rows march on, over those alone (as in intersect_optimized).
    rows, marching = np.arange(len(origins)), result
    for i in range(int(steps.max(initial=0))):
        active &= i < steps
        if not active.any():
            break
        if 2 * np.count_nonzero(active) < len(active):
            result.put(rows, marching)
            keep = np.flatnonzero(active)
            rows, rays, marching, active = rows[keep], rays.rows(keep), marching.rows(keep), active[keep]
            steps, s0, z0, q0, block0 = steps[keep], s0[keep], z0[keep], q0[keep], block0.rows(keep)
            ray_a, ray_ab, wa, wb = ray_a[keep], ray_ab[keep], wa[keep], wb[keep]
        safe_steps = np.maximum(steps, 1)
        sigma0 = i / safe_steps
        sigma1 = (i + 1) / safe_steps
        s1 = rays.sa[:, :2] + (rays.sb[:, :2] - rays.sa[:, :2]) * sigma1[:, None]
        z1 = sample_layers(image, s1)
        block1 = texel_block(image, s1)
        q1 = camera.unproject(s1[:, 0], s1[:, 1], camera.w_from_opengl_depth(z1[:, 0]))
        d1, d2, r = q1 - q0, ray_ab, q0 - ray_a
        aa, bb, cc = _dot(d1, d1), _dot(d1, d2), _dot(d2, d2)
        dd, ee = _dot(d1, r), _dot(d2, r)
        denominator = aa * cc - bb * bb
        w_ray0 = 1.0 / ((1.0 - sigma0) / wa + sigma0 / wb)
        in_front_at_start = w_ray0 <= camera.w_from_opengl_depth(z0[:, 0])
        with np.errstate(divide="ignore", invalid="ignore"):
            mu = (bb * ee - cc * dd) / denominator
            lam = (aa * ee - bb * dd) / denominator
        connected = active & samples_connected(image, s0, s1, z0[:, 0], z1[:, 0])
        note_unseen(marching, connected & steep_join(image, s0, s1, z0[:, 0], z1[:, 0]), np.full(len(active), int(Unseen.SILHOUETTE)),
                    sigma0, rays)
        row0, column0 = texel_of(image, s0)
        row1, column1 = texel_of(image, s1)
        one_texel = (row0 == row1) & (column0 == column1)
        regular = ~one_texel & (denominator > MIN_LINES_SINE_SQUARED * aa * cc)  # see the GLSL
        surface_hit = (
            connected & regular & in_front_at_start & (mu >= 0) & (mu <= 1) & (lam >= 0) & (lam <= 1)
        )
        if surface_hit.any():
            note_unseen(marching, surface_hit & hit_unseen(image, s0, s1, z0[:, 0], z1[:, 0], block0, block1),
                        np.full(len(active), int(Unseen.SILHOUETTE)), sigma0, rays)
            lam = np.where(surface_hit, lam, 0.0)
            p = ray_a + ray_ab * lam[:, None]
            s = camera.project(np.where(surface_hit[:, None], p, camera.C + camera.c))[:, :2]
            t = rays.t_enter + lam * (rays.t_exit - rays.t_enter)
            color = sample_color(image, nearer_sample(np.where(surface_hit, mu, 0.0), s0, s1))
            _record(marching, surface_hit, t, s, color, image.object_id, i + 2)
            active &= ~surface_hit
        # A point-like or ray-parallel 3-D segment: the 2-D intersection in depth (see the GLSL).
        r0 = rays.sa[:, 2] + (rays.sb[:, 2] - rays.sa[:, 2]) * sigma0
        r1 = rays.sa[:, 2] + (rays.sb[:, 2] - rays.sa[:, 2]) * sigma1
        cross, k = segments_cross(r0 - z0[:, 0], r1 - z1[:, 0])
        degenerate_hit = active & connected & ~regular & cross
        if degenerate_hit.any():
            note_unseen(marching, degenerate_hit & hit_unseen(image, s0, s1, z0[:, 0], z1[:, 0], block0, block1),
                        np.full(len(active), int(Unseen.SILHOUETTE)), sigma0, rays)
            t = ray_parameter(sigma0 + (sigma1 - sigma0) * k, rays.pa[:, 2], rays.pb[:, 2], rays.t_enter, rays.t_exit)
            s = s0 + (s1 - s0) * k[:, None]
            _record(marching, degenerate_hit, t, s, sample_color(image, nearer_sample(k, s0, s1)), image.object_id, i + 2)
            active &= ~degenerate_hit
        through_back, k_back = back_crossing(image, s0, s1, r0, r1, z0, z1)
        back_hit = active & through_back
        if back_hit.any():
            note_unseen(marching, back_hit & hit_unseen(image, s0, s1, z0[:, 1], z1[:, 1], block0, block1),
                        np.full(len(active), int(Unseen.SILHOUETTE)), sigma0, rays)
            t = ray_parameter(sigma0 + (sigma1 - sigma0) * k_back, rays.pa[:, 2], rays.pb[:, 2], rays.t_enter, rays.t_exit)
            s = s0 + (s1 - s0) * k_back[:, None]
            _record(marching, back_hit, t, s, sample_back_color(image, nearer_sample(k_back, s0, s1)), image.object_id, i + 2)
            active &= ~back_hit
        note_unseen(marching, active, step_unseen(image, s0, s1, r0, r1, z0, z1, block0, block1), sigma0, rays)
        entered = active & inside_solid(r1, z1)
        if entered.any():
            t = ray_parameter(sigma1, rays.pa[:, 2], rays.pb[:, 2], rays.t_enter, rays.t_exit)
            _record(marching, entered, t, s1, sample_color(image, s1), image.object_id, i + 2)
            active &= ~entered
        s0, z0, q0, block0 = s1, z1, q1, block1
    if marching is not result:
        result.put(rows, marching)
    return result


def _track_margins(result: RayHits, active: NDArray[np.bool_], s: Array, layers: Array) -> None:
    texel = np.min(np.abs(s[:, :2] - np.round(s[:, :2])), axis=1)
    # The crossing and inside tests decide at ray depth = surface or back face +- the tolerance.
    r, front, back = s[:, 2], layers[:, 0], layers[:, 1]
    edges = np.stack([front - CONTACT_DEPTH_TOLERANCE, front + CONTACT_DEPTH_TOLERANCE, back + CONTACT_DEPTH_TOLERANCE])
    depth = np.where(front < BACKGROUND_DEPTH, np.min(np.abs(r - edges), axis=0), np.inf)
    result.texel_margin[active] = np.minimum(result.texel_margin, texel)[active]
    result.depth_margin[active] = np.minimum(result.depth_margin, depth)[active]


def _track_connection(result: RayHits, active: NDArray[np.bool_], slack: Array, z0: Array, z1: Array) -> None:
    """The join-or-not decision between samples is a depth decision too: record how close it was."""
    surface = (z0 < BACKGROUND_DEPTH) & (z1 < BACKGROUND_DEPTH)
    closeness = np.where(surface, np.abs(slack), np.inf)
    result.depth_margin[active] = np.minimum(result.depth_margin, closeness)[active]


def _dot(x: Array, y: Array) -> Array:
    return np.einsum("ij,ij->i", x, y)


def _record(result: RayHits, mask: NDArray[np.bool_], t: Array, s: Array, color: Array, object_id: int, samples: int) -> None:
    result.hit[mask] = True
    result.t[mask] = t[mask]
    result.image_position[mask] = s[mask]
    result.color[mask] = color[mask]
    result.object_id[mask] = object_id
    result.samples[mask] = samples


def intersect_depth_image(image: DepthImageData, origins: Array, directions: Array, algorithm: Algorithm) -> RayHits:
    """The hits `algorithm` must find (the hierarchical traversal: the optimized march's)."""
    if algorithm == Algorithm.BASIC:
        return intersect_basic(image, origins, directions)
    return intersect_optimized(image, origins, directions)


def nearest_depth_image_hit(
    images: Sequence[DepthImageData], origins: Array, directions: Array, algorithm: Algorithm = Algorithm.OPTIMIZED
) -> RayHits:
    """The nearest hit over several depth images, as the mirror shader keeps it. Every image is
    marched to its end here; the shader visits them nearest first and stops at the nearest hit
    (lib/reflected_scene.glsl): the same hit, fewer samples, and nothing unseen after the hit."""
    best = RayHits.misses(len(origins))
    samples = np.zeros(len(origins), np.int64)
    for image in images:
        candidate = intersect_depth_image(image, origins, directions, algorithm)
        samples += candidate.samples
        closer = candidate.hit & (~best.hit | (candidate.t < best.t))
        _record(best, closer, candidate.t, candidate.image_position, candidate.color, image.object_id, 0)
        best.conditioning[closer] = candidate.conditioning[closer]
        best.texel_margin[:] = np.minimum(best.texel_margin, candidate.texel_margin)
        best.depth_margin[:] = np.minimum(best.depth_margin, candidate.depth_margin)
        earlier = (candidate.unseen != Unseen.NONE) & (candidate.unseen_t < best.unseen_t)
        best.unseen_t[earlier] = candidate.unseen_t[earlier]
        best.unseen[earlier] = candidate.unseen[earlier]
    best.samples[:] = samples
    return best
