"""Image files decoded, as they are written, into the texels a `Texture` holds: (H, W, 4) uint8
RGBA, the colour sRGB-encoded, row 0 the top.

Pillow opens the file; what its modes hold is decided here, mode by mode, because Pillow's own
`convert("RGBA")` clips 16-bit samples (a 16-bit grey at 25 % came out white) and truncates float
ones (0.5 came out black). Each mode is either read to the right values or refused in one line
(`ImageRefused`, which the callers turn into a SceneError naming the file and field, or the glTF
image), before any GL work:

| Pillow mode | from | read as |
|---|---|---|
| `1`, `L`, `P`, `RGB`, `RGBA`, `LA`, `PA`, `RGBX`, `CMYK`, `YCbCr` | 1- to 8-bit PNG, JPEG (CMYK too), GIF, BMP, TIFF, WebP... | Pillow's conversion, which is exact for these (a transparent colour key or palette entry gives alpha 0; one Pillow misses is applied here: see `_grey_key`) |
| `RGB`, `RGBA` from 16-bit samples | 16-bit RGB(A) and grey+alpha PNG | Pillow keeps each sample's high byte: within one 8-bit step of the exact value (`round(v * 255 / 65535)`) |
| `I;16`, `I;16B`, `I;16L`, `I;16N` | 16-bit greyscale PNG, TIFF | `round(v * 255 / 65535)`: the samples are sRGB-encoded, as 8-bit ones are (PNG, glTF), so 25 % stays 25 % |
| `F` | 32-bit float TIFF | linear values: a float image is linear light by convention (OpenEXR, Photoshop's and GIMP's 32-bit float), so the texel is their sRGB encoding, decoded back to the same linear value (within an 8-bit step) when drawn; a value outside [0, 1] (no albedo is) or not finite is refused |
| `I` (32-bit integers), `I;16S`, `LAB`, `HSV`, others | 32-bit integer TIFF, CIELab TIFF, ... | refused: no range says what white is, or Pillow has no exact conversion |

The texels are 8 bits per channel whatever the file holds (texture arrays, the traced rays' atlas
and SRGB_TABLE are 8-bit sRGB): a 16-bit or float file keeps 8 bits of its precision. An image of
several frames (a GIF, an APNG, a multi-page TIFF) gives its first. Colour profiles and gamma
chunks are not applied (the glTF specification says to ignore them; the texels are taken as sRGB).
"""

from __future__ import annotations

import contextvars
import io
import re
import struct
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from PIL import Image, UnidentifiedImageError

from .colour import encode_srgb
from .host_memory import available_memory

#: What an image must be, as refusals say it.
DECODABLE = "an image file Pillow can decode (PNG, JPEG, ...)"
#: The most texels an image texture may have, read from its header before it is decoded (8192 x
#: 8192): 256 MiB as the 8-bit RGBA texels, which the texture arrays, their mipmaps and the traced
#: rays' atlas copy again. (Pillow's own guard, DecompressionBombError, stops at 179 million.)
MAX_TEXELS = 2**26
#: Modes whose `convert("RGBA")` is exact (8-bit samples, or fewer scaled to 8).
CONVERTED = ("1", "L", "P", "RGB", "RGBA", "LA", "PA", "RGBX", "CMYK", "YCbCr")
#: 16-bit unsigned greyscale, in Pillow's byte orders.
GREY_16 = ("I;16", "I;16B", "I;16L", "I;16N")
#: Why the other modes are refused, for the one line.
REFUSED = {"I": "32-bit integer samples: no range says what white is (save 8- or 16-bit, or 32-bit float)",
           "I;16S": "signed 16-bit samples: no range says what black is (save unsigned 8- or 16-bit)",
           "LAB": "CIELab colour, which Pillow does not convert to sRGB exactly (save RGB)",
           "HSV": "HSV colour (save RGB)"}


#: Bytes a decoded texel is kept in (8-bit RGBA), and the most a decode holds at once per texel
#: (Pillow's image and the RGBA copy made of it) before the first is let go.
DECODED_TEXEL_BYTES, DECODING_TEXEL_BYTES = 4, 8


