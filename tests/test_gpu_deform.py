"""Skinning and morphing on the GPU (gpu/deform.py, deform.comp) against the numpy truth
(scene/gltf_deform.py): the same vertices and normals at every time, within float32 rounding,
written into the mesh arena in place; and the renderer using it."""

from __future__ import annotations

from pathlib import Path

import moderngl
import numpy as np
import pytest

from depthimpostor.gpu.deform import GpuDeform, part_rows, part_texels
from depthimpostor.gpu.meshes import MeshArena
from depthimpostor.gpu.shaders import ProgramCache
from depthimpostor.scene import Scene
from depthimpostor.scene.gltf_deform import PartMotion
from gltf_files import GltfWriter, quaternion, skinned_column
from test_gltf_animation import DATA, load_quietly

#: float32 against float64 arithmetic on coordinates of order 1 to 10.
TOLERANCE = 2e-5


def motions(scene: Scene) -> list[PartMotion]:
    found = [obj.motion for obj in scene.objects if obj.deforms]
    assert found and all(isinstance(m, PartMotion) for m in found)
    return [m for m in found if isinstance(m, PartMotion)]


def assert_gpu_matches_cpu(ctx: moderngl.Context, motion: PartMotion, times: tuple[float, ...]) -> None:
    """deform.comp's vertices at each time, read back from an arena where the part sits after
    another mesh (its first vertex not 0), equal mesh_at's; the other mesh's stay untouched."""
    assert motion.gpu_refusal is None
    assert len(part_texels(motion)[0]) == part_rows(motion)  # the plan's figure is the upload's
    rest = motion.mesh_at(0.0)
    other = rest.transformed(np.diag([2.0, 2.0, 2.0, 1.0]))
    arena = MeshArena(ctx, [other, rest])
    deform = GpuDeform(ctx, ProgramCache(ctx))
    try:
        for time in times:
            deform.deform(motion, time, arena.vertices, arena.first_vertex[rest])
            ctx.memory_barrier()
            vertices = np.frombuffer(arena.vertices.read(), np.float32).reshape(-1, 8)
            expected = motion.mesh_at(time)
            placed = vertices[arena.first_vertex[rest]:]
            assert np.isfinite(placed).all()
            np.testing.assert_allclose(placed[:, :3], expected.positions, atol=TOLERANCE, err_msg=f"t = {time}")
            np.testing.assert_allclose(placed[:, 3:6], expected.normals, atol=TOLERANCE, err_msg=f"t = {time}")
            np.testing.assert_array_equal(placed[:, 6:], rest.interleaved()[:, 6:])  # UVs untouched
            np.testing.assert_array_equal(vertices[: len(other.positions)], other.interleaved())
    finally:
        deform.release()
        arena.release()


def test_a_skinned_column_on_the_gpu_is_the_cpu_skin(ctx: moderngl.Context, tmp_path: Path) -> None:
    w = GltfWriter()
    skinned_column(w, w.material("Blue"), translation=(0.3, 0.0, -0.3), rings=6, sides=8)
    (motion,) = motions(load_quietly(w.write(tmp_path / "c.glb")))
    assert not np.allclose(motion.mesh_at(1.0).positions, motion.mesh_at(0.0).positions)  # it bends
    assert_gpu_matches_cpu(ctx, motion, (0.0, 0.4, 1.0, 1.7))


def morphing_part(tmp_path: Path) -> Scene:
    """Two primitives of one material (one part) with two morph targets of position and normal
    deltas, animated weights, under a node turned, scaled unevenly and moved (no skin: the part is
    placed by its node after the morph)."""
    w = GltfWriter()
    material = w.material("Grey")
    rng = np.random.default_rng(3)
    primitives = []
    for shift in (0.0, 2.0):
        positions = rng.uniform(-1, 1, (6, 3)) + (shift, 0, 0)
        normals = rng.normal(size=(6, 3))
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        primitive = w.primitive(positions, [[0, 1, 2], [2, 3, 4], [3, 4, 5]], normals, material=material)
        primitive["targets"] = [{"POSITION": w.accessor(rng.normal(size=(6, 3)), "VEC3"),
                                 "NORMAL": w.accessor(0.5 * rng.normal(size=(6, 3)), "VEC3")} for _ in range(2)]
        primitives.append(primitive)
    mesh = w.mesh(*primitives)
    node = w.node(mesh=mesh, translation=[0.5, 1.0, -2.0], rotation=quaternion((1, 2, 0), 35.0), scale=[1.0, 2.0, 0.5])
    w.animation((node, "weights", [0.0, 1.0, 2.0], [0.0, 0.0, 1.0, -0.5, 0.3, 0.8], "LINEAR"))
    return load_quietly(w.write(tmp_path / "m.glb"))


def test_morph_targets_on_the_gpu_are_the_cpu_morph(ctx: moderngl.Context, tmp_path: Path) -> None:
    (motion,) = motions(morphing_part(tmp_path))
    assert motion.skin is None and len(motion.primitives) == 2
    assert_gpu_matches_cpu(ctx, motion, (0.0, 0.5, 1.0, 1.5))


@pytest.mark.parametrize("name", ["RiggedSimple.glb", "AnimatedMorphCube/AnimatedMorphCube.gltf",
                                  "AnimatedMorphSphere/AnimatedMorphSphere.gltf",
                                  "MorphPrimitivesTest/MorphPrimitivesTest.gltf"])
def test_the_khronos_samples_deform_on_the_gpu_as_on_the_cpu(ctx: moderngl.Context, name: str) -> None:
    """RiggedSimple (a skin of two bones, MAT4 inverse binds), AnimatedMorphCube and
    AnimatedMorphSphere (morph targets of positions and normals, animated), MorphPrimitivesTest
    (two primitives, weights of the mesh)."""
    for motion in motions(load_quietly(DATA / name)):
        assert_gpu_matches_cpu(ctx, motion, (0.0, 0.3, 1.0, 1.6))


@pytest.mark.parametrize(("name", "why"), [("SimpleMorph/SimpleMorph.gltf", "without normals"),
                                           ("SimpleSkin/simple_skin.gltf", "without normals")])
def test_what_the_gpu_cannot_make_says_why(name: str, why: str) -> None:
    """A primitive without normals is given flat ones per triangle (glTF 3.7.2.1): a per-triangle
    result, which deform.comp (a vertex an invocation) does not make; the CPU deforms it."""
    for motion in motions(load_quietly(DATA / name)):
        assert motion.gpu_refusal is not None and why in motion.gpu_refusal


def test_a_pose_past_the_uniform_block_is_read_from_a_storage_buffer(ctx: moderngl.Context, tmp_path: Path,
                                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """The same skin with a uniform block of 4 rows: its 2 joints' 8 rows go in a storage buffer."""
    import depthimpostor.gpu.deform as deform_module

    monkeypatch.setattr(deform_module, "DEFORM_POSE_BLOCK_ROWS", 4)
    assert "POSE_IN_STORAGE" in deform_module.deform_defines(8) and "POSE_IN_STORAGE" not in deform_module.deform_defines(4)
    w = GltfWriter()
    skinned_column(w, w.material("Blue"), rings=4, sides=6)
    (motion,) = motions(load_quietly(w.write(tmp_path / "c.glb")))
    assert_gpu_matches_cpu(ctx, motion, (0.5, 1.0))
