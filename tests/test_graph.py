"""The render graph (depthimpostor/graph.py): the plan's passes with what each reads and writes,
checked, printed by `plan`, and run by the renderer node by node."""

from __future__ import annotations

import moderngl
import pytest

from conftest import SCENES
from depthimpostor.constants import Algorithm, Method
from depthimpostor.graph import GraphError, Pass, RenderNode, build_graph, check_graph
from depthimpostor.plan import plan_render
from depthimpostor.renderer import Renderer
from depthimpostor.scene import load_scene


def test_a_pass_that_reads_what_nothing_wrote_is_refused() -> None:
    with pytest.raises(GraphError, match="reads baked images, which no earlier pass writes"):
        check_graph((RenderNode(Pass.ENVIRONMENT, ("frame colour",), ("frame colour",), ""),
                     RenderNode(Pass.REFLECTORS, ("frame depth", "baked images"), ("frame colour",), "")))
    # Baked after they are read: the order matters, not only the set.
    with pytest.raises(GraphError):
        check_graph((RenderNode(Pass.REFLECTORS, ("shadow maps",), ("frame colour",), ""),
                     RenderNode(Pass.SHADOW_MAPS, (), ("shadow maps",), "")))


def test_the_reflectors_read_what_their_variant_samples() -> None:
    scene = load_scene(SCENES / "glass_and_mirrors.toml")
    graph = {node.stage: node for node in plan_render(scene, Method.DEPTH, Algorithm.HIERARCHICAL).graph}
    assert set(graph[Pass.REFLECTORS].reads) >= {"baked images", "depth pyramids", "bounce images",
                                                  "glass interiors", "shadow maps"}
    traced = {node.stage: node for node in plan_render(load_scene(SCENES / "default.toml"), Method.RAYTRACE).graph}
    assert "BVH" in traced[Pass.REFLECTORS].reads and "baked images" not in traced[Pass.REFLECTORS].reads
    with pytest.raises(GraphError):  # pyramids read, none planned
        build_graph([(Pass.STAND_IN, ""), (Pass.REFLECTORS, "")], {}, ("baked images",), reads_pyramids=True)


@pytest.mark.parametrize(("name", "method", "algorithm"), [
    ("glass_and_mirrors.toml", Method.DEPTH, Algorithm.HIERARCHICAL),
    ("shadows.toml", Method.HYBRID, Algorithm.OPTIMIZED),
    ("default.toml", Method.RAYTRACE, Algorithm.OPTIMIZED),
])
def test_the_renderer_runs_the_plans_graph(ctx: moderngl.Context, name: str, method: Method,
                                           algorithm: Algorithm) -> None:
    """Every node of the plan's graph runs on the first frame (everything is stale), and nothing
    else; on the second, only the eye's passes (nothing moved)."""
    scene = load_scene(SCENES / name).with_overrides(size=(64, 36), impostor_resolution=32)
    with Renderer(ctx, scene, algorithm, method=method) as renderer:
        renderer.render()
        assert set(renderer.stats.passes) == {node.stage.value for node in renderer.plan.graph}
        first = renderer.stats.passes.copy()
        renderer.render()
        again = renderer.stats.passes - first
        assert set(again) == {Pass.ENVIRONMENT.value, Pass.REFLECTORS.value} | (
            {Pass.DIFFUSE.value} if renderer.plan.runs(Pass.DIFFUSE) else set())


def test_the_nodes_hold_the_plans_programs_and_the_renderer_compiles_them(ctx: moderngl.Context) -> None:
    """Each planned shader variant belongs to the node that runs it, and a renderer compiles the
    nodes' programs before the passes ask for them: after its first frame it holds those and no other."""
    scene = load_scene(SCENES / "glass_and_mirrors.toml").with_overrides(size=(64, 36), impostor_resolution=16)
    plan = plan_render(scene, Method.DEPTH, Algorithm.HIERARCHICAL)
    by_node = [key for node in plan.graph for key in node.programs]
    assert sorted(by_node) == sorted(plan.program_keys) and len(by_node) == len(set(by_node))
    assert all(key[0][-1] in ("reflector_surface.frag", "reflector.frag") for node in plan.graph
               if node.stage is Pass.REFLECTORS for key in node.programs)
    with Renderer(ctx, scene, Algorithm.HIERARCHICAL) as renderer:
        assert renderer.programs.keys == plan.program_keys  # compiled at construction, before a frame
        renderer.render()
        assert renderer.programs.keys == plan.program_keys
