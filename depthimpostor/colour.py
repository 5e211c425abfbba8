"""The colour pipeline: the renderer's linear float colour to the numbers a display shows.

Every pass renders linear radiance in float, and every accuracy figure is taken there. Only what
is shown or written as an 8-bit image goes through the display transform (docs/colour.md):

    linear -> x 2^exposure -> tone map (none: clamp; aces; reinhard) -> sRGB encode -> 8 bits

shaders/lib/display.glsl is the same transform for the viewer's window, with the same names and
the constants of constants.py. `encode_srgb` is the one sRGB encoder of every file the package
writes: a linear 0.5 grey is written as 188.
"""

from __future__ import annotations

import numpy as np

from .constants import (
    ACES_A, ACES_B, ACES_C, ACES_D, ACES_E, SRGB_GAMMA, SRGB_LINEAR_LIMIT, SRGB_LINEAR_SLOPE, SRGB_OFFSET, ToneMapping,
)

#: What `render.tone_mapping` and `--tone-mapping` may be.
TONE_MAPPINGS = tuple(mapping.option for mapping in ToneMapping)


def encode_srgb(linear: np.ndarray) -> np.ndarray:
    """The sRGB transfer function (IEC 61966-2-1) of linear values in [0, 1]."""
    c = np.clip(linear, 0.0, 1.0)
    # The power of the clamped value: the linear segment's values (below the limit) are not taken
    # from it, but np.where evaluates both sides, and c ** (1 / 2.4) of 0 is fine.
    return np.where(c <= SRGB_LINEAR_LIMIT, SRGB_LINEAR_SLOPE * c,
                    (1.0 + SRGB_OFFSET) * c ** (1.0 / SRGB_GAMMA) - SRGB_OFFSET)


def tone_map(linear: np.ndarray, mapping: ToneMapping | str, exposure: float = 0.0) -> np.ndarray:
    """Linear colour scaled by 2^`exposure` (stops) and compressed into [0, 1] per channel."""
    mapping = ToneMapping[mapping.upper()] if isinstance(mapping, str) else mapping
    # NaN would survive every clamp below as NaN and turn into an arbitrary byte: black, as before.
    x = np.maximum(np.nan_to_num(np.asarray(linear, dtype=np.float64), nan=0.0, posinf=np.inf), 0.0) * 2.0 ** exposure
    if mapping == ToneMapping.ACES:
        with np.errstate(invalid="ignore"):  # inf / inf: a channel past float's range, shown white
            mapped = np.where(np.isinf(x), 1.0, x * (ACES_A * x + ACES_B) / (x * (ACES_C * x + ACES_D) + ACES_E))
    elif mapping == ToneMapping.REINHARD:
        with np.errstate(invalid="ignore"):
            mapped = np.where(np.isinf(x), 1.0, x / (1.0 + x))
    else:
        mapped = x
    return np.clip(mapped, 0.0, 1.0)


def quantize(encoded: np.ndarray) -> np.ndarray:
    """Values in [0, 1] to the nearest of 256 levels."""
    return (np.clip(encoded, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)


def display_encode(linear: np.ndarray, mapping: ToneMapping | str = ToneMapping.NONE,
                   exposure: float = 0.0) -> np.ndarray:
    """A linear float frame as the 8-bit sRGB image a PNG holds and a display shows."""
    return quantize(encode_srgb(tone_map(linear, mapping, exposure)))
