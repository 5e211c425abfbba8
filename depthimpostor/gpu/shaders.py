"""GLSL sources: a tiny `#include` preprocessor, injected defines, a program cache, readable errors.

- `#include "x.glsl"` resolves relative to the including file (or to `shaders/`) and is expanded
  wherever it appears, inside an include guard: the GLSL preprocessor then keeps the first copy it
  actually compiles, so that an include inside an `#if` branch works whichever branch is taken
  (merging once in Python, blind to `#if`, would drop a chunk first met in a dropped branch).
  Each copy is wrapped in `#line` directives whose source-string numbers map back to file names,
  so that a compile error points at the right line of the right file.
- Defines go in as a prefix right after `#version`; the body is never rewritten.
- Programs are cached by (files, defines) per context and compiled once: a vertex + fragment
  pair, or a compute shader alone.
- Files under `generated/` are not on disk: Python writes them from `constants.py` so that struct
  layouts exist in one place.
"""

from __future__ import annotations

import posixpath
import re
import stat
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import moderngl

from ..constants import (
    ANALYTIC_PLANE, DEPTH_IMAGE, IMAGE_GRID, LIGHT, LIGHTING, MATERIAL, PLANES, TEXTURE_RECORD, TRIANGLE_INSTANCE,
    glsl_constants,
)
from ..errors import ShaderError
from ..lights import soft_shadow_disk_glsl
from ..resources import shaders_dir
from ..texture_layout import material_arrays_glsl
from .texel_records import glsl_reader

_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*$')
#: Some drivers (Mesa among them) report source-string 0 whatever `#line L N` said, so the file
#: number is also encoded in the line number: line = file * stride + line in file.
_LINE_STRIDE = 10000
#: Mesa / Intel: `0:12(5): error: ...`; NVIDIA: `0(12) : error C1008: ...`.
_ERROR_LOCATION = re.compile(r"^\s*(\d+)(?::(\d+)\(\d+\)|\((\d+)\))\s*:?\s*(.*)$")

Defines = Mapping[str, str | int | float]


def _line_directive(file_number: int, line: int) -> str:
    return f"#line {file_number * _LINE_STRIDE + line} {file_number}"


def _include_guard(name: str) -> str:
    return "INCLUDED_" + re.sub(r"\W", "_", name).upper()


def _generated_sources() -> dict[str, str]:
    return {
        "generated/depth_image.glsl": DEPTH_IMAGE.glsl() + IMAGE_GRID.glsl(),
        # The traced methods' instance records, read from the BVH's node texture.
        "generated/triangle_instance.glsl": TRIANGLE_INSTANCE.glsl() + glsl_reader(TRIANGLE_INSTANCE, "BVH_TEXTURE_WIDTH"),
        "generated/material.glsl": MATERIAL.glsl(),
        # Each after the structs it holds: the preprocessor includes a generated file once.
        "generated/lighting.glsl": LIGHT.glsl() + LIGHTING.glsl(),
        "generated/planes.glsl": '#include "material.glsl"\n' + ANALYTIC_PLANE.glsl() + PLANES.glsl(),
        "generated/soft_shadow_disk.glsl": soft_shadow_disk_glsl(),
        "generated/texture_record.glsl": TEXTURE_RECORD.glsl(),
        "generated/material_arrays.glsl": material_arrays_glsl(),
    }


#: A file's lines, and (line index, included name) of each of its #include lines.
ParsedFile = tuple[list[str], list[tuple[int, str]]]

#: Every shader file read, by path: (modification time, size, text, parsed), shared by every
#: library (each Renderer makes one: reading and parsing the files again cost a renderer about 10 ms).
#: A file whose time or size changed is read again, so that a reload sees an edit.
_FILES: dict[Path, tuple[int, int, str, ParsedFile]] = {}


def _parse(text: str) -> ParsedFile:
    lines = text.splitlines()
    return lines, [(i, match.group(1)) for i, line in enumerate(lines) if (match := _INCLUDE.match(line))]


