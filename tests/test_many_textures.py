"""Image textures in any number (texture_layout.py, gpu/textures.py): 64 distinct images of eight
sizes (so that some are grouped and resampled) and all three wrap modes, each on its own object,
seen directly and in a mirror against the truth; an edge-on mirrored-repeat floor against the same
floor drawn by GL's own repeat; the layout's grouping and packing; and the GL limits that remain,
each refused in one line naming the image."""

from __future__ import annotations

import colorsys
import dataclasses
from collections.abc import Iterator
from pathlib import Path

import moderngl
import numpy as np
import pytest
from PIL import Image

from conftest import assert_finite
from depthimpostor.constants import MATERIAL_ARRAYS, Method, Wrap
from depthimpostor.errors import GpuLimitError
from depthimpostor.gpu.limits import GpuLimits, context_limits, use_limits
from depthimpostor.oracles.compare import compare
from depthimpostor.oracles.truth import TruthTracer
from depthimpostor.plan import plan_render
from depthimpostor.renderer import Renderer
from depthimpostor.scene import DiffuseMaterial, Scene, load_scene
from depthimpostor.texture_layout import shelf_pack, size_groups, texture_defines, texture_layout
from depthimpostor.textures import SRGB_TABLE, resample

#: Eight sizes (width, height), more than MATERIAL_ARRAYS: some images are resampled to a group's size.
SIZES = [(8, 8), (16, 16), (16, 8), (12, 20), (32, 32), (24, 24), (8, 16), (20, 12)]
WRAPS = ["repeat", "clamp", "mirrored_repeat"]


