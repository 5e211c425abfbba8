"""The binary data of a glTF file: its buffers, views and accessors (sparse substitutions made),
and its images (decoded by image_files.py, whose reading of Pillow's modes is what a file means).
Every range is checked from the JSON and the files' sizes before a byte is read (`layout`), so
that the scene's counts can be summed before anything is decoded (gltf.py).

glTF 2.0, 3.6: a buffer is a GLB's BIN chunk, a data URI or a file beside the glTF file; a buffer
view a byte range of one; an accessor `count` elements of a `type` (SCALAR, VEC2...) of a
`componentType`, from a view at `byteOffset`, `byteStride` apart (packed where not given),
integers scaled into [0, 1] or [-1, 1] where `normalized`; `sparse` then replaces the elements
at `sparse.indices` by `sparse.values` (on zeros where the accessor has no view).

Every problem is a SceneError at the JSON path: `x.glb: accessors[3].sparse.indices: ...`.
"""

from __future__ import annotations

import base64
import stat
import struct
import urllib.parse
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from depthimpostor.errors import SceneError
from depthimpostor.image_files import ImageRefused, read_image
from depthimpostor.scene.fields import At, read_file_bytes, show

#: glTF's component types (3.6.2.2), little-endian.
COMPONENTS: dict[int, np.dtype[Any]] = {5120: np.dtype("<i1"), 5121: np.dtype("<u1"), 5122: np.dtype("<i2"), 5123: np.dtype("<u2"),
              5125: np.dtype("<u4"), 5126: np.dtype("<f4")}
#: The element types read here: the vertex attributes and indices a mesh needs, and a skin's
#: inverse bind matrices (MAT4, column-major).
WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}
#: What a sparse accessor's indices may be (3.6.2.3).
INDEX_COMPONENTS = (5121, 5123, 5125)

_GLB_BIN = 0x004E4942


#: A buffer view's byteStride (glTF 2.0, 3.6.1.1).
MIN_STRIDE, MAX_STRIDE = 4, 252


def glb_binary(data: bytes) -> bytes | None:
    """A .glb's BIN chunk (the buffer without a `uri`), or None where it has none."""
    json_length = struct.unpack_from("<I", data, 12)[0]
    start = 20 + json_length
    if start + 8 > len(data):
        return None
    length, kind = struct.unpack_from("<II", data, start)
    return data[start + 8:start + 8 + length] if kind == _GLB_BIN else None


def _data_uri(uri: str, at: At) -> bytes:
    """The bytes of a `data:` URI (base64, or percent-encoded)."""
    meta, _, payload = uri.partition(",")
    try:
        return base64.b64decode(payload) if meta.endswith(";base64") \
            else urllib.parse.unquote_to_bytes(payload)
    except ValueError as error:  # binascii.Error
        raise at.error(f"expected a data URI of base64 bytes, got one that is not: {error}") from None


@dataclass(frozen=True)
class Layout:
    """Where an accessor's elements are, checked against its view and buffer before a byte is read."""

    dtype: np.dtype[Any]
    width: int  # components per element
    count: int
    normalized: bool

    @property
    def decoded_bytes(self) -> int:
        """What `accessor` returns: 8-byte floats or integers."""
        return 8 * self.count * self.width