def _read_file(path: Path, modified: int, size: int) -> tuple[str, ParsedFile]:
    cached = _FILES.get(path)
    if cached is None or cached[:2] != (modified, size):
        text = path.read_text(encoding="utf-8")
        cached = _FILES[path] = (modified, size, text, _parse(text))
    return cached[2], cached[3]


@dataclass
class PreprocessedSource:
    text: str
    files: list[str] = field(default_factory=list)  # source-string number -> file name


class ShaderLibrary:
    """Reads and preprocesses the GLSL files of one shaders/ folder."""

    def __init__(self, root: Path | None = None) -> None:
        self.root = root or shaders_dir()
        self.generated = _generated_sources()
        # Each file read, split and its includes found once per library: a program expands a chunk
        # wherever it is included (the mirror shader dozens of times), and reading and matching
        # every line each time took 35 ms a mirror program (4 ms now). A reload makes a new
        # library, which looks at the files again (_read_file).
        self._parsed: dict[str, ParsedFile] = {}
        self._resolved: dict[tuple[str, str], str] = {}

    def read(self, name: str) -> str:
        return self.generated[name] if name in self.generated else self._file(name)[0]

    def _file(self, name: str) -> tuple[str, ParsedFile]:
        path = self.root / name
        try:
            status = path.stat()
        except OSError:
            status = None
        if status is None or not stat.S_ISREG(status.st_mode):
            raise ShaderError(f"shader file {name!r} not found in {self.root}")
        return _read_file(path, status.st_mtime_ns, status.st_size)

    def _lines(self, name: str) -> ParsedFile:
        """The file's lines, and (line index, included name) of each of its #include lines."""
        parsed = self._parsed.get(name)
        if parsed is None:
            parsed = self._parsed[name] = _parse(self.generated[name]) if name in self.generated else self._file(name)[1]
        return parsed

    def preprocess(self, name: str, defines: Defines) -> PreprocessedSource:
        lines = self._lines(name)[0]
        version_index = next((i for i, line in enumerate(lines) if line.strip()), None)
        if version_index is None or not lines[version_index].startswith("#version"):
            raise ShaderError(f"{name}: the first line must be a #version directive")
        result = PreprocessedSource(text="", files=[name])
        prefix = [lines[version_index]]
        if defines.get("NEEDS_STORAGE_BLOCKS") and int(lines[version_index].split()[1]) < 430:
            # A GLSL 3.30 stage reading a storage buffer (GL 4.3's, the caller checks the context
            # has it). #extension must precede every declaration, so it goes before the defines.
            prefix.append("#extension GL_ARB_shader_storage_buffer_object : require")
        prefix += [f"#define {key} {value}" for key, value in {**glsl_constants(), **defines}.items()]
        body = self._expand(name, version_index + 1, version_index + 2, result, stack=[name])
        result.text = "\n".join(prefix + [_line_directive(0, version_index + 2)] + body) + "\n"
        return result

    def _expand(self, name: str, start: int, first_line: int, result: PreprocessedSource, stack: list[str]) -> list[str]:
        """The file's lines from index `start` (numbered from `first_line`), each #include replaced."""
        lines, includes = self._lines(name)
        file_number = result.files.index(name)
        out: list[str] = []
        position = start
        for index, included in includes:
            if index < start:
                continue
            out += lines[position:index]
            target = self._resolve(name, included)
            if target in stack:
                raise ShaderError(f"{name}: #include cycle: {' -> '.join([*stack, target])}")
            if target not in result.files:
                result.files.append(target)
            guard = _include_guard(target)
            out += [f"#ifndef {guard}", f"#define {guard}", _line_directive(result.files.index(target), 1)]
            out += self._expand(target, 0, 1, result, [*stack, target])
            out.append(f"#endif  // {target}")
            out.append(_line_directive(file_number, first_line + index - start + 1))
            position = index + 1
        out += lines[position:]
        return out

    def _resolve(self, including: str, target: str) -> str:
        found = self._resolved.get((including, target))
        if found is not None:
            return found
        relative = posixpath.normpath(posixpath.join(posixpath.dirname(including), target))
        for candidate in (relative, posixpath.normpath(target)):
            if candidate in self.generated or (self.root / candidate).is_file():
                self._resolved[(including, target)] = candidate
                return candidate
        raise ShaderError(f"{including}: #include \"{target}\" not found (looked in {Path(including).parent}/ and shaders/)")


