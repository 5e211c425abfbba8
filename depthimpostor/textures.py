"""Image textures on the CPU: decoding images into `Texture`s, and the numpy sampling the truth
uses, the same algorithm as shaders/lib/material_texture.glsl's `material_texel_rgba` for traced rays.

The comparison rule. The rasterized passes (the camera view and every baked image) sample with
mipmaps and trilinear filtering, as a renderer should. The ray-traced paths (triangles.glsl, the
analytic planes) cannot: a reflected ray has no screen-space derivatives to choose a mip level
from. They filter level 0 bilinearly, in the shader, from four texelFetch reads of the 8-bit
texels decoded through one exact sRGB table (SRGB_TABLE: a GPU's own decode may be approximate,
llvmpipe's by up to 0.0012), with weights computed in float32 rather than by the texture unit,
whose sub-texel weights have as few as 8 bits on common hardware. The truth does exactly that in
numpy, so raytrace against the truth differs by float rounding alone; the depth-image methods
show their baked, trilinearly filtered (and GPU-decoded) colours and differ by that too.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
from PIL import Image

from .colour import encode_srgb
from .constants import Wrap
from .image_files import ImageRefused, read_image
from .scene.fields import At
from .scene.model import Texture


def srgb_to_linear(encoded: np.ndarray) -> np.ndarray:
    """The sRGB transfer function undone (IEC 61966-2-1), for values in [0, 1]."""
    return np.where(encoded <= 0.04045, encoded / 12.92, ((encoded + 0.055) / 1.055) ** 2.4)


#: Every 8-bit sRGB value decoded, in float32: the traced rays' decode table (material_texture.glsl).
SRGB_TABLE = srgb_to_linear(np.arange(256) / 255.0).astype(np.float32)
#: The same in float64, for a texture's mean colour.
_DECODED = srgb_to_linear(np.arange(256) / 255.0)


def texture_from_pixels(pixels: np.ndarray, sampler: dict[str, int], scale: tuple[float, float] = (1.0, 1.0),
                        name: str = "") -> Texture:
    """A Texture of decoded (H, W, 4) uint8 sRGB RGBA texels, row 0 the top (image_files.py);
    `name` what messages call it."""
    # The mean of the decoded texels, summed by value: each channel's 256 counts times the decoded
    # values. (Decoding every texel in float64 took 8 bytes a sample and four temporaries: 6 GB
    # for an 8192^2 image; np.bincount widens each sample to 8 bytes too, 2.7 s there. OpenCV
    # counts uint8 in place, in integers, and hands the counts over as float32: exact to 2^24 a
    # value, within 6e-8 of it beyond, which a mean colour cannot show.)
    texels = max(pixels.shape[0] * pixels.shape[1], 1)
    contiguous = np.ascontiguousarray(pixels)
    r, g, b = (float(cv2.calcHist([contiguous], [c], None, [256], [0, 256]).ravel().astype(np.float64) @ _DECODED
                     / texels) for c in range(3))
    return Texture(pixels, sampler, (r, g, b), scale, name)


#: A file's stamp: what tells its bytes changed without reading them (the modification time to the
#: nanosecond, and the size, for file systems whose clocks tick in seconds).
FileStamp = tuple[int, int]
# One decoded image (and its mean colour) per file, whatever the scales and wraps of the slots that
# share it (decoding an 8192^2 image twice cost seconds and 256 MiB), and one Texture per (file,
# scale, wrap) so that objects sharing an image share a slot. Keyed by the file alone, with its
# stamp beside: a file edited while the viewer runs replaces its entries instead of leaving the old
# image's pixels held beside the new ones.
_DECODED_FILES: dict[Path, tuple[FileStamp, Texture]] = {}
_CACHE: dict[tuple[Path, tuple[float, float], tuple[int, int]], tuple[FileStamp, Texture]] = {}


def read_texture(path: Path, at: At, scale: tuple[float, float], wrap: tuple[int, int]) -> Texture:
    """The image file at `path` (PNG, JPEG, anything image_files.py reads as written) as a texture,
    one Texture per (file as it is now, scale, wrap); a file that is missing, is not an image or
    holds what cannot be read as written is refused at `at`."""
    try:
        resolved = path.resolve(strict=True)
        status = resolved.stat()
    except OSError:
        raise at.error(f"expected an existing image file, got {str(path)!r}: not found") from None
    stamp = (status.st_mtime_ns, status.st_size)
    key = (resolved, scale, wrap)
    cached = _CACHE.get(key)
    if cached is not None and cached[0] == stamp:
        return cached[1]
    decoded_entry = _DECODED_FILES.get(resolved)
    if decoded_entry is None or decoded_entry[0] != stamp:
        try:
            pixels = read_image(resolved)
        except ImageRefused as refused:
            raise at.error(f"expected {refused.expected}, got {str(path)!r}: {refused.got}") from None
        decoded_entry = (stamp, texture_from_pixels(pixels, {}, name=resolved.name))
        _DECODED_FILES[resolved] = decoded_entry
    decoded = decoded_entry[1]
    texture = Texture(decoded.image, {"wrapS": wrap[0], "wrapT": wrap[1]}, decoded.mean_color, scale, decoded.name)
    _CACHE[key] = (stamp, texture)
    return texture


def resample(image: np.ndarray, size: tuple[int, int], srgb: bool = True) -> np.ndarray:
    """An (H, W, 4) sRGB image resampled to `size` (width, height) for a texture array's layer
    (texture_layout.py): its colour in linear light (decoded, filtered, encoded again: filtering the
    encoded values would darken edges between light and dark), its alpha as it is, each channel by
    Pillow's Lanczos filter (3 lobes: sharp, little ringing; its overshoot is clipped). `srgb`
    False: data (a metallic-roughness map), filtered as stored."""
    if not srgb:
        channels = [image[..., c].astype(np.float32) / 255.0 for c in range(4)]
        filtered = np.stack([np.asarray(Image.fromarray(np.ascontiguousarray(channel), mode="F")
                                        .resize(size, Image.Resampling.LANCZOS)) for channel in channels], axis=-1)
        return np.asarray(np.rint(np.clip(filtered, 0.0, 1.0) * 255.0), np.uint8)
    linear = SRGB_TABLE[image[..., :3]]
    channels = [linear[..., c] for c in range(3)] + [image[..., 3].astype(np.float32) / 255.0]
    filtered = np.stack([np.asarray(Image.fromarray(np.ascontiguousarray(channel), mode="F")
                                    .resize(size, Image.Resampling.LANCZOS)) for channel in channels], axis=-1)
    filtered = np.clip(filtered, 0.0, 1.0)
    encoded = np.concatenate([encode_srgb(filtered[..., :3]), filtered[..., 3:]], axis=-1)
    return np.asarray(np.rint(encoded * 255.0), np.uint8)


def wrap_texels(index: np.ndarray, size: int, mode: int) -> np.ndarray:
    """Integer texel coordinates brought into [0, size) by a wrap mode (the GL rules)."""
    if mode == Wrap.CLAMP_TO_EDGE:
        return np.clip(index, 0, size - 1)
    if mode == Wrap.MIRRORED_REPEAT:
        period = np.mod(index, 2 * size)
        return np.where(period < size, period, 2 * size - 1 - period)
    return np.mod(index, size)


def texture_bilinear(texture: Texture, uvs: np.ndarray) -> np.ndarray:
    """The texture's linear RGB at (n, 2) UVs (before its transform, Texture.uv_rows): level 0,
    bilinear, its wrap modes: material_texture.glsl's material_texel for traced rays in numpy."""
    rgb = texture.image[..., :3]
    decoded = SRGB_TABLE[rgb] if texture.srgb else rgb.astype(np.float32) / np.float32(255.0)
    return _bilinear(texture, decoded.astype(np.float64), uvs)


