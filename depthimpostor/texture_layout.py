"""Where each of a scene's image textures lives on the GPU, decided before any GL object exists:
the plan sizes it (GpuTextures.bytes_for) and checks it against the GL's limits (gpu/limits.py),
and gpu/textures.py makes what it says.

Rasterized passes (the eye's diffuse pass, every bake) sample mipmapped sRGB texture arrays, at
most MATERIAL_ARRAYS of them whatever the number of textures: the 16 samplers a fragment shader
is sure to have are spent on a fixed few arrays, not one unit per texture. Every layer of an array
has one size, so the scene's distinct images are grouped by size: with at most MATERIAL_ARRAYS
distinct sizes each size is an array and every image goes in unchanged (the shipped scenes' frames
are what they were with one texture a unit). With more, the two groups whose merging adds the
fewest texels are merged, again and again, into a group whose layers are as wide and as high as
its widest and highest image: an image smaller than its layer is resampled up to it (in linear
light, Lanczos: textures.resample), never down, so no detail is lost; the cost is memory (the
smaller image's texels times the ratio) and a slightly smoother magnified image than the truth's
bilinear level 0 (docs/scene_format.md).

Traced rays read level 0 of every image, unchanged, from one 8-bit integer atlas (texelFetch,
decoded through an exact table: textures.py), the images packed on shelves (tallest first) in an
atlas about as wide as it is high, so that dozens fit within GL_MAX_TEXTURE_SIZE.

Identical images (the same file under two `scale`s or wraps: two texture slots) share a layer and
a rectangle; the slots' records (constants.TEXTURE_RECORD, one table) differ in their wraps.
"""

from __future__ import annotations

import collections
import functools
import hashlib
from dataclasses import dataclass

import numpy as np

from .constants import MATERIAL_ARRAYS, TEXTURE_RECORD, Wrap
from .scene.model import Scene, Texture

#: Bytes of one texel in the arrays (GL_SRGB8_ALPHA8) and in the traced rays' atlas (RGBA8UI).
TEXEL_BYTES = 4


def mip_chain_texels(width: int, height: int) -> int:
    """Texels of a level 0 of width x height and all its mip levels down to 1x1."""
    levels = max(width, height).bit_length()
    return sum(max(1, width >> m) * max(1, height >> m) for m in range(levels))


@dataclass(frozen=True)
class ArrayLayout:
    """One texture array: the size of its layers and the images (indices into
    TextureLayout.images) on them, layer by layer."""

    size: tuple[int, int]  # (width, height)
    images: tuple[int, ...]
    srgb: bool = True  # GL_SRGB8_ALPHA8 (colour); False: GL_RGBA8 (data: metallic-roughness, occlusion)

    @property
    def bytes(self) -> int:
        return mip_chain_texels(*self.size) * len(self.images) * TEXEL_BYTES


@dataclass(frozen=True)
class TextureLayout:
    """A scene's textures on the GPU: `textures` in slot order, the distinct `images` they show
    (`image_of[slot]`), the arrays and each image's (array, layer) `places`, and each image's level-0
    rectangle (x, y, width, height) in the traced rays' atlas of `atlas_size`."""

    textures: tuple[Texture, ...]
    images: tuple[np.ndarray, ...]
    image_of: tuple[int, ...]
    arrays: tuple[ArrayLayout, ...]
    places: tuple[tuple[int, int], ...]
    texel_rects: np.ndarray  # (images, 4) int32
    atlas_size: tuple[int, int]  # (width, height)

    def records(self) -> np.ndarray:
        """The TextureRecords block: one constants.TEXTURE_RECORD a texture slot."""
        records = np.zeros(len(self.textures), TEXTURE_RECORD.dtype)
        for slot, texture in enumerate(self.textures):
            image = self.image_of[slot]
            records["sampling"][slot] = (*self.places[image], *texture.wrap)
            records["texels"][slot] = self.texel_rects[image]
            records["uv_u"][slot], records["uv_v"][slot] = texture.uv_rows
            records["srgb"][slot] = int(texture.srgb)
            records["uv_set"][slot] = texture.uv_set
        return records

    @property
    def resampled(self) -> tuple[int, ...]:
        """The images whose size is not their layer's (resampled when uploaded)."""
        return tuple(image for image, (array, _) in enumerate(self.places)
                     if self.images[image].shape[1::-1] != self.arrays[array].size)

    @property
    def records_bytes(self) -> int:
        return len(self.textures) * TEXTURE_RECORD.dtype.itemsize

    @property
    def atlas_bytes(self) -> int:
        return self.atlas_size[0] * self.atlas_size[1] * TEXEL_BYTES

    @property
    def bytes(self) -> int:
        """GPU memory of it all: the arrays with their mipmaps, the atlas and the records."""
        return sum(array.bytes for array in self.arrays) + self.atlas_bytes + self.records_bytes

    def summary(self) -> str:
        """One line for `plan`: the arrays, what was resampled, the atlas, and the GL limits that apply."""
        def count(n: int, noun: str) -> str:
            return f"{n} {noun}{'s' * (n != 1)}"
        arrays = ", ".join(f"{len(a.images)} of {a.size[0]}x{a.size[1]}" for a in self.arrays)
        resampled = f", {len(self.resampled)} resampled up to their array's size" if self.resampled else ""
        return (f"textures: {count(len(self.textures), 'texture')} of {count(len(self.images), 'distinct image')} in "
                f"{count(len(self.arrays), 'array')} ({arrays}){resampled}; their level 0 in a "
                f"{self.atlas_size[0]}x{self.atlas_size[1]} atlas for traced rays; checked against GL_MAX_TEXTURE_SIZE, "
                "GL_MAX_ARRAY_TEXTURE_LAYERS and GL_MAX_UNIFORM_BLOCK_SIZE")

    def slot_of_image(self, image: int) -> int:
        """The first texture slot that shows `image` (messages name a texture by its slot)."""
        return self.image_of.index(image)


