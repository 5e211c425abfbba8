"""Writes the image textures the project's scenes use, from procedural data (nothing downloaded):
scenes/textures/checker_f.png, a checker of 8x8 squares with an "F" in one corner square, so that
a texture seen the wrong way round (flipped or turned) shows it.

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


def main() -> None:
    folder = Path(__file__).resolve().parent.parent / "scenes" / "textures"
    folder.mkdir(exist_ok=True)
    checker_f().save(folder / "checker_f.png", optimize=True)
    print(folder / "checker_f.png")


if __name__ == "__main__":
    main()
