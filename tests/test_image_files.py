"""Images read as written (image_files.py): every PNG colour type and bit depth, JPEG, float and
integer TIFF, through a TOML texture and a glTF image, to the 8-bit sRGB texels a texture holds
(a 16-bit grey at 25 % is 25 %), or refused in one line before any GL work. No GL context."""

from __future__ import annotations

import io
import struct
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from depthimpostor.scene import DiffuseMaterial, load_scene
from depthimpostor.textures import SRGB_TABLE, srgb_to_linear
from gltf_files import GltfWriter
from png_files import GREY, GREY_ALPHA, PALETTE, RGB, RGBA, damaged, png
from test_cli import assert_one_line_error, run_in_process

#: The largest step between two 8-bit sRGB values, in linear light (at the top, 254 to 255).
LINEAR_STEP = float(np.diff(SRGB_TABLE).max())


def toml_texels(tmp_path: Path, data: bytes, name: str = "t.png") -> np.ndarray:
    """The texels a TOML scene's texture holds of the image file `data`."""
    (tmp_path / name).write_bytes(data)
    path = tmp_path / "s.toml"
    path.write_text(f'[[objects]]\nname = "card"\nshape = {{ type = "box", size = [1.0, 1.0, 1.0] }}\n'
                    f'material = {{ type = "diffuse", texture = "{name}" }}\n', encoding="utf-8")
    material = load_scene(path).objects[0].material
    assert isinstance(material, DiffuseMaterial) and material.texture is not None
    return material.texture.image


def gltf_texels(tmp_path: Path, data: bytes, mime: str = "image/png", **texture: object) -> np.ndarray:
    """The texels of a glTF material's baseColorTexture holding the image `data`."""
    w = GltfWriter()
    base = {"index": w.image_texture(data, mime, **texture)}
    material = w.material("Painted", pbrMetallicRoughness={"baseColorTexture": base})
    quad = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]
    w.node(mesh=w.mesh(w.primitive(quad, [[0, 1, 2], [0, 2, 3]], uvs=[[0, 1], [1, 1], [1, 0], [0, 0]],
                                   material=material)))
    loaded = load_scene(w.write(tmp_path / "x.glb")).objects[0].material
    assert isinstance(loaded, DiffuseMaterial) and loaded.texture is not None
    return loaded.texture.image


def eight_bit(samples: np.ndarray) -> np.ndarray:
    """16-bit samples as the exact 8-bit value, round(v * 255 / 65535)."""
    return np.rint(np.asarray(samples, np.float64) * 255.0 / 65535.0)


# --- read as written ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("reader", [toml_texels, gltf_texels])
def test_a_16_bit_grey_at_25_percent_reads_25_percent(tmp_path: Path, reader: object) -> None:
    """It was drawn white: Pillow's conversion clips 16-bit samples at 255. The texel is the
    sample scaled to 8 bits, so the albedo drawn (its sRGB decoding) is 25 % encoded, within one
    8-bit step; black, half and white stay themselves."""
    samples = np.array([[16384, 0, 32768, 65535]])
    texels = reader(tmp_path, png(samples, GREY, 16))  # type: ignore[operator]
    assert texels.dtype == np.uint8 and texels.shape == (1, 4, 4)
    assert np.array_equal(texels[0, :, 0], eight_bit(samples[0])) and texels[0, 0, 0] == 64
    assert np.array_equal(texels[..., 0], texels[..., 2]) and (texels[..., 3] == 255).all()
    assert abs(SRGB_TABLE[texels[0, 0, 0]] - srgb_to_linear(np.float64(0.25))) <= LINEAR_STEP


@pytest.mark.parametrize("colour_type, channels", [(RGB, 3), (RGBA, 4), (GREY_ALPHA, 2)])
def test_16_bit_colour_and_grey_with_alpha_read_within_one_step(tmp_path: Path, colour_type: int,
                                                                channels: int) -> None:
    """Pillow keeps the high byte of 16-bit RGB(A) and grey+alpha samples: within one step."""
    samples = np.array([[[16384, 32768, 65535, 49152][:channels], [1000, 40000, 0, 65535][:channels]]])
    texels = toml_texels(tmp_path, png(samples, colour_type, 16)).astype(np.float64)
    expected = eight_bit(samples)
    rgba = {3: expected, 4: expected, 2: expected[..., [0, 0, 0, 1]]}[channels]
    if channels == 3:
        rgba = np.concatenate([rgba, np.full((1, 2, 1), 255.0)], axis=-1)
    assert np.abs(texels - rgba).max() <= 1.0


