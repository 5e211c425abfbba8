"""The viewer's overlay: panels of text drawn over a finished frame, with Pillow's font.

Text is laid out on the CPU into quads (six vertices per glyph, pixel-aligned so that the glyph
atlas maps one to one onto the frame) and drawn in one call with alpha blending.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import moderngl
import numpy as np

from ..gpu.gl_state import RasterState, raster_state
from ..gpu.bindings import TextureUnit
from ..font import SOLID, GlyphAtlas, rasterize
from ..gpu.shaders import ProgramCache
from ..gpu.uniforms import write

Anchor = Literal["top-left", "top-right"]

#: Pixels between a panel's edge and its text, and its colour (dark, mostly opaque: legible on
#: a white sky and a black mirror alike).
PANEL_PADDING = 6
PANEL_COLOR = (0.0, 0.0, 0.0, 0.62)
TEXT_COLOR = (1.0, 1.0, 1.0, 1.0)
#: Pixels between a tab-separated first column and the rest of its line.
COLUMN_GAP = 16
#: Floats per vertex: position (2), atlas texel (2), colour (4).
_VERTEX_FLOATS = 8


@dataclass(frozen=True)
class Panel:
    lines: tuple[str, ...]  # a tab in a line starts its second column, aligned across the panel
    anchor: Anchor = "top-left"


def _quad(
    position: tuple[float, float], size: tuple[float, float], texel: tuple[float, float],
    texel_size: tuple[float, float], color: tuple[float, ...],
) -> list[list[float]]:
    """Two triangles covering `size` pixels at `position`, their atlas texels spanning `texel_size`."""
    (x, y), (width, height), (tx, ty), (tw, th) = position, size, texel, texel_size
    corners = [(0, 0), (1, 0), (1, 1), (0, 0), (1, 1), (0, 1)]
    return [[x + i * width, y + j * height, tx + i * tw, ty + j * th, *color] for i, j in corners]


def _tab_stop(lines: tuple[str, ...], atlas: GlyphAtlas) -> float:
    """Where text after a tab starts: past the widest text before one, so columns line up."""
    firsts = [line.split("\t")[0] for line in lines if "\t" in line]
    return max((atlas.text_width(first) for first in firsts), default=0.0) + COLUMN_GAP


def _line_width(line: str, atlas: GlyphAtlas, tab_stop: float) -> float:
    first, tab, rest = line.partition("\t")
    return tab_stop + atlas.text_width(rest) if tab else atlas.text_width(first)


def layout(panels: list[Panel], atlas: GlyphAtlas, size: tuple[int, int]) -> np.ndarray:
    """The vertices of every panel's background and glyphs, (n, 8) float32, in frame pixels."""
    cell_width, line_height = atlas.cell_size
    solid_x, solid_y = atlas.cells[SOLID]
    vertices: list[list[float]] = []
    for panel in panels:
        tab_stop = _tab_stop(panel.lines, atlas)
        width = max((_line_width(line, atlas, tab_stop) for line in panel.lines), default=0.0) + 2 * PANEL_PADDING
        height = len(panel.lines) * line_height + 2 * PANEL_PADDING
        x0 = PANEL_PADDING if panel.anchor == "top-left" else size[0] - PANEL_PADDING - width
        # A panel wider than the frame keeps its left edge in view.
        x0, y0 = round(max(x0, PANEL_PADDING)), PANEL_PADDING
        # The solid cell is sampled at its centre texel, stretched over the panel.
        solid_centre = (solid_x + cell_width / 2, solid_y + line_height / 2)
        vertices += _quad((x0, y0), (width, height), solid_centre, (0.0, 0.0), PANEL_COLOR)
        for row, line in enumerate(panel.lines):
            pen = float(x0 + PANEL_PADDING)
            top = y0 + PANEL_PADDING + row * line_height
            for character in line:
                if character == "\t":
                    pen = float(x0 + PANEL_PADDING) + tab_stop
                    continue
                glyph = atlas.glyph(character)
                if character != " ":
                    tx, ty = atlas.cells[glyph]
                    cell = (cell_width, line_height)
                    vertices += _quad((round(pen) - atlas.margin, top), cell, (tx, ty), cell, TEXT_COLOR)
                pen += atlas.advances[glyph]
    return np.asarray(vertices, np.float32).reshape(-1, _VERTEX_FLOATS)


class OverlayPass:
    def __init__(self, ctx: moderngl.Context, programs: ProgramCache, font_pixels: int) -> None:
        self.ctx = ctx
        self.program = programs.get("overlay.vert", "overlay.frag")
        self.atlas = rasterize(font_pixels)
        height, width = self.atlas.coverage.shape
        self.glyphs = ctx.texture((width, height), 1, self.atlas.coverage.tobytes())
        self.glyphs.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._vertices: moderngl.Buffer | None = None
        self._vertex_array: moderngl.VertexArray | None = None

    def draw(self, panels: list[Panel], size: tuple[int, int]) -> None:
        """Blend the panels over the bound framebuffer, which is `size` pixels."""
        vertices = layout(panels, self.atlas, size)
        if len(vertices) == 0:
            return
        data = vertices.tobytes()
        if self._vertices is None or self._vertex_array is None or self._vertices.size < len(data):
            self._release_buffers()
            # Room to grow: the text changes every frame, the buffer is reused while it fits.
            self._vertices = self.ctx.buffer(reserve=2 * len(data))
            self._vertex_array = self.ctx.vertex_array(
                self.program, [(self._vertices, "2f 2f 4f", "in_position", "in_texel", "in_color")]
            )
        vertex_array = self._vertex_array
        self._vertices.write(data)
        self.glyphs.use(TextureUnit.GLYPHS)
        write(self.program, "u_glyphs", TextureUnit.GLYPHS)
        write(self.program, "u_target_size", (float(size[0]), float(size[1])))
        with raster_state(self.ctx, RasterState(depth_test=False, blend=True)):
            vertex_array.render(moderngl.TRIANGLES, vertices=len(vertices))

    def _release_buffers(self) -> None:
        for item in (self._vertex_array, self._vertices):
            if item is not None:
                item.release()
        self._vertex_array = self._vertices = None

    def release(self) -> None:
        self._release_buffers()
        self.glyphs.release()
