"""What the GL context cannot hold is refused before anything is made, naming the setting to change.

Each of issue 21's reproductions (`--size 16384x16384`, glass_and_mirrors at `--impostor-res 4096`,
63 reflected objects at 2048, the viewer's `]` from 2048 to 4096) ended in "the framebuffer is not
complete". Here they run against small limits given to the context (`limits._read_limits`, the one
place the limits come from), scaled down so that nothing large is allocated: the same checks
refuse them, in one line, with exit 2.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import moderngl
import pytest

from conftest import SCENES
from depthimpostor.gpu import limits
from depthimpostor.cli import main
from depthimpostor.errors import GpuLimitError
from depthimpostor.gpu.limits import GpuLimits, context_limits, parse_memory, use_limits
from depthimpostor.renderer import Renderer
from depthimpostor.scene import load_scene

MIB = 2**20

#: A small GL: textures and renderbuffers of 2048 a side at most, one texture of 16 MiB at most, a
#: renderbuffer of 32 MiB, and 256 MiB in all.
SMALL = GpuLimits(max_texture_size=2048, max_renderbuffer_size=2048, max_viewport=(2048, 2048),
                  max_texture_bytes=16 * MIB, max_renderbuffer_bytes=32 * MIB, memory=256 * MIB,
                  memory_source="the test's budget")


@pytest.fixture
def small_gl(monkeypatch: pytest.MonkeyPatch) -> Iterator[GpuLimits]:
    """Every context made from here on reports the SMALL limits."""
    monkeypatch.setattr(limits, "_read_limits", lambda ctx: SMALL)
    yield SMALL


@pytest.fixture
def small_ctx(ctx: moderngl.Context) -> Iterator[moderngl.Context]:
    """The session's context with the SMALL limits, restored afterwards."""
    before = context_limits(ctx)
    use_limits(ctx, SMALL)
    yield ctx
    use_limits(ctx, before)


