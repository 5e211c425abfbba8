"""Writes the image textures the project's scenes use, from procedural data (nothing downloaded):
scenes/textures/checker_f.png, a checker of 8x8 squares with an "F" in one corner square, so that
a texture seen the wrong way round (flipped or turned) shows it; scenes/textures/stained_glass.png,
RGBA panes of four colours (by column) and four alphas (by row) in an opaque lead frame, for
glTF's alphaMode BLEND (scenes/blend_near_mirror.toml).

    python3 tools/make_textures.py
"""

from __future__ import annotations

from pathlib import Path

from PIL import Image, ImageDraw

SIZE, SQUARES = 256, 8
LIGHT, DARK, LETTER = (235, 225, 200), (60, 90, 150), (200, 30, 30)


def checker_f() -> Image.Image:
    image = Image.new("RGB", (SIZE, SIZE), LIGHT)
    draw = ImageDraw.Draw(image)
    side = SIZE // SQUARES
    for row in range(SQUARES):
        for column in range(SQUARES):
            if (row + column) % 2:
                draw.rectangle([column * side, row * side, (column + 1) * side - 1, (row + 1) * side - 1], fill=DARK)
    # An F in the top-left square (a light one): its stem on the left, its bars pointing right.
    x, y, s = 0, 0, side
    draw.rectangle([x + s // 4, y + s // 8, x + s // 4 + s // 6, y + 7 * s // 8], fill=LETTER)
    draw.rectangle([x + s // 4, y + s // 8, x + 3 * s // 4, y + s // 8 + s // 6], fill=LETTER)
    draw.rectangle([x + s // 4, y + 7 * s // 16, x + 5 * s // 8, y + 7 * s // 16 + s // 6], fill=LETTER)
    return image


#: stained_glass.png: its panes' colours (by column) and alphas (by row, top first), and the lead.
PANE_COLOURS = ((220, 40, 40), (40, 180, 60), (50, 80, 230), (240, 210, 40))
PANE_ALPHAS = (50, 110, 170, 230)
LEAD, LEAD_WIDTH, GLASS_SIZE = (30, 30, 30, 255), 4, 128


def stained_glass() -> Image.Image:
    image = Image.new("RGBA", (GLASS_SIZE, GLASS_SIZE), LEAD)
    draw = ImageDraw.Draw(image)
    side = GLASS_SIZE // 4
    for row, alpha in enumerate(PANE_ALPHAS):
        for column, colour in enumerate(PANE_COLOURS):
            draw.rectangle([column * side + LEAD_WIDTH // 2, row * side + LEAD_WIDTH // 2,
                            (column + 1) * side - 1 - LEAD_WIDTH // 2, (row + 1) * side - 1 - LEAD_WIDTH // 2],
                           fill=(*colour, alpha))
    return image


def main() -> None:
    folder = Path(__file__).resolve().parent.parent / "scenes" / "textures"
    folder.mkdir(exist_ok=True)
    checker_f().save(folder / "checker_f.png", optimize=True)
    print(folder / "checker_f.png")
    stained_glass().save(folder / "stained_glass.png", optimize=True)
    print(folder / "stained_glass.png")


if __name__ == "__main__":
    main()
