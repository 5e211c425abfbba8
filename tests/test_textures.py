"""Image textures: the right way round seen directly and in a mirror (an "F" drawn here with
Pillow, its strokes located in the frame), the traced methods against the Embree truth on a
textured scene, the numpy sampler against GL's wrap rules, and the bad inputs."""

from __future__ import annotations

from pathlib import Path

import moderngl
import numpy as np
import pytest
from PIL import Image, ImageDraw

from conftest import assert_finite, scene_from_toml
from depthimpostor.oracles.compare import compare
from depthimpostor.constants import Method, Wrap
from depthimpostor.renderer import Renderer
from depthimpostor.scene import DiffuseMaterial, Scene, load_scene
from depthimpostor.scene.model import Texture
from depthimpostor.textures import texture_bilinear, wrap_texels
from test_cli import assert_one_line_error, run_in_process

SCENES = Path(__file__).resolve().parent.parent / "scenes"


def write_f(path: Path) -> Path:
    """A 64x64 white image with a red "F": its stem on the left, its two bars pointing right from
    the top and the middle of the stem."""
    image = Image.new("RGB", (64, 64), (255, 255, 255))
    draw = ImageDraw.Draw(image)
    draw.rectangle([12, 8, 22, 56], fill=(200, 20, 20))  # stem
    draw.rectangle([12, 8, 50, 18], fill=(200, 20, 20))  # top bar
    draw.rectangle([12, 28, 40, 37], fill=(200, 20, 20))  # middle bar
    image.save(path)
    return path


def f_scene(folder: Path, eye_z: float, card_z: float, mirror: bool) -> Scene:
    """A thin box with the F on every face (upright from outside: meshes.box's UVs), a camera on
    the Z axis looking down -Z, and (`mirror`) a mirror facing +Z at z = -2."""
    write_f(folder / "f.png")
    mirror_object = """
[[objects]]
name = "mirror"
shape = { type = "plane", size = [8.0, 6.0] }
material = { type = "mirror", tint = [1.0, 1.0, 1.0] }
position = [0.0, 0.0, -2.0]
rotation = [90.0, 0.0, 0.0]
""" if mirror else ""
    text = f"""
[render]
size = [240, 180]
impostor_resolution = 256
ambient = 1.0

[camera]
eye = [0.0, 0.0, {eye_z}]
target = [0.0, 0.0, -2.0]
fov_y = 30.0

[[objects]]
name = "card"
shape = {{ type = "box", size = [2.0, 2.0, 0.05] }}
material = {{ type = "diffuse", texture = "f.png" }}
position = [0.0, 0.0, {card_z}]
{mirror_object}"""
    path = folder / "f.toml"
    path.write_text(text, encoding="utf-8")
    return load_scene(path)


def f_strokes(frame: np.ndarray) -> tuple[float, float]:
    """Where the F's red strokes lie in their bounding box: (the stem's side: the mean column of the
    red pixels in the box's lower half, -1 at its left edge to +1 at its right; the bars' side: the
    share of red pixels in the upper half)."""
    red = (frame[..., 0] > 0.2) & (frame[..., 1] < 0.1 * frame[..., 0])
    rows, columns = np.nonzero(red)
    assert len(rows) > 200, f"only {len(rows)} red pixels: the F is not in view"
    top, bottom, left, right = rows.min(), rows.max(), columns.min(), columns.max()
    lower = rows > (top + bottom) / 2
    stem_side = float(np.mean((columns[lower] - left) / max(right - left, 1) * 2.0 - 1.0))
    return stem_side, float(np.mean(rows < (top + bottom) / 2))


def test_a_texture_seen_directly_reads_the_right_way_round(ctx: moderngl.Context, tmp_path: Path) -> None:
    with Renderer(ctx, f_scene(tmp_path, 4.0, 0.0, mirror=False)) as renderer:
        renderer.render()
        frame = renderer.read_color_float()
    assert_finite(frame)
    stem_side, upper_share = f_strokes(frame)
    assert stem_side < -0.4  # the stem on the left: not mirrored
    assert upper_share > 0.6  # the bars in the upper half: not upside down


@pytest.mark.parametrize("method", [Method.RAYTRACE, Method.HYBRID, Method.DEPTH], ids=lambda m: m.option)
def test_a_texture_seen_in_a_mirror_reads_mirrored(ctx: moderngl.Context, tmp_path: Path, method: Method) -> None:
    """The card behind the camera faces the mirror; its front, seen in the mirror, shows the F
    reversed left to right and still upright (a sign facing a mirror reads backwards in it, which
    is why ambulances write theirs backwards)."""
    with Renderer(ctx, f_scene(tmp_path, 4.0, 6.0, mirror=True), method=method) as renderer:
        renderer.render()
        frame = renderer.read_color_float()
    assert_finite(frame)
    stem_side, upper_share = f_strokes(frame)
    assert stem_side > 0.4  # the stem on the right
    assert upper_share > 0.6


