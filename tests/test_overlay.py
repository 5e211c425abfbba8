"""The viewer's overlay text and the copy of a frame into the window, drawn headless."""

from __future__ import annotations

from collections.abc import Iterator

import moderngl
import numpy as np
import pytest

from depthimpostor.gpu.context import bind_default_framebuffer
from depthimpostor.font import CHARACTERS, SOLID, rasterize
from depthimpostor.passes.overlay import PANEL_PADDING, OverlayPass, Panel, layout
from depthimpostor.passes.present import PresentPass
from depthimpostor.gpu.shaders import ProgramCache

SIZE = (240, 120)


@pytest.fixture
def programs(ctx: moderngl.Context) -> Iterator[ProgramCache]:
    cache = ProgramCache(ctx)
    yield cache
    cache.release()


def test_every_printable_character_has_a_glyph() -> None:
    atlas = rasterize(14)
    for character in CHARACTERS + SOLID:
        x, y = atlas.cells[character]
        width, height = atlas.cell_size
        ink = atlas.coverage[y : y + height, x : x + width]
        assert (ink.max() > 0) == (character != " "), repr(character)
        assert atlas.advances[character] > 0
    assert atlas.glyph("\u00e9") == "?"


def test_layout_places_one_quad_per_glyph_inside_its_panel() -> None:
    atlas = rasterize(14)
    vertices = layout([Panel(("ab c", "d")), Panel(("x",), "top-right")], atlas, SIZE)
    assert vertices.shape == ((2 + 4 + 1) * 6, 8)  # two panels, four visible glyphs
    right_panel = vertices[-12:-6]
    assert right_panel[:, 0].max() == pytest.approx(SIZE[0] - PANEL_PADDING, abs=1)


def read(framebuffer: moderngl.Framebuffer) -> np.ndarray:
    return np.frombuffer(framebuffer.read(components=4), np.uint8).reshape(SIZE[1], SIZE[0], 4).astype(int)


def test_overlay_draws_inside_its_panel_only(ctx: moderngl.Context, programs: ProgramCache) -> None:
    texture = ctx.texture(SIZE, 4)
    framebuffer = ctx.framebuffer([texture])
    overlay = OverlayPass(ctx, programs, 14)
    try:
        framebuffer.use()
        framebuffer.clear(0.5, 0.5, 0.5, 1.0)
        before = read(framebuffer)
        overlay.draw([Panel(("frame 12.3 ms", "fps 81"))], SIZE)
        after = read(framebuffer)
    finally:
        bind_default_framebuffer(ctx)
        overlay.release()
        framebuffer.release()
        texture.release()
    changed = np.argwhere(np.abs(after - before).max(axis=2) > 0)
    rows, columns = changed[:, 0], changed[:, 1]
    height = 2 * overlay.atlas.line_height + 2 * PANEL_PADDING
    assert rows.min() == PANEL_PADDING and rows.max() == PANEL_PADDING + height - 1  # row 0 is the top
    assert columns.min() == PANEL_PADDING and columns.max() < SIZE[0] // 2
    panel = after[PANEL_PADDING : PANEL_PADDING + height, PANEL_PADDING : columns.max()]
    assert panel[..., 0].min() < 64 and panel[..., 0].max() > 200, "dark panel, white text"


def test_present_flips_rows_and_copies_pixels_exactly(ctx: moderngl.Context, programs: ProgramCache) -> None:
    rng = np.random.default_rng(5)
    pixels = rng.integers(0, 256, (SIZE[1], SIZE[0], 4), dtype=np.uint8)
    frame = ctx.texture(SIZE, 4, pixels.tobytes())
    target = ctx.texture(SIZE, 4)
    framebuffer = ctx.framebuffer([target])
    present = PresentPass(ctx, programs)
    try:
        framebuffer.use()
        present.draw(frame)
        shown = read(framebuffer)
    finally:
        bind_default_framebuffer(ctx)
        present.release()
        for item in (framebuffer, target, frame):
            item.release()
    np.testing.assert_array_equal(shown, pixels[::-1].astype(int))
