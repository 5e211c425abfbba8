"""HDR images: environment maps read, float frames written.

Two well-kept libraries, one per format, each the reference or the most used reader of its format:
OpenEXR's own Python bindings (the Academy Software Foundation's; numpy in and out) for .exr, and
OpenCV for Radiance .hdr (RGBE), which OpenEXR does not read and Pillow does not either. (OpenCV
5's wheels no longer carry an EXR codec, and imageio reads .hdr only through OpenCV or a FreeImage
binary it downloads at run time.)

Images are (height, width, 3) float32 linear RGB, row 0 at the top.
"""

from __future__ import annotations

import ctypes
import io
import os
import re
import sys
from collections.abc import Iterator
from contextlib import contextmanager, redirect_stderr, redirect_stdout
from pathlib import Path
from typing import IO

import numpy as np

from .image_files import ImageRefused, charge_scene_image

#: The files an equirect environment and a float frame (`-o frame.exr`) may be.
HDR_SUFFIXES = (".hdr", ".exr")

_EXR_MAGIC = b"\x76\x2f\x31\x01"
_RADIANCE_MAGIC = b"#?"  # "#?RADIANCE" or "#?RGBE": the first line of every Radiance picture file

#: The largest side of an image read: GL 4.1 and later guarantee textures of 16384 texels a side.
MAX_SIDE = 16384
#: The most pixels an image may have, read from its header before it is decoded (8192 x 4096, an
#: equirect map's 2:1): 384 MiB as float32 RGB, which the decoders hold twice on the way.
MAX_PIXELS = 2**25
#: How much of a Radiance file its text header may take (real ones take a few hundred bytes).
_HEADER_BYTES = 2**16


class HdrImageError(ValueError):
    """A file that is not an HDR image this package reads; the message says why (no path: the
    caller names the file and the field)."""


def read_hdr(path: Path) -> np.ndarray:
    """A .hdr or .exr file's RGB as (height, width, 3) float32, row 0 at the top.

    Raises HdrImageError for a file that is not one (by its first bytes, not its name), that its
    library cannot decode, or whose pixels are not finite; OSError where it cannot be read."""
    with open(path, "rb") as file:
        header = file.read(_HEADER_BYTES)
    head = header[:4]
    if head == _EXR_MAGIC:
        _check_size(*_exr_size(path))
        image = _read_exr(path)
    elif head.startswith(_RADIANCE_MAGIC):
        _check_size(*_radiance_size(header))
        image = _read_radiance(path)
    else:
        raise HdrImageError("expected an HDR image (an OpenEXR .exr or a Radiance .hdr file), got a file that is "
                            f"neither (it starts with {head!r})")
    if image.shape[0] < 1 or image.shape[1] < 1:
        raise HdrImageError(f"expected an image of at least 1x1 pixels, got {image.shape[1]}x{image.shape[0]}")
    bad = ~np.isfinite(image)
    if bad.any():
        y, x, _ = np.argwhere(bad)[0]
        raise HdrImageError(f"expected finite pixel values, got {image[y, x].tolist()} at pixel ({x}, {y})")
    return np.ascontiguousarray(image, dtype=np.float32)


#: Bytes an environment's pixel is kept in (float32 RGB), and the most its decode holds at once (the
#: decoder's float32 image, RGBA for OpenEXR, beside the RGB copy made of it), charged to the scene's
#: image budget (image_files.scene_images_budget) with its textures.
KEPT_PIXEL_BYTES, DECODING_PIXEL_BYTES = 12, 28


def _check_size(width: int, height: int) -> None:
    if width < 1 or height < 1:
        raise HdrImageError(f"expected an image of at least 1x1 pixels, got {width}x{height} (its header)")
    if max(width, height) > MAX_SIDE or width * height > MAX_PIXELS:
        raise HdrImageError(f"expected an image of at most {MAX_SIDE} pixels a side and {MAX_PIXELS:,} in all "
                            f"(8192x4096), got {width}x{height} (its header, read before decoding)")
    try:
        charge_scene_image(width, height, KEPT_PIXEL_BYTES, DECODING_PIXEL_BYTES)
    except ImageRefused as refused:
        raise HdrImageError(str(refused)) from None


def _exr_size(path: Path) -> tuple[int, int]:
    """An OpenEXR file's width and height from its header's dataWindow (every OpenEXR file has
    one; a multi-part file's first part), the header read alone."""
    import OpenEXR

    try:
        with _quiet_descriptors(), OpenEXR.File(str(path), header_only=True) as exr:
            low, high = exr.header()["dataWindow"]
    except (RuntimeError, ValueError, KeyError, TypeError) as error:
        raise HdrImageError(f"expected a readable OpenEXR image, got one OpenEXR cannot decode ({error})") from None
    return int(high[0]) - int(low[0]) + 1, int(high[1]) - int(low[1]) + 1