def assert_float_noise(ctx: moderngl.Context, scene: Scene, method: Method, mirror_pixels: int) -> None:
    """The method against Embree's truth at 320x180: float noise apart (the traced rays sample
    level 0 bilinearly through the exact sRGB table, as the truth does: textures.py)."""
    with Renderer(ctx, scene.with_overrides(size=(320, 180)), reflection_data=True, method=method) as renderer:
        renderer.render()
        figures = compare(renderer).figures
    assert figures.mirror_pixels > mirror_pixels
    assert figures.wrong_object_share < 0.001
    # 4.7e-6 measured at 512x512 (raytrace); the GPU's own sRGB decode would give 4e-4.
    assert figures.color_rmse < 3e-5, figures.color_rmse


@pytest.mark.parametrize("method", [Method.RAYTRACE, Method.HYBRID], ids=lambda m: m.option)
def test_the_textured_scene_matches_the_truth(ctx: moderngl.Context, method: Method) -> None:
    scene = load_scene(SCENES / "textured_near_mirror.toml")
    assert len(scene.textures) == 2 and scene.texture_slot(scene.objects[0].material) == 0  # floor (repeated), box
    assert_float_noise(ctx, scene, method, mirror_pixels=5000)


def test_round_shapes_with_textures_match_the_truth(ctx: moderngl.Context, tmp_path: Path) -> None:
    """Sphere, cylinder and torus UVs (textured_meshes.py), a mirrored-repeat floor, two textures."""
    write_f(tmp_path / "f.png")
    Image.new("RGB", (8, 8), (40, 200, 90)).save(tmp_path / "green.png")
    objects = "".join(f"""
[[objects]]
name = "{name}"
shape = {shape}
material = {{ type = "diffuse", texture = "{image}" }}
position = {position}
""" for name, shape, image, position in [
        ("sphere", '{ type = "sphere", radius = 0.4 }', "f.png", "[-1.0, 0.8, -0.4]"),
        ("cylinder", '{ type = "cylinder", radius = 0.3, height = 0.8 }', "green.png", "[0.0, 0.4, -0.4]"),
        ("torus", '{ type = "torus", major = 0.3, minor = 0.1 }', "f.png", "[1.0, 0.8, -0.4]"),
    ])
    (tmp_path / "round.toml").write_text(f"""
[camera]
eye = [0.0, 1.2, 3.4]
target = [0.0, 0.8, -1.5]

[[objects]]
name = "floor"
shape = {{ type = "plane", size = [20.0, 20.0] }}
material = {{ type = "diffuse", texture = {{ path = "f.png", scale = [10, 10], wrap = "mirrored_repeat" }} }}

[[objects]]
name = "mirror"
shape = {{ type = "plane", size = [5.0, 2.6] }}
material = {{ type = "mirror" }}
position = [0.0, 1.4, -1.5]
rotation = [90.0, 0.0, 0.0]
{objects}""", encoding="utf-8")
    scene = load_scene(tmp_path / "round.toml")
    assert len(scene.textures) == 3  # f.png repeated, f.png mirrored, green.png
    assert_float_noise(ctx, scene, Method.RAYTRACE, mirror_pixels=5000)


def test_the_numpy_sampler_wraps_as_gl_does() -> None:
    index = np.arange(-5, 6)
    assert wrap_texels(index, 4, Wrap.REPEAT).tolist() == [3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1]
    assert wrap_texels(index, 4, Wrap.CLAMP_TO_EDGE).tolist() == [0, 0, 0, 0, 0, 0, 1, 2, 3, 3, 3]
    assert wrap_texels(index, 4, Wrap.MIRRORED_REPEAT).tolist() == [3, 3, 2, 1, 0, 0, 1, 2, 3, 3, 2]
    # Two texels, sRGB 0 and 255: halfway between their centres is 0.5 linear (decoded, then filtered).
    image = np.zeros((1, 2, 4), np.uint8)
    image[0, 1, :3] = 255
    texture = Texture(image, {"wrapS": int(Wrap.CLAMP_TO_EDGE)}, (0.5, 0.5, 0.5))
    np.testing.assert_allclose(texture_bilinear(texture, np.array([[0.5, 0.5], [0.25, 0.5], [0.0, 0.5]])),
                               [[0.5] * 3, [0.0] * 3, [0.0] * 3])


