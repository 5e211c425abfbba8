"""The render graph's nodes (depthimpostor/node.py): one class per pass, declaring what it reads
and writes beside how it runs, in the module of its pass; graph.NODES orders them."""

from __future__ import annotations

import pytest

from depthimpostor.constants import Method
from depthimpostor.graph import NODES, GraphError, Pass, build_graph
from depthimpostor.methods.registry import METHODS


def test_every_pass_has_exactly_one_node_class_in_its_passs_module() -> None:
    assert sorted(node.stage.name for node in NODES) == sorted(stage.name for stage in Pass)
    for node in NODES:
        assert node.when, node  # what `depthimpostor plan` says of it
        # Beside the pass it runs, not in the graph's own modules.
        assert node.__module__.split(".")[1] in ("passes", "methods"), node


def test_the_bakes_come_before_what_reads_them_and_the_stand_in_after_the_diffuse_pass() -> None:
    """The order printed is the order run (render_graph.RenderGraph.draw): the bakes that shading
    reads (deforming parts, the sky's prefilter, shadow maps) first; then the eye's passes that
    read no baked image (the sky, the diffuse objects), whose depth the stand-in's bake finds
    the images a frame's rays enter behind; then the stand-in and the bakes that read it; then
    the eye's other passes, the mirror pass among them."""
    order = [node.stage for node in NODES]
    bakes = [node.stage for node in NODES if node.bakes]
    first_eye = next(i for i, node in enumerate(NODES) if not node.bakes)
    assert order[first_eye:first_eye + 2] == [Pass.ENVIRONMENT, Pass.DIFFUSE]
    assert order.index(Pass.STAND_IN) == first_eye + 2
    assert set(bakes) - set(order[:first_eye]) == {Pass.STAND_IN, Pass.BOUNCES, Pass.PYRAMIDS, Pass.COLOUR_MIPS}
    assert all(not node.bakes for node in NODES[order.index(Pass.COLOUR_MIPS) + 1:])
    assert order.index(Pass.REFLECTORS) > order.index(Pass.COLOUR_MIPS)


@pytest.mark.parametrize("method", list(Method), ids=lambda m: m.option)
def test_each_nodes_reads_are_written_before_it_in_the_order(method: Method) -> None:
    """Every node a method can plan, in the order of NODES, each reading what an earlier one
    wrote: build_graph refuses (GraphError) a node that reads what nothing before it wrote."""
    spec = METHODS[method]
    eye = spec.seen_from_eye
    possible = {Pass.STAND_IN: eye is None, Pass.EYE_IMAGES: eye is not None, Pass.BOUNCES: spec.bounces,
                Pass.PYRAMIDS: spec.marches_depth_images,
                Pass.COLOUR_MIPS: spec.bakes_images and not spec.names_triangles}
    stages = [(node.stage, "") for node in NODES if possible.get(node.stage, True)]
    eye_reads = () if eye is None else eye.reads + ("shadow maps",) * eye.shades  # every light casts shadows
    eye_images = (eye_reads, eye is not None and eye.reads_frame)
    graph = build_graph(stages, {}, spec.outputs, spec.marches_depth_images, eye_images)
    reflectors, transparent = graph[-2:]  # the blended objects last, over the reflectors
    assert reflectors.stage is Pass.REFLECTORS and set(spec.outputs) <= set(reflectors.reads)
    assert transparent.stage is Pass.TRANSPARENT
    # Reversed, the nodes read what is written only later: the order is checked, not only the set.
    with pytest.raises(GraphError, match="which no earlier pass writes"):
        build_graph(stages[::-1], {}, spec.outputs, spec.marches_depth_images, eye_images)
