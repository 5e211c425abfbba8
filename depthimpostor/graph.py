"""The frame as a graph of passes: the plan's passes (plan.py) in the order a frame runs them, each
with the named resources it reads and writes. Built from the plan, checked (every resource read has
been written by an earlier pass, or is the frame's own cleared target), printed by
`depthimpostor plan`, and run node by node by the renderer (renderer.py's `_run`), so that what
runs is what the plan says. This is not a scheduler: about eight nodes in a fixed order.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import Enum

from .gpu.shaders import ProgramKey


class Pass(Enum):
    """The render passes, in the order a frame runs them; the value names them in plans and stats."""

    SHADOW_MAPS = "shadow maps"
    STAND_IN = "reflected objects"  # the method's bake: depth images, cube maps, billboards, triangles
    BOUNCES = "reflections of reflections"
    PYRAMIDS = "depth pyramids"
    COLOUR_MIPS = "colour mips"  # the baked images' prefiltered colours: a glossy mirror's cone reads them
    ENVIRONMENT = "environment"
    DIFFUSE = "diffuse objects"
    EYE_IMAGES = "images seen from the eye"  # planar reflections' renders, SSR's frame copy (methods/seen_from_eye.py)
    GLASS_INTERIORS = "glass interiors"
    REFLECTORS = "mirrors and glass"


#: What every frame starts with: its colour and depth targets, cleared.
FRAME = ("frame colour", "frame depth")

#: The passes that bake (they run only for what is stale) and the eye's passes (every frame).
BAKES = (Pass.SHADOW_MAPS, Pass.STAND_IN, Pass.BOUNCES, Pass.PYRAMIDS, Pass.COLOUR_MIPS)


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
    `programs` (the plan's shader variants, by the pass that runs them). `stand_in`: what the
    method's stand-in makes for the reflectors to read ("baked images", "BVH", or what its
    eye-images node makes: "planar images", "frame copy"); `reads_pyramids`: the reflectors'
    variant marches with the hierarchical traversal; `eye_images`: what the eye-images node reads
    (the shadow maps where it shades), and whether the frame's diffuse pass writes the eye's surface for it
    (SSR). GraphError where a pass would read what nothing wrote."""
    planned = {stage for stage, _ in stages}
    shadows = ("shadow maps",) if Pass.SHADOW_MAPS in planned else ()
    pyramids = ("depth pyramids",) if reads_pyramids else ()
    bounces = ("bounce images",) if Pass.BOUNCES in planned else ()
    colour_mips = ("colour mips",) if Pass.COLOUR_MIPS in planned else ()
    interiors = ("glass interiors",) if Pass.GLASS_INTERIORS in planned else ()
    eye_reads, eye_surface = eye_images
    surface = ("eye surface",) if eye_surface else ()
    # Made in the frame (planar renders, the frame copy): by the eye-images node, not the bake's.
    made_in_frame = stand_in if Pass.EYE_IMAGES in planned else ()
    baked = tuple(name for name in stand_in if name not in made_in_frame)
    io: dict[Pass, tuple[tuple[str, ...], tuple[str, ...]]] = {
        Pass.SHADOW_MAPS: ((), ("shadow maps",)),
        # Baked images are shaded, shadows included; a BVH is triangles alone.
        Pass.STAND_IN: (shadows if "baked images" in stand_in else (), baked),
        Pass.BOUNCES: (("baked images", *shadows), bounces),
        Pass.PYRAMIDS: (("baked images", *bounces), ("depth pyramids",)),
        Pass.COLOUR_MIPS: (("baked images", *bounces), ("colour mips",)),
        Pass.ENVIRONMENT: (("frame colour",), ("frame colour",)),
        Pass.DIFFUSE: (("frame colour", "frame depth", *shadows), ("frame colour", "frame depth", *surface)),
        Pass.EYE_IMAGES: (eye_reads, made_in_frame),
        Pass.GLASS_INTERIORS: ((), interiors),
        Pass.REFLECTORS: (("frame colour", "frame depth", *stand_in, *surface, *pyramids, *colour_mips, *bounces,
                           *interiors, *shadows),
                          ("frame colour", "frame depth")),
    }
    nodes = tuple(RenderNode(stage, *io[stage], why, programs.get(stage, ())) for stage, why in stages)
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