def _distinct_images(textures: tuple[Texture, ...]) -> tuple[tuple[np.ndarray, ...], tuple[int, ...], tuple[bool, ...]]:
    """The distinct images (by content and colour space) in order of first use, each slot's, and
    whether each image is colour (sRGB) or data."""
    # Only images that share a shape and a colour space can be equal: the others are never hashed
    # (hashing an 8192^2 image took a second), nor is an array met before under another slot.
    shapes = collections.Counter((texture.image.shape, texture.srgb) for texture in textures)
    index: dict[tuple[tuple[int, ...], bytes | int, bool], int] = {}
    seen: dict[tuple[int, bool], int] = {}
    images: list[np.ndarray] = []
    srgb: list[bool] = []
    image_of = []
    for texture in textures:
        known = seen.get((id(texture.image), texture.srgb))
        if known is None:
            shape = (texture.image.shape, texture.srgb)
            content: bytes | int = (hashlib.blake2b(np.ascontiguousarray(texture.image).data, digest_size=16).digest()
                                    if shapes[shape] > 1 else id(texture.image))
            key = (texture.image.shape, content, texture.srgb)
            if key not in index:
                index[key] = len(images)
                images.append(texture.image)
                srgb.append(texture.srgb)
            known = seen[(id(texture.image), texture.srgb)] = index[key]
        image_of.append(known)
    return tuple(images), tuple(image_of), tuple(srgb)


def size_groups(sizes: list[tuple[int, int]], groups: int = MATERIAL_ARRAYS) -> list[tuple[int, int]]:
    """Each image's layer size (its group's), for images of `sizes` (width, height): at most `groups`
    distinct ones. Each distinct size starts as a group; while there are too many, the two whose
    merged group (as wide and as high as the larger of each) adds the fewest texels merge."""
    counts: dict[tuple[int, int], int] = {}
    for size in sizes:
        counts[size] = counts.get(size, 0) + 1
    # A group: its layer size, its image count, and the distinct sizes in it.
    found = [(size, count, {size}) for size, count in sorted(counts.items())]
    while len(found) > groups:
        def added(pair: tuple[int, int]) -> tuple[int, int, int]:
            (a, na, _), (b, nb, _) = found[pair[0]], found[pair[1]]
            merged = max(a[0], b[0]) * max(a[1], b[1]) * (na + nb)
            return merged - a[0] * a[1] * na - b[0] * b[1] * nb, *pair
        i, j = min(((i, j) for i in range(len(found)) for j in range(i + 1, len(found))), key=added)
        (a, na, members_a), (b, nb, members_b) = found[i], found[j]
        found[i] = ((max(a[0], b[0]), max(a[1], b[1])), na + nb, members_a | members_b)
        del found[j]
    layer = {member: size for size, _, members in found for member in members}
    return [layer[size] for size in sizes]


def _shelves(sizes: list[tuple[int, int]], order: list[int], width: int) -> tuple[np.ndarray, int]:
    """Rectangles of `sizes` placed in `order` on shelves of `width`: (n, 4) and the height used."""
    rects = np.zeros((len(sizes), 4), np.int32)
    x = y = shelf = 0
    for k in order:
        w, h = sizes[k]
        if x + w > width:  # the shelf is full: a new one above the tallest of this one
            x, y, shelf = 0, y + shelf, 0
        rects[k] = (x, y, w, h)
        x, shelf = x + w, max(shelf, h)
    return rects, y + shelf