_RADIANCE_SIZE = re.compile(rb"\n\r?\n([-+][XY]) +(\d+) +([-+][XY]) +(\d+)\r?\n")


def _radiance_size(header: bytes) -> tuple[int, int]:
    """A Radiance file's width and height from its resolution line ("-Y 512 +X 1024": rows first
    where the first axis is Y), which follows the blank line that ends its text header."""
    found = _RADIANCE_SIZE.search(header)
    if found is None:
        raise HdrImageError(f"expected a readable Radiance image, got one without a resolution line (such as "
                            f"\"-Y 512 +X 1024\") after its header in its first {_HEADER_BYTES} bytes")
    first, second = int(found[2]), int(found[4])
    return (second, first) if found[1].endswith(b"Y") else (first, second)


@contextmanager
def _quiet_descriptors() -> Iterator[None]:
    """File descriptors 1 and 2 sent to /dev/null: OpenEXR's C++ core writes its own lines about a
    damaged file (to stdout and stderr: stdout may be the PNG being written, `-o /dev/stdout`),
    which the HdrImageError says once, in the package's words. (C's buffers are flushed on the way
    out, where the C++ streams write: a line left in them would be written after the restore. The
    bindings' own warning goes through Python's sys.stdout, which is not always descriptor 1.)"""
    sys.stdout.flush(), sys.stderr.flush()
    saved = [os.dup(fd) for fd in (1, 2)]
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        for fd in (1, 2):
            os.dup2(null, fd)
        with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()):
            yield
    finally:
        ctypes.CDLL(None).fflush(None)
        for fd, copy in zip((1, 2), saved, strict=True):
            os.dup2(copy, fd)
            os.close(copy)
        os.close(null)


def _read_exr(path: Path) -> np.ndarray:
    import OpenEXR

    try:
        with _quiet_descriptors(), OpenEXR.File(str(path)) as exr:
            channels = exr.channels()
            # The bindings group R, G, B (and A) into one "RGB" or "RGBA" channel of (h, w, n) pixels.
            for name in ("RGB", "RGBA"):
                if name in channels:
                    return np.asarray(channels[name].pixels, dtype=np.float32)[..., :3]
            if "Y" in channels:  # a luminance image: grey
                grey = np.asarray(channels["Y"].pixels, dtype=np.float32)
                return np.repeat(grey[..., None], 3, axis=2)
    except (RuntimeError, ValueError) as error:  # the library's words for a damaged or truncated file
        raise HdrImageError(f"expected a readable OpenEXR image, got one OpenEXR cannot decode ({error})") from None
    raise HdrImageError(f"expected an OpenEXR image with R, G and B (or Y) channels, got {sorted(channels)}")


def _read_radiance(path: Path) -> np.ndarray:
    import cv2
    from cv2.utils import logging as cv2_logging

    # OpenCV answers a file it cannot decode with None, after logging its own error to stderr: this
    # function's HdrImageError says it once, in the package's words.
    level = cv2_logging.getLogLevel()
    cv2_logging.setLogLevel(cv2_logging.LOG_LEVEL_SILENT)
    try:
        image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    except cv2.error:  # its own limits (a side past 2^20...): the file cannot be read as written
        image = None
    finally:
        cv2_logging.setLogLevel(level)
    if image is None or image.dtype != np.float32 or image.ndim != 3 or image.shape[2] != 3:
        raise HdrImageError("expected a readable Radiance image, got one OpenCV cannot decode")
    return image[..., ::-1]  # OpenCV's BGR


def write_hdr(file: IO[bytes], image: np.ndarray, suffix: str) -> None:
    """Write a (height, width, 3) float image (row 0 at the top) into `file` as `suffix` (.exr:
    32-bit float, ZIP-compressed, lossless; .hdr: Radiance RGBE, 8-bit mantissas with a shared
    exponent, about 1 % precision, no negative values)."""
    pixels = np.ascontiguousarray(image, dtype=np.float32)
    if suffix.lower() == ".exr":
        import OpenEXR

        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
        buffer = io.BytesIO()
        with OpenEXR.File(header, {"RGB": pixels}) as exr:
            exr.write(buffer)
        file.write(buffer.getvalue())
    elif suffix.lower() == ".hdr":
        import cv2

        ok, encoded = cv2.imencode(".hdr", np.ascontiguousarray(np.maximum(pixels, 0.0)[..., ::-1]))
        if not ok:
            raise ValueError("OpenCV could not encode the image as Radiance .hdr")
        file.write(encoded.tobytes())
    else:
        raise ValueError(f"expected one of {HDR_SUFFIXES}, got {suffix!r}")