def texture_alpha_bilinear(texture: Texture, uvs: np.ndarray) -> np.ndarray:
    """The texture's alpha (linear, in [0, 1]) at (n, 2) UVs, as texture_bilinear samples colours:
    material_texture.glsl's material_texel_rgba(...).a for traced rays."""
    return _bilinear(texture, texture.image[..., 3:4].astype(np.float64) / 255.0, uvs)[:, 0]


def _bilinear(texture: Texture, texels: np.ndarray, uvs: np.ndarray) -> np.ndarray:
    """(n, channels) bilinear samples of `texels` ((height, width, channels) float64, the texture's
    level 0 decoded) at UVs placed by the texture's transform, with its wrap modes."""
    height, width = texels.shape[:2]
    (a, b, c), (d, e, f) = texture.uv_rows
    placed = np.stack([uvs[:, 0] * a + uvs[:, 1] * b + c, uvs[:, 0] * d + uvs[:, 1] * e + f], axis=1)
    x = placed * (width, height) - 0.5  # texel centres at half-integers
    base = np.floor(x)
    fraction = x - base
    i0, j0 = base[:, 0].astype(np.int64), base[:, 1].astype(np.int64)
    wrap_s, wrap_t = texture.wrap
    columns = [wrap_texels(i0 + k, width, wrap_s) for k in (0, 1)]
    rows = [wrap_texels(j0 + k, height, wrap_t) for k in (0, 1)]
    fx, fy = fraction[:, 0:1], fraction[:, 1:2]
    top = texels[rows[0], columns[0]] * (1 - fx) + texels[rows[0], columns[1]] * fx
    bottom = texels[rows[1], columns[0]] * (1 - fx) + texels[rows[1], columns[1]] * fx
    return np.asarray(top * (1 - fy) + bottom * fy)
