"""GPU copies of the scene's image textures, in any number, where texture_layout.py puts them.

- Rasterized fragments (the eye's diffuse pass, every bake) sample at most MATERIAL_ARRAYS
  GL_SRGB8_ALPHA8 texture arrays with mipmaps, so that the GPU decodes texels to linear before it
  filters (moderngl's texture_array takes no internal format: its storage is specified again here
  through glTexImage3D). Array k is bound on two units: MATERIAL_ARRAY_k with a repeating sampler
  object and MATERIAL_ARRAY_CLAMPED_k with a clamping one. A texture's wrap modes cannot be state
  of an array it shares: one that repeats on both axes is sampled through the repeating sampler
  with its UV as it is (GL's own wrap and filter: what a texture of its own gave, bit for bit); any
  other through the clamping sampler, its UV folded in the shader (a mirrored repeat's fold then
  clamping is exactly GL's mirrored repeat at every mip level: lib/material_texture.glsl).
- Traced rays read every image's level 0 from one GL_RGBA8UI atlas on MATERIAL_TEXELS and decode
  it through an exact table (textures.py's comparison rule).
- One uniform buffer holds every slot's record (constants.TEXTURE_RECORD: array, layer, wraps,
  atlas rectangle), bound on UniformBlock.TEXTURE_RECORDS: a block sized by the scene's count
  (TEXTURE_COUNT), not a texture, because the mirror shader already samples the 16 textures a
  fragment shader is sure to have (tests/test_bindings.py); its limit is GL_MAX_UNIFORM_BLOCK_SIZE
  (16 KiB at least: 512 textures; gpu/limits.py checks it).
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass

import moderngl
import numpy as np

from .bindings import TextureUnit, UniformBlock
from .context import gl_function
from ..errors import GpuLimitError
from ..scene.model import Scene, Texture
from ..texture_layout import TextureLayout, texture_layout
from ..textures import resample

#: GL_SRGB8_ALPHA8: 8-bit sRGB colour, linear alpha (moderngl exports no name for it).
GL_SRGB8_ALPHA8 = 0x8C43
GL_RGBA8 = 0x8058
GL_TEXTURE_2D_ARRAY, GL_RGBA, GL_UNSIGNED_BYTE = 0x8C1A, 0x1908, 0x1401


def array_unit(array: int, clamped: bool) -> int:
    """The texture unit of texture array `array` with its repeating or its clamping sampler."""
    first = TextureUnit.MATERIAL_ARRAY_CLAMPED_0 if clamped else TextureUnit.MATERIAL_ARRAY_0
    return int(first) + array


def _srgb_array(ctx: moderngl.Context, layers: np.ndarray, unit: int, srgb: bool = True) -> moderngl.TextureArray:
    """An sRGB texture array of `layers` ((n, H, W, 4) uint8, row 0 of each the top: v = 0 is the
    image's top, glTF's convention), with mipmaps, left bound on `unit`; `srgb` False: a GL_RGBA8
    array of data (its texels sampled as stored)."""
    count, height, width = layers.shape[:3]
    array = ctx.texture_array((width, height, count), 4, dtype="f1")
    address = gl_function(ctx, "glTexImage3D")
    if not address:
        raise GpuLimitError(f"{ctx.info['GL_RENDERER']}: no glTexImage3D entry point found for an sRGB texture array")
    tex_image_3d = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_int,
                                    ctypes.c_int, ctypes.c_int, ctypes.c_uint, ctypes.c_uint, ctypes.c_void_p)(address)
    data = np.ascontiguousarray(layers)
    array.use(unit)  # glTexImage3D acts on the array bound to the active unit
    tex_image_3d(GL_TEXTURE_2D_ARRAY, 0, GL_SRGB8_ALPHA8 if srgb else GL_RGBA8, width, height, count, 0, GL_RGBA,
                 GL_UNSIGNED_BYTE,
                 data.ctypes.data)
    array.build_mipmaps()
    return array


def _atlas(ctx: moderngl.Context, layout: TextureLayout) -> moderngl.Texture:
    """Every image's level 0 in its rectangle, as GL_RGBA8UI: texelFetch alone reads it (no
    filter; the shader wraps)."""
    width, height = layout.atlas_size
    if len(layout.images) == 1 and layout.images[0].shape[1::-1] == (width, height):
        atlas = np.ascontiguousarray(layout.images[0])  # the atlas is the one image: no copy of it
    else:
        atlas = np.zeros((height, width, 4), np.uint8)
        for image, (x, y, w, h) in zip(layout.images, layout.texel_rects, strict=True):
            atlas[y:y + h, x:x + w] = image
    texels = ctx.texture((width, height), 4, atlas.data, dtype="u1")  # a view, not tobytes(): no second copy
    texels.filter = (moderngl.NEAREST, moderngl.NEAREST)  # an integer texture is incomplete otherwise
    return texels


@dataclass
class _Made:
    """What one set of textures was made into."""

    textures: tuple[Texture, ...]
    arrays: list[moderngl.TextureArray]
    atlas: moderngl.Texture
    records: moderngl.Buffer

    def release(self) -> None:
        for array in self.arrays:
            array.release()
        self.atlas.release()
        self.records.release()


class GpuTextures:
    """Owns the uploaded textures (made when a frame first needs them, again when the scene's
    textures change) and binds them."""

    def __init__(self, ctx: moderngl.Context) -> None:
        self.ctx = ctx
        self._made: _Made | None = None
        self._samplers: tuple[moderngl.Sampler, moderngl.Sampler] | None = None

    def _sampler(self, repeat: bool) -> moderngl.Sampler:
        sampler = self.ctx.sampler(repeat_x=repeat, repeat_y=repeat,
                                   filter=(moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR), anisotropy=1.0)
        return sampler

    def _make(self, scene: Scene) -> _Made:
        layout = texture_layout(scene)
        arrays = []
        for k, array in enumerate(layout.arrays):
            width, height = array.size
            images = [image if image.shape[1::-1] == (width, height) else resample(image, array.size, array.srgb)
                      for image in (layout.images[i] for i in array.images)]
            # One layer goes up as it is (np.stack would copy it: 256 MiB for an 8192^2 image).
            layers = images[0][None] if len(images) == 1 else np.stack(images)
            arrays.append(_srgb_array(self.ctx, layers, array_unit(k, clamped=False), array.srgb))
        records = self.ctx.buffer(layout.records().tobytes())
        return _Made(scene.textures, arrays, _atlas(self.ctx, layout), records)

    def use(self, scene: Scene) -> None:
        """Bind the scene's textures, their atlas and records, making them first if they are not
        the ones made last."""
        if not scene.textures:
            return
        if self._made is not None and self._made.textures != scene.textures:
            self._made.release()
            self._made = None
        if self._made is None:
            self._made = self._make(scene)
        if self._samplers is None:
            self._samplers = (self._sampler(repeat=True), self._sampler(repeat=False))
        for k, array in enumerate(self._made.arrays):
            for clamped, sampler in zip((False, True), self._samplers, strict=True):
                array.use(array_unit(k, clamped))
                sampler.use(array_unit(k, clamped))
        self._made.atlas.use(TextureUnit.MATERIAL_TEXELS)
        self._made.records.bind_to_uniform_block(UniformBlock.TEXTURE_RECORDS)

    @staticmethod
    def bytes_for(scene: Scene) -> int:
        """GPU memory of the scene's textures: the arrays with every mip level, the atlas of
        level-0 copies and the records (texture_layout.py)."""
        return texture_layout(scene).bytes if scene.textures else 0

    def release(self) -> None:
        if self._made is not None:
            self._made.release()
            self._made = None
        if self._samplers is not None:
            for sampler in self._samplers:
                sampler.release()
            self._samplers = None
