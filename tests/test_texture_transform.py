"""KHR_texture_transform (issue 33 item 1): a texture's offset, rotation and scale, read from the
glTF file, drawn by every pass (its texture record's UV rows) and by the truth
(textures.texture_bilinear) alike."""

from __future__ import annotations

import math
from pathlib import Path

import moderngl
import numpy as np

from conftest import assert_finite
from depthimpostor.renderer import Renderer
from depthimpostor.scene import load_scene
from depthimpostor.scene.model import Texture
from depthimpostor.textures import texture_bilinear, texture_from_pixels
from gltf_files import GltfWriter

SIZE = 8


def _image() -> np.ndarray:
    """An asymmetric image: random colours, so that any turn or flip of it shows."""
    rgba = np.random.default_rng(3).integers(0, 256, (SIZE, SIZE, 4), dtype=np.uint8)
    rgba[..., 3] = 255
    return rgba


def _turned(rgba: np.ndarray) -> np.ndarray:
    """The image a quarter turn with offset (0, 1) shows (uv' = (v, 1 - u)): texel (i, j) of the
    result (column i, row j) is the original's at column j, row SIZE - 1 - i."""
    return np.transpose(rgba, (1, 0, 2))[:, ::-1]


def _quad_file(path: Path, rgba: np.ndarray, transform: dict[str, object] | None) -> Path:
    """A square facing the camera, its UVs over the whole image, the texture with `transform`."""
    w = GltfWriter()
    info: dict[str, object] = {"index": w.texture(rgba)}
    if transform is not None:
        info["extensions"] = {"KHR_texture_transform": transform}
        w.json["extensionsUsed"] = ["KHR_texture_transform"]
    material = w._append("materials", {"pbrMetallicRoughness": {"baseColorTexture": info, "metallicFactor": 0.0}})
    positions = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
    uvs = [(0, 1), (1, 1), (1, 0), (0, 0)]
    quad = w.primitive(np.array(positions, np.float32), np.array([[0, 1, 2], [0, 2, 3]], np.uint16),
                       np.array([(0, 0, 1)] * 4, np.float32), np.array(uvs, np.float32), material=material)
    w.node(mesh=w.mesh(quad))
    return w.write(path)


def _render(ctx: moderngl.Context, path: Path) -> np.ndarray:
    scene = load_scene(path).with_overrides(size=(64, 64))
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        color = renderer.read_color_float()
    assert_finite(color)
    return color


def test_a_quarter_turn_draws_the_turned_image(ctx: moderngl.Context, tmp_path: Path) -> None:
    """A quad whose texture is turned a quarter by KHR_texture_transform (rotation pi/2, offset
    (0, 1)) draws as the same quad showing the turned image without the extension, and not as the
    unturned image."""
    rgba = _image()
    transformed = _render(ctx, _quad_file(tmp_path / "a.glb", rgba, {"rotation": math.pi / 2, "offset": [0.0, 1.0]}))
    turned = _render(ctx, _quad_file(tmp_path / "b.glb", _turned(rgba), None))
    plain = _render(ctx, _quad_file(tmp_path / "c.glb", rgba, None))
    assert np.abs(transformed - turned).max() < 2e-3
    assert np.abs(transformed - plain).max() > 0.2


def test_the_truth_samples_through_the_same_transform() -> None:
    """textures.texture_bilinear applies offset, rotation and scale as the extension orders them
    (T R S): a quarter turn with offset (0, 1) samples the turned image, a scale of 2 repeats it."""
    rgba = _image()
    centres = (np.stack(np.meshgrid(np.arange(SIZE), np.arange(SIZE)), axis=-1).reshape(-1, 2) + 0.5) / SIZE
    texture = texture_from_pixels(rgba, {})
    turned = Texture(texture.image, {}, texture.mean_color, offset=(0.0, 1.0), rotation=math.pi / 2)
    expected = texture_bilinear(texture_from_pixels(_turned(rgba), {}), centres)
    np.testing.assert_allclose(texture_bilinear(turned, centres), expected, atol=1e-9)
    doubled = Texture(texture.image, {}, texture.mean_color, scale=(2.0, 2.0))
    np.testing.assert_allclose(texture_bilinear(doubled, centres / 2.0 + 0.5), texture_bilinear(texture, centres),
                               atol=1e-9)
