"""Write scenes/sky.exr: a small analytic HDR sky (no downloaded file), for scenes/hdr_sky.toml.

    python3 tools/make_hdr_sky.py                   # writes scenes/sky.exr
    python3 tools/make_hdr_sky.py -o other.exr --size 1024x512

The sky is the Perez et al. (1993) all-weather luminance model with clear-sky coefficients (the
shape Preetham, Shirley and Smits (1999) fit to turbidity), coloured from a horizon white to a
zenith blue, over a dark ground, with a sun disc of SUN_RADIANCE and a soft limb. It is written as
an equirectangular image in the package's convention (shaders/lib/environment.glsl): column u
is the longitude atan2(x, -z) from -pi to pi, row v the angle from the zenith, row 0 at the top;
each pixel holds the sky at its centre's direction. Half floats keep the file small (a few hundred
KiB); the renderer and the truth read the same decoded values, so nothing is lost between them.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from depthimpostor.hdr import write_hdr

ROOT = Path(__file__).resolve().parent.parent
#: The sun's direction (toward it): 30 degrees up, behind and to the right of the default camera,
#: where a mirror in front of the camera shows it.
SUN = np.array([0.55, 0.5, 0.67])
SUN_RADIUS_DEGREES = 2.5  # five times the real sun's, to cover a few pixels of a 512-wide map
SUN_RADIANCE = 40.0  # at the disc's centre; the sky is about 1
#: Perez's luminance coefficients A to E from Preetham et al.'s fit at turbidity 2.5 (a clear sky).
PEREZ = (-1.016, -0.461, 5.27, -2.276, 0.203)
#: The sky's luminance at the zenith; the model brightens it about threefold toward the horizon.
ZENITH_LUMINANCE = 0.4
ZENITH_COLOR = np.array([0.22, 0.42, 0.95])
HORIZON_COLOR = np.array([0.95, 0.95, 1.0])
GROUND_COLOR = np.array([0.28, 0.25, 0.22])


def directions(width: int, height: int) -> np.ndarray:
    """(height, width, 3) unit directions at the pixel centres."""
    u = (np.arange(width) + 0.5) / width
    v = (np.arange(height) + 0.5) / height
    longitude = (u - 0.5) * 2.0 * np.pi
    polar = v * np.pi
    s = np.sin(polar)[:, None]
    return np.stack([s * np.sin(longitude)[None, :], np.cos(polar)[:, None] * np.ones(width),
                     -s * np.cos(longitude)[None, :]], axis=2)


def perez(cos_theta: np.ndarray, gamma: np.ndarray) -> np.ndarray:
    a, b, c, d, e = PEREZ
    return (1.0 + a * np.exp(b / np.maximum(cos_theta, 0.01))) * (1.0 + c * np.exp(d * gamma) + e * np.cos(gamma) ** 2)


def sky(width: int, height: int) -> np.ndarray:
    d = directions(width, height)
    sun = SUN / np.linalg.norm(SUN)
    gamma = np.arccos(np.clip(d @ sun, -1.0, 1.0))  # angle to the sun
    cos_theta = d[..., 1]
    theta_sun = np.arccos(sun[1])
    luminance = perez(cos_theta, gamma) / perez(np.array(1.0), np.array(theta_sun))  # 1 at the zenith
    up = np.clip(cos_theta, 0.0, 1.0)[..., None]
    color = HORIZON_COLOR + (ZENITH_COLOR - HORIZON_COLOR) * np.sqrt(up)
    above = ZENITH_LUMINANCE * luminance[..., None] * color
    # Below the horizon: the ground, lit a little more toward the sun's side, with a short blend so
    # that the horizon is not a one-pixel step.
    below = GROUND_COLOR * (1.0 + 0.3 * np.clip(d @ np.array([sun[0], 0.0, sun[2]]), 0.0, 1.0))[..., None]
    blend = np.clip(cos_theta / 0.03 + 0.5, 0.0, 1.0)[..., None]
    image = below + (above - below) * blend
    # The sun's disc: limb darkened (1 - 0.6 (1 - cos of the angle across the disc)), its edge
    # smoothed over a quarter of its radius so that filtering it does not depend on where texels fall.
    r = np.degrees(gamma) / SUN_RADIUS_DEGREES
    limb = 1.0 - 0.6 * (1.0 - np.sqrt(np.clip(1.0 - r ** 2, 0.0, 1.0)))
    edge = np.clip((1.0 - r) / 0.25, 0.0, 1.0)
    image += (SUN_RADIANCE * limb * edge)[..., None] * np.array([1.0, 0.95, 0.85])
    return image


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", type=Path, default=ROOT / "scenes" / "sky.exr")
    parser.add_argument("--size", default="512x256", help="WIDTHxHEIGHT (default 512x256)")
    args = parser.parse_args()
    width, height = (int(part) for part in args.size.split("x"))
    with open(args.output, "wb") as file:
        write_hdr(file, sky(width, height).astype(np.float16), args.output.suffix)
    print(args.output)


if __name__ == "__main__":
    main()
