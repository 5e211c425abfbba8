"""What the bakes of a scene of many objects skip or read more cheaply (issue 32: start 1,000
objects in under 2 s), held against the way they did it before: each draw of one object binds its
own material record instead of indexing the scene's table per fragment, and a frame bakes only the
images its reflected rays may enter (methods/entered_images.py), the others when a later frame's may."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import moderngl
import numpy as np
import pytest
from conftest import scene_from_toml
from PIL import Image, ImageDraw

from depthimpostor.constants import MATERIAL_BLOCK_RECORDS, Method
from depthimpostor.methods.atlas import ImpostorAtlas
from depthimpostor.methods.baked_images import BakedImages
from depthimpostor.methods.entered_images import EnteredImages
from depthimpostor.plan import plan_render
from depthimpostor.gpu import uniforms
from depthimpostor.gpu.uniforms import materials_in_storage
from depthimpostor.passes import diffuse
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene

HEAD = """
[render]
size = [160, 90]
impostor_resolution = 24
ambient = 0.3
[camera]
eye = [0.0, 2.0, 6.0]
target = [0.0, 0.5, 0.0]
[[lights]]
type = "directional"
direction = [-0.4, -1.0, -0.3]
[[objects]]
name = "mirror"
shape = { type = "sphere", radius = 0.7 }
material = { type = "mirror" }
position = [0.0, 0.8, 0.0]
"""


def textured_ring(folder: Path, count: int, extra: str = "") -> Scene:
    """`count` small objects in rings about a mirror sphere, each checkered in a colour of its own
    (every record of a table past MATERIAL_BLOCK_RECORDS read: a wrong one shows another colour),
    every fifth textured with an "F" in a colour factor of its own (a texture seen the wrong way
    round or not at all shows)."""
    return scene_from_toml(textured_ring_toml(folder, count, extra), str(folder / "ring.toml"), folder)


def textured_ring_toml(folder: Path, count: int, extra: str = "") -> str:
    """textured_ring's scene file (its texture written into `folder`)."""
    image = Image.new("RGB", (32, 32), (255, 255, 255))
    draw = ImageDraw.Draw(image)
    draw.rectangle([6, 4, 11, 28], fill=(200, 20, 20))
    draw.rectangle([6, 4, 25, 9], fill=(200, 20, 20))
    draw.rectangle([6, 14, 20, 18], fill=(200, 20, 20))
    image.save(folder / "f.png")
    text = HEAD
    for k in range(count):
        angle, ring = 2.0 * math.pi * k / 50, 1.3 + 0.3 * (k // 50)
        hue = (k * 0.618034) % 1.0
        colour = ", ".join(f"{0.5 + 0.45 * math.cos(2.0 * math.pi * (hue + c / 3.0)):.4f}" for c in range(3))
        material = (f'{{ type = "diffuse", color = [{colour}], texture = "f.png" }}' if k % 5 == 0 else
                    f'{{ type = "checker", color_a = [{colour}], color_b = [0.1, 0.1, 0.1], scale = 0.05 }}')
        shape = '{ type = "sphere", radius = 0.09 }' if k % 2 else '{ type = "box", size = [0.14, 0.14, 0.14] }'
        text += (f'[[objects]]\nname = "object {k}"\nshape = {shape}\nmaterial = {material}\n'
                 f"position = [{ring * math.cos(angle):.4f}, {0.1 + 0.05 * (k % 7):.4f}, {ring * math.sin(angle):.4f}]\n"
                 f"rotation = [0.0, {(37.0 * k) % 360:.1f}, 0.0]\n")
    return text + extra


def baked_atlas(ctx: moderngl.Context, scene: Scene, method: Method) -> tuple[list[bytes], np.ndarray, list[str]]:
    """Every layer of the atlas `method` bakes for `scene`, its first frame, and the uniform blocks
    its bakes' one-object program reads materials from."""
    with Renderer(ctx, scene, method=method) as renderer:
        renderer.render()
        baked = renderer.graph.baked_images
        assert baked is not None
        blocks = [name for name in ("DrawnMaterial", "MaterialRecords") if name in baked.diffuse.program]
        return [texture.read() for texture in baked.atlas.textures], renderer.read_color_float(), blocks


@pytest.mark.parametrize("method", [Method.DEPTH, Method.HYBRID])
def test_a_bakes_draw_reads_its_own_record_and_bakes_what_the_table_gives(
        ctx: moderngl.Context, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, method: Method) -> None:
    """Past a uniform block's records the table is a storage buffer, which llvmpipe reads per
    fragment at a cost: the bakes bind each object's record as a one-record uniform block instead.
    The atlas is the one baked by indexing the table, to the bit, in every layer."""
    scene = textured_ring(tmp_path, 200)
    assert len(scene.materials) == 200 > MATERIAL_BLOCK_RECORDS and materials_in_storage(scene)
    atlas, frame, blocks = baked_atlas(ctx, scene, method)
    assert blocks == ["DrawnMaterial"]
    # The way before: every program reads the table (the one-object draws write u_material_index).
    table_defines = uniforms.shading_defines
    monkeypatch.setattr(diffuse, "shading_defines", lambda scene, drawn_material=False: table_defines(scene))
    table_atlas, table_frame, table_blocks = baked_atlas(ctx, scene, method)
    assert table_blocks == ["MaterialRecords"]
    assert len(atlas) == len(table_atlas) >= 2
    for layer, table_layer in zip(atlas, table_atlas, strict=True):
        assert layer == table_layer
    np.testing.assert_array_equal(frame, table_frame)
    colours = np.frombuffer(atlas[0], np.uint8).reshape(-1, 4)
    assert len(np.unique(colours[colours[:, 3] > 0, :3], axis=0)) > 200  # the images show their colours


def assert_baked_alike(frame: np.ndarray, eager: np.ndarray) -> None:
    """`frame`, whose images were baked lazily, is the frame of baking them all (`eager`) but for
    where its images sit in the atlas: a lazily baked image takes the next free tile
    (BakedImages.place), and the rasterizer rounds an image's window positions a little
    differently at another tile (the viewport's origin is added in float), so a texel's colour may
    be one 8-bit level off, and what is computed from texel places a float's rounding. A lazily
    baked frame whose images sit where the eager renderer's do is the same to the bit (the
    1,000-object scene at 32^2, and the sample view turned on from the start)."""
    assert np.isfinite(frame).all()
    difference = np.abs(frame - eager)
    assert difference.max() <= 1.0 / 255.0 + 1e-6
    assert (difference.max(axis=-1) > 1e-5).mean() <= 0.005


#: Where the eye stands in turn: the scene's view, then round the mirror and nearer (other images'
#: objects come into its reflection).
VIEWS = [None, (2.5, 1.2, 5.0), (-3.0, 2.8, 3.5)]


def frames_along(ctx: moderngl.Context, scene: Scene, method: Method) -> tuple[list[np.ndarray], list[int], int]:
    """The frames of `scene` from each of VIEWS, the images baked by the end of each, and how many
    images there are."""
    frames, baked_by = [], []
    with Renderer(ctx, scene, method=method) as renderer:
        baked = renderer.graph.baked_images
        assert baked is not None
        for eye in VIEWS:
            if eye is not None:
                renderer.look_at(dataclasses.replace(scene.camera, eye=eye))
            renderer.render()
            frames.append(renderer.read_color_float())
            baked_by.append(baked.bakes)
        return frames, baked_by, len(baked.depth_images)


@pytest.mark.parametrize("method,samples", [(Method.DEPTH, 1), (Method.DEPTH, 4), (Method.HYBRID, 1),
                                            (Method.BILLBOARD, 1)])
def test_a_frame_bakes_the_images_its_rays_enter_and_is_the_frame_of_baking_them_all(
        ctx: moderngl.Context, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, method: Method, samples: int) -> None:
    """A scene of 300 textured objects about a mirror (its images found through lists): the first
    frame bakes only the images its mirror pixels' rays may enter; as the eye moves, a frame bakes
    those its rays come to enter. Every frame (each sub-frame of an anti-aliased one with its own
    rays) is the one of a renderer that bakes every image at once, to the bit."""
    scene = textured_ring(tmp_path, 300).with_overrides(samples=samples)
    assert BakedImages.bakes_lazily(scene, 300)
    assert any("each baked when a frame's reflected rays may first enter it" in p.reason
               for p in plan_render(scene, method).passes)
    lazy, baked_by, images = frames_along(ctx, scene, method)
    assert baked_by[0] < images and baked_by[0] < baked_by[-1] <= images, baked_by  # the rest as rays come to them
    monkeypatch.setattr(BakedImages, "bakes_lazily", classmethod(lambda cls, scene, images: False))
    eager, eager_baked_by, _ = frames_along(ctx, scene, method)
    assert eager_baked_by == [images] * len(VIEWS)
    for lazy_frame, eager_frame in zip(lazy, eager, strict=True):
        assert_baked_alike(lazy_frame, eager_frame)


def test_a_frame_that_sees_what_the_last_saw_runs_no_second_pass(ctx: moderngl.Context, tmp_path: Path,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """The images a frame's rays enter are found again only where the eye moved: a static scene's
    next frames (whose stale images no ray enters) cost no pass and bake nothing. Once the world
    moves, every stale image is baked (the pass would run at every frame)."""
    scene = textured_ring(tmp_path, 300)
    calls = []
    find = EnteredImages.find
    monkeypatch.setattr(EnteredImages, "find", lambda self, *args: calls.append(1) or find(self, *args))
    with Renderer(ctx, scene) as renderer:
        baked = renderer.graph.baked_images
        assert baked is not None
        for _ in range(3):
            renderer.render()
        assert len(calls) == 1 and 0 < baked.bakes < len(baked.depth_images) and len(renderer.stats.bake_seconds) == 1
        renderer.look_at(dataclasses.replace(scene.camera, eye=VIEWS[1]))
        renderer.render()
        assert len(calls) == 2 and baked.bakes < len(baked.depth_images)
        # Once the world moves (an object, a light), what is stale is baked whole, with no pass.
        world = renderer.world
        baked.move({g.index: g for g in world.geometry}, {world.reflected_objects[0].index}, set())
        renderer.render()
        assert len(calls) == 2 and not baked.stale and baked.bakes >= len(baked.depth_images)


def test_a_lazy_frame_draws_its_diffuse_objects_once(ctx: moderngl.Context, tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """The images a frame's rays enter are found behind the frame's own depth: the render graph
    runs the eye's diffuse pass before the stand-in's bake (render_graph._schedule), so the
    diffuse objects are drawn once a frame, not a second time for the finding pass; and the
    finding pass still sees them: a board between the eye and half the mirror leaves fewer images
    entered than with every mirror pixel counted."""
    scene = textured_ring(tmp_path, 300, '[[objects]]\nname = "board"\nshape = { type = "box", size = [0.6, 1.0, 0.05] }\n'
                                         'material = { type = "diffuse", color = [0.5, 0.5, 0.5] }\n'
                                         'position = [0.3, 1.3, 3.0]\n')
    drawn_by: list[object] = []
    draw = diffuse.DiffusePass.draw
    monkeypatch.setattr(diffuse.DiffusePass, "draw",
                        lambda self, *args, **kwargs: drawn_by.append(self) or draw(self, *args, **kwargs))
    with Renderer(ctx, scene) as renderer:
        graph, baked = renderer.graph, renderer.graph.baked_images
        assert baked is not None and baked.lazily
        renderer.render()
        assert sum(owner is graph.diffuse for owner in drawn_by) == 1
        behind = baked.bakes
    find = EnteredImages.find
    monkeypatch.setattr(EnteredImages, "find", lambda self, camera, surfaces, mirrors, behind_frame=False:
                        find(self, camera, surfaces, mirrors, False))
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        assert renderer.graph.baked_images is not None
        assert behind < renderer.graph.baked_images.bakes, "the frame's diffuse objects hid no mirror pixel"


def test_the_sample_view_of_a_lazily_baked_scene_shows_every_image_baked(ctx: moderngl.Context, tmp_path: Path,
                                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """The sample view's diffuse pass draws the baked images' samples, so its frames bake before
    the eye's passes, every stale image (render_graph.RenderGraph.draw): turned on after a lazy
    frame, or on from the start, it shows what a renderer that bakes every image at once shows."""
    scene = textured_ring(tmp_path, 300)

    def sample_views(turned_on_late: bool) -> list[np.ndarray]:
        with Renderer(ctx, scene) as renderer:
            if turned_on_late:
                renderer.render()  # lazily: some images stay stale
            renderer.set_show_samples(True)
            frames = []
            for _ in range(2):
                renderer.render()
                frames.append(renderer.read_color_float())
            return frames

    lazy_late, lazy_first = sample_views(True), sample_views(False)
    monkeypatch.setattr(BakedImages, "bakes_lazily", classmethod(lambda cls, scene, images: False))
    (eager, _) = sample_views(False)
    for frame in lazy_first:  # placed as the eager renderer places them: each its slot's tile
        assert np.isfinite(frame).all()
        np.testing.assert_array_equal(frame, eager)
    for frame in lazy_late:
        assert_baked_alike(frame, eager)


def test_a_lazy_atlas_makes_the_rows_its_frames_bake_and_keeps_them_as_it_grows(ctx: moderngl.Context,
                                                                              tmp_path: Path) -> None:
    """Baked lazily, the images a frame bakes take the atlas's first tiles (BakedImages.place) and
    the atlas makes only the rows they fill (llvmpipe writes every byte of a texture it makes: a
    thousand objects' atlas took a second); a later frame that bakes more makes more rows, the
    images baked before keeping their texels; the benchmark's bake_again makes them all."""
    scene = textured_ring(tmp_path, 300)
    with Renderer(ctx, scene) as renderer:
        baked = renderer.graph.baked_images
        assert baked is not None and baked.lazily
        atlas = baked.atlas
        assert atlas.rows_made == 1
        renderer.render()
        first = [image for image in baked.depth_images if image.slot not in baked.stale]
        places = sorted(atlas.slot_of(image.tile) for image in first)
        assert places == list(range(len(first))) < [*range(len(baked.depth_images))]  # the first tiles, in order
        assert atlas.rows_made == -(-len(first) // atlas.columns) < atlas.rows
        assert atlas.bytes < ImpostorAtlas.bytes_for(atlas.count, atlas.resolution, True, back_colors=True)
        texels = [atlas.read(image) for image in first]
        rows = atlas.rows_made
        baked.bake_again()
        renderer.render()
        assert atlas.rows_made == atlas.rows > rows and not baked.stale
        # Baked again, in the tiles they had: the same texels (the same draws at the same places).
        for image, before in zip(first, texels, strict=True):
            after = atlas.read(image)
            np.testing.assert_array_equal(after.color, before.color)
            np.testing.assert_array_equal(after.depth, before.depth)


def test_an_atlas_grown_keeps_what_its_rows_hold(ctx: moderngl.Context) -> None:
    """ImpostorAtlas.grow copies the rows made into the larger textures (every attachment)."""
    from depthimpostor.oracles.reference import DepthImageData
    from depthimpostor.ppc import PPC

    atlas = ImpostorAtlas(ctx, 20, 8, back_colors=True, beyond=True, triangle_ids=True, rows_made=1)
    try:
        assert atlas.rows == 4 and atlas.rows_made == 1 and atlas.size == (40, 8)
        camera = PPC.look_at((0, 0, 0), (0, 0, -1), (0, 1, 0), 40.0, 8, 8)
        rng = np.random.default_rng(1)
        data = DepthImageData(camera, rng.uniform(0, 1, (8, 8, 3)).round(2), rng.uniform(0.2, 0.9, (8, 8)).astype(np.float32),
                              1, rng.uniform(0.9, 1.0, (8, 8)).astype(np.float32), rng.uniform(0, 1, (8, 8, 3)).round(2),
                              rng.uniform(0.9, 1.0, (8, 8)).astype(np.float32))
        tile = atlas.tile_origin(3)
        atlas.write(tile, data)
        image = dataclasses.make_dataclass("Tile", ["tile", "target", "camera"])((*tile, 8, 8), type("T", (), {"index": 1}),
                                                                              camera)  # what read reads of an image
        before = atlas.read(image)  # type: ignore[arg-type]
        atlas.grow(11)  # three rows needed, at least twice the one made: three
        assert atlas.rows_made == 3 and atlas.size == (40, 24)
        atlas.grow(2)  # made already
        assert atlas.rows_made == 3
        after = atlas.read(image)  # type: ignore[arg-type]
        for name in ("color", "depth", "back_layer", "back_color", "beyond_depth"):
            np.testing.assert_array_equal(getattr(after, name), getattr(before, name))
        atlas.grow(100)  # at most the grid's rows
        assert atlas.rows_made == 4
    finally:
        atlas.release()
