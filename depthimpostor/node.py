"""A node of the render graph: what a pass reads, what it writes and how it runs, in one class.

Each pass of a frame is one subclass of `Node`, in (or beside) the module that implements the
pass (`passes/shadows.py`'s `ShadowMapsNode`, `methods/pyramid.py`'s `PyramidsNode`, ...). Its
`reads` and `writes` declare the named resources it uses for a plan's facts (graph.py checks that
nothing is read before it is written, and `depthimpostor plan` prints them); `stale`, `run` and
`follow` execute it against the GL objects the render graph holds (render_graph.py), which runs
the plan's nodes in order with no branch on which node is which. `graph.NODES` lists the node
classes in the order a frame runs them: adding a pass is its class, a value of `Pass` naming it,
a line in `NODES`, and the plan's reason for running it (plan.py).

Followed: filament's FrameGraph, whose `addPass` takes a setup lambda that declares the pass's
reads and writes through a Builder and an execute lambda that runs it with the resources the
graph resolves; here the pair is two methods of one class (`reads`/`writes` and `run`), as pygfx
writes each effect pass as a class holding its shader and its `render`. As in filament, the
resources belong to the graph, not to a pass: the stand-in is written by one node and read by six,
and persists between frames (filament's imported resources). Not followed: filament's culling of
passes whose output nobody reads (the plan plans only what is needed) and its transient
allocation (every image here outlives a frame); about ten nodes run in a fixed order.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING, ClassVar

if TYPE_CHECKING:
    from .ppc import PPC
    from .render_graph import RenderGraph
    from .targets import FrameTargets
    from .world import World


class Pass(Enum):
    """The render passes (one `Node` class each); the value names them in plans and stats.
    `graph.NODES` orders them."""

    DEFORM = "deforming parts"  # glTF skins and morph targets at a new time (passes/deform.py)
    ENVIRONMENT_LIGHTING = "environment prefilter"  # an equirect sky's prefiltered specular, once per sky (ibl.py)
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
    TRANSPARENT = "blended objects"  # glTF's alphaMode BLEND, over the frame (passes/transparent.py)


#: What every frame starts with: its colour and depth targets, cleared.
FRAME = ("frame colour", "frame depth")


@dataclass(frozen=True)
class GraphFacts:
    """What the nodes' reads and writes depend on, from the plan."""

    planned: frozenset[Pass]
    #: What the method's stand-in makes for the reflectors to read ("baked images", "BVH", or what
    #: its eye-images node makes: "planar images", "frame copy").
    stand_in: tuple[str, ...]
    #: Does the reflectors' variant march with the hierarchical traversal (and so read pyramids)?
    reads_pyramids: bool
    #: What the eye-images node reads (the shadow maps where it shades).
    eye_reads: tuple[str, ...] = ()
    #: Does the frame's diffuse pass write the eye's surface (SSR reads it)?
    eye_surface: bool = False
    #: Everything the planned nodes write (in any order): filled in from their `writes` before
    #: any node's `reads` is asked, so `writes` must not depend on it.
    written: frozenset[str] = frozenset()

    def made(self, *names: str) -> tuple[str, ...]:
        """Those of `names` that a planned node writes: what a node reads where it is made (the
        shadow maps where a light casts shadows, the bounce images where reflectors show each other)."""
        return tuple(name for name in names if name in self.written)

    @property
    def surface(self) -> tuple[str, ...]:
        return ("eye surface",) if self.eye_surface else ()

    @property
    def made_in_frame(self) -> bool:
        """Is the stand-in made in the frame (by the eye-images node), not baked?"""
        return Pass.EYE_IMAGES in self.planned


@dataclass(frozen=True)
class Frame:
    """What the eye's passes draw through and into (the bakes ignore it)."""

    camera: PPC  # the frame's camera, or one of its sub-pixel positions
    unjittered: PPC  # the frame's own camera
    targets: FrameTargets


class Node(ABC):
    """One pass of the render graph, bound to the graph whose GL objects it runs."""

    stage: ClassVar[Pass]
    #: When it runs, as `depthimpostor plan` says.
    when: ClassVar[str]
    #: A bake: it runs before the eye's passes that read what it writes (graph.NODES orders them),
    #: once per frame, only when `stale`, and timed apart; the eye's passes run every frame (every
    #: sub-frame with anti-aliasing).
    bakes: ClassVar[bool] = False
    #: Part of the mirror pass's time (GraphOptions.time_mirror_pass): it begins at the first such node.
    mirror_time: ClassVar[bool] = False

    def __init__(self, graph: RenderGraph) -> None:
        self.graph = graph

    @staticmethod
    def reads(facts: GraphFacts) -> tuple[str, ...]:
        """The resources it reads (graph.py's check: each written by an earlier node or FRAME)."""
        return ()

    @staticmethod
    @abstractmethod
    def writes(facts: GraphFacts) -> tuple[str, ...]:
        """The resources it writes (without `facts.made`: see GraphFacts.written)."""

    def stale(self) -> bool:
        """Has a bake anything to do this frame? Asked of each group of bakes (render_graph.draw) before any of it runs."""
        return True

    @abstractmethod
    def run(self, frame: Frame) -> bool:
        """Run it (its draw calls and images counted in the graph's stats); whether it did
        anything, which counts it in `RenderStats.passes`."""

    def follow(self, earlier: World, world: World) -> None:
        """The world moved from `earlier` to `world`: mark stale what depends on what moved."""
        return None  # most nodes keep nothing between frames that a move makes stale