def test_8_bit_grey_with_alpha_and_a_palette_with_transparency_read_exactly(tmp_path: Path) -> None:
    """Grey+alpha becomes grey in RGB with its alpha; a palette's tRNS gives its entries' alpha."""
    grey_alpha = toml_texels(tmp_path, png(np.array([[[64, 200], [255, 0]]]), GREY_ALPHA, 8), "la.png")
    assert grey_alpha.tolist() == [[[64, 64, 64, 200], [255, 255, 255, 0]]]
    palette = bytes([10, 20, 30, 40, 50, 60, 70, 80, 90])
    indexed = toml_texels(tmp_path, png(np.array([[0, 1, 2]]), PALETTE, 8, bytes([255, 0, 128]), palette), "p.png")
    assert indexed.tolist() == [[[10, 20, 30, 255], [40, 50, 60, 0], [70, 80, 90, 128]]]
    low_bits = toml_texels(tmp_path, png(np.array([[0, 1, 2, 3]]), PALETTE, 2, bytes([0]), palette + bytes(3)), "p2.png")
    assert low_bits[0, :, 3].tolist() == [0, 255, 255, 255]


@pytest.mark.parametrize("depth", [2, 4, 16])
def test_a_grey_transparent_value_below_or_above_8_bits_is_transparent(tmp_path: Path, depth: int) -> None:
    """A greyscale PNG's tRNS value at its own depth: Pillow scales 2- and 4-bit samples to 0..255
    but compared them with the unscaled key (so nothing was transparent), and drew 16-bit ones white."""
    top = (1 << depth) - 1
    samples = np.array([[0, 1, top // 2 + 1, top]])
    texels = toml_texels(tmp_path, png(samples, GREY, depth, struct.pack(">H", 1)))
    assert texels[0, :, 3].tolist() == [255, 0, 255, 255]
    assert np.array_equal(texels[0, :, 0], np.rint(samples[0] * 255.0 / top))


def test_a_16_bit_rgb_transparent_colour_is_transparent(tmp_path: Path) -> None:
    samples = np.array([[[16384, 0, 65535], [16384, 0, 65534 - 512]]])
    texels = toml_texels(tmp_path, png(samples, RGB, 16, struct.pack(">HHH", 16384, 0, 65535)))
    assert texels[0, :, 3].tolist() == [0, 255]


def test_a_float_tiff_holds_linear_values(tmp_path: Path) -> None:
    """It was drawn black (Pillow truncates floats to integers). A float image is linear light:
    0.5 is stored as its sRGB encoding (188), which decodes to 0.5 within one step."""
    tiff = io.BytesIO()
    Image.fromarray(np.array([[0.5, 0.0, 1.0, 0.2]], np.float32)).save(tiff, format="TIFF")
    texels = toml_texels(tmp_path, tiff.getvalue(), "f.tif")
    assert texels[0, :, 0].tolist() == [188, 0, 255, 124]
    assert np.abs(SRGB_TABLE[texels[0, :, 0]] - [0.5, 0.0, 1.0, 0.2]).max() <= LINEAR_STEP


@pytest.mark.parametrize("mode, colour, expected", [("L", 64, (64, 64, 64)), ("RGB", (200, 30, 90), (200, 30, 90)),
                                                    ("CMYK", (0, 255, 0, 0), (255, 0, 255))])
def test_jpeg_grey_colour_and_cmyk_read_within_compression(tmp_path: Path, mode: str, colour: object,
                                                           expected: tuple[int, int, int]) -> None:
    jpeg = io.BytesIO()
    Image.new(mode, (16, 16), colour).save(jpeg, format="JPEG", quality=100)  # type: ignore[arg-type]
    texels = toml_texels(tmp_path, jpeg.getvalue(), "t.jpg").astype(int)
    assert np.abs(texels[..., :3] - expected).max() <= 2 and (texels[..., 3] == 255).all()


def test_a_gltf_webp_texture_reads_its_webp_source(tmp_path: Path) -> None:
    """EXT_texture_webp: the extension's image, not the fallback `source`."""
    webp, fallback = io.BytesIO(), png(np.zeros((2, 2)), GREY, 8)
    Image.new("RGB", (2, 2), (40, 200, 90)).save(webp, format="WEBP", lossless=True)
    w = GltfWriter()
    texture = w.image_texture(fallback)
    w.json["images"].append({"bufferView": w.view(webp.getvalue()), "mimeType": "image/webp"})
    w.json["textures"][texture]["extensions"] = {"EXT_texture_webp": {"source": 1}}
    w.json["extensionsUsed"] = w.json["extensionsRequired"] = ["EXT_texture_webp"]
    material = w.material("Painted", pbrMetallicRoughness={"baseColorTexture": {"index": texture}})
    w.node(mesh=w.mesh(w.primitive([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], uvs=[[0, 0], [1, 0], [0, 1]],
                                   material=material)))
    loaded = load_scene(w.write(tmp_path / "x.glb")).objects[0].material
    assert isinstance(loaded, DiffuseMaterial) and loaded.texture is not None
    assert loaded.texture.image[0, 0].tolist() == [40, 200, 90, 255]


# --- refused in one line ------------------------------------------------------------------------------------


def float_tiff(values: list[float]) -> bytes:
    tiff = io.BytesIO()
    Image.fromarray(np.array([values], np.float32)).save(tiff, format="TIFF")
    return tiff.getvalue()


def int_tiff() -> bytes:
    tiff = io.BytesIO()
    Image.new("I", (2, 2), 70000).save(tiff, format="TIFF")
    return tiff.getvalue()


REFUSED = {
    "damaged": (lambda: damaged(png(np.full((8, 8), 16384), GREY, 16)),
                "expected an image file Pillow can decode (PNG, JPEG, ...), got {name}a damaged file: OSError"),
    "float_above_1": (lambda: float_tiff([0.5, 2.0]),
                      "expected float samples in [0, 1] (linear light: an albedo reflects at most all the light), "
                      "got {name}values from 0.5 to 2"),
    "float_nan": (lambda: float_tiff([0.5, float("nan")]), "expected float samples that are finite, got {name}NaN"),
    "integer_32": (int_tiff, "expected an image of 8- or 16-bit samples or 32-bit float ones, got {name}32-bit integer"),
}


@pytest.mark.parametrize("case", list(REFUSED))
def test_an_image_that_cannot_be_read_as_written_is_refused_in_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], case: str) -> None:
    """Through the CLI, from a TOML texture (naming the field and the file) and from a glTF image
    (naming the image by index and name): exit 2, one line, no traceback, before any GL work."""
    make, message = REFUSED[case]
    (tmp_path / "t.img").write_bytes(make())
    toml = tmp_path / "s.toml"
    toml.write_text('[[objects]]\nname = "card"\nshape = { type = "box", size = [1.0, 1.0, 1.0] }\n'
                    'material = { type = "diffuse", texture = "t.img" }\n', encoding="utf-8")
    assert_one_line_error(*run_in_process(["render", str(toml), "-o", str(tmp_path / "out.png")], capsys),
                          f"{toml}: objects[0].material.texture: ", message.format(name=f"{str(tmp_path / 't.img')!r}: "))
    w = GltfWriter()
    texture = w.image_texture(make())
    w.json["images"][0]["name"] = "bark"
    material = w.material("Painted", pbrMetallicRoughness={"baseColorTexture": {"index": texture}})
    w.node(mesh=w.mesh(w.primitive([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], uvs=[[0, 0], [1, 0], [0, 1]],
                                   material=material)))
    glb = w.write(tmp_path / "x.glb")
    assert_one_line_error(*run_in_process(["render", str(glb), "-o", str(tmp_path / "out.png")], capsys),
                          f'{glb}: images[0] "bark": ', message.format(name=""))
    assert not (tmp_path / "out.png").exists()