def shelf_pack(sizes: list[tuple[int, int]]) -> tuple[np.ndarray, tuple[int, int]]:
    """Rectangles of `sizes` (width, height) packed on shelves, tallest first: (n, 4) (x, y, width,
    height) and the atlas size. Of the widths that end the first shelf after each image, the one
    whose atlas has the shortest longer side (what GL_MAX_TEXTURE_SIZE limits), then the least area."""
    if not sizes:
        return np.zeros((0, 4), np.int32), (1, 1)
    order = sorted(range(len(sizes)), key=lambda k: (-sizes[k][1], -sizes[k][0], k))
    widths = sorted(set(np.cumsum([sizes[k][0] for k in order]).tolist()))
    packings = []
    for width in widths:
        rects, height = _shelves(sizes, order, width)
        packings.append((max(width, height), width * height, width, height, rects))
    side, area, width, height, rects = min(packings, key=lambda packing: packing[:3])
    return rects, (width, height)


@functools.lru_cache(maxsize=8)
def _layout(textures: tuple[Texture, ...]) -> TextureLayout:
    images, image_of, srgb = _distinct_images(textures)
    sizes = [(int(image.shape[1]), int(image.shape[0])) for image in images]
    # Colour and data never share an array (one is decoded from sRGB, the other not): with both,
    # each gets half the arrays.
    spaces = sorted(set(srgb), reverse=True)
    arrays: dict[tuple[bool, tuple[int, int]], list[int]] = {}
    for space in spaces:
        members = [k for k in range(len(images)) if srgb[k] == space]
        groups = MATERIAL_ARRAYS // len(spaces)
        for image, size in zip(members, size_groups([sizes[k] for k in members], groups), strict=True):
            arrays.setdefault((space, size), []).append(image)
    # Arrays colour first, each space's in order of size (the smallest first), each image's place in them.
    ordered = [ArrayLayout(size, tuple(members), space)
               for (space, size), members in sorted(arrays.items(), key=lambda item: (not item[0][0], item[0][1]))]
    places = [(0, 0)] * len(images)
    for a, array in enumerate(ordered):
        for layer, image in enumerate(array.images):
            places[image] = (a, layer)
    rects, atlas_size = shelf_pack(sizes)
    return TextureLayout(textures, images, image_of, tuple(ordered), tuple(places), rects, atlas_size)


def texture_layout(scene: Scene) -> TextureLayout:
    """The layout of `scene`'s textures (the same for every scene with the same textures: the
    frames of an animation, whose Scene objects differ)."""
    return _layout(scene.textures)


def texture_defines(scene: Scene) -> dict[str, int]:
    """The variant of lib/material_texture.glsl the scene's textures call for: TEXTURE_COUNT records,
    TEXTURE_ARRAYS arrays, and the samplers its textures need: REPEATING_TEXTURES where one repeats
    on both axes (the arrays' repeating samplers), FOLDED_TEXTURES where one clamps or mirrors on an
    axis (their clamping samplers, the UV folded in the shader). None without textures."""
    if not scene.textures:
        return {}
    wraps = {texture.wrap for texture in scene.textures}
    repeat = (int(Wrap.REPEAT), int(Wrap.REPEAT))
    return {"TEXTURE_COUNT": len(scene.textures), "TEXTURE_ARRAYS": len(texture_layout(scene).arrays),
            **({"REPEATING_TEXTURES": 1} if repeat in wraps else {}),
            **({"FOLDED_TEXTURES": 1} if wraps - {repeat} else {})}


def material_arrays_glsl() -> str:
    """lib/material_texture.glsl's texture arrays (generated/material_arrays.glsl): the samplers of
    the first TEXTURE_ARRAYS of MATERIAL_ARRAYS arrays, each on a repeating and a clamping sampler,
    and the if-chains that pick one by number (GLSL 3.30 indexes samplers with constants alone)."""
    lines = []
    for k in range(MATERIAL_ARRAYS):
        lines += [f"#if TEXTURE_ARRAYS > {k}", "#ifdef REPEATING_TEXTURES", f"uniform sampler2DArray u_material_array_{k};",
                  "#endif", "#ifdef FOLDED_TEXTURES", f"uniform sampler2DArray u_material_array_clamped_{k};",
                  "#endif", "#endif"]
    for define, name, signature, call in (
            ("REPEATING_TEXTURES", "material_array", "vec3 coordinate", "texture(u_material_array_{k}, coordinate)"),
            ("FOLDED_TEXTURES", "material_array_clamped", "vec3 coordinate, vec2 dx, vec2 dy",
             "textureGrad(u_material_array_clamped_{k}, coordinate, dx, dy)")):
        lines += [f"#ifdef {define}", f"vec4 {name}(int array, {signature}) {{"]
        for k in range(MATERIAL_ARRAYS - 1, 0, -1):
            lines += [f"#if TEXTURE_ARRAYS > {k}", f"    if (array == {k}) return {call.format(k=k)};", "#endif"]
        lines += [f"    return {call.format(k=0)};", "}", "#endif"]
    return "\n".join(lines) + "\n"

