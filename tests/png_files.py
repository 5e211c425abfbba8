"""PNG files of any bit depth and colour type, written here byte by byte (Pillow writes no 16-bit
RGB, no 2-bit grey with a transparent value): what image_files.py must read as written."""

from __future__ import annotations

import struct
import zlib

import numpy as np

GREY, RGB, PALETTE, GREY_ALPHA, RGBA = 0, 2, 3, 4, 6


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def png(samples: np.ndarray, colour_type: int, depth: int, transparent: bytes | None = None,
        palette: bytes | None = None) -> bytes:
    """A PNG of (H, W) or (H, W, C) integer `samples` at `depth` bits (1, 2, 4 packed along each row;
    16 big-endian); `transparent` the tRNS chunk's bytes, `palette` the PLTE chunk's."""
    samples = np.asarray(samples)
    height, width = samples.shape[:2]
    if depth < 8:
        bits = np.unpackbits(samples.astype(np.uint8).reshape(height, width, 1), axis=2)[:, :, 8 - depth:]
        rows = np.packbits(bits.reshape(height, -1), axis=1)
    else:
        rows = samples.astype(">u2" if depth == 16 else np.uint8).reshape(height, -1).view(np.uint8)
    raw = b"".join(b"\0" + row.tobytes() for row in rows)
    header = struct.pack(">IIBBBBB", width, height, depth, colour_type, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", header) + (_chunk(b"PLTE", palette) if palette else b"")
            + (_chunk(b"tRNS", transparent) if transparent is not None else b"")
            + _chunk(b"IDAT", zlib.compress(raw)) + _chunk(b"IEND", b""))


def damaged(data: bytes) -> bytes:
    """The PNG with its pixel data cut short: its header reads, its pixels do not."""
    start = data.index(b"IDAT") + 4
    return data[:start + 4] + b"\0" * 8
