"""Text for the viewer's overlay: printable ASCII rasterized once by Pillow into a glyph atlas.

Each glyph gets a cell one line high, drawn at the cell's left edge plus a margin; the overlay
draws the whole cell at the pen position and advances the pen by the glyph's advance width, so
cells overlap where glyphs are narrow (coverage is zero there, and blending adds nothing).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from PIL import Image, ImageDraw, ImageFont

#: The characters the atlas holds; anything else is drawn as "?".
CHARACTERS = "".join(chr(code) for code in range(32, 127))
#: A cell of full coverage, for solid rectangles (the overlay's panels) drawn with the text's program.
SOLID = "\x7f"
REPLACEMENT = "?"
#: Empty pixels around each glyph's ink, so that neighbouring cells never bleed into each other.
_MARGIN = 2


@dataclass(frozen=True)
class GlyphAtlas:
    coverage: np.ndarray  # (height, width) uint8, row 0 at the top
    cells: dict[str, tuple[int, int]]  # character -> (x, y) of its cell's top-left in the atlas
    advances: dict[str, float]  # pen advance in pixels
    cell_size: tuple[int, int]  # (width, height) of every cell
    margin: int  # pixels between a cell's left edge and the pen position

    @property
    def line_height(self) -> int:
        return self.cell_size[1]

    def glyph(self, character: str) -> str:
        return character if character in self.cells else REPLACEMENT

    def text_width(self, text: str) -> float:
        return sum(self.advances[self.glyph(c)] for c in text)


def load_font(size: int) -> ImageFont.FreeTypeFont | ImageFont.ImageFont:
    """Pillow's bundled font at `size` pixels (FreeType), or its fixed bitmap font where Pillow was
    built without FreeType."""
    try:
        return ImageFont.load_default(size=size)
    except (ImportError, OSError, TypeError):
        return ImageFont.load_default()


def rasterize(size: int) -> GlyphAtlas:
    """The atlas of CHARACTERS at `size` pixels, plus the SOLID cell."""
    font = load_font(size)
    ascent, descent = font.getmetrics() if hasattr(font, "getmetrics") else (size, size // 4)
    boxes = {c: font.getbbox(c) for c in CHARACTERS}
    cell_width = int(math.ceil(max(box[2] for box in boxes.values()))) + 2 * _MARGIN
    cell_height = max(int(ascent + descent), max(int(box[3]) for box in boxes.values())) + _MARGIN
    glyphs = CHARACTERS + SOLID
    columns = 16
    rows = math.ceil(len(glyphs) / columns)
    image = Image.new("L", (columns * cell_width, rows * cell_height), 0)
    draw = ImageDraw.Draw(image)
    cells: dict[str, tuple[int, int]] = {}
    for index, character in enumerate(glyphs):
        x, y = (index % columns) * cell_width, (index // columns) * cell_height
        cells[character] = (x, y)
        if character == SOLID:
            draw.rectangle((x, y, x + cell_width - 1, y + cell_height - 1), fill=255)
        else:
            draw.text((x + _MARGIN, y), character, fill=255, font=font)
    advances = {c: float(font.getlength(c)) for c in CHARACTERS}
    advances[SOLID] = float(cell_width)
    return GlyphAtlas(np.asarray(image, np.uint8).copy(), cells, advances, (cell_width, cell_height), _MARGIN)