def quadrant_image(k: int, size: tuple[int, int]) -> Image.Image:
    """Image k: four flat quadrants of its own hue (a golden-ratio walk: no two alike), so that a
    texture shown on another's object, turned or flipped, is a wrong colour over most of it."""
    r, g, b = colorsys.hsv_to_rgb((k * 0.618034) % 1.0, 0.85, 0.95)
    base = np.array([r, g, b])
    quadrants = [base, base * 0.45, 0.3 + 0.7 * base, 0.8 * (1.0 - base)]
    width, height = size
    pixels = np.zeros((height, width, 3), np.uint8)
    for q, colour in enumerate(quadrants):
        rows = slice(0, height // 2) if q < 2 else slice(height // 2, height)
        columns = slice(0, width // 2) if q % 2 == 0 else slice(width // 2, width)
        pixels[rows, columns] = np.rint(np.clip(colour, 0.0, 1.0) * 255.0)
    return Image.fromarray(pixels, "RGB")


def textured_plane(k: int, name: str, size: str, position: str, rotation: str, wrap: str, scale: str) -> str:
    return (f'\n[[objects]]\nname = "{name}"\nshape = {{ type = "plane", size = {size} }}\n'
            f'material = {{ type = "diffuse", texture = {{ path = "t{k}.png", scale = {scale}, wrap = "{wrap}" }} }}\n'
            f"position = {position}\nrotation = {rotation}\n")


def sixty_four_textures(folder: Path) -> Scene:
    """60 small boxes in a 10 x 6 grid before a mirror (images 0-59, UVs scaled by 1.5 so that each
    wrap mode shows), a floor, two side walls and a wall behind the camera (images 60-63): 64
    distinct images, 60 objects a mirror shows as depth images."""
    for k in range(64):
        quadrant_image(k, SIZES[k % len(SIZES)]).save(folder / f"t{k}.png")
    objects = [textured_plane(60, "floor", "[12.0, 12.0]", "[0.0, 0.0, 0.0]", "[0.0, 0.0, 0.0]", "mirrored_repeat",
                              "[6.0, 6.0]"),
               textured_plane(61, "left wall", "[12.0, 4.0]", "[-3.6, 2.0, 0.0]", "[0.0, 0.0, -90.0]", "clamp",
                              "[1.3, 1.3]"),
               textured_plane(62, "right wall", "[12.0, 4.0]", "[3.6, 2.0, 0.0]", "[0.0, 0.0, 90.0]", "repeat",
                              "[3.0, 2.0]"),
               textured_plane(63, "back wall", "[8.0, 4.0]", "[0.0, 2.0, 7.0]", "[-90.0, 0.0, 0.0]", "repeat",
                              "[2.0, 1.0]")]
    for k in range(60):
        x, z = -2.7 + 0.6 * (k % 10), -1.4 + 0.6 * (k // 10)
        objects.append(f'\n[[objects]]\nname = "box {k}"\nshape = {{ type = "box", size = [0.34, 0.34, 0.34] }}\n'
                       f'material = {{ type = "diffuse", texture = {{ path = "t{k}.png", scale = [1.5, 1.5], '
                       f'wrap = "{WRAPS[k % 3]}" }} }}\n'
                       f"position = [{x:.2f}, 0.2, {z:.2f}]\nrotation = [0.0, {17 * k % 50 - 25}.0, 0.0]\n")
    (folder / "many.toml").write_text(f"""
[render]
size = [384, 216]
impostor_resolution = 64
ambient = 1.0

[camera]
eye = [0.0, 3.4, 4.6]
target = [0.0, 0.4, -0.8]
fov_y = 50.0

[[objects]]
name = "mirror"
shape = {{ type = "plane", size = [7.0, 3.6] }}
material = {{ type = "mirror" }}
position = [0.0, 1.8, -2.4]
rotation = [90.0, 0.0, 0.0]
{"".join(objects)}""", encoding="utf-8")
    return load_scene(folder / "many.toml")


@pytest.fixture(scope="module")
def many(tmp_path_factory: pytest.TempPathFactory) -> Scene:
    return sixty_four_textures(tmp_path_factory.mktemp("many_textures"))


def test_sixty_four_textures_are_laid_out_in_a_few_arrays(many: Scene) -> None:
    layout = texture_layout(many)
    assert len(many.textures) == 64 and len(layout.arrays) == MATERIAL_ARRAYS
    assert sum(len(array.images) for array in layout.arrays) == 64
    assert layout.resampled, "eight sizes in four arrays: some images are resampled"
    for image, (array, layer) in enumerate(layout.places):
        height, width = layout.images[image].shape[:2]
        layer_width, layer_height = layout.arrays[array].size
        assert layout.arrays[array].images[layer] == image
        assert layer_width >= width and layer_height >= height  # resampled up, never down
    records = layout.records()
    assert [tuple(r) for r in records["sampling"][:3, 2:]] == [(0x8370, 0x8370), (0x812F, 0x812F), (0x2901, 0x2901)]
    assert texture_defines(many) == {"TEXTURE_COUNT": 64, "TEXTURE_ARRAYS": 4, "REPEATING_TEXTURES": 1,
                                     "FOLDED_TEXTURES": 1}
    lines = plan_render(many, Method.RAYTRACE).format().splitlines()
    line = next(line for line in lines if line.startswith("  textures: "))
    assert line.startswith("  textures: 64 textures of 64 distinct images in 4 arrays (") and "resampled up" in line
    assert "  image textures: 64 (any number: in texture arrays" in "\n".join(lines)  # the plan's limits section


def eye_truth(renderer: Renderer) -> tuple[np.ndarray, np.ndarray]:
    """Each pixel's truth seen directly (a primary ray through its centre: level 0 bilinear) and the
    object it shows."""
    camera = renderer.camera
    rows, columns = np.mgrid[0:camera.height, 0:camera.width] + 0.5
    directions = camera.ray_direction(columns.ravel(), rows.ravel())
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    world = renderer.world
    hits = TruthTracer(renderer.scene, [*world.shadow_casters, *world.reflectors], world.analytic_planes, []).trace(
        np.broadcast_to(camera.C, directions.shape), directions)
    return hits.color.reshape(camera.height, camera.width, 3), hits.object_id.reshape(camera.height, camera.width)


def test_each_of_sixty_four_textures_shows_on_its_own_object(ctx: moderngl.Context, many: Scene) -> None:
    """Seen directly (the diffuse pass's texture arrays, trilinear, against the truth's level 0):
    every object's pixels have its own image's colours; a swapped layer or record would give some
    object another's hue over most of it. In the mirror, the depth method (baked from the same
    arrays) and raytrace (the atlas, exactly as the truth) against the truth."""
    with Renderer(ctx, many, reflection_data=True, method=Method.DEPTH) as renderer:
        renderer.render()
        frame = renderer.read_color_float()
        truth, object_id = eye_truth(renderer)
        depth = compare(renderer).figures
    assert_finite(frame)
    error = np.abs(np.clip(frame[..., :3], 0.0, 1.0) - np.clip(truth, 0.0, 1.0)).max(axis=-1)
    mirror = next(i for i, o in enumerate(many.objects) if o.is_mirror)
    medians = {}
    behind = next(i for i, o in enumerate(many.objects) if o.name == "back wall")  # seen in the mirror alone
    for index in range(len(many.objects)):
        if index not in (mirror, behind):
            pixels = error[object_id == index]
            assert len(pixels) >= 100, f"objects[{index}] is not in view: {len(pixels)} pixels"
            medians[index] = float(np.median(pixels))
    # Measured: 0.087 at most (a small box, minified: the mips blur its quadrants' edges); two
    # boxes' records swapped: 0.41 on each.
    worst = max(medians, key=medians.__getitem__)
    assert medians[worst] < 0.15, (worst, medians[worst])
    # Measured 0.041 and 0.005 (images of 64 texels a side for boxes of ~12 pixels).
    assert depth.mirror_pixels > 20000 and depth.wrong_object_share < 0.01
    assert depth.color_rmse < 0.05, depth.color_rmse
    with Renderer(ctx, many, reflection_data=True, method=Method.RAYTRACE) as renderer:
        renderer.render()
        assert_finite(renderer.read_color_float())
        traced = compare(renderer).figures
    # Float noise (6.7e-7 measured; 0.008 with texel -1 of a repeated wall wrapped by GLSL's %).
    assert traced.wrong_object_share < 0.001
    assert traced.color_rmse < 3e-5, traced.color_rmse


def fine_checker(size: int) -> Image.Image:
    """One-texel black and white squares: level 0 and the coarse levels (grey) differ most, so that
    a wrong mip level anywhere shows."""
    cells = (np.indices((size, size)).sum(axis=0) % 2) * 255
    cells[: size // 2, : size // 4] = 200  # a patch that makes the image asymmetric: a wrong fold shows
    return Image.fromarray(np.stack([cells] * 3, axis=-1).astype(np.uint8), "RGB")


def edge_on_floor(folder: Path, image: str, scale: float, wrap: str) -> Scene:
    (folder / f"{image}.toml").write_text(f"""
[render]
size = [256, 144]
ambient = 1.0

[camera]
eye = [0.0, 0.25, 9.5]
target = [0.3, 0.0, 0.0]
fov_y = 40.0

[[objects]]
name = "floor"
shape = {{ type = "plane", size = [20.0, 20.0] }}
material = {{ type = "diffuse", texture = {{ path = "{image}", scale = [{scale}, {scale}], wrap = "{wrap}" }} }}
""", encoding="utf-8")
    return load_scene(folder / f"{image}.toml")


def test_an_edge_on_mirrored_floor_has_no_seams(ctx: moderngl.Context, tmp_path: Path) -> None:
    """A mirrored-repeat image (its UV folded in the shader, sampled with the unfolded UV's
    derivatives) against the image mirrored into a 2 x 2 tile that GL's own repeat draws: the same
    texels and mip levels at every pixel, seams included, nearly edge-on (levels 0 to the coarsest).
    With the folded UV's derivatives, every seam would be a line of the finest level's aliasing."""
    checker = fine_checker(16)
    checker.save(tmp_path / "mirrored.png")
    tile = np.asarray(checker)
    tile = np.concatenate([tile, tile[:, ::-1]], axis=1)
    Image.fromarray(np.concatenate([tile, tile[::-1]], axis=0)).save(tmp_path / "tiled.png")
    frames = []
    for image, scale, wrap in (("mirrored.png", 24.0, "mirrored_repeat"), ("tiled.png", 12.0, "repeat")):
        scene = edge_on_floor(tmp_path, image, scale, wrap)
        assert ("FOLDED_TEXTURES" in texture_defines(scene)) == (wrap != "repeat")
        with Renderer(ctx, scene) as renderer:
            renderer.render()
            frames.append(renderer.read_color_float()[..., :3])
    assert_finite(frames[0])
    floor = np.abs(frames[1][..., 2] - frames[1][..., 0]) < 0.03  # grey: the sky is blue
    assert 0.3 < floor.mean() < 0.9
    # Measured: 0.0017 at most; 0.36 with the derivatives of the folded UV.
    difference = np.abs(frames[0] - frames[1])[floor]
    assert float(difference.max()) < 0.01, float(difference.max())
    # Far away the checker is grey (a coarse level), not level 0's black and white: the levels are chosen.
    horizon = int(np.argmax(floor.mean(axis=1) > 0.9))
    far = frames[0][horizon:horizon + 6][floor[horizon:horizon + 6]]
    assert float(far.std()) < 0.05, float(far.std())


def test_sizes_are_grouped_into_at_most_four_arrays() -> None:
    assert size_groups([(8, 8), (16, 16), (8, 8)]) == [(8, 8), (16, 16), (8, 8)]  # few sizes: as they are
    sizes = [(8, 8), (16, 16), (16, 8), (12, 20), (256, 256), (8, 16)]
    groups = size_groups(sizes)
    assert len(set(groups)) == MATERIAL_ARRAYS and (256, 256) in groups
    assert all(g[0] >= s[0] and g[1] >= s[1] for g, s in zip(groups, sizes, strict=True))
    # The small ones merge among themselves, not into the large one (the fewest added texels).
    assert groups[sizes.index((8, 16))] != (256, 256)


def test_shelf_packing_keeps_images_apart_and_square() -> None:
    sizes = [SIZES[k % len(SIZES)] for k in range(64)] + [(100, 30)]
    rects, (width, height) = shelf_pack(sizes)
    used = np.zeros((height, width), int)
    for x, y, w, h in rects:
        used[y:y + h, x:x + w] += 1
    assert used.max() == 1 and (rects[:, 2:] == sizes).all()
    assert max(width, height) < 2 * min(width, height)
    assert used.sum() / used.size > 0.6


def test_resampling_is_in_linear_light() -> None:
    """Black and white columns halved: the mean light, 0.5 linear, is sRGB 188 (away from the
    image's edges, where the filter rings); filtering the encoded values would give 128."""
    image = np.zeros((4, 16, 4), np.uint8)
    image[:, ::2, :3] = 255
    image[..., 3] = 255
    half = resample(image, (8, 4))
    assert np.abs(half[:, 2:6, :3].astype(int) - 188).max() <= 4 and (half[..., 3] == 255).all()
    flat = np.full((5, 7, 4), 90, np.uint8)
    assert (resample(flat, (16, 16)) == 90).all()
    assert abs(SRGB_TABLE[188] - 0.5) < 0.003


@pytest.fixture
def ctx_limits(ctx: moderngl.Context) -> Iterator[moderngl.Context]:
    before = context_limits(ctx)
    yield ctx
    use_limits(ctx, before)


@pytest.mark.parametrize("limit, fragments", [
    ({"max_array_texture_layers": 20}, ("the image texture objects[43].material.texture (t38.png) would be layer 21",
                                        "GL_MAX_ARRAY_TEXTURE_LAYERS of 20")),
    ({"max_uniform_block_size": 1024}, ("the first past it: objects[17].material.texture (t12.png)",
                                        "GL_MAX_UNIFORM_BLOCK_SIZE of 1024")),
    ({"max_texture_size": 24}, ("the image texture objects[1].material.texture (t60.png) is 32x32",
                                "GL_MAX_TEXTURE_SIZE of 24")),
    ({"max_texture_size": 100}, ("the atlas of the scene's 64 images that traced rays read would be 160x152",
                                 "GL_MAX_TEXTURE_SIZE of 100")),
])
def test_the_gl_limits_that_remain_are_refused_naming_the_image(ctx_limits: moderngl.Context, many: Scene,
                                                                limit: dict[str, int], fragments: tuple[str, ...]) -> None:
    """Refused before anything is made (the plan's figures against the context's limits), in one
    line. (--method raytrace: the depth method's atlas of baked images would be refused first.)"""
    use_limits(ctx_limits, dataclasses.replace(GpuLimits(16384, 16384, (16384, 16384)), **limit))
    with pytest.raises(GpuLimitError) as refused:
        Renderer(ctx_limits, many, method=Method.RAYTRACE).release()
    message = str(refused.value)
    assert "\n" not in message and all(fragment in message for fragment in fragments), message


def test_a_texture_repeating_on_one_axis_and_clamped_on_the_other(ctx: moderngl.Context, tmp_path: Path) -> None:
    """A glTF sampler may repeat u and clamp v: the clamping sampler, u folded by fract. Seen from
    above and magnified (level 0, as the truth samples), it matches the truth but within half a
    texel of each repeat seam, where it clamps instead of blending with the opposite edge (the
    documented approximation); beyond v = 1 it shows the last row, as GL's clamp does."""
    quadrant_image(5, (8, 8)).save(tmp_path / "q.png")
    (tmp_path / "mixed.toml").write_text("""
[render]
size = [192, 192]
ambient = 1.0
[camera]
eye = [0.0, 3.0, 0.001]
up = [0.0, 0.0, -1.0]
target = [0.0, 0.0, 0.0]
fov_y = 45.0
[[objects]]
name = "card"
shape = { type = "plane", size = [2.4, 2.4] }
material = { type = "diffuse", texture = { path = "q.png", scale = [2.5, 1.6] } }
""", encoding="utf-8")
    scene = load_scene(tmp_path / "mixed.toml")
    card = scene.objects[0]
    assert isinstance(card.material, DiffuseMaterial) and card.material.texture is not None
    texture = card.material.texture
    mixed = dataclasses.replace(texture, sampler={"wrapS": int(Wrap.REPEAT), "wrapT": int(Wrap.CLAMP_TO_EDGE)})
    scene = dataclasses.replace(scene, objects=(dataclasses.replace(card, material=dataclasses.replace(
        card.material, texture=mixed)),))
    assert texture_defines(scene)["FOLDED_TEXTURES"] == 1 and "REPEATING_TEXTURES" not in texture_defines(scene)
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        frame = renderer.read_color_float()[..., :3]
        truth, object_id = eye_truth(renderer)
    assert_finite(frame)
    card_pixels = object_id == 0
    error = np.abs(frame - truth).max(axis=-1)[card_pixels]
    # Most of the card (88 % measured; the rest the seams' bands and the GPU's 8-bit filter weights
    # across the quadrants' edges) is the truth's level 0; a repeated v or a clamped u would put a
    # third of it in another quadrant's colour ...
    assert float(np.median(error)) < 0.005 and float(np.mean(error < 0.02)) > 0.8, float(np.mean(error < 0.02))
    # ... and nowhere off by more than half the difference of two texels across a seam.
    assert float(error.max()) < 0.6
