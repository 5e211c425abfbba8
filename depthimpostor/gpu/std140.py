"""std140 structs described once: a GLSL struct's declaration and the numpy dtype that packs a
uniform buffer's bytes for it both come from one list of (name, type) or (name, type, count).

The rules are GL 4.5's section 7.6.2.2 for the types we use: a scalar aligns to 4 bytes, a vec2
to 8, a vec3 and a vec4 to 16 (a vec3 is 12 bytes: a scalar after it fills its fourth slot), a
mat4 is four vec4 columns, a struct aligns to its largest member's alignment rounded up to 16 and
its size is rounded up to that, and an array's elements sit that struct's size apart. Arrays of
scalars and vectors smaller than a vec4 would have a gap after each element, which a numpy
sub-array cannot express, so they are refused: such data goes into a struct, or a vec4.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

#: GLSL type -> (numpy base type, shape, size in bytes, std140 base alignment).
_TYPES: dict[str, tuple[str, tuple[int, ...], int, int]] = {
    "float": ("<f4", (), 4, 4),
    "int": ("<i4", (), 4, 4),
    "vec2": ("<f4", (2,), 8, 8),
    "ivec2": ("<i4", (2,), 8, 8),
    "vec3": ("<f4", (3,), 12, 16),
    "ivec3": ("<i4", (3,), 12, 16),
    "vec4": ("<f4", (4,), 16, 16),
    "ivec4": ("<i4", (4,), 16, 16),
    "mat4": ("<f4", (4, 4), 64, 16),
}

#: A member: (name, GLSL type name or a Struct) or (name, type, array length).
Field = tuple[str, "str | Struct"] | tuple[str, "str | Struct", int]


def _round_up(value: int, alignment: int) -> int:
    return -(-value // alignment) * alignment


@dataclass(frozen=True)
class Struct:
    """A GLSL struct under std140: `glsl()` declares it, `dtype` packs it (mat4 members column by
    column: a numpy row of one holds a GL column)."""

    name: str
    fields: tuple[Field, ...]

    @cached_property
    def alignment(self) -> int:
        return _round_up(max(_member(field)[2] for field in self.fields), 16)

    @cached_property
    def dtype(self) -> np.dtype:
        names, formats, offsets = [], [], []
        offset = 0
        for field in self.fields:
            member_dtype, size, alignment = _member(field)
            offset = _round_up(offset, alignment)
            names.append(field[0])
            formats.append(member_dtype)
            offsets.append(offset)
            offset += size
        return np.dtype({"names": names, "formats": formats, "offsets": offsets,
                         "itemsize": _round_up(offset, self.alignment)})

    def glsl(self) -> str:
        """This struct's declaration (a struct it holds is declared apart, before it)."""
        members = []
        for field in self.fields:
            kind = field[1].name if isinstance(field[1], Struct) else field[1]
            members.append(f"    {kind} {field[0]}{f'[{field[2]}]' if len(field) == 3 else ''};")
        return f"struct {self.name} {{\n" + "\n".join(members) + "\n};\n"


def _member(field: Field) -> tuple[np.dtype | tuple[str, tuple[int, ...]], int, int]:
    """A member's numpy type, size and std140 alignment."""
    kind = field[1]
    count = field[2] if len(field) == 3 else None
    if isinstance(kind, Struct):
        if count is None:
            return kind.dtype, kind.dtype.itemsize, kind.alignment
        return np.dtype((kind.dtype, (count,))), kind.dtype.itemsize * count, kind.alignment
    base, shape, size, alignment = _TYPES[kind]
    if count is None:
        return (base, shape), size, alignment
    if size % 16:
        raise ValueError(f"{field[0]}: an array of {kind} has padding after each element under std140; "
                         "put the values in a struct or a vec4")
    return (base, (count, *shape)), size * count, alignment

