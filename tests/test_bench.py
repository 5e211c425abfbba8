"""The benchmark's smoke test: every file written, every figure finite. Timing itself is never
asserted in a test (it belongs to the benchmark's own output)."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest
from PIL import Image

from conftest import SCENES
from depthimpostor.bench import COLUMNS, RESOLUTION_METHODS
from depthimpostor.cli import main
from depthimpostor.constants import Method
from depthimpostor.methods.registry import METHODS


def test_bench_writes_every_file_with_finite_figures(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "results"
    arguments = ["bench", str(SCENES / "default.toml"), "--resolutions", "16,32", "--size", "96x54",
                 "--frames", "2", "--warmup", "1", "--bakes", "1", "-o", str(out)]
    assert main(arguments) == 0
    printed = capsys.readouterr().out
    assert printed.startswith("depthimpostor bench, ") and "GL: " in printed and "machine: " in printed
    assert sorted(path.name for path in out.iterdir()) == [
        "bench.csv", "bench.md", "frontier-default.png", "samples-default.png"]
    with (out / "bench.csv").open(encoding="utf-8") as file:
        lines = file.read().splitlines()
    header = [line for line in lines if line.startswith("# ")]
    assert any("GL: " in line for line in header) and any("settings: " in line for line in header)
    rows = list(csv.DictReader(line for line in lines if not line.startswith("# ")))
    assert list(rows[0]) == COLUMNS
    # Two resolutions for the methods that bake images (depth images with both default
    # algorithms), one row for each of the others.
    def algorithms(method: Method) -> tuple[str, ...]:
        return ("optimized", "hierarchical") if METHODS[method].marches_depth_images else ("-",)

    expected = {(m.option, a, r) for m in RESOLUTION_METHODS for a in algorithms(m) for r in ("16", "32")}
    # The planar method is for flat mirrors alone: left out of the default scene's sphere.
    expected |= {(m.option, "-", "0") for m in Method if m not in RESOLUTION_METHODS and not METHODS[m].flat_mirrors}
    assert {(row["method"], row["algorithm"], row["resolution"]) for row in rows} == expected
    assert len(rows) == len(expected)
    for row in rows:
        for name, value in row.items():
            if name in ("scene", "method", "algorithm", "stand_in"):
                continue
            number = float(value)
            if name == "psnr_db" and float(row["color_rmse"]) == 0.0:
                continue  # an exact frame has no finite PSNR
            assert math.isfinite(number), (row["method"], row["resolution"], name, value)
        assert float(row["frame_ms_median"]) > float(row["mirror_pass_ms_median"]) > 0 and int(row["mirror_pixels"]) > 0
        # The GL time queries of the same frames: the mirror pass is a part of the eye's passes.
        assert float(row["gl_time_query_ms"]) >= float(row["gl_mirror_pass_ms"]) > 0
        assert float(row["samples_per_ray_max"]) >= float(row["samples_per_ray_mean"]) >= 0
    depth = {row["resolution"]: row for row in rows if row["method"] == "depth" and row["algorithm"] == "optimized"}
    assert float(depth["32"]["memory_mib"]) > float(depth["16"]["memory_mib"])
    assert float(depth["16"]["bake_ms_median"]) > 0
    # The hierarchical traversal: the same picture from its pyramids (which cost memory).
    for resolution in ("16", "32"):
        hierarchical = next(row for row in rows if row["algorithm"] == "hierarchical" and row["resolution"] == resolution)
        assert hierarchical["color_rmse"] == depth[resolution]["color_rmse"]
        assert float(hierarchical["memory_mib"]) > float(depth[resolution]["memory_mib"])
        assert "depth pyramids" in hierarchical["stand_in"]
    for name in ("frontier-default.png", "samples-default.png"):
        assert Image.open(out / name).size[0] > 400


def test_bench_refuses_an_unknown_method(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "--methods", "depth,mirrorball"]) == 2
    assert "--methods" in capsys.readouterr().err
    assert main(["bench", "--algorithms", "optimized,octree"]) == 2
    assert "--algorithms" in capsys.readouterr().err


@pytest.mark.parametrize(("option", "value", "expected"), [
    ("--warmup", "-1", "expected an integer >= 0, got -1"),  # was statistics.StatisticsError after the run
    ("--bakes", "0", "expected a positive integer, got 0"),  # was exit 0 with bakes of 0.0 ms
    ("--bakes", "-1", "expected a positive integer, got -1"),
    ("--resolutions", "0", 'expected an integer in [4, 4096] or "auto", got 0'),  # named --impostor-res
    ("--resolutions", "64,auto,5000", ('expected an integer in [4, 4096] or "auto", got 5000 '
                                       "(in the list '64,auto,5000')")),
    ("--size", "0x10", "expected 2 integers in [1, 16384], got 0x10"),
])
def test_bench_refuses_a_bad_number_naming_its_option(
    option: str, value: str, expected: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Refused by argparse before any scene is read or context made, in the option's own name.
    The other settings are tiny, so that a bench that ran anyway would end soon."""
    small = {"--methods": "depth", "--algorithms": "optimized", "--resolutions": "16", "--size": "32x18",
             "--frames": "1", "--warmup": "0", "--bakes": "1"}
    arguments = [part for name, setting in {**small, option: value}.items() for part in (name, setting)]
    with pytest.raises(SystemExit) as exit_:
        main(["bench", str(SCENES / "default.toml"), *arguments, "-o", str(tmp_path / "never")])
    assert exit_.value.code == 2
    captured = capsys.readouterr()
    assert captured.out == "" and "Traceback" not in captured.err
    assert captured.err.splitlines()[-1] == f"depthimpostor bench: error: argument {option}: {expected}"
    assert not (tmp_path / "never").exists()
