"""GPU copies of the scene's image textures: sRGB, mipmapped, trilinear, the sampler's wrap modes.

Each `Texture` (by identity) is uploaded once, as GL_SRGB8_ALPHA8 so that the GPU decodes its
texels to linear before filtering (moderngl has no sRGB flag; `ctx.texture` takes the internal
format). Texture slot k of the scene (Scene.textures) is bound on TextureUnit.MATERIAL_TEXTURE_0
+ k for every frame: the diffuse pass, every bake, and the traced methods' shader all read it
there (passes/uniforms.write_textures points their samplers at those units); every slot's level 0 as
8-bit integers, stacked in one texture on MATERIAL_TEXELS, which traced rays decode through an
exact table (material_texture.glsl).
"""

from __future__ import annotations

import ctypes

import moderngl
import numpy as np

from .bindings import TextureUnit
from ..constants import MAX_TEXTURES, Wrap
from .context import gl_function
from ..errors import GpuLimitError
from ..scene.model import Scene, Texture
from ..textures import texel_rects

#: GL_SRGB8_ALPHA8: 8-bit sRGB colour, linear alpha (moderngl exports no name for it).
GL_SRGB8_ALPHA8 = 0x8C43

_REPEAT_X = {Wrap.REPEAT: True, Wrap.CLAMP_TO_EDGE: False, Wrap.MIRRORED_REPEAT: True}


GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T = 0x0DE1, 0x2802, 0x2803


def _set_wrap(ctx: moderngl.Context, gpu: moderngl.Texture, wrap_s: Wrap, wrap_t: Wrap) -> None:
    """Both wrap modes set through glTexParameteri (on the texture bound to its slot-0 unit, which
    GpuTextures.use binds again before any draw), for the mode moderngl cannot set."""
    address = gl_function(ctx, "glTexParameteri")
    if not address:
        raise GpuLimitError(f"{ctx.info['GL_RENDERER']}: no glTexParameteri entry point found for a mirrored-repeat "
                            f"texture")
    tex_parameter = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_uint, ctypes.c_int)(address)
    gpu.use(texture_unit(0))
    tex_parameter(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, int(wrap_s))
    tex_parameter(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, int(wrap_t))


def texture_unit(slot: int) -> int:
    """The texture unit of the scene's texture slot `slot` (< MAX_TEXTURES: scene/limits.py)."""
    return int(TextureUnit.MATERIAL_TEXTURE_0) + slot


class GpuTextures:
    """Owns the uploaded textures (made when a frame first needs them) and binds a scene's."""

    def __init__(self, ctx: moderngl.Context) -> None:
        self.ctx = ctx
        # Keyed by the texture itself (identity: Texture has eq=False), which keeps it alive.
        self._textures: dict[Texture, moderngl.Texture] = {}
        # Every texture's level 0 as 8-bit integers, stacked (textures.texel_rects), for the
        # textures it was made of (traced rays decode these exactly).
        self._texels: tuple[tuple[Texture, ...], moderngl.Texture] | None = None

    def _upload(self, texture: Texture) -> moderngl.Texture:
        height, width = texture.image.shape[:2]
        # Row 0 of the image (its top) goes first: texture coordinate v = 0 is the image's top,
        # glTF's convention, with no flip anywhere.
        gpu = self.ctx.texture((width, height), 4, texture.image.tobytes(), internal_format=GL_SRGB8_ALPHA8)
        gpu.build_mipmaps()
        gpu.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)  # trilinear
        gpu.anisotropy = 1.0
        wrap_s, wrap_t = (Wrap(mode) for mode in texture.wrap)
        gpu.repeat_x, gpu.repeat_y = _REPEAT_X[wrap_s], _REPEAT_X[wrap_t]
        # moderngl's repeat flags know REPEAT and CLAMP_TO_EDGE alone: a mirrored one is set in GL.
        if Wrap.MIRRORED_REPEAT in (wrap_s, wrap_t):
            _set_wrap(self.ctx, gpu, wrap_s, wrap_t)
        return gpu

    def _texel_stack(self, scene: Scene) -> moderngl.Texture:
        """Level 0 of each of the scene's textures, stacked top to bottom as texel_rects says,
        as GL_RGBA8UI: texelFetch alone reads it (no filter; the shader wraps)."""
        textures = scene.textures[:MAX_TEXTURES]
        if self._texels is not None and self._texels[0] == textures:
            return self._texels[1]
        if self._texels is not None:
            self._texels[1].release()
        rects = texel_rects(scene)
        width, height = int(rects[:, 2].max()), int((rects[:, 1] + rects[:, 3]).max())
        limit = self.ctx.info["GL_MAX_TEXTURE_SIZE"]
        if height > limit:
            raise GpuLimitError(f"the scene's textures stack to {height} texel rows for traced rays, over this GL's "
                                f"limit of {limit} ({self.ctx.info['GL_RENDERER']}): use fewer or smaller images")
        stack = np.zeros((height, width, 4), np.uint8)
        for texture, (x, y, w, h) in zip(textures, rects[: len(textures)], strict=True):
            stack[y:y + h, x:x + w] = texture.image
        texels = self.ctx.texture((width, height), 4, stack.tobytes(), dtype="u1")
        texels.filter = (moderngl.NEAREST, moderngl.NEAREST)  # an integer texture is incomplete otherwise
        self._texels = (textures, texels)
        return texels

    def use(self, scene: Scene) -> None:
        """Bind the scene's textures on their units, uploading those not yet on the GPU."""
        for slot, texture in enumerate(scene.textures[:MAX_TEXTURES]):
            if texture not in self._textures:
                self._textures[texture] = self._upload(texture)
            self._textures[texture].use(texture_unit(slot))
        if scene.textures:
            self._texel_stack(scene).use(TextureUnit.MATERIAL_TEXELS)

    @staticmethod
    def bytes_for(scene: Scene) -> int:
        """GPU memory of the scene's textures: 4 bytes a texel, a third more for the mipmaps, and
        the stack of level 0 copies (as wide as the widest)."""
        if not scene.textures:
            return 0
        rects = texel_rects(scene)
        stack = int(rects[:, 2].max()) * int((rects[:, 1] + rects[:, 3]).max()) * 4
        return stack + sum(texture.image.shape[0] * texture.image.shape[1] * 4 * 4 // 3 for texture in scene.textures)

    def release(self) -> None:
        for texture in self._textures.values():
            texture.release()
        self._textures.clear()
        if self._texels is not None:
            self._texels[1].release()
            self._texels = None
