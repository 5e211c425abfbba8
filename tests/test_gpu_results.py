"""tools/gpu_results.py, the one command for a GPU (issue 35, item 4): its pure parts here; CI runs the
whole of it with --quick on llvmpipe (.ci/run), against the committed llvmpipe reference."""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import moderngl

from depthimpostor.gpu.compile_logs import program_logs

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tools"))
import gpu_results  # noqa: E402

VERTEX = "#version 330 core\nvoid main() { gl_Position = vec4(0.0); }\n"


def test_a_driver_warning_on_a_program_that_compiled_is_kept(ctx: moderngl.Context) -> None:
    """moderngl shows no log for a program that compiled: the driver's warnings are read apart.
    (The source is new to the driver each run: Mesa's shader cache, on disk, gives no log for a
    program it compiled before.)"""
    fresh = time.time_ns() % 1_000_000_007
    warned = ctx.program(vertex_shader=VERTEX,
                         fragment_shader=f"#version 330 core\nout vec4 c;\nvoid main() {{ float x; c = vec4(x) + {fresh}.0; }}\n")
    quiet = ctx.program(vertex_shader=VERTEX,
                        fragment_shader="#version 330 core\nout vec4 c;\nvoid main() { c = vec4(1.0); }\n")
    try:
        assert "uninitialized" in program_logs(ctx, warned)
        assert program_logs(ctx, quiet) == ""
    finally:
        warned.release()
        quiet.release()


def test_results_are_named_after_the_gl_renderer() -> None:
    assert gpu_results.renderer_slug("NVIDIA H100 80GB HBM3/PCIe/SSE2") == "nvidia-h100-80gb-hbm3"
    assert gpu_results.renderer_slug("llvmpipe (LLVM 15.0.6, 256 bits)") == "llvmpipe"
    assert gpu_results.is_software("llvmpipe (LLVM 15.0.6, 256 bits)")
    assert not gpu_results.is_software("NVIDIA H100 80GB HBM3/PCIe/SSE2")


def _figures(**changes: float) -> dict[str, object]:
    figures: dict[str, object] = {"finite": True, "mirror_pixels": 4000, "wrong_object_percent": 0.5,
                                  "wrong_surface_percent": 3.0, "retraced_percent": 0.0, "color_rmse": 0.02,
                                  "direct_rmse": 0.0, "glass_rmse": 0.0, "geometric_error_median_percent": 0.1}
    return {**figures, **changes}


def test_the_check_passes_figures_within_tolerance_and_names_each_one_outside() -> None:
    reference = {"a depth optimized": _figures(), "a ssr -": {"refused": "no"}, "b depth optimized": _figures()}
    close = {"a depth optimized": _figures(color_rmse=0.021, mirror_pixels=4010), "a ssr -": {"refused": "no"}}
    assert gpu_results.judge(close, reference) == ([], [], 2)
    broken = {"a depth optimized": _figures(wrong_object_percent=4.0), "a ssr -": _figures(),
              "b depth optimized": _figures(finite=False, color_rmse=math.nan), "c raytrace -": _figures()}
    failures, unknown, compared = gpu_results.judge(broken, reference)
    assert unknown == ["c raytrace -"] and compared == 3
    assert any(f.startswith("a depth optimized: wrong_object_percent 4") for f in failures)
    assert any(f.startswith("a ssr -: rendered here, refused in the reference") for f in failures)
    assert "b depth optimized: the frame holds NaN or Inf" in failures
    assert any(f.startswith("b depth optimized: color_rmse nan") for f in failures)


def test_the_committed_reference_covers_every_shipped_scene_and_method() -> None:
    """A new scene or method makes the llvmpipe reference stale: remake it (--check-only)."""
    reference = json.loads(gpu_results.REFERENCE.read_text(encoding="utf-8"))
    assert "llvmpipe" in reference["gl"]
    expected = {gpu_results.check_key(name, method, algorithm)
                for name, _, method, algorithm in gpu_results.check_configurations(None)}
    assert set(reference["results"]) == expected
    assert all(figures.get("finite", True) for figures in reference["results"].values())


def test_only_the_frames_of_failed_configurations_are_kept(tmp_path: Path) -> None:
    results: dict[str, object] = {"a.toml planar -": {}, "a.toml depth basic": {}, "ab.toml planar -": {}}
    for key in results:
        gpu_results.frame_file(tmp_path, key).write_bytes(b"frame")
    assert gpu_results.frame_file(tmp_path, "a.toml depth basic").name == "a_depth_basic.npy"
    gpu_results.keep_failed_frames(tmp_path, results, ["a.toml planar -: color_rmse 0.12, reference 0.06"])
    assert sorted(path.name for path in tmp_path.iterdir()) == ["a_planar_-.npy"]
    gpu_results.keep_failed_frames(tmp_path, results, [])
    assert not tmp_path.exists()
