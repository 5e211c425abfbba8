"""The frame as a graph of passes: the plan's passes (plan.py) in the order a frame runs them, each
with the named resources it reads and writes, as its node class declares them (node.py). Built
from the plan, checked (every resource read has been written by an earlier pass, or is the frame's
own cleared target), printed by `depthimpostor plan`, and run node by node by the render graph
(render_graph.py), so that what runs is what the plan says (but for the sample view, whose diffuse
pass draws the baked images' samples: its frames run the bakes first). This is not a scheduler:
about ten nodes in a fixed order, the order of `NODES`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

from .gpu.shaders import ProgramKey
from .methods.bounces import BouncesNode
from .methods.colour_mips import ColourMipsNode
from .methods.pyramid import PyramidsNode
from .methods.seen_from_eye import EyeImagesNode
from .methods.stand_in import StandInNode
from .node import FRAME, GraphFacts, Node, Pass
from .passes.deform import DeformNode
from .passes.diffuse import DiffuseNode
from .passes.environment import EnvironmentLightingNode, EnvironmentNode
from .passes.glass import GlassInteriorsNode
from .passes.reflectors import ReflectorsNode
from .passes.shadows import ShadowMapsNode
from .passes.transparent import TransparentNode

__all__ = ["FRAME", "NODES", "GraphError", "Pass", "RenderNode", "build_graph", "check_graph", "format_graph",
           "in_order", "node_class"]

#: Every node class, in the order a frame runs them. The bakes run only when stale, and are timed
#: apart from the eye's passes (render_graph.py); the stand-in's bake and those that read what it
#: writes come after the eye's passes that read none of it (the sky, the diffuse objects), so that
#: a frame finds the images its reflected rays enter behind its own depth and bakes those alone
#: (methods/entered_images.py) instead of drawing its diffuse objects a second time to find them.
NODES: tuple[type[Node], ...] = (
    DeformNode,  # as the world moves, before the stand-in follows it (its BVH refit reads the meshes)
    EnvironmentLightingNode,  # before anything that shades a metallic-roughness surface, bakes included
    ShadowMapsNode,  # before anything that shades: the baked images show shadows too
    EnvironmentNode,
    DiffuseNode,
    StandInNode,
    BouncesNode,
    PyramidsNode,
    ColourMipsNode,
    EyeImagesNode,
    GlassInteriorsNode,
    ReflectorsNode,
    TransparentNode,  # over everything opaque, the mirrors' reflections included
)

_BY_STAGE: dict[Pass, type[Node]] = {node.stage: node for node in NODES}


def node_class(stage: Pass) -> type[Node]:
    return _BY_STAGE[stage]


def in_order(stage: Pass) -> int:
    """Where `stage` runs in a frame (a sort key)."""
    return NODES.index(_BY_STAGE[stage])


@dataclass(frozen=True)
class RenderNode:
    stage: Pass
    reads: tuple[str, ...]
    writes: tuple[str, ...]
    why: str  # the plan's reason
    programs: tuple[ProgramKey, ...] = ()  # the plan's shader variants this node runs

    def format(self) -> str:
        reads = ", ".join(self.reads) or "nothing"
        compiles = f"; {len(self.programs)} program{'s' * (len(self.programs) != 1)}" if self.programs else ""
        return f"{self.stage.value}: reads {reads}; writes {', '.join(self.writes)}{compiles}"


def build_graph(stages: Sequence[tuple[Pass, str]], programs: Mapping[Pass, tuple[ProgramKey, ...]],
                stand_in: tuple[str, ...], reads_pyramids: bool,
                eye_images: tuple[tuple[str, ...], bool] = ((), False)) -> tuple[RenderNode, ...]:
    """The planned passes (`stages`: each with the plan's reason) as nodes, each with its
    `programs` (the plan's shader variants, by the pass that runs them) and the reads and writes its
    node class declares for these facts (node.py's GraphFacts: `stand_in`, `reads_pyramids`, and
    `eye_images`: what the eye-images node reads, and whether the frame's diffuse pass writes the
    eye's surface for it). GraphError where a pass would read what nothing wrote."""
    eye_reads, eye_surface = eye_images
    facts = GraphFacts(frozenset(stage for stage, _ in stages), stand_in, reads_pyramids, eye_reads, eye_surface)
    writes = {stage: _BY_STAGE[stage].writes(facts) for stage, _ in stages}
    facts = replace(facts, written=frozenset(name for names in writes.values() for name in names))
    nodes = tuple(RenderNode(stage, _BY_STAGE[stage].reads(facts), writes[stage], why, programs.get(stage, ()))
                  for stage, why in stages)
    check_graph(nodes)
    return nodes


class GraphError(RuntimeError):
    """A plan whose passes read what none wrote: a bug in planning, not in the scene."""


def check_graph(nodes: tuple[RenderNode, ...]) -> None:
    written = set(FRAME)
    for node in nodes:
        missing = [name for name in node.reads if name not in written]
        if missing:
            raise GraphError(f"the {node.stage.value} pass reads {', '.join(missing)}, which no earlier pass writes")
        written.update(node.writes)


def format_graph(nodes: tuple[RenderNode, ...]) -> str:
    return "\n".join([f"graph ({len(nodes)} nodes, in order):"] + [f"  {node.format()}" for node in nodes])
