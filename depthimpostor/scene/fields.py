"""Readers for scene-file values: each knows what it expects, so every error can say so.

A `Reader` checks one value and says what it expects; an `At` carries the file and the dotted path
of that value; a `Table` checks a TOML table's keys and reads its fields; a `Variant` is one `type`
of a table. Messages read `FILE: dotted.path: expected ..., got ...`.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import stat
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Generic, TypeVar, cast

from depthimpostor.constants import MAX_COORDINATE
from depthimpostor.errors import SceneError

T = TypeVar("T")
Vec3 = tuple[float, float, float]


def show(value: Any) -> str:
    """A value as TOML would write it, short enough for a one-line message."""
    text = _shown(value, 81)
    return text if len(text) <= 80 else text[:77] + "..."


def _shown(value: Any, room: int) -> str:
    """`show`'s text, cut once it passes `room` characters: a value read from a file may be a list
    of millions or nested thousands deep (hostile JSON), and the message shows 80 characters."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value[:room])
    if isinstance(value, Mapping):
        opening, closing, parts = "{", "}", ((f"{k} = ", v) for k, v in value.items())
    elif isinstance(value, (list, tuple)):
        opening, closing, parts = "[", "]", (("", v) for v in value)
    else:
        return str(value)[:room]
    text = opening
    for k, (key, item) in enumerate(parts):
        if len(text) > room:
            return text
        text += (", " if k else "") + key + _shown(item, room - len(text))
    return text + closing


@dataclass(frozen=True)
class Bounds:
    """A closed interval, or half-open at the bottom; its `str` is how messages describe it."""

    lo: float = -math.inf
    hi: float = math.inf
    open_lo: bool = False

    def __contains__(self, x: float) -> bool:
        return (x > self.lo if self.open_lo else x >= self.lo) and x <= self.hi

    def __str__(self) -> str:
        if self.hi == math.inf:
            return "" if self.lo == -math.inf else f" {'>' if self.open_lo else '>='} {self.lo:g}"
        return f" in {'(' if self.open_lo else '['}{self.lo:g}, {self.hi:g}]"


ANY, UNIT, NON_NEGATIVE, POSITIVE = Bounds(), Bounds(0, 1), Bounds(0), Bounds(0, open_lo=True)


@dataclass(frozen=True)
class Reader(Generic[T]):
    """Turns one TOML value into a T, or None when it does not fit; `expected` says what fits."""

    expected: str
    parse: Callable[[Any], T | None]


def _is_number(v: Any) -> bool:
    # bool is a subclass of int in Python, but `true` is not a number in a scene file; TOML also
    # allows inf and nan, which would poison every matrix they reach, and numbers past what
    # float32 geometry holds (MAX_COORDINATE), which overflow on the GPU.
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and abs(v) <= MAX_COORDINATE


#: What a message adds when a value holds a number past MAX_COORDINATE.
TOO_LARGE = f"of magnitude at most {MAX_COORDINATE:g} (float32 geometry squares distances)"


def _too_large(v: Any) -> bool:
    """Does `v` (a number, or a list of them) hold a finite number past MAX_COORDINATE?"""
    if isinstance(v, (list, tuple)):
        return any(_too_large(x) for x in v)
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and abs(v) > MAX_COORDINATE


