"""The triangle methods' BVH refitted on the GPU for deforming meshes (methods/gpu_refit.py,
bvh_refit.comp) against the CPU refit (bvh.refit_triangle_forest) and the CPU path's frames."""

from __future__ import annotations

from pathlib import Path

import moderngl
import numpy as np
import pytest

from conftest import assert_finite
from depthimpostor.constants import Method
from depthimpostor.meshes import Mesh
from depthimpostor.methods.bvh import refit_triangle_forest
from depthimpostor.methods.instances import NODE_TEXELS
from depthimpostor.methods.triangles import TrianglePass, triangle_stride
from depthimpostor.node import Pass
from depthimpostor.plan import plan_render
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene, load_scene
from depthimpostor.scene.gltf_deform import PartMotion
from depthimpostor.world import World
from gltf_files import bending_scene
from test_gltf_animation import load_quietly


def bent_tube(tmp_path: Path) -> Scene:
    """The bending scene's column as a tube of 1,000 triangles: a tree of many levels."""
    return load_quietly(bending_scene(tmp_path / "bending.glb", rings=24, sides=20)).with_overrides(
        size=(192, 108), impostor_resolution=128)


def traced(renderer: Renderer) -> TrianglePass:
    triangles = renderer.graph.triangles
    assert triangles is not None
    return triangles


def texels(texture: moderngl.Texture) -> np.ndarray:
    return np.frombuffer(texture.read(), np.float32).reshape(-1, 4)


def test_the_gpu_refit_holds_what_it_bounds_and_is_the_cpu_refit(ctx: moderngl.Context, tmp_path: Path) -> None:
    """After the bend (t = 1): the triangle texture holds the deformed triangles (the CPU's mesh
    within float rounding); every leaf's box holds its triangles and every inner node's its
    children's; every box is the CPU refit's over the same (GPU-deformed) triangles, exactly, and
    the CPU refit's over the CPU-deformed ones within rounding; the roots read back are the texture's."""
    scene = bent_tube(tmp_path)
    with Renderer(ctx, scene, method=Method.RAYTRACE) as renderer:
        rest = traced(renderer).bottom
        renderer.set_time(1.0)
        triangles = traced(renderer)
        assert triangles.gpu is not None and triangles.gpu.refits == 1 and renderer.graph.deform.dispatches == 1
        layout, bvh = triangles.layout, triangles.bottom
        stride = triangle_stride(scene)
        count = sum(layout.mesh_triangles)
        corners = texels(triangles.triangles)[: count * stride].reshape(count, stride, 4)[:, :3, :3]
        nodes = texels(triangles.nodes)[NODE_TEXELS * layout.mesh_base: layout.node_texels].reshape(-1, NODE_TEXELS, 4)
        lower, upper = nodes[:, 0, :3], nodes[:, 1, :3]
        # The CPU's deformed meshes, in the triangle texture's order.
        cpu = np.concatenate([m.positions[m.indices] for m in triangles.distinct])[bvh.order]
        moved = np.abs(cpu - np.concatenate([m.positions[m.indices] for m in traced_meshes_at_rest(scene)])[bvh.order])
        assert moved.max() > 0.5  # the tube bent
        np.testing.assert_allclose(corners, cpu, atol=2e-5)
        assert np.isfinite(nodes).all()
        for node in range(bvh.node_count):
            if bvh.count[node]:
                held = corners[bvh.first[node]: bvh.first[node] + bvh.count[node]].reshape(-1, 3)
                assert (lower[node] <= held).all() and (held <= upper[node]).all()
            else:
                for child in (bvh.first[node], bvh.first[node] + 1):
                    assert (lower[node] <= lower[child]).all() and (upper[child] <= upper[node]).all()
        unordered = np.empty_like(corners)
        unordered[bvh.order] = corners
        same = refit_triangle_forest(rest, unordered)
        np.testing.assert_array_equal(lower, same.lower)
        np.testing.assert_array_equal(upper, same.upper)
        unordered[bvh.order] = cpu
        from_cpu = refit_triangle_forest(rest, unordered)
        np.testing.assert_allclose(lower, from_cpu.lower, atol=2e-5)
        np.testing.assert_allclose(upper, from_cpu.upper, atol=2e-5)
        roots = range(len(triangles.distinct))
        np.testing.assert_array_equal(bvh.lower[roots], lower[roots])
        np.testing.assert_array_equal(bvh.upper[roots], upper[roots])