def test_a_material_with_a_texture_defaults_to_white(tmp_path: Path) -> None:
    scene = f_scene(tmp_path, 4.0, 0.0, mirror=False)
    material = scene.objects[0].material
    assert isinstance(material, DiffuseMaterial) and material.color == (1.0, 1.0, 1.0)
    assert material.texture is not None and material.texture.image.shape == (64, 64, 4)


@pytest.mark.parametrize("material, fragments", [
    ('{ type = "diffuse", texture = "missing.png" }',
     ("objects[0].material.texture", "expected an existing image file", "missing.png")),
    ('{ type = "diffuse", texture = { path = "not_an_image.png" } }',
     ("objects[0].material.texture.path", "expected an image file Pillow can decode")),
    ('{ type = "diffuse", texture = { path = "f.png", wrap = "tile" } }',
     ("objects[0].material.texture.wrap", "expected one of")),
    ('{ type = "diffuse", texture = { path = "f.png", scale = [0, 1] } }', ("objects[0].material.texture.scale",)),
])
def test_bad_textures_exit_2_in_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str], material: str,
                                         fragments: tuple[str, ...]) -> None:
    write_f(tmp_path / "f.png")
    (tmp_path / "not_an_image.png").write_text("no pixels here", encoding="utf-8")
    path = tmp_path / "bad.toml"
    path.write_text(f'[[objects]]\nname = "card"\nshape = {{ type = "box", size = [1.0, 1.0, 1.0] }}\n'
                    f"material = {material}\n", encoding="utf-8")
    assert_one_line_error(*run_in_process(["plan", str(path)], capsys), *fragments)


