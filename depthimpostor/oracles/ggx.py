"""The truth of a glossy mirror (`roughness` > 0): GGX (Trowbridge-Reitz, alpha = roughness^2)
integrated by importance sampling, GGX_SAMPLES reflected rays per pixel.

Each ray's microfacet normal is drawn from GGX's distribution of visible normals for the pixel's
own view (Heitz 2018, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4)); the ray is
the view reflected about it, traced and shaded exactly as a perfect mirror's single ray is. With
that sampling the estimator of the BRDF times the cosine is F G2/G1(v), which for Smith's
separable shadowing is F G1(l): each ray is weighted by G1(l) (0 for a ray below the surface).

The weights are normalized (the pixel is sum(w L) / sum(w), times the mirror's tint): the lobe's
shape is exact, but its overall scale (the split sum's second factor, the "DFG" energy term, and
Fresnel) is left at the tint, as the renderer leaves it. The comparison then measures the blur
the methods approximate, not an energy term that none of them models.

The samples are a 64-point Hammersley set shifted per pixel by a seeded random offset (a
Cranley-Patterson rotation, GGX_SEED): the same truth on every run, and no pattern shared by
neighbouring pixels. Their noise at 64 samples is well under the methods' errors at the
roughnesses the docs measure (docs/methods_and_results.md, "Glossy mirrors").
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

Array = np.ndarray

#: Reflected rays per glossy mirror pixel.
GGX_SAMPLES = 64
#: The seed of the per-pixel offsets of the sample set.
GGX_SEED = 25
#: Pixels sampled at a time: 64 rays each, a few arrays of (pixels * 64, 3) float64 in flight.
GGX_CHUNK = 4096


def ggx_alpha(roughness: float) -> float:
    """The GGX width alpha of a `roughness` (the usual perceptual remapping, alpha = roughness^2)."""
    return roughness * roughness


def hammersley(count: int) -> Array:
    """`count` 2-D points of the Hammersley set in [0, 1)^2: (i / n, the radical inverse of i)."""
    bits = np.arange(count, dtype=np.uint32)
    inverse = np.zeros(count)
    scale = 0.5
    while bits.any():
        inverse += (bits & 1) * scale
        bits >>= 1
        scale *= 0.5
    return np.stack([np.arange(count) / count, inverse], axis=1)


def tangent_frames(normals: Array) -> tuple[Array, Array]:
    """Two unit tangents completing each unit normal to a right-handed frame (Frisvad's, made
    robust near -Z by Duff et al. 2017)."""
    sign = np.where(normals[:, 2] >= 0.0, 1.0, -1.0)
    a = -1.0 / (sign + normals[:, 2])
    b = normals[:, 0] * normals[:, 1] * a
    tangent = np.stack([1.0 + sign * normals[:, 0] ** 2 * a, sign * b, -sign * normals[:, 0]], axis=1)
    bitangent = np.stack([b, sign + normals[:, 1] ** 2 * a, -normals[:, 1]], axis=1)
    return tangent, bitangent


def sample_visible_normals(view: Array, alpha: float, u: Array) -> Array:
    """Heitz's VNDF sampling in the local frame (z the macro normal): for each local unit `view`
    (z > 0) and point `u` in [0, 1)^2, a microfacet normal seen from it."""
    stretched = view * np.array([alpha, alpha, 1.0])
    stretched /= np.linalg.norm(stretched, axis=1, keepdims=True)
    length2 = stretched[:, 0] ** 2 + stretched[:, 1] ** 2
    length = np.sqrt(length2)
    safe = np.where(length > 0.0, length, 1.0)
    t1 = np.where((length2 > 0.0)[:, None],
                  np.stack([-stretched[:, 1] / safe, stretched[:, 0] / safe, np.zeros_like(safe)], axis=1),
                  np.array([1.0, 0.0, 0.0]))
    t2 = np.cross(stretched, t1)
    radius, phi = np.sqrt(u[:, 0]), 2.0 * np.pi * u[:, 1]
    p1, p2 = radius * np.cos(phi), radius * np.sin(phi)
    s = 0.5 * (1.0 + stretched[:, 2])
    p2 = (1.0 - s) * np.sqrt(np.clip(1.0 - p1 * p1, 0.0, None)) + s * p2
    normal = (p1[:, None] * t1 + p2[:, None] * t2
              + np.sqrt(np.clip(1.0 - p1 * p1 - p2 * p2, 0.0, None))[:, None] * stretched)
    normal = normal * np.array([alpha, alpha, 1.0])
    normal[:, 2] = np.clip(normal[:, 2], 0.0, None)
    return normal / np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)


def smith_g1(cosine: Array, alpha: float) -> Array:
    """Smith's masking for GGX of a direction at `cosine` to the macro normal (0 below it)."""
    c = np.clip(cosine, 0.0, 1.0)
    tan2 = np.where(c > 0.0, (1.0 - c * c) / np.maximum(c * c, 1e-300), 0.0)
    return np.where(c > 0.0, 2.0 / (1.0 + np.sqrt(1.0 + alpha * alpha * tan2)), 0.0)