class GltfData:
    """A file's buffers, views, accessors and images, each read once, when first asked for. Every
    layout (buffer lengths, views' ranges, accessors' counts and strides) is checked from the JSON
    and the files' sizes before anything is decoded, so that counts can be summed first."""

    def __init__(self, path: Path, header: Mapping[str, Any], source: str) -> None:
        self.path, self.header, self.source = path, header, source
        self._buffers: dict[int, bytes] = {}
        self._glb: bytes | None = None
        self._images: dict[int, np.ndarray] = {}  # one decode an image, whatever the textures that use it

    def _item(self, key: str, value: Any, at: At) -> Mapping[str, Any]:
        listed = self.header.get(key, [])
        count = len(listed) if isinstance(listed, list) else 0
        if not (isinstance(value, int) and not isinstance(value, bool) and 0 <= value < count):
            raise at.error(f"expected an index in [0, {count}) of {key}, got {show(value)}")
        item = listed[value]
        if not isinstance(item, Mapping):
            raise SceneError(self.source, f"{key}[{value}]", f"expected a JSON object, got {show(item)}")
        return item

    def _count(self, item: Mapping[str, Any], key: str, at: At, default: int | None = None) -> int:
        value = item.get(key, default)
        if not (isinstance(value, int) and not isinstance(value, bool) and value >= 0):
            raise at.key(key).error(f"expected a whole number >= 0, got {show(value)}")
        return value

    def _file(self) -> bytes:
        if self._glb is None:
            self._glb = read_file_bytes(self.path, self.source, "a glTF file")
        return self._glb

    def _uri(self, item: Mapping[str, Any], at: At) -> str | None:
        uri = item.get("uri")
        if uri is not None and not isinstance(uri, str):
            raise at.key("uri").error(f"expected a string, got {show(uri)}")
        return uri

    def _available(self, i: int, item: Mapping[str, Any], at: At) -> int:
        """The bytes buffers[i] holds, without reading a file: a file's size, a data URI decoded
        (it is in the JSON already), a .glb's BIN chunk's length."""
        uri = self._uri(item, at)
        if uri is None or uri.startswith("data:"):
            return len(self.buffer(i, at))
        try:
            status = (self.path.parent / urllib.parse.unquote(uri)).stat()
        except OSError as error:  # check_header found it: a race, or a name too long
            raise at.key("uri").error(f"cannot read {show(uri)}: {error.strerror or error}") from None
        return status.st_size if stat.S_ISREG(status.st_mode) else len(self.buffer(i, at))

    def buffer_length(self, value: Any, at: At) -> int:
        """buffers[value]'s byteLength, checked against what the buffer holds."""
        item = self._item("buffers", value, at)
        at = At(self.source, f"buffers[{value}]")
        length, available = self._count(item, "byteLength", at), self._available(value, item, at)
        if available < length:
            raise at.error(f"expected {length} bytes (byteLength), got {available}")
        return length

    def buffer(self, value: Any, at: At) -> bytes:
        """The bytes of buffers[value]."""
        item = self._item("buffers", value, at)
        i: int = value
        if i not in self._buffers:
            at = At(self.source, f"buffers[{i}]")
            uri = self._uri(item, at)
            if uri is None:
                data = glb_binary(self._file()) if self.path.suffix.lower() == ".glb" else None
                if data is None:
                    raise at.error("expected a uri, or the BIN chunk of a .glb, got neither")
            elif uri.startswith("data:"):
                data = _data_uri(uri, at.key("uri"))
            else:
                data = read_file_bytes(self.path.parent / urllib.parse.unquote(uri), self.source, "a buffer file")
            self._buffers[i] = data
        return self._buffers[i]

    def view_layout(self, value: Any, at: At) -> tuple[Any, int, int, int | None]:
        """bufferViews[value]'s buffer, byte range (start, length) and byteStride (None: packed),
        checked against its buffer's byteLength."""
        view = self._item("bufferViews", value, at)
        view_at = At(self.source, f"bufferViews[{value}]")
        buffer = view.get("buffer")
        length_of_buffer = self.buffer_length(buffer, view_at.key("buffer"))
        start, length = self._count(view, "byteOffset", view_at, 0), self._count(view, "byteLength", view_at)
        if start + length > length_of_buffer:
            raise view_at.error(f"expected a range within its buffer of {length_of_buffer} bytes, got bytes {start} to "
                                f"{start + length}")
        stride = view.get("byteStride")
        if stride is not None and not (isinstance(stride, int) and not isinstance(stride, bool)
                                       and MIN_STRIDE <= stride <= MAX_STRIDE):
            raise view_at.key("byteStride").error(f"expected a number of bytes in [{MIN_STRIDE}, {MAX_STRIDE}], "
                                                  f"got {show(stride)}")
        return buffer, start, length, stride

    def view(self, value: Any, at: At) -> tuple[bytes, int | None]:
        """The bytes of bufferViews[value] and its byteStride (None: packed)."""
        buffer, start, length, stride = self.view_layout(value, at)
        return self.buffer(buffer, at)[start:start + length], stride

    def _check_elements(self, value: Any, offset: int, count: int, element: int, at: At, packed: bool = False) -> int:
        """The stride of `count` elements of `element` bytes from a buffer view, checked to lie within it."""
        _, _, length, stride = self.view_layout(value, at.key("bufferView"))
        stride = element if stride is None or packed else stride
        end = offset + stride * (count - 1) + element if count else offset
        if stride < element or end > length:
            raise at.error(f"expected {count} elements of {element} bytes, {stride} apart from byte {offset}, within "
                           f"its buffer view of {length} bytes, got a view too short (or a stride too small)")
        return stride

    def _elements(self, value: Any, offset: int, count: int, dtype: np.dtype[Any], width: int, at: At,
                  packed: bool = False) -> np.ndarray:
        """`count` elements of `width` components from a buffer view (packed where `packed`)."""
        element = dtype.itemsize * width
        stride = self._check_elements(value, offset, count, element, at, packed)
        data = self.view(value, at.key("bufferView"))[0]
        end = offset + stride * (count - 1) + element if count else offset
        rows = np.lib.stride_tricks.as_strided(np.frombuffer(data, np.uint8, offset=offset, count=end - offset),
                                               shape=(count, element), strides=(stride, 1))
        return rows.copy().view(dtype).reshape(count, width)

    def layout(self, k: Any, at: At) -> Layout:
        """accessors[k]'s type, count and place, every range checked, nothing read."""
        accessor = self._item("accessors", k, at)
        at = At(self.source, f"accessors[{k}]")
        dtype = COMPONENTS.get(accessor.get("componentType", -1)) if isinstance(accessor.get("componentType"), int) else None
        if dtype is None:
            raise at.key("componentType").error(f"expected one of {', '.join(map(str, COMPONENTS))}, got "
                                                f"{show(accessor.get('componentType'))}")
        kind = accessor.get("type")
        width = WIDTHS.get(kind) if isinstance(kind, str) else None
        if width is None:
            raise at.key("type").error(f"expected one of {', '.join(WIDTHS)} (a vertex attribute or indices), "
                                       f"got {show(kind)}")
        count = self._count(accessor, "count", at)
        if "bufferView" in accessor:
            self._check_elements(accessor["bufferView"], self._count(accessor, "byteOffset", at, 0), count,
                                 dtype.itemsize * width, at)
        if "sparse" in accessor:
            self._sparse_layout(accessor["sparse"], count, dtype.itemsize * width, at.key("sparse"))
        return Layout(dtype, width, count, accessor.get("normalized") is True)

    def _sparse_layout(self, sparse: Any, count: int, element: int, at: At) -> tuple[int, Mapping[str, Any],
                                                                                        Mapping[str, Any], int]:
        """A sparse substitution's count, `indices` and `values` objects and index component type, checked."""
        if not isinstance(sparse, Mapping):
            raise at.error(f"expected a JSON object, got {show(sparse)}")
        substitutions = self._count(sparse, "count", at)
        if substitutions > count:
            raise at.key("count").error(f"expected at most the accessor's count {count}, got {substitutions}")
        indices, replacing = sparse.get("indices"), sparse.get("values")
        if not isinstance(indices, Mapping) or not isinstance(replacing, Mapping):
            raise at.error("expected `indices` and `values` objects, got " + ("neither" if not isinstance(indices, Mapping)
                                                                              and not isinstance(replacing, Mapping)
                                                                              else "one of them"))
        index_type = indices.get("componentType")
        if index_type not in INDEX_COMPONENTS or isinstance(index_type, bool):
            raise at.key("indices").key("componentType").error(
                f"expected one of {', '.join(map(str, INDEX_COMPONENTS))} (unsigned integers), got {show(index_type)}")
        self._check_elements(indices.get("bufferView"), self._count(indices, "byteOffset", at.key("indices"), 0),
                             substitutions, COMPONENTS[index_type].itemsize, at.key("indices"), packed=True)
        self._check_elements(replacing.get("bufferView"), self._count(replacing, "byteOffset", at.key("values"), 0),
                             substitutions, element, at.key("values"), packed=True)
        return substitutions, indices, replacing, index_type

    def accessor(self, k: int) -> np.ndarray:
        """accessors[k] as (count, width): float64 for floats and normalized integers (scaled as
        glTF 3.11 says), int64 for other integers (indices; quantized positions), with any sparse
        substitutions made."""
        at = At(self.source, f"accessors[{k}]")
        layout = self.layout(k, At(self.source, "accessors"))
        accessor = self.header["accessors"][k]
        dtype, width, count = layout.dtype, layout.width, layout.count
        if "bufferView" in accessor:
            values = self._elements(accessor["bufferView"], self._count(accessor, "byteOffset", at, 0), count,
                                    dtype, width, at)
        else:
            values = np.zeros((count, width), dtype)
        if "sparse" in accessor:
            self._substitute(values, accessor["sparse"], dtype, width, at.key("sparse"))
        return _scaled(values, dtype, layout.normalized)

    def _substitute(self, values: np.ndarray, sparse: Any, dtype: np.dtype[Any], width: int, at: At) -> None:
        """values[sparse.indices] = sparse.values, in place."""
        count, indices, replacing, index_type = self._sparse_layout(sparse, len(values), dtype.itemsize * width, at)
        where = self._elements(indices.get("bufferView"), self._count(indices, "byteOffset", at.key("indices"), 0),
                               count, COMPONENTS[index_type], 1, at.key("indices"), packed=True).ravel()
        if where.size and int(where.max()) >= len(values):
            raise at.key("indices").error(f"expected indices below the accessor's count {len(values)}, got "
                                          f"{int(where.max())}")
        values[where.astype(np.int64)] = self._elements(
            replacing.get("bufferView"), self._count(replacing, "byteOffset", at.key("values"), 0), count, dtype, width,
            at.key("values"), packed=True)

    def image(self, i: int) -> np.ndarray:
        """images[i]'s texels (image_files.py), or a SceneError at images[i] saying why not; decoded
        once (a packed occlusion-roughness-metalness image serves three slots)."""
        if isinstance(i, int) and i in self._images:
            return self._images[i]
        self._images[i] = self._decode_image(i)
        return self._images[i]

    def _decode_image(self, i: int) -> np.ndarray:
        image = self._item("images", i, At(self.source, "images"))
        name = image.get("name")
        at = At(self.source, f"images[{i}]" + (f" {show(name)}" if isinstance(name, str) and name else ""))
        if "bufferView" in image:
            data = self.view(image["bufferView"], at.key("bufferView"))[0]
        elif isinstance(image.get("uri"), str):
            uri = image["uri"]
            data = _data_uri(uri, at.key("uri")) if uri.startswith("data:") else \
                read_file_bytes(self.path.parent / urllib.parse.unquote(uri), self.source, "an image file")
        else:
            raise at.error("expected a uri or a bufferView, got neither")
        try:
            return read_image(data)
        except ImageRefused as refused:
            raise at.error(f"expected {refused.expected}, got {refused.got}") from None


def _scaled(values: np.ndarray, dtype: np.dtype[Any], normalized: bool) -> np.ndarray:
    """Floats as float64; normalized integers to [0, 1] (unsigned) or [-1, 1] (signed,
    max(c / (2^(n-1) - 1), -1)); other integers as int64."""
    if dtype.kind == "f":
        return values.astype(np.float64)
    if not normalized:
        return values.astype(np.int64)
    largest = float(np.iinfo(dtype).max)
    return np.maximum(values.astype(np.float64) / largest, -1.0)
