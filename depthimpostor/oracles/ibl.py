"""shaders/lib/environment_lighting.glsl (and lib/environment.glsl's lookup) in numpy, function by
function under the same names: what the truth's exact hits on metallic-roughness surfaces take
from an equirect sky (ibl.py states the rule and the split).

The truth reads the same numbers as the shaders: the nine irradiance terms are ibl.py's
projection (float64 here, float32 in the Lights block), and the prefiltered specular levels are
the GPU's own, read back once from the sky's texture (`SkyLighting.texture`, passes/environment.py's
read_back) and sampled with the shader's filter. Why read back rather than prefilter again in
numpy: the prefilter reads the sky through the GPU's mip chain and trilinear filter, which numpy
cannot reproduce to float precision; with the same texels on both sides, the truth and every
method's hits light a surface identically, and `compare` measures where a reflected ray lands (the
stand-ins), not two estimates of one integral. That the levels are the integral they stand for is
tested apart (tests/test_environment_lighting.py: against a numpy GGX convolution of the sky).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..constants import IBL_LEVELS
from ..ibl import irradiance_sh9, level_row, level_size, sh9_basis
from ..scene.model import Environment

Array = np.ndarray


@dataclass(frozen=True, eq=False)
class SkyLighting:
    """What a sky lights surfaces with: its texture as the shaders read it (its image, and its
    prefiltered levels below it), and its nine irradiance terms."""

    texture: Array  # (rows, columns, 3) float32, read back from the GPU
    irradiance: Array  # (9, 3) float64: ibl.irradiance_sh9 of the sky's image

    @classmethod
    def of(cls, environment: Environment, texture: Array) -> SkyLighting:
        if environment.image is None:
            raise ValueError(f"a {environment.type} environment has no image to light surfaces with")
        return cls(texture, irradiance_sh9(environment.image))


def sky_frame(env: Environment, directions: Array) -> Array:
    """Directions in the sky image's own frame: turned back by the sky's rotation about +Y."""
    radians = np.radians(env.rotation)
    c, s = np.cos(radians), np.sin(radians)
    x = c * directions[:, 0] - s * directions[:, 2]
    z = s * directions[:, 0] + c * directions[:, 2]
    return np.stack([x, directions[:, 1], z], axis=1)


def equirect_coordinates(d: Array) -> Array:
    """Where sky-frame directions `d` (any length) fall in an equirect image, (n, 2): the share of
    the longitude atan2(x, -z) across and of the angle from the zenith down (truth.equirect_lookup
    states the mapping); straight up or down, the longitude is 0."""
    x, y, z = d[:, 0], d[:, 1], d[:, 2]
    horizontal = np.hypot(x, z)
    around = horizontal > 0.0
    longitude = np.where(around, np.arctan2(x, -z), 0.0)
    polar = np.where(around, np.arctan2(horizontal, y), np.where(y < 0.0, np.pi, 0.0))
    return np.stack([longitude / (2.0 * np.pi) + 0.5, polar / np.pi], axis=1)


def equirect_texels(image: Array, uv: Array) -> Array:
    """The equirect `image`'s texels at `uv` (equirect_coordinates'), filtered bilinearly between
    the four texel centres around each: columns wrap, rows clamp at the poles."""
    height, width = image.shape[:2]
    tx = uv[:, 0] * width - 0.5
    ty = uv[:, 1] * height - 0.5
    bx, by = np.floor(tx), np.floor(ty)
    fx, fy = (tx - bx)[:, None], (ty - by)[:, None]
    x0 = (bx.astype(np.int64) + width) % width
    x1 = (bx.astype(np.int64) + 1 + width) % width
    y0 = np.clip(by.astype(np.int64), 0, height - 1)
    y1 = np.clip(by.astype(np.int64) + 1, 0, height - 1)
    texels = image.astype(np.float64)
    top = texels[y0, x0] + (texels[y0, x1] - texels[y0, x0]) * fx
    bottom = texels[y1, x0] + (texels[y1, x1] - texels[y1, x0]) * fx
    return top + (bottom - top) * fy


def environment_irradiance(env: Environment, sky: SkyLighting, normals: Array) -> Array:
    """The radiance a white diffuse surface of each unit normal shows under the sky (its
    irradiance over pi), from the nine terms; clamped at 0 as the shader is (their ringing)."""
    return env.intensity * np.maximum(sh9_basis(sky_frame(env, normals)) @ sky.irradiance, 0.0)


def prefiltered_level(env: Environment, sky: SkyLighting, level: int, d: Array) -> Array:
    """Prefiltered level `level` (1..IBL_LEVELS) along sky-frame directions `d`."""
    if env.image is None:
        raise ValueError("only an equirect sky has prefiltered levels")
    width, height = level_size(level)
    row = level_row(level, env.image.shape[0])
    return equirect_texels(sky.texture[row:row + height, :width], equirect_coordinates(d))


def environment_specular(env: Environment, sky: SkyLighting, directions: Array, roughness: float | Array) -> Array:
    """The sky's radiance through GGX lobes of `roughness` about `directions` (the reflected view):
    linear between the two levels about roughness * IBL_LEVELS, level 0 the sky itself."""
    if env.image is None:
        raise ValueError("only an equirect sky has prefiltered levels")
    lod = np.clip(np.broadcast_to(roughness, len(directions)), 0.0, 1.0) * IBL_LEVELS
    below = np.minimum(lod.astype(np.int64), IBL_LEVELS - 1)
    d = sky_frame(env, directions)
    result = np.zeros((len(directions), 3))
    for level in np.unique(below):
        chosen = below == level
        low = (equirect_texels(env.image, equirect_coordinates(d[chosen])) if level == 0
               else prefiltered_level(env, sky, int(level), d[chosen]))
        high = prefiltered_level(env, sky, int(level) + 1, d[chosen])
        result[chosen] = low + (high - low) * (lod[chosen] - level)[:, None]
    return env.intensity * result