def test_a_shape_without_uvs_refuses_a_texture(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write_f(tmp_path / "f.png")
    path = tmp_path / "knot.toml"
    path.write_text('[[objects]]\nname = "knot"\nshape = { type = "torus_knot", p = 2, q = 3, radius = 0.5, tube = 0.1 }\n'
                    'material = { type = "diffuse", texture = "f.png" }\n', encoding="utf-8")
    assert_one_line_error(*run_in_process(["plan", str(path)], capsys), "objects[0].material.texture",
                          "got a torus_knot shape, which has none")


def test_more_textures_than_four_are_planned_and_drawn(ctx: moderngl.Context, tmp_path: Path) -> None:
    """Five distinct textures (once refused: one texture unit each, four units): planned and drawn,
    the fifth card showing its own image (tests/test_many_textures.py draws 64)."""
    write_f(tmp_path / "f.png")
    Image.new("RGB", (8, 8), (40, 200, 90)).save(tmp_path / "green.png")
    cards = "".join(f'[[objects]]\nname = "card {k}"\nshape = {{ type = "box", size = [1.0, 1.0, 1.0] }}\n'
                    f'material = {{ type = "diffuse", texture = {{ path = "{"green" if k == 4 else "f"}.png", '
                    f'scale = [{k + 1}, 1] }} }}\nposition = [{1.5 * k - 3.0}, 0.0, 0.0]\n' for k in range(5))
    path = tmp_path / "many.toml"
    path.write_text('[render]\nsize = [160, 90]\nambient = 1.0\n[camera]\neye = [0.0, 0.0, 7.0]\n'
                    'target = [0.0, 0.0, 0.0]\n' + cards, encoding="utf-8")
    scene = load_scene(path)
    assert len(scene.textures) == 5
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        frame = renderer.read_color_float()
    assert_finite(frame)
    green = (frame[..., 1] > 0.4) & (frame[..., 0] < 0.1)
    columns = np.nonzero(green.any(axis=0))[0]
    assert green.sum() > 200 and columns.min() > 110, (green.sum(), columns.min())  # the rightmost card alone


QUAD_OBJ = """# A 2 x 2 square in the XZ plane facing +Y, its texture coordinates as a plane shape lays them out
v -1 0 -1
v 1 0 -1
v 1 0 1
v -1 0 1
vt 0 1
vt 1 1
vt 1 0
vt 0 0
f 1/1 4/4 3/3
f 1/1 3/3 2/2
"""

TEXTURED_CARD = """[render]
size = [96, 96]
ambient = 1.0
[camera]
eye = [0.0, 3.0, 0.001]
up = [0.0, 0.0, -1.0]
target = [0.0, 0.0, 0.0]
fov_y = 45.0
[[objects]]
name = "card"
shape = {shape}
material = {{ type = "diffuse", color = [1.0, 1.0, 1.0], texture = "f.png" }}
"""


def test_a_mesh_files_texture_coordinates_are_read(ctx: moderngl.Context, tmp_path: Path) -> None:
    """An OBJ's `vt` coordinates (v up from the image's bottom row, as files have them) texture it
    as the project's own shapes are textured: a square read from a file, its corners' coordinates
    those a plane shape gives its corners, draws the plane's very picture (the "F" upright, seen
    from above)."""
    write_f(tmp_path / "f.png")
    (tmp_path / "quad.obj").write_text(QUAD_OBJ, encoding="utf-8")
    frames = []
    for name, shape in (("plane", '{ type = "plane", size = [2.0, 2.0] }'), ("mesh", '{ type = "mesh", path = "quad.obj" }')):
        (tmp_path / f"{name}.toml").write_text(TEXTURED_CARD.format(shape=shape), encoding="utf-8")
        with Renderer(ctx, load_scene(tmp_path / f"{name}.toml")) as renderer:
            renderer.render()
            frames.append(renderer.read_color_float())
    assert_finite(frames[1])
    red = (frames[0][..., 0] > 0.5) & (frames[0][..., 1] < 0.3)
    assert red.mean() > 0.05, "the F is in the plane's picture"
    np.testing.assert_allclose(frames[1], frames[0], atol=2e-3)


def test_a_mesh_file_without_texture_coordinates_refuses_a_texture(tmp_path: Path,
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    write_f(tmp_path / "f.png")
    (tmp_path / "bare.obj").write_text("\n".join(line for line in QUAD_OBJ.splitlines() if not line.startswith("vt"))
                                       .replace("/1", "").replace("/2", "").replace("/3", "").replace("/4", ""),
                                       encoding="utf-8")
    (tmp_path / "bare.toml").write_text(TEXTURED_CARD.format(shape='{ type = "mesh", path = "bare.obj" }'),
                                        encoding="utf-8")
    assert_one_line_error(*run_in_process(["plan", str(tmp_path / "bare.toml")], capsys), "objects[0].material.texture",
                          "bare.obj, which has none")


def test_an_image_file_is_decoded_once_whatever_its_slots(tmp_path: Path) -> None:
    """Two slots of one file (two scales, two wraps) are two textures of one decoded image (an
    8192^2 image decoded twice cost seconds and 256 MiB), and the mean colour is the mean of the
    decoded texels."""
    rng = np.random.default_rng(7)
    pixels = rng.integers(0, 256, (37, 53, 4), dtype=np.uint8)
    Image.fromarray(pixels, "RGBA").save(tmp_path / "noise.png")
    scene = scene_from_toml("""
[[objects]]
name = "floor"
shape = { type = "plane", size = [4.0, 4.0] }
material = { type = "diffuse", texture = { path = "noise.png", scale = [3.0, 3.0] } }
[[objects]]
name = "box"
shape = { type = "box", size = [1.0, 1.0, 1.0] }
material = { type = "diffuse", texture = { path = "noise.png", wrap = "clamp" } }
position = [0.0, 0.5, 0.0]
""", "noise.toml", tmp_path)
    first, second = scene.textures
    assert first is not second and first.scale != second.scale and first.image is second.image
    decoded = ((pixels[..., :3] / 255.0 + 0.055) / 1.055) ** 2.4
    decoded = np.where(pixels[..., :3] / 255.0 <= 0.04045, pixels[..., :3] / 255.0 / 12.92, decoded)
    np.testing.assert_allclose(first.mean_color, decoded.reshape(-1, 3).mean(axis=0), rtol=1e-12)


def test_an_image_file_edited_in_place_is_read_again_and_its_old_pixels_let_go(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The caches are keyed by the file, its stamp (modification time, size) beside: an image
    rewritten while the viewer runs gives its new texels, and the old decode is not kept beside the
    new one (keyed by (file, time), every edit of an 8192^2 image held another 256 MiB)."""
    import os

    from depthimpostor import textures
    from depthimpostor.scene.fields import At

    monkeypatch.setattr(textures, "_CACHE", {})
    monkeypatch.setattr(textures, "_DECODED_FILES", {})
    path = tmp_path / "wall.png"
    at = At("s.toml", "objects[0].material.texture")
    Image.new("RGB", (8, 8), (255, 0, 0)).save(path)
    first = textures.read_texture(path, at, (1.0, 1.0), (int(Wrap.REPEAT), int(Wrap.REPEAT)))
    assert textures.read_texture(path, at, (1.0, 1.0), (int(Wrap.REPEAT), int(Wrap.REPEAT))) is first
    Image.new("RGB", (8, 8), (0, 0, 255)).save(path)
    stat = path.stat()
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns + 1_000_000_000))  # a clock that ticks in seconds
    second = textures.read_texture(path, at, (1.0, 1.0), (int(Wrap.REPEAT), int(Wrap.REPEAT)))
    assert tuple(first.image[0, 0, :3]) == (255, 0, 0) and tuple(second.image[0, 0, :3]) == (0, 0, 255)
    assert len(textures._DECODED_FILES) == 1 and len(textures._CACHE) == 1