def _format_compile_error(
    program: str, defines: Defines, log: str, sources: Mapping[str, PreprocessedSource], library: ShaderLibrary
) -> str:
    """Turn a driver's log into 'file:line: message' with the offending lines shown."""
    report = [f"GLSL program {program!r} failed to build (defines: {dict(defines) or 'none'})"]
    stage_source = next(iter(sources.values()))
    for raw in log.splitlines():
        if raw.strip().lower().endswith("_shader") and raw.strip().split("_")[0] in sources:
            stage_source = sources[raw.strip().split("_")[0]]
        match = _ERROR_LOCATION.match(raw)
        if not match or "error" not in raw.lower():
            continue
        file_number, line_number = divmod(int(match.group(2) or match.group(3)), _LINE_STRIDE)
        files = stage_source.files
        file_name = files[file_number] if file_number < len(files) else f"<source {file_number}>"
        report.append(f"{file_name}:{line_number}: {match.group(4).strip()}")
        try:
            text = library.read(file_name).splitlines()
        except ShaderError:
            continue
        for number in range(max(1, line_number - 2), min(len(text), line_number + 2) + 1):
            marker = ">>" if number == line_number else "  "
            report.append(f"  {marker} {number:4d} | {text[number - 1]}")
    if len(report) == 1:
        report.append(log.strip())
    return "\n".join(report)


#: Writes into one program where it finds what is bound for every frame (texture units, uniform
#: block bindings: gpu/uniforms.write_scene_uniforms); a uniform the program lacks is skipped.
SceneUniforms = Callable[[moderngl.Program], None]

#: A program's stages (vertex and fragment file, or a compute file alone) and its defines.
ProgramKey = tuple[tuple[str, ...], tuple[tuple[str, str], ...]]


def program_key(stages: tuple[str, ...], defines: Defines | None = None) -> ProgramKey:
    """What identifies a compiled program: the cache's key, and what a render plan lists."""
    return stages, tuple(sorted((k, str(v)) for k, v in (defines or {}).items()))