class _SceneImages:
    """What the images of the scene being loaded may take: the machine's available memory when
    it started loading, less what its images decoded so far keep."""

    def __init__(self, available: int | None) -> None:
        self.available, self.kept = available, 0


_SCENE_IMAGES: contextvars.ContextVar[_SceneImages | None] = contextvars.ContextVar("scene_images", default=None)


@contextmanager
def scene_images_budget() -> Iterator[None]:
    """While a scene loads, every image it decodes (textures, glTF images, the environment) is checked from its
    header against what the scene's images left of the machine's available memory, before it is
    decoded: each image fits alone (MAX_TEXELS), and all of them must fit together. (Nested: the
    outermost load's budget holds.)"""
    if _SCENE_IMAGES.get() is not None:
        yield
        return
    token = _SCENE_IMAGES.set(_SceneImages(available_memory()))
    try:
        yield
    finally:
        _SCENE_IMAGES.reset(token)


def _charge(width: int, height: int) -> None:
    """Count an 8-bit image about to be decoded against the scene's budget, or refuse it first."""
    charge_scene_image(width, height, DECODED_TEXEL_BYTES, DECODING_TEXEL_BYTES)


def charge_scene_image(width: int, height: int, kept_bytes: int, decoding_bytes: int) -> None:
    """Count an image about to be decoded against the scene's budget (`kept_bytes` a texel once
    decoded, `decoding_bytes` at most while it decodes), or raise ImageRefused first. Textures and
    glTF images through read_image; the HDR environment through hdr.read_hdr, at its own sizes."""
    budget = _SCENE_IMAGES.get()
    if budget is None or budget.available is None:
        return
    texels = width * height
    if budget.kept + texels * decoding_bytes > budget.available:
        raise ImageRefused(
            f"images that fit in the machine's available memory once decoded ({budget.available / 2**20:,.1f} MiB "
            f"when the scene began loading; its images so far keep {budget.kept / 2**20:,.1f} MiB)",
            f"{width}x{height}, which takes {texels * decoding_bytes / 2**20:,.1f} MiB to decode (its header, "
            "read before decoding)")
    budget.kept += texels * kept_bytes


class ImageRefused(Exception):
    """An image that cannot be read as written: what was expected, and what the image is (the
    callers put the file's name or the glTF image's between them)."""

    def __init__(self, expected: str, got: str) -> None:
        super().__init__(f"expected {expected}, got {got}")
        self.expected, self.got = expected, got


def read_image(file: Path | bytes) -> np.ndarray:
    """The texels of an image file, or of its bytes (a glTF buffer view, a data URI), its size
    read from its header and checked against MAX_TEXELS before a pixel is decoded (Pillow's `open`
    reads the header alone)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)  # MAX_TEXELS is below it
            image = Image.open(file if isinstance(file, Path) else io.BytesIO(file))
    except UnidentifiedImageError:
        raise ImageRefused(DECODABLE, "data in no image format Pillow knows") from None
    except Image.DecompressionBombError as error:  # past Pillow's guard, which says the texels alone
        raise ImageRefused(_AT_MOST, _bomb_size(file, str(error))) from None
    except Exception as error:  # a plugin's own error on a damaged header (SyntaxError, ValueError...)
        raise ImageRefused(DECODABLE, f"a damaged file: {type(error).__name__}: {error}") from error
    with image:
        width, height = image.size
        if width * height > MAX_TEXELS:
            raise ImageRefused(_AT_MOST, f"{width}x{height}, {width * height:,} texels (its header, read before "
                                         "decoding)")
        _charge(width, height)
        return decode_image(image)


_AT_MOST = f"an image of at most {MAX_TEXELS:,} texels (8192x8192)"
_PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _bomb_size(file: Path | bytes, message: str) -> str:
    """What an image past Pillow's guard is: a PNG's width and height from its IHDR chunk (the
    first, at byte 16), or the texels Pillow's message counts."""
    if isinstance(file, Path):
        with open(file, "rb") as opened:
            head = opened.read(24)
    else:
        head = file[:24]
    if head.startswith(_PNG_MAGIC) and len(head) == 24:
        width, height = struct.unpack(">II", head[16:24])
        return f"{width}x{height}, {width * height:,} texels (its header, read before decoding)"
    texels = re.search(r"\((\d+) pixels\)", message)
    return f"one of {int(texels[1]):,} texels (its header, read before decoding)" if texels else message