def traced_meshes_at_rest(scene: Scene) -> list[Mesh]:
    return list(dict.fromkeys(item.local_mesh for item in World(scene, time=0.0).reflected_objects))


def frames(ctx: moderngl.Context, scene: Scene, method: Method, gpu: bool) -> list[np.ndarray]:
    pictures = []
    with Renderer(ctx, scene, method=method) as renderer:
        renderer.graph.deform.enabled = gpu
        for time in (0.0, 1.0):
            renderer.set_time(time)
            renderer.render()
            pictures.append(renderer.read_color_float())
            assert_finite(pictures[-1])
        triangles = traced(renderer) if method is Method.RAYTRACE else renderer.graph.stand_in.triangles  # type: ignore[union-attr]
        assert (triangles.gpu is not None and triangles.gpu.refits == 1) == gpu and triangles.refits == 1
        assert renderer.graph.deform.dispatches == int(gpu)
    return pictures


@pytest.mark.parametrize("method", [Method.RAYTRACE, Method.HYBRID], ids=lambda m: m.option)
def test_the_bent_tube_traced_after_the_gpu_refit_is_the_cpu_paths_picture(ctx: moderngl.Context, tmp_path: Path,
                                                                           method: Method) -> None:
    """The frames at t = 0 and t = 1 with the GPU's skin and refit and with the CPU's: the same
    pictures within float rounding (a pixel or two on a silhouette at most), and both move."""
    scene = bent_tube(tmp_path)
    gpu, cpu = frames(ctx, scene, method, True), frames(ctx, scene, method, False)
    for on_gpu, on_cpu in zip(gpu, cpu, strict=True):
        differs = np.abs(on_gpu - on_cpu).max(axis=2) > 1e-3
        assert differs.sum() <= 4, differs.sum()
    moved = np.abs(gpu[1] - gpu[0]).max(axis=2) > 0.05
    assert moved.sum() > 300


@pytest.mark.parametrize(("method", "programs"), [(Method.RAYTRACE, {"deform.comp", "bvh_refit.comp"}),
                                                  (Method.DEPTH, {"deform.comp"})], ids=lambda v: getattr(v, "option", ""))
def test_the_deforming_parts_pass_is_planned_with_its_programs_and_only_those_run(
        ctx: moderngl.Context, tmp_path: Path, method: Method, programs: set[str]) -> None:
    """Issue 33 item 5: the deform pass (and the refit's program for a traced method) planned for a
    scene whose parts deform, with its reason; after frames at two times the renderer has compiled
    the plan's programs and no other; a still scene plans neither."""
    scene = bent_tube(tmp_path)
    with Renderer(ctx, scene, method=method) as renderer:
        for time in (0.0, 1.0):
            renderer.set_time(time)
            renderer.render()
        plan = renderer.plan
        reason = next(p.reason for p in plan.passes if p.stage is Pass.DEFORM)
        assert "1 deforming glTF part" in reason and "deform.comp" in reason
        assert ("bvh_refit.comp" in reason) == (method is Method.RAYTRACE)
        assert {stages[0] for stages, _ in plan.program_keys if stages[0].endswith(".comp")} == programs
        assert renderer.programs.keys == plan.program_keys
    still = load_scene(Path(__file__).parent.parent / "scenes" / "default.toml")
    assert not plan_render(still, method).runs(Pass.DEFORM)
    assert not any(stages[0].endswith(".comp") for stages, _ in plan_render(still, method).program_keys)


def test_a_part_deformed_on_the_cpu_is_refitted_on_the_gpu_as_on_the_cpu(ctx: moderngl.Context, tmp_path: Path,
                                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """A part deform.comp refuses (here every part, as one without normals would be) is uploaded
    from the CPU, and the GPU refit reads those vertices: the same picture, bit for bit, as the
    CPU refit's (the same float32 triangles give the same boxes)."""
    monkeypatch.setattr(PartMotion, "gpu_refusal", property(lambda self: "refused for the test"))
    scene = bent_tube(tmp_path)
    pictures = []
    for gpu_refit in (True, False):
        with Renderer(ctx, scene, method=Method.RAYTRACE) as renderer:
            triangles = traced(renderer)
            if not gpu_refit:
                triangles.gpu = None
            renderer.set_time(1.0)
            renderer.render()
            pictures.append(renderer.read_color_float())
            assert renderer.graph.deform.dispatches == 0 and triangles.refits == 1
            assert (triangles.gpu is not None and triangles.gpu.refits == 1) == gpu_refit
    assert_finite(pictures[0])
    np.testing.assert_array_equal(pictures[0], pictures[1])