class ProgramCache:
    """Compiles each program (vertex + fragment, or compute) once per (files, defines) per
    context and owns them.

    `scene_uniforms` is written into each program as it is made (a reload's too). It holds no
    value that changes as the scene moves: the lights and analytic planes are uniform blocks, one
    buffer each that every program reads (gpu/scene_blocks.py), so that a program made after they
    moved (a new setting, a reload) cannot see them where they were.
    """

    def __init__(self, ctx: moderngl.Context, library: ShaderLibrary | None = None,
                 scene_uniforms: SceneUniforms | None = None) -> None:
        self.ctx = ctx
        self.library = library or ShaderLibrary()
        self._programs: dict[ProgramKey, moderngl.Program | moderngl.ComputeShader] = {}
        self._scene_uniforms = scene_uniforms

    def compile(self, key: ProgramKey) -> None:
        """Make the program a plan names by its key (render_graph.py compiles a plan's programs first)."""
        self._get(key[0], dict(key[1]))

    def get(self, vertex: str, fragment: str, defines: Defines | None = None) -> moderngl.Program:
        program = self._get((vertex, fragment), defines)
        assert isinstance(program, moderngl.Program)
        return program

    def without_defines(self, program: moderngl.Program, names: tuple[str, ...]) -> moderngl.Program:
        """`program`, one of this cache's, compiled again without the defines `names` (tools and
        tests that hold a variant against the shaders' fallback: tools/shading_cost.py)."""
        for (stages, defines), cached in self._programs.items():
            if cached is program and len(stages) == 2:
                return self.get(stages[0], stages[1], {name: value for name, value in defines if name not in names})
        raise ValueError("the program is not one of this cache's")

    def with_defines(self, program: moderngl.Program, extra: Mapping[str, int]) -> moderngl.Program:
        """`program`, one of this cache's, compiled again with the defines `extra` added (tools that
        bound a pass by leaving part of it out: tools/interactive_frame.py)."""
        for (stages, defines), cached in self._programs.items():
            if cached is program and len(stages) == 2:
                return self.get(stages[0], stages[1], {**dict(defines), **extra})
        raise ValueError("the program is not one of this cache's")

    def compute(self, name: str, defines: Defines | None = None) -> moderngl.ComputeShader:
        """A compute shader (GLSL 4.30: the caller checks the context has it)."""
        program = self._get((name,), defines)
        assert isinstance(program, moderngl.ComputeShader)
        return program

    def _get(self, stages: tuple[str, ...], defines: Defines | None) -> moderngl.Program | moderngl.ComputeShader:
        defines = dict(defines or {})
        key = program_key(stages, defines)
        program = self._programs.get(key)
        if program is None:
            program = self._build(stages, defines)
            self._programs[key] = program
            if self._scene_uniforms is not None and isinstance(program, moderngl.Program):
                self._scene_uniforms(program)
        return program

    @property
    def variants(self) -> list[tuple[str, str, tuple[tuple[str, str], ...]]]:
        """(vertex, fragment, defines) of every vertex + fragment program compiled so far (for
        plans, stats and tests)."""
        return [(stages[0], stages[1], defines) for stages, defines in self._programs if len(stages) == 2]

    def programs(self) -> list[moderngl.Program]:
        """Every vertex + fragment program compiled so far."""
        return [program for program in self._programs.values() if isinstance(program, moderngl.Program)]

    def compiled(self) -> list[tuple[ProgramKey, moderngl.Program | moderngl.ComputeShader]]:
        """Every program compiled so far (compute shaders too), with its key."""
        return list(self._programs.items())

    @property
    def keys(self) -> set[ProgramKey]:
        """Every program compiled so far, as `program_key` names it."""
        return set(self._programs)

    @property
    def compute_variants(self) -> list[tuple[str, tuple[tuple[str, str], ...]]]:
        """(file, defines) of every compute shader compiled so far."""
        return [(stages[0], defines) for stages, defines in self._programs if len(stages) == 1]

    def rewrite_scene_uniforms(self, scene_uniforms: SceneUniforms) -> None:
        """Write `scene_uniforms` (another scene's texture table: Renderer.set_scene) into every
        program made so far, and into each made from now on."""
        self._scene_uniforms = scene_uniforms
        for program in self._programs.values():
            if isinstance(program, moderngl.Program):
                scene_uniforms(program)

    def reloaded(self) -> ProgramCache:
        """A new cache holding every program of this one, compiled from the files as they are
        now. Raises ShaderError (and leaves this cache as it is) if any of them fails."""
        fresh = ProgramCache(self.ctx, ShaderLibrary(self.library.root), self._scene_uniforms)
        try:
            for stages, defines in self._programs:
                fresh._get(stages, dict(defines))
        except ShaderError:
            fresh.release()
            raise
        return fresh

    def _build(self, stages: tuple[str, ...], defines: Defines) -> moderngl.Program | moderngl.ComputeShader:
        kinds = ("compute",) if len(stages) == 1 else ("vertex", "fragment")
        sources = {kind: self.library.preprocess(name, defines) for kind, name in zip(kinds, stages, strict=False)}
        try:
            if len(stages) == 1:
                return self.ctx.compute_shader(sources["compute"].text)
            return self.ctx.program(vertex_shader=sources["vertex"].text, fragment_shader=sources["fragment"].text)
        except moderngl.Error as error:
            name = " + ".join(stages)
            raise ShaderError(_format_compile_error(name, defines, str(error), sources, self.library)) from None

    def release(self) -> None:
        for program in self._programs.values():
            program.release()
        self._programs.clear()
