"""Image-based lighting from an equirect sky: what a metallic-roughness surface takes from the sky
for its ambient term in place of the constant `render.ambient` (lib/environment_lighting.glsl,
oracles/ibl.py).

The rule (issue 33 item 5): only a scene with an equirect sky *and* a metallic-roughness material
pays for it (`uses_environment_lighting`); a gradient or constant sky, or a scene of diffuse and
checker materials alone, keeps the constant ambient and compiles and runs nothing of this.

As glTF-Sample-Viewer and three.js split it:
- the diffuse part is the sky's irradiance, as nine spherical-harmonic terms (three.js's light
  probes, Filament's irradiance): projected here in numpy, exactly (every texel by its solid
  angle), once per sky, and written into the Lights block; the shader and the truth evaluate the
  same nine numbers;
- the specular part is the sky prefiltered by GGX lobes of IBL_LEVELS roughnesses
  (passes/environment.py's prefilter, on the GPU, once per sky: shaders/env_prefilter.frag, after
  ibl_filtering.frag), kept in the rows of the sky's texture below its image (the mirror shader
  already samples 16 textures: no sampler is added), read between the two levels about the
  surface's roughness, level 0 being the sky itself;
- both times the split sum's DFG term, the existing fit (lib/brdf.glsl's ambient_specular).
"""

from __future__ import annotations

import numpy as np

from .constants import IBL_LEVELS, IBL_SAMPLES, IBL_WIDTH
from .scene.model import MetallicRoughnessMaterial, Scene

Array = np.ndarray


def uses_environment_lighting(scene: Scene) -> bool:
    """Does the scene light its metallic-roughness materials from its sky (an equirect map and at
    least one such material)? Otherwise they take the constant ambient, and no prefilter runs."""
    return scene.environment.is_map and any(isinstance(m, MetallicRoughnessMaterial) for m in scene.materials)


#: What the prefilter took on this project's machine (Mesa llvmpipe 22.3, 2 cores shared with other
#: work), the median of 7 runs of tools/prefilter_cost.py on showcase.toml's 512x256 sky (1.09 to
#: 1.32 s; 2026-11-27): `plan` states it beside the count of reads. It depends on the levels'
#: sizes and IBL_SAMPLES alone, not on the sky's size (the reads are mip-filtered).
PREFILTER_SECONDS = 1.26


def level_size(level: int) -> tuple[int, int]:
    """Prefiltered level `level`'s (1..IBL_LEVELS) width and height in texels."""
    width = IBL_WIDTH >> (level - 1)
    return width, width // 2


def level_row(level: int, image_height: int) -> int:
    """The first row of prefiltered level `level` in the sky's texture: the levels are stacked
    below the image's `image_height` rows, each half as high as the one above (the closed form of
    the sum of the heights above it, as lib/environment_lighting.glsl computes it)."""
    first = IBL_WIDTH // 2
    return image_height + 2 * first - 2 * (first >> (level - 1))


def map_size(image: Array) -> tuple[int, int]:
    """The size of the texture that holds the sky's image and, below it, its prefiltered levels."""
    height, width = image.shape[:2]
    return max(width, IBL_WIDTH), level_row(IBL_LEVELS + 1, height)


def map_bytes(image: Array) -> int:
    """GPU memory of that texture (RGBA32F: three-component float is not a colour-renderable format)."""
    width, height = map_size(image)
    return width * height * 16


def prefilter_reads() -> int:
    """How many filtered texture reads the prefilter makes (its cost, for `plan`)."""
    return sum(level_size(level)[0] * level_size(level)[1] for level in range(1, IBL_LEVELS + 1)) * IBL_SAMPLES


def texel_directions(width: int, height: int) -> tuple[Array, Array]:
    """The unit directions of an equirect image's texel centres in the image's own frame, as the
    lookup (truth.equirect_lookup) maps them: the longitude atan2(x, -z) across, the angle from +Y
    down; returned as (height, width, 3), with each row's solid angle (height,)."""
    longitude = ((np.arange(width) + 0.5) / width - 0.5) * 2.0 * np.pi
    polar = (np.arange(height) + 0.5) / height * np.pi
    s, c = np.sin(polar)[:, None], np.cos(polar)[:, None]
    directions = np.stack([s * np.sin(longitude), np.broadcast_to(c, (height, width)), -s * np.cos(longitude)], axis=2)
    edges = np.arange(height + 1) / height * np.pi
    solid_angle = 2.0 * np.pi / width * (np.cos(edges[:-1]) - np.cos(edges[1:]))
    return directions, solid_angle


