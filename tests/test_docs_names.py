"""Every file and function that docs/, README and the code's comments name exists (issue 35, item 1:
"about a dozen name files that moved"). A name is checked where it can be told from prose:
- a path with a folder that the repository has (`passes/pyramid.py`, `shaders/lib/shading.glsl`,
  `tools/frames.py`): some file's path ends with it, or it is one of the GLSL sources the package
  generates (`generated/...`); a path under a folder the repository lacks (`report/difference.png`,
  an output) and a one-letter stem (`scenes/x.toml`, a placeholder) are not names of ours;
- a bare source file name (`renderer.py`, `beyond_run.frag`): some file has it;
- `file`'s `name` (`renderer.py`'s `_run`): the file says `name`;
- a backquoted `module.name` whose module is one of the package's (`textures.texture_bilinear`,
  `bench.run_bench`): the module has it; and `Class.name` for a class of the package.
"""

from __future__ import annotations

import contextlib
import importlib
import inspect
import pkgutil
import re
from functools import cache
from pathlib import Path
from types import ModuleType

import depthimpostor
from depthimpostor.gpu.shaders import _generated_sources

ROOT = Path(__file__).resolve().parent.parent
SOURCE_SUFFIXES = (".py", ".glsl", ".frag", ".vert", ".comp", ".sh")
PATH = re.compile(r"(?<![\w/.~$-])((?:[\w-]+/)+[\w.-]+\.[a-z]+|[\w-]+(?:\.py|\.glsl|\.frag|\.vert|\.comp|\.sh))"
                  r"(?![\w/(-])")
FILE_NAME = re.compile(r"`?((?:[\w-]+/)*[\w-]+\.(?:py|glsl|frag|vert|comp))`?'s `(\w+)`")
DOTTED = re.compile(r"`([A-Za-z_]\w*(?:\.[A-Za-z_]\w*)+)(?:\(\))?`")
#: Bare file names of other projects that the text names as theirs (the works we learn from):
#: not names of ours.
OTHERS = {"ibl_filtering.frag": "glTF-Sample-Viewer's GGX prefilter",
          "mesh.frag": "pyrender's shader, which tools/independent_compare.py patches"}


def documents() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), *sorted((ROOT / "depthimpostor").rglob("*.py")),
            *sorted((ROOT / "tools").glob("*.py")), *sorted((ROOT / "tools").glob("*.sh")),
            *sorted(p for p in (ROOT / "shaders").rglob("*") if p.suffix in SOURCE_SUFFIXES)]


@cache
def repository_files() -> tuple[str, ...]:
    skip = {".git", "__pycache__", ".whl", ".gl", ".ci", ".pytest_cache", ".hypothesis"}
    # A virtual environment inside the checkout (.venv, or any folder holding a pyvenv.cfg) is
    # not the repository: its include/GL/ or images/ folders would pass for ours.
    skip |= {venv.parent.name for venv in ROOT.glob("*/pyvenv.cfg")}
    files = [p.relative_to(ROOT).as_posix() for p in ROOT.rglob("*")
             if p.is_file() and not skip & set(p.relative_to(ROOT).parts)]
    return tuple(files) + tuple(f"shaders/{name}" for name in _generated_sources())


@cache
def folders() -> frozenset[str]:
    return frozenset(part for path in repository_files() for part in path.split("/")[:-1])


def path_exists(name: str) -> bool:
    if "/" not in name:
        return any(path.rsplit("/", 1)[-1] == name for path in repository_files())
    return any(path == name or path.endswith("/" + name) for path in repository_files())


def is_ours(name: str) -> bool:
    """Does `name` claim to be a file of this repository (see the module's docstring)?"""
    parts = name.split("/")
    if len(parts[-1].split(".")[0]) == 1:  # x.glsl, scenes/S.toml: placeholders
        return False
    if len(parts) == 1:
        return name.endswith(SOURCE_SUFFIXES) and name not in OTHERS
    return parts[0] in folders() and not name.startswith(("/", "tmp/"))


def where(path: Path, text: str, index: int) -> str:
    return f"{path.relative_to(ROOT)}:{text.count(chr(10), 0, index) + 1}"


def test_every_file_named_exists() -> None:
    stale = []
    for path in documents():
        text = path.read_text(encoding="utf-8")
        for match in PATH.finditer(text):
            name = match.group(1)
            if is_ours(name) and not path_exists(name):
                stale.append(f"{where(path, text, match.start())}: {name}")
    assert not stale, "files named that do not exist:\n" + "\n".join(stale)


