"""Records stored as texels of a float texture, for tables that no uniform block may cap and that a
GL 3.3 context must still read (it has no storage buffers; three.js keeps bone matrices in a
float texture the same way). The layout is a std140 Struct's (gpu/std140.py), described once:
every member is a vec4, an ivec4 or a mat4, so that a record is a run of whole texels, one a
vec4 or a mat4 column, in the order the Struct lists them. `to_texels` packs numpy records of the
Struct's dtype into them and `glsl_reader` writes the GLSL function that reads one back.

Integers are stored as float values, not bit patterns: a texel fetch may flush a float's
denormal bit patterns (small integers') to zero, and values below 2^24 are exact in float32.
"""

from __future__ import annotations

import numpy as np

from .std140 import Struct

#: Texels a member takes.
_TEXELS = {"vec4": 1, "ivec4": 1, "mat4": 4}
#: Integers a float32 holds exactly.
_EXACT_INTEGERS = 2**24


def _members(struct: Struct) -> list[tuple[str, str]]:
    members = []
    for field in struct.fields:
        kind = field[1]
        if len(field) != 2 or not isinstance(kind, str) or kind not in _TEXELS:
            raise ValueError(f"{struct.name}.{field[0]}: a texel record holds vec4, ivec4 and mat4 members alone")
        members.append((field[0], kind))
    return members


def texel_count(struct: Struct) -> int:
    """Texels one record of `struct` takes."""
    return sum(_TEXELS[kind] for _, kind in _members(struct))


def to_texels(struct: Struct, records: np.ndarray) -> np.ndarray:
    """(n * texel_count, 4) float32 texels of n records of struct.dtype (a mat4's numpy rows are
    its GL columns, as in a uniform buffer)."""
    columns = []
    for name, kind in _members(struct):
        values = np.asarray(records[name]).reshape(len(records), _TEXELS[kind], 4)
        if kind == "ivec4" and np.abs(values).max(initial=0) >= _EXACT_INTEGERS:
            raise ValueError(f"{struct.name}.{name}: integers of 2^24 or more are not exact as float32 texels")
        columns.append(values.astype(np.float32))
    return np.concatenate(columns, axis=1).reshape(-1, 4)


def glsl_reader(struct: Struct, width: str) -> str:
    """`#define <NAME>_TEXELS n` and `<Name> read_<name>(sampler2D data, int texel)`, which reads the
    record that starts at element `texel` of a texture whose element i is texel (i % width, i / width):
    `width` is the GLSL expression of its width. Declare the struct (struct.glsl()) before it."""
    snake = "".join(f"_{c.lower()}" if c.isupper() else c for c in struct.name).lstrip("_")
    lines = [f"#define {snake.upper()}_TEXELS {texel_count(struct)}",
             f"{struct.name} read_{snake}(sampler2D data, int texel) {{",
             f"    {struct.name} record;"]
    offset = 0
    for name, kind in _members(struct):
        texels = [f"texelFetch(data, ivec2((texel + {offset + k}) % {width}, (texel + {offset + k}) / {width}), 0)"
                  for k in range(_TEXELS[kind])]
        value = {"vec4": texels[0], "ivec4": f"ivec4({texels[0]})", "mat4": "mat4(" + ", ".join(texels) + ")"}[kind]
        lines.append(f"    record.{name} = {value};")
        offset += _TEXELS[kind]
    return "\n".join([*lines, "    return record;", "}"]) + "\n"