def refused(args: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    """Run the CLI in-process; assert one line on stderr and exit 2; return the line."""
    code = main(args)
    captured = capsys.readouterr()
    assert code == 2, captured.err
    assert "Traceback" not in captured.err
    [line] = captured.err.splitlines()
    assert line.startswith("depthimpostor: ")
    return line


def many_objects_scene(folder: Path, count: int, resolution: int) -> Path:
    """A mirror sphere and `count` small boxes round it, every one a depth image."""
    lines = ["[render]", "size = [64, 36]", f"impostor_resolution = {resolution}", "",
             "[camera]", "eye = [0.0, 2.0, 9.0]", "target = [0.0, 0.0, 0.0]", "",
             "[[objects]]", 'name = "mirror"', 'shape = { type = "sphere", radius = 1.0 }',
             'material = { type = "mirror" }', ""]
    for i in range(count):
        angle = 6.283185307 * i / count
        lines += ["[[objects]]", f'name = "box{i}"', 'shape = { type = "box", size = [0.1, 0.1, 0.1] }',
                  'material = { type = "diffuse", color = [0.8, 0.3, 0.2] }',
                  f"position = [{3.0 * math.cos(angle):.4f}, {0.3 * (i % 5):.2f}, {3.0 * math.sin(angle):.4f}]", ""]
    path = folder / "many.toml"
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


def test_a_frame_over_the_renderbuffer_limit_names_size(
    small_gl: GpuLimits, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "never.png"
    line = refused(["render", "--size", "4096x4096", "-o", str(out)], capsys)  # 16384^2 on llvmpipe
    assert "GL_MAX_RENDERBUFFER_SIZE of 2048" in line and "lower --size" in line
    assert not out.exists()
    # Within the sides but over the renderbuffer's bytes: 2048 x 2048 RGBA32F is 64 MiB.
    line = refused(["render", "--size", "2048x2048", "-o", str(out)], capsys)
    assert "64 MiB" in line and "lower --size" in line


def test_an_atlas_over_the_texture_limits_names_impostor_res(
    small_gl: GpuLimits, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scene = str(SCENES / "glass_and_mirrors.toml")
    out = str(tmp_path / "never.png")
    # 15 images of 1024 need a 4096 x 4096 atlas: over the side (4096 on llvmpipe: over its bytes).
    line = refused(["render", scene, "--impostor-res", "1024", "--size", "64x36", "-o", out], capsys)
    assert "atlas of 15 baked images of 1024x1024" in line and "GL_MAX_TEXTURE_SIZE of 2048" in line
    assert line.endswith("lower --impostor-res")
    # `plan` prints the plan, then refuses it as `render` does.
    code = main(["plan", scene, "--impostor-res", "1024", "--size", "64x36"])
    captured = capsys.readouterr()
    assert code == 2 and "memory:" in captured.out and "lower --impostor-res" in captured.err


def test_sixty_three_reflected_objects_over_the_texture_bytes(
    small_gl: GpuLimits, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # 63 images of 256 (of 2048 on llvmpipe): an 8 x 8 grid, 2048 x 2048 RG32F, 32 MiB > 16 MiB.
    scene = many_objects_scene(tmp_path, 63, 256)
    line = refused(["render", str(scene), "-o", str(tmp_path / "never.png")], capsys)
    assert "atlas of 63 baked images of 256x256 would take 32 MiB (2048x2048)" in line
    assert "16 MiB" in line and line.endswith("lower --impostor-res")
    assert not (tmp_path / "never.png").exists()


def test_the_memory_budget_and_max_memory(small_gl: GpuLimits, tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    out = str(tmp_path / "out.png")
    line = refused(["render", "--size", "160x90", "--max-memory", "4M", "-o", out], capsys)
    assert "over the 4.00 MiB of --max-memory" in line and "raise --max-memory" in line
    # The view command takes it too: tests/test_viewer.py runs it in a window.
    for command in (["compare", "-o", str(tmp_path / "report")], ["plan"],
                    ["bench", "--resolutions", "64", "--methods", "depth", "-o", str(tmp_path / "bench")]):
        line = refused([*command, "--size", "160x90", "--max-memory", "1M"], capsys)
        assert "--max-memory" in line
    # Refused after the outputs were checked: the check left no empty folder behind.
    assert not (tmp_path / "report").exists() and not (tmp_path / "bench").exists()
    assert main(["render", "--size", "160x90", "--max-memory", "200M", "--frames", "1", "-o", out]) == 0


def test_renderer_keeps_its_resolution_when_the_next_does_not_fit(small_ctx: moderngl.Context) -> None:
    """The viewer's `]`: the renderer refuses a resolution the context cannot hold before making
    anything, and draws on with the old one."""
    scene = load_scene(SCENES / "default.toml").with_overrides(size=(64, 36), impostor_resolution=512)
    with Renderer(small_ctx, scene) as renderer:
        renderer.render()
        with pytest.raises(GpuLimitError, match="lower --impostor-res"):
            renderer.set_impostor_resolution(1024)  # 5 images: a 3072 x 2048 atlas
        assert renderer.scene.render.impostor_resolution == 512
        assert renderer.graph.baked_images is not None and renderer.graph.baked_images.atlas.resolution == 512
        renderer.render()
        with pytest.raises(GpuLimitError, match="lower --size"):
            renderer.resize((4096, 64))
        assert renderer.scene.render.size == (64, 36)
        renderer.render()
        assert renderer.read_color().shape == (36, 64, 3)


def test_an_incomplete_framebuffer_is_refused_as_a_limit(ctx: moderngl.Context) -> None:
    """What no query tells (the driver runs out of memory) still ends in one line, not a traceback."""
    with pytest.raises(GpuLimitError, match="could not make a framebuffer.*lower --size"), \
            limits.allocating(ctx, "--size"):
        raise moderngl.Error("the framebuffer is not complete (INCOMPLETE_ATTACHMENT)")


@pytest.mark.parametrize(("text", "size"), [("512M", 512 * MIB), ("1.5G", 3 * 2**29), ("2GiB", 2 * 2**30),
                                            ("800MB", 800 * MIB), ("64", 64 * MIB), ("100k", 100 * 1024)])
def test_memory_sizes(text: str, size: int) -> None:
    assert parse_memory(text) == size


@pytest.mark.parametrize("text", ["", "0", "-1G", "lots", "1.5X", "nan", "0.0000001K"])
def test_bad_memory_sizes(text: str) -> None:
    with pytest.raises(ValueError, match="expected a positive size"):
        parse_memory(text)
