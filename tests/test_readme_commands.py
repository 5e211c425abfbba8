"""Every command README.md and docs/guide.md show runs on a fresh clone (issue 35), at small sizes.

The commands are read from the documents themselves, so a command edited there is the command
tested here. Each runs in this process through the CLI's `main`, in a scratch folder, with the
scene paths as the documents write them (relative to the repository root) and a small frame:
`--size 64x36` where the command takes it, fewer frames and a shorter video. What is changed is
only how much work a command does, never which code it reaches.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from conftest import PROJECT_ROOT
from test_cli import run_in_process

#: A command in a document: `depthimpostor ...` (or `python3 -m depthimpostor ...`), at the start
#: of a line of a fenced block or after a shell prompt (`$ `), up to a comment.
_COMMAND = re.compile(r"(?:^(?:\$ )?|&& )(?:python3 -m )?depthimpostor (?P<args>[^#\n]+)", re.MULTILINE)
#: Synopsis lines (`[SCENE]`, `out.png|out.exr`) show the options, not a command to run.
_SYNOPSIS = re.compile(r"[\[|]")
#: A committed glTF model for the README's `your_scene.glb`.
YOUR_SCENE = PROJECT_ROOT / "tests" / "data" / "gltf" / "BoxTextured.glb"
#: Subcommands that draw frames and take --size.
_SIZED = {"render", "compare", "bench", "truth"}


def _fenced(text: str) -> str:
    """The document's fenced code blocks, joined."""
    return "\n".join(re.findall(r"```[a-z]*\n(.*?)```", text, re.DOTALL))


def documented_commands() -> list[tuple[str, str]]:
    """(document, command line) for every runnable command README.md and docs/guide.md show."""
    found = []
    for name in ("README.md", "docs/guide.md"):
        for match in _COMMAND.finditer(_fenced((PROJECT_ROOT / name).read_text(encoding="utf-8"))):
            args = match["args"].strip()
            if not _SYNOPSIS.search(args):
                found.append((name, args))
    return found


#: Options whose value is made smaller: a shorter video, fewer frames, smaller depth images.
SMALLER = {"--duration": "0.2", "--frames": "2", "--impostor-res": "32", "--resolutions": "32"}


def small(args: list[str], scratch: Path) -> list[str]:
    """The same command, with less work: a small frame, a short video, few timed frames, and its
    outputs in `scratch`."""
    command, rest = args[0], args[1:]
    out: list[str] = [command]
    values = iter(rest)
    for arg in values:
        if arg in ("-o", "--video"):
            out += [arg, str(scratch / Path(next(values)).name)]
        elif arg in SMALLER:
            next(values)
            out += [arg, SMALLER[arg]]
        elif arg.endswith((".toml", ".glb", ".gltf")):
            out.append(str(YOUR_SCENE if arg == "your_scene.glb" else PROJECT_ROOT / arg))
        else:
            out.append(arg)
    if command in _SIZED and "--size" not in out:
        out += ["--size", "64x36"]
    if command == "bench":
        out += ["--frames", "1", "--warmup", "0", "--bakes", "1", "-o", str(scratch / "bench")]
    return out


def test_the_documents_show_the_commands_this_test_runs() -> None:
    """The extraction finds what the documents show (so that an empty list cannot pass)."""
    commands = [args for _, args in documented_commands()]
    for expected in ("render scenes/default.toml", "compare scenes/checker_near_mirror.toml", "bench scenes/bunny.toml",
                     "plan scenes/carousel.toml", "render your_scene.glb", "view scenes/lecture_8x9.toml"):
        assert any(command.startswith(expected) for command in commands), expected
    assert len(commands) >= 12


@pytest.mark.parametrize(("document", "command"), documented_commands(), ids=lambda value: value[:60])
def test_a_documented_command_runs(document: str, command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                   monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # what a command writes by default (render.png) lands here
    args = shlex.split(command)
    if args[0] == "view":
        # The window's own tests (tests/test_viewer.py, under Xvfb) open it; here its arguments
        # must parse as the document writes them.
        from depthimpostor.cli import build_parser
        parsed = build_parser().parse_args(small(args, tmp_path))
        assert parsed.run is not None
        return
    code, stdout, stderr = run_in_process(small(args, tmp_path), capsys)
    assert code == 0, f"{document}: depthimpostor {command}: exit {code}\n{stderr}"