def ggx_directions(incoming: Array, normals: Array, alpha: float, seed: int = GGX_SEED,
                   first_pixel: int = 0) -> tuple[Array, Array]:
    """For each pixel (unit `incoming` ray from the eye, unit `normals` facing it), GGX_SAMPLES
    reflected directions (pixels * samples, 3), pixel-major, and their weights G1(l)."""
    count = len(incoming)
    tangent, bitangent = tangent_frames(normals)
    view = -incoming
    local_view = np.stack([np.einsum("ij,ij->i", view, tangent), np.einsum("ij,ij->i", view, bitangent),
                           np.clip(np.einsum("ij,ij->i", view, normals), 1e-6, None)], axis=1)
    local_view /= np.linalg.norm(local_view, axis=1, keepdims=True)
    # One offset per pixel, the same whatever the chunking: drawn for the pixels' global indices.
    offsets = np.random.default_rng(seed).random((first_pixel + count, 2))[first_pixel:]
    u = (hammersley(GGX_SAMPLES)[None, :, :] + offsets[:, None, :]) % 1.0
    views = np.repeat(local_view, GGX_SAMPLES, axis=0)
    micro = sample_visible_normals(views, alpha, u.reshape(-1, 2))
    local = 2.0 * np.einsum("ij,ij->i", views, micro)[:, None] * micro - views
    weights = smith_g1(local[:, 2], alpha)
    t, b, n = (np.repeat(x, GGX_SAMPLES, axis=0) for x in (tangent, bitangent, normals))
    world = local[:, :1] * t + local[:, 1:2] * b + local[:, 2:3] * n
    return world / np.linalg.norm(world, axis=1, keepdims=True), weights


def glossy_average(incoming: Array, normals: Array, roughness: float, central: Array,
                   radiance: Callable[[Array, Array], Array]) -> Array:
    """The normalized GGX average of what each pixel's sampled rays see: `radiance(pixels,
    directions)` traces the rays of pixels (indices into these arrays) along directions and
    returns their colours. `central` (the single reflected ray's colour) stands where every sample
    fell below the surface (a grazing view of a very rough mirror)."""
    alpha = ggx_alpha(roughness)
    result = central.copy()
    for start in range(0, len(incoming), GGX_CHUNK):
        stop = min(start + GGX_CHUNK, len(incoming))
        directions, weights = ggx_directions(incoming[start:stop], normals[start:stop], alpha, first_pixel=start)
        pixels = np.repeat(np.arange(start, stop), GGX_SAMPLES)
        kept = weights > 0.0
        colors = np.zeros((len(directions), 3))
        colors[kept] = radiance(pixels[kept], directions[kept])
        weighted = (colors * weights[:, None]).reshape(stop - start, GGX_SAMPLES, 3).sum(axis=1)
        total = weights.reshape(stop - start, GGX_SAMPLES).sum(axis=1)
        some = total > 0.0
        result[start:stop][some] = weighted[some] / total[some, None]
    return result