def _is_integer(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def number(bounds: Bounds = ANY) -> Reader[float]:
    return Reader(f"a number{bounds}", lambda v: float(v) if _is_number(v) and v in bounds else None)


def integer(bounds: Bounds = ANY) -> Reader[int]:
    return Reader(f"an integer{bounds}", lambda v: v if _is_integer(v) and v in bounds else None)


# The shortest direction vector (axis, light direction, camera up) taken: directions are made unit
# length in float32 on the GPU and in numpy, where the squares of components under about 1e-19
# underflow to 0 and the unit vector becomes NaN; 1e-9 leaves that far behind.
MIN_DIRECTION_LENGTH = 1e-9


def numbers(n: int, bounds: Bounds = ANY, nonzero: bool = False) -> Reader[tuple[float, ...]]:
    def parse(v: Any) -> tuple[float, ...] | None:
        fits = isinstance(v, (list, tuple)) and len(v) == n and all(_is_number(x) and x in bounds for x in v)
        if not fits:
            return None
        values = tuple(float(x) for x in v)
        return values if not nonzero or math.hypot(*values) >= MIN_DIRECTION_LENGTH else None

    return Reader(f"{n} numbers{bounds}" + (f", of length at least {MIN_DIRECTION_LENGTH:g}" if nonzero else ""), parse)


def integers(n: int, bounds: Bounds = ANY) -> Reader[tuple[int, ...]]:
    def parse(v: Any) -> tuple[int, ...] | None:
        fits = isinstance(v, (list, tuple)) and len(v) == n and all(_is_integer(x) and x in bounds for x in v)
        return tuple(v) if fits else None

    return Reader(f"{n} integers{bounds}", parse)


def vec3(bounds: Bounds = ANY, nonzero: bool = False) -> Reader[Vec3]:
    return cast(Reader[Vec3], numbers(3, bounds, nonzero))


def number_or_vec3(bounds: Bounds) -> Reader[Vec3]:
    """One number for all three components, or three numbers (a scale)."""
    one, three = number(bounds), vec3(bounds)

    def parse(v: Any) -> Vec3 | None:
        s = one.parse(v)
        return (s, s, s) if s is not None else three.parse(v)

    return Reader(f"{one.expected} or {three.expected}", parse)


def word_or(word: str, reader: Reader[T]) -> Reader[T | str]:
    """`word` itself, or what `reader` reads (`impostor_resolution = "auto"` or a number of pixels)."""
    return Reader(f"{reader.expected} or {json.dumps(word)}", lambda v: v if v == word else reader.parse(v))


def choice(options: Sequence[str]) -> Reader[str]:
    return Reader(f"one of: {', '.join(options)}", lambda v: v if isinstance(v, str) and v in options else None)


BOOLEAN = Reader("true or false", lambda v: v if isinstance(v, bool) else None)
NAME = Reader("a non-empty string", lambda v: v if isinstance(v, str) and v.strip() else None)
SIZE = cast(Reader[tuple[int, int]], integers(2, Bounds(1, 16384)))
RESOLUTION = integer(Bounds(4, 4096))
#: A decimation target: fewer than 4 triangles cannot enclose anything.
TRIANGLE_TARGET = integer(Bounds(4))


@dataclass(frozen=True)
class At:
    """Where a value sits: the file (or "command line"), the dotted path in it, and the folder that
    relative model paths start from."""

    source: str
    path: str
    base_dir: Path = Path()

    def key(self, name: str) -> At:
        return dataclasses.replace(self, path=f"{self.path}.{name}" if self.path else name)

    def index(self, i: int) -> At:
        return dataclasses.replace(self, path=f"{self.path}[{i}]")

    def error(self, message: str) -> SceneError:
        return SceneError(self.source, self.path, message)

    def read(self, value: Any, reader: Reader[T]) -> T:
        parsed = reader.parse(value)
        if parsed is None:
            too_large = f", {TOO_LARGE}" if _too_large(value) else ""
            raise self.error(f"expected {reader.expected}{too_large}, got {show(value)}")
        return parsed


@dataclass(frozen=True)
class Variant(Generic[T]):
    """One `type` of a table: the fields it may have besides `type`, and how to build it."""

    fields: tuple[str, ...]
    build: Callable[[Table], T]


class Table:
    """A TOML table at a known place; `fields` (None: any) are the keys it may have."""

    def __init__(self, value: Any, at: At, fields: Sequence[str] | None) -> None:
        if not isinstance(value, Mapping):
            raise at.error(f"expected a table, got {show(value)}")
        # Checked before any field is read, so that a misspelt key is reported as itself rather
        # than as the required field it was meant to be.
        unknown = [k for k in value if k not in fields] if fields is not None else []
        if unknown:
            raise at.error(f"unknown field {json.dumps(unknown[0])}; expected one of: {', '.join(fields or ())}")
        self.data: Mapping[str, Any] = value
        self.at = at

    def req(self, key: str, reader: Reader[T]) -> T:
        if key not in self.data:
            raise self.at.key(key).error(f"missing required field; expected {reader.expected}")
        return self.at.key(key).read(self.data[key], reader)

    def opt(self, key: str, reader: Reader[T], default: T) -> T:
        return self.at.key(key).read(self.data[key], reader) if key in self.data else default

    def section(self, key: str, fields: Sequence[str]) -> Table:
        """The sub-table at `key` (empty when absent, so that every field takes its default)."""
        return Table(self.data.get(key, {}), self.at.key(key), fields)

    def variant(self, key: str, variants: Mapping[str, Variant[T]], default: T | None = None,
                default_type: str | None = None) -> T:
        """The sub-table at `key` built by the variant its `type` names; `default` when it is absent."""
        if key in self.data:
            return read_variant(self.data[key], self.at.key(key), variants, default_type)
        if default is None:
            kinds = choice(list(variants)).expected
            raise self.at.key(key).error(f"missing required field; expected a table with type = {kinds}")
        return default

    def array(self, key: str, at_least: int = 0, at_most: int | None = None) -> list[tuple[Any, At]]:
        """The values of the array of tables `[[key]]` (empty when absent), each with its place."""
        at, value = self.at.key(key), self.data.get(key, [])
        if not isinstance(value, list):
            raise at.error(f"expected an array of tables ([[{key}]]), got {show(value)}")
        if len(value) < at_least:
            raise at.error(f"expected at least {at_least} [[{key}]] table(s), got {len(value)}")
        if at_most is not None and len(value) > at_most:
            raise at.error(f"expected at most {at_most} [[{key}]] tables, got {len(value)}")
        return [(v, at.index(i)) for i, v in enumerate(value)]


def read_variant(value: Any, at: At, variants: Mapping[str, Variant[T]], default_type: str | None = None) -> T:
    """A table built by the variant its `type` names (`default_type` when it names none)."""
    kinds = choice(list(variants))
    head = Table(value, at, None)
    kind = head.req("type", kinds) if default_type is None else head.opt("type", kinds, default_type)
    return variants[kind].build(Table(value, at, ("type", *variants[kind].fields)))


#: The largest file a scene reads whole (a glTF file, its buffers in it): past it, more likely a
#: mistake than a model, and over what a scene's meshes can take (scene/limits.py).
MAX_FILE_BYTES = 2 * 2**30

def leaves_folder(written: str) -> bool:
    """Does a relative path climb out of the folder it is relative to (`..` past its start)? The
    rule for every file a scene or glTF file names by a relative path (docs/scene_format.md,
    "Paths"): it is in that folder or below it. Judged on the path as written, not on where links
    lead: a link the user put in the folder is theirs to follow."""
    normal = os.path.normpath(written)
    return normal == os.pardir or normal.startswith(os.pardir + os.sep)


#: What `read_file_bytes` says a file that is not a regular one is.
_FILE_KINDS = ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
               (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


def read_file_bytes(path: Path, source: str, expected: str, limit: int = MAX_FILE_BYTES) -> bytes:
    """A scene file's bytes, or one SceneError naming what went wrong (`expected`: what the file
    should be, said when a directory is given instead). Only a regular file of at most `limit`
    bytes is read: a FIFO would block until a writer came, a link to /dev/zero read until the
    memory ran out. (Opened without blocking, then asked what it is: no window between the two.)"""
    try:
        descriptor = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except IsADirectoryError as err:
        raise SceneError(source, "", f"expected {expected}, got a directory") from err
    except FileNotFoundError as err:
        raise SceneError(source, "", "no such file") from err
    except OSError as err:
        raise SceneError(source, "", f"cannot read the file: {err.strerror or err}") from err
    status = os.fstat(descriptor)
    if not stat.S_ISREG(status.st_mode):
        os.close(descriptor)
        if stat.S_ISDIR(status.st_mode):
            raise SceneError(source, "", f"expected {expected}, got a directory")
        kind = next((name for test, name in _FILE_KINDS if test(status.st_mode)), "a special file")
        raise SceneError(source, "", f"expected {expected} (a regular file), got {kind}")
    with open(descriptor, "rb") as file:
        too_large = f"expected {expected} of at most {limit / 2**20:g} MiB, got "
        size = status.st_size
        if size > limit:
            raise SceneError(source, "", f"{too_large}one of {size / 2**20:.1f} MiB")
        try:
            data = file.read(limit + 1)  # a file whose size says 0 (in /proc) may still hold more
        except OSError as err:
            raise SceneError(source, "", f"cannot read the file: {err.strerror or err}") from err
        if len(data) > limit:
            raise SceneError(source, "", f"{too_large}more")
        return data
