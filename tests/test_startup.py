"""Start-up (issue 24, item 6): `render` draws one frame unless --frames asks for timing, and the
modules only some scenes need are imported when a scene needs them, not with the package."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from conftest import PROJECT_ROOT, SCENES

from depthimpostor.cli import main
from depthimpostor.renderer import Renderer

#: Imported only for what needs them: trimesh and fast-simplification (with scipy and networkx)
#: for model files and the simplified method, embreex for the truth.
LAZY = ("trimesh", "fast_simplification", "embreex", "scipy", "networkx")


def _modules_after(code: str) -> set[str]:
    """The LAZY modules imported by `code`, run in a fresh interpreter on this checkout."""
    env = {**os.environ, "PYTHONPATH": str(PROJECT_ROOT)}
    script = f"{code}\nimport sys\nprint(' '.join(m for m in {LAZY!r} if m in sys.modules))"
    done = subprocess.run([sys.executable, "-c", script], cwd=PROJECT_ROOT, env=env, capture_output=True, text=True,
                          timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    return set(done.stdout.splitlines()[-1].split())


def test_importing_the_renderer_imports_no_model_library() -> None:
    assert _modules_after("import depthimpostor.renderer, depthimpostor.api, depthimpostor.cli") == set()


def test_rendering_a_scene_of_primitives_imports_no_model_library(tmp_path: Path) -> None:
    out = tmp_path / "default.png"
    code = ("from depthimpostor.cli import main\n"
            f"assert main(['render', {str(SCENES / 'default.toml')!r}, '-o', {str(out)!r}, '--size', '64x36']) == 0")
    assert _modules_after(code) == set()
    assert out.is_file()


def test_render_draws_one_frame_unless_asked_for_timing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    frames: list[int] = []
    draw = Renderer.render

    def counted(self: Renderer, *args: Any, **kwargs: Any) -> Any:
        frames.append(1)
        return draw(self, *args, **kwargs)

    monkeypatch.setattr(Renderer, "render", counted)
    assert main(["render", "-o", str(tmp_path / "x.png"), "--size", "32x18"]) == 0
    assert len(frames) == 1 and "first frame" in capsys.readouterr().out
    assert main(["render", "-o", str(tmp_path / "x.png"), "--size", "32x18", "--frames", "2"]) == 0
    assert len(frames) == 1 + 3 and "median of 2" in capsys.readouterr().out
