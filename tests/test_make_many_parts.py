"""tools/make_many_parts.py, the scene-size benchmark's glTF file: what it promises (shared meshes,
a mesh of two materials, nested transforms, a name on everything, the same bytes from the same
seed) in a small file, which loads and plans."""

from __future__ import annotations

import importlib.util
import math
import warnings
from pathlib import Path
from types import ModuleType

import numpy as np

from conftest import PROJECT_ROOT
from depthimpostor.constants import Method
from depthimpostor.errors import SceneWarning
from depthimpostor.plan import plan_render
from depthimpostor.scene import PlaneShape, load_scene


def tool() -> ModuleType:
    spec = importlib.util.spec_from_file_location("make_many_parts", PROJECT_ROOT / "tools" / "make_many_parts.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_a_small_file_has_what_the_benchmark_needs(tmp_path: Path) -> None:
    make = tool()
    count = 30
    path = make.build(count, seed=1).write(tmp_path / "a.glb")
    assert make.build(count, seed=1).write(tmp_path / "b.glb").read_bytes() == path.read_bytes()
    assert make.build(count, seed=2).write(tmp_path / "c.glb").read_bytes() != path.read_bytes()
    with warnings.catch_warnings():
        warnings.simplefilter("error", SceneWarning)  # every textured part has its TEXCOORD_0
        scene = load_scene(path)
    parts = [o for o in scene.objects if o.origin is not None and "." in o.origin.node_name]
    nodes = {o.origin.node for o in parts if o.origin is not None}
    assert len(nodes) == count
    barrels = [o for o in parts if o.origin is not None and o.origin.mesh_name == "barrel"]
    assert barrels and len(parts) == count + len(barrels) // 2  # a barrel node: its wood side and metal ends
    assert {o.origin.mesh_name for o in parts if o.origin is not None} == {"crate", "barrel", "ball", "ring"}
    assert all(o.origin is not None and o.origin.node_name and o.origin.mesh_name and o.origin.material_name
               for o in scene.objects)
    assert {type(o.shape) for o in scene.objects if o.origin is not None and o.origin.node_name == "Floor"} == {PlaneShape}
    assert len(scene.mirrors) == 1 and len(scene.textures) == 4
    # Nested transforms: a part stands on the floor of its row (turned and set back), not at its local origin.
    crate = next(o for o in parts if o.origin is not None and o.origin.mesh_name == "crate")
    positions = crate.shape.mesh.positions  # type: ignore[union-attr]
    assert math.isclose(float(positions[:, 1].min()), 0.0, abs_tol=1e-5) and float(positions[:, 2].mean()) > 1.0
    assert np.all(np.isfinite(positions))
    plan = plan_render(scene, Method.DEPTH)
    assert plan.images and sum(o.from_gltf for o in plan.objects) == len(scene.objects)
