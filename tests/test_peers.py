"""`bench --peers` (issue 35, item 3): Mitsuba 3 and the renderer with no reflections timed in the
methods' rounds, each with its error against the same truth. CI installs the extra (pyproject's
test extra holds it): this runs there, never skipped."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from conftest import SCENES
from depthimpostor.cli import main
from depthimpostor.peers import without_reflectors
from depthimpostor.scene import load_scene


def test_bench_peers_writes_each_peer_s_ratio_and_error_beside_the_methods(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "results"
    arguments = ["bench", str(SCENES / "default.toml"), "--methods", "depth,raytrace", "--algorithms", "optimized",
                 "--resolutions", "32", "--size", "96x54", "--frames", "2", "--warmup", "1", "--bakes", "1",
                 "--peers", "-o", str(out)]
    assert main(arguments) == 0
    capsys.readouterr()
    table = (out / "peers.md").read_text(encoding="utf-8")
    assert "| mitsuba frame / this frame | no reflections frame / this frame |" in table
    rows = {line.split(" | ")[0].strip("| "): line for line in table.splitlines() if line.startswith("| ")
            and not line.startswith("| drawn by") and not line.startswith("|---")}
    assert set(rows) == {"`depth` optimized, images 32", "`raytrace`", next(k for k in rows if k.startswith("**mitsuba**")),
                         "**no reflections**"}
    for label, line in rows.items():
        cells = [cell.strip() for cell in line.strip("|").split("|")]
        median = float(cells[1].split()[0])
        rmse, ratios = float(cells[2]), [float(cell) for cell in cells[3:]]
        assert median > 0 and np.isfinite(rmse) and all(r > 0 and np.isfinite(r) for r in ratios), line
        if label == "`raytrace`":
            assert rmse < 1e-3  # exact, against the same truth
        if label == "**no reflections**":
            assert rmse > 0.05 and ratios[1] == pytest.approx(1.0)  # its mirrors show nothing
        if label.startswith("**mitsuba**"):
            assert re.search(r"\((llvm_ad_rgb|scalar_rgb)\)", label) and ratios[0] == pytest.approx(1.0)


def test_the_no_reflection_peer_keeps_every_object_and_no_reflector() -> None:
    scene = load_scene(SCENES / "two_mirrors.toml")
    bare = without_reflectors(scene)
    assert len(bare.objects) == len(scene.objects) and any(o.is_reflector for o in scene.objects)
    assert not any(o.is_reflector for o in bare.objects)
