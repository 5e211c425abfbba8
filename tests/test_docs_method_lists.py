"""The docs' and the command line's lists of methods and algorithms are the registry's (issue 35, item 1:
the guide's `render` synopsis, `--algorithm`'s help and docs/python_api.md's list had gone stale)."""

from __future__ import annotations

import re
from pathlib import Path

from depthimpostor.cli import build_parser
from depthimpostor.constants import Algorithm
from depthimpostor.methods.registry import METHODS

ROOT = Path(__file__).resolve().parent.parent
METHOD_NAMES = [spec.option for spec in METHODS.values()]
ALGORITHM_NAMES = [algorithm.name.lower() for algorithm in Algorithm]


def _docs() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def test_every_synopsis_lists_the_registry_s_methods_and_algorithms() -> None:
    seen = 0
    for path in _docs():
        text = path.read_text(encoding="utf-8")
        for option, names in re.findall(r"--(method|algorithm) ([a-z-]+(?:\|[a-z-]+)+)", text):
            assert names.split("|") == (METHOD_NAMES if option == "method" else ALGORITHM_NAMES), f"{path.name}: {names}"
            seen += 1
    assert seen >= 3  # the guide's render and view synopses at least


def test_python_api_lists_the_registry_s_methods_and_algorithms() -> None:
    text = (ROOT / "docs" / "python_api.md").read_text(encoding="utf-8")
    row = next(line for line in text.splitlines() if line.startswith("| `method`, `algorithm` |"))
    methods, algorithms = row.split("|")[2].split(";")
    assert re.findall(r"`([a-z-]+)`", methods) == METHOD_NAMES
    assert re.findall(r"`([a-z-]+)`", algorithms) == ALGORITHM_NAMES


def _help(command: str, dest: str) -> str:
    subparsers = next(a for a in build_parser()._actions if a.dest == "command")
    parser = subparsers.choices[command]  # type: ignore[index]
    return next(action.help for action in parser._actions if action.dest == dest)


def test_the_help_says_what_every_method_and_algorithm_is() -> None:
    for command in ("render", "compare", "view", "plan"):
        for spec in METHODS.values():
            assert f"{spec.option}: {spec.label}" in _help(command, "method"), (command, spec.option)
        for name in ALGORITHM_NAMES:
            assert f"{name}: " in _help(command, "algorithm"), (command, name)