#: The real spherical harmonics of bands 0-2 as polynomials of the unit direction (x, y, z), in the
#: order `sh9_basis` returns them, and each one's constant squared times the cosine lobe's band
#: factor over pi (Ramamoorthi and Hanrahan 2001: A_0 = pi, A_1 = 2 pi / 3, A_2 = pi / 4): the
#: irradiance over pi, the radiance a white diffuse surface shows, is then sum(c_i * basis_i(n)).
SH9_FACTORS = np.array([
    1.0 / (4.0 * np.pi),  # 1
    *[3.0 / (4.0 * np.pi) * 2.0 / 3.0] * 3,  # y, z, x
    *[15.0 / (4.0 * np.pi) / 4.0] * 3,  # xy, yz, xz
    5.0 / (16.0 * np.pi) / 4.0,  # 3 z^2 - 1
    15.0 / (16.0 * np.pi) / 4.0,  # x^2 - y^2
])


def sh9_basis(directions: Array) -> Array:
    """The nine polynomials of (n, 3) unit directions, (n, 9): 1, y, z, x, xy, yz, xz, 3z^2 - 1,
    x^2 - y^2 (lib/environment_lighting.glsl's environment_irradiance, term by term)."""
    x, y, z = directions[:, 0], directions[:, 1], directions[:, 2]
    return np.stack([np.ones_like(x), y, z, x, x * y, y * z, x * z, 3.0 * z * z - 1.0, x * x - y * y], axis=1)


_SH_CACHE: dict[int, tuple[Array, Array]] = {}


def irradiance_sh9(image: Array) -> Array:
    """The sky `image`'s irradiance terms, (9, 3) float64: sum(c_i * basis_i(n)) is the radiance a
    white diffuse surface of normal n shows under it (before the sky's intensity and rotation,
    which the lookup applies). Every texel counts by its solid angle, at its centre's direction;
    computed once per image. Separably: a texel's direction is (s a, c, s b) for its row's sine and
    cosine s, c and its column's a = sin(longitude), b = -cos(longitude), so each of the nine
    polynomials is a row function times a column function, and one pass over the image sums
    the six column functions each needs (1, a, b, a^2, b^2, ab) row by row."""
    cached = _SH_CACHE.get(id(image))
    if cached is not None and cached[0] is image:
        return cached[1]
    height, width = image.shape[:2]
    longitude = ((np.arange(width) + 0.5) / width - 0.5) * 2.0 * np.pi
    a, b = np.sin(longitude), -np.cos(longitude)
    columns = np.stack([np.ones(width), a, b, a * a, b * b, a * b], axis=1)  # (width, 6)
    rows = np.einsum("jic,ik->kjc", image, columns, dtype=np.float64)  # (6, height, 3)
    one, ma, mb, maa, mbb, mab = rows
    polar = (np.arange(height) + 0.5) / height * np.pi
    edges = np.arange(height + 1) / height * np.pi
    w = (2.0 * np.pi / width * (np.cos(edges[:-1]) - np.cos(edges[1:])))[:, None]  # each row's texels' solid angle
    s, c = np.sin(polar)[:, None], np.cos(polar)[:, None]
    terms = np.stack([(w * one).sum(0), (w * c * one).sum(0), (w * s * mb).sum(0), (w * s * ma).sum(0),
                      (w * s * c * ma).sum(0), (w * c * s * mb).sum(0), (w * s * s * mab).sum(0),
                      (w * (3.0 * s * s * mbb - one)).sum(0), (w * (s * s * maa - c * c * one)).sum(0)])
    terms *= SH9_FACTORS[:, None]
    if len(_SH_CACHE) > 8:  # a handful of skies at once at most (tests, the viewer's scene changes)
        _SH_CACHE.clear()
    _SH_CACHE[id(image)] = (image, terms)
    return terms