def defines(file: str, name: str) -> bool:
    """Does `file` define `name` (not merely mention it in a comment)? Python: a def, class, or an
    assignment (of the module, or of self); GLSL: a function, a uniform, or a define it is
    compiled with or defines."""
    path = ROOT / file
    text = path.read_text(encoding="utf-8") if path.exists() else _generated_sources().get(file.removeprefix("shaders/"), "")
    python = rf"(?m)^\s*(?:def|class)\s+{name}\b|^\s*(?:self\.)?{name}\s*(?::[^=]*)?="
    glsl = rf"\b(?:[A-Za-z_]\w*)\s+{name}\s*\(|\buniform\s+\w+\s+{name}\b|#(?:define|ifdef|ifndef)\s+{name}\b|defined\({name}\)"
    return re.search(python if file.endswith(".py") else glsl, text) is not None


def test_every_function_named_in_a_file_is_there() -> None:
    stale = []
    for path in documents():
        text = path.read_text(encoding="utf-8")
        for match in FILE_NAME.finditer(text):
            file, name = match.groups()
            homes = [p for p in repository_files() if p == file or p.endswith("/" + file)]
            if homes and not any(defines(home, name) for home in homes):
                stale.append(f"{where(path, text, match.start())}: {file}'s {name}")
    assert not stale, "names said to be in a file that does not have them:\n" + "\n".join(stale)


@cache
def package_modules() -> dict[str, list[ModuleType]]:
    """Each module of the package by its last name and its dotted names below the package."""
    found: dict[str, list[ModuleType]] = {}
    for info in pkgutil.walk_packages(depthimpostor.__path__, "depthimpostor."):
        if info.name.endswith("__main__") or ".viewer" in info.name or ".notebook" in info.name:  # the command line runs; a window and Jupyter
            continue
        module = importlib.import_module(info.name)
        relative = info.name.removeprefix("depthimpostor.")
        for key in {relative, relative.rsplit(".", 1)[-1]}:
            found.setdefault(key, []).append(module)
    return found


@cache
def package_classes() -> dict[str, list[type]]:
    found: dict[str, list[type]] = {}
    for modules in package_modules().values():
        for module in modules:
            for name, value in vars(module).items():
                if inspect.isclass(value) and value.__module__.startswith("depthimpostor") and value not in \
                        found.get(name, []):
                    found.setdefault(name, []).append(value)
    return found


#: What ends a `name.suffix` that is a file (checked as a file above), not an attribute.
FILE_SUFFIXES = {"py", "glsl", "frag", "vert", "comp", "md", "png", "toml", "csv", "json", "txt", "sh", "glb", "ply",
                 "obj", "exr", "hdr", "gif", "mp4", "jpg"}
SWIZZLE = re.compile(r"[xyzw]{1,4}|[rgba]{1,4}")


def _named_like(variable: str) -> list[type]:
    """The package's classes that a variable named `variable` would hold (renderer: Renderer,
    plan: RenderPlan), for `renderer.sub_frames` in prose."""
    wanted = variable.replace("_", "").lower()
    return [klass for name, classes in package_classes().items() if name.lower().endswith(wanted) for klass in classes]


def resolves(dotted: str) -> bool | None:
    """Whether `dotted` names something of the package; None where it is not a name of ours."""
    parts = dotted.split(".")
    if parts[-1] in FILE_SUFFIXES or SWIZZLE.fullmatch(parts[-1]):
        return None
    for cut in range(len(parts) - 1, 0, -1):
        owners: list[object] = list(package_modules().get(".".join(parts[:cut]), []))
        if not owners and cut == 1:
            owners = list(package_classes().get(parts[0], []))
        if owners:
            for owner in owners:
                value: object = owner
                for attribute in parts[cut:]:
                    value = getattr(value, attribute, _MISSING)
                    if value is _MISSING:
                        break
                    # a dataclass field, or an attribute set in __init__: known by its annotations
                if value is not _MISSING or parts[cut] in _annotations(owner):
                    return True
            return cut == 1 and any(hasattr(klass, parts[1]) or parts[1] in _annotations(klass)
                                    for klass in _named_like(parts[0]))
    return None


_MISSING = object()


def _annotations(owner: object) -> set[str]:
    names: set[str] = set()
    for klass in getattr(owner, "__mro__", ()):
        names |= set(getattr(klass, "__annotations__", {}))
        with contextlib.suppress(OSError, TypeError):  # a class without source (a builtin's)
            names |= set(re.findall(r"self\.(\w+)\s*[:=]", inspect.getsource(klass)))
    return names


def test_every_backquoted_module_function_exists() -> None:
    stale = []
    for path in documents():
        text = path.read_text(encoding="utf-8")
        for match in DOTTED.finditer(text):
            if resolves(match.group(1)) is False:
                stale.append(f"{where(path, text, match.start())}: {match.group(1)}")
    assert not stale, "names that the package does not have:\n" + "\n".join(stale)