def decode_image(image: Image.Image) -> np.ndarray:
    """The image's (H, W, 4) uint8 sRGB RGBA texels, read-only; `ImageRefused` where it cannot be
    read as written (its mode, its values, or a damaged file: Pillow decodes lazily, so a broken
    file may open and fail here)."""
    source_bits = _sample_bits(image)  # read before load(), which forgets how the file stores samples
    try:
        image.load()
        pixels = _rgba(image, source_bits)
    except ImageRefused:
        raise
    except Exception as error:  # Pillow's decoders raise OSError, SyntaxError, EOFError, ValueError...
        raise ImageRefused(DECODABLE, f"a damaged file: {type(error).__name__}: {error}") from error
    pixels.flags.writeable = False
    return pixels


def _sample_bits(image: Image.Image) -> int:
    """The bits per sample the file stores, where its raw mode says (PNG's "L;2", "RGB;16B"), else 8."""
    tile = getattr(image, "tile", None) or []
    raw = tile[0].args if tile and isinstance(tile[0].args, str) else ""
    for bits in (16, 4, 2, 1):
        if raw.endswith((f";{bits}", f";{bits}B", f";{bits}L", f";{bits}N")):
            return bits
    return 8


def _rgba(image: Image.Image, source_bits: int) -> np.ndarray:
    mode = image.mode
    if mode in GREY_16:
        return _grey_16(image)
    if mode == "F":
        return _linear_float(image)
    if mode not in CONVERTED:
        raise ImageRefused("an image of 8- or 16-bit samples or 32-bit float ones",
                           REFUSED.get(mode, f"Pillow's mode {mode!r}, which has no exact conversion to sRGB"))
    key = image.info.get("transparency")
    if mode in ("L", "RGB") and key is not None and source_bits != 8:
        image = image.copy()
        # A 16-bit RGB key is matched on the high bytes Pillow keeps: exact but for colours within
        # 1/256 of the key, which a colour key rarely has beside it.
        image.info["transparency"] = _grey_key(key, source_bits) if mode == "L" else tuple(int(v) >> 8 for v in key)
    return np.asarray(image.convert("RGBA"), dtype=np.uint8).copy()


def _grey_key(key: int, bits: int) -> int:
    """A greyscale PNG's transparent value (tRNS) at the scale of Pillow's 8-bit samples. Pillow
    scales 1-, 2- and 4-bit samples to 0..255 but compares them with the key as the file writes it
    (so a 2-bit key of 1 matched nothing)."""
    return int(key) * 255 // ((1 << bits) - 1)


def _grey_16(image: Image.Image) -> np.ndarray:
    """16-bit greyscale: each sample scaled by 255 / 65535 and rounded (not clipped at 255); a
    transparent value (tRNS) gives alpha 0 where a sample equals it exactly."""
    samples = np.asarray(image).astype(np.float64)
    grey = np.rint(samples * (255.0 / 65535.0)).astype(np.uint8)
    alpha = np.full(grey.shape, 255, np.uint8)
    key = image.info.get("transparency")
    if isinstance(key, int):
        alpha[samples == key] = 0
    return np.stack([grey, grey, grey, alpha], axis=-1)


def _linear_float(image: Image.Image) -> np.ndarray:
    """32-bit float greyscale, linear light in [0, 1], as its sRGB encoding."""
    samples = np.asarray(image).astype(np.float64)
    if not np.isfinite(samples).all():
        raise ImageRefused("float samples that are finite", "NaN or infinity")
    low, high = (float(samples.min()), float(samples.max())) if samples.size else (0.0, 0.0)
    if low < 0.0 or high > 1.0:
        raise ImageRefused("float samples in [0, 1] (linear light: an albedo reflects at most all the light)",
                           f"values from {low:g} to {high:g}")
    grey = np.rint(encode_srgb(samples) * 255.0).astype(np.uint8)
    return np.stack([grey, grey, grey, np.full(grey.shape, 255, np.uint8)], axis=-1)
