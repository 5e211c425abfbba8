"""The methods whose stand-in depends on the eye (planar reflections, screen-space reflections):
what they make is made in the frame, for its camera, by the render graph's eye-images node
(`EyeImagesNode` below), after the diffuse objects and before the reflectors, every frame.

Every frame, and not only when the eye moves (as glass interiors are, passes/glass.py): what
they show is the frame's own pixels (SSR) or lines up with them (planar), so a sub-pixel jitter
(render.samples) changes it as much as a moved eye; and a frame's cost then includes what a
moving camera pays, which is what `bench` reports (its camera stands still).
"""

from __future__ import annotations

from typing import ClassVar

import moderngl

from ..geometry import ObjectGeometry
from ..gpu.meshes import GpuMeshes
from ..gpu.scene_blocks import DrawnMaterials
from ..gpu.shaders import ProgramCache
from ..node import Frame, GraphFacts, Node, Pass
from ..ppc import PPC
from ..scene.model import Scene


class SeenFromEye:
    """A stand-in made in the frame from the eye (planar.PlanarPass, screen_space.ScreenSpacePass)."""

    #: What one of its images is called in summaries.
    image_noun: ClassVar[str]
    image_plural: ClassVar[str]
    #: One image per reflector (planar), or one for the frame (SSR)?
    per_reflector: ClassVar[bool] = False
    #: What its eye node reads and writes (the graph's resource names, node.py), shadows aside.
    reads: ClassVar[tuple[str, ...]] = ()
    writes: ClassVar[tuple[str, ...]]
    #: Does the frame's diffuse pass write the eye's surface (position, object) for it?
    reads_frame: ClassVar[bool] = False
    #: Is it drawn with the scene's shading (and so reads the shadow maps)?
    shades: ClassVar[bool] = False

    def __init__(self, ctx: moderngl.Context, programs: ProgramCache, scene: Scene, meshes: GpuMeshes,
                 materials: DrawnMaterials, reflectors: list[ObjectGeometry]) -> None:
        self.ctx, self.programs, self.scene, self.meshes = ctx, programs, scene, meshes
        self.made = 0  # images made so far (stats)
        self.size: tuple[int, int] | None = None  # the frame size its targets have
        self.reflectors = len(reflectors)
        self.glossy = scene.has_rough_mirrors  # a rough mirror reads its images prefiltered

    @classmethod
    def bytes_for(cls, size: tuple[int, int], reflectors: int, glossy: bool = False) -> int:
        raise NotImplementedError

    @classmethod
    def variants(cls, scene: Scene) -> list[tuple[tuple[str, ...], dict[str, int] | None, str]]:
        """The programs its eye node compiles (stages, defines, why), for the plan."""
        raise NotImplementedError

    def diffuse_framebuffer(self, frame: moderngl.Framebuffer, size: tuple[int, int]) -> moderngl.Framebuffer:
        """What the frame's diffuse pass draws through (`frame`: the frame's colour and depth); a
        stand-in that reads what the eye saw (reads_frame) adds its own targets beside them."""
        return frame

    @property
    def bytes(self) -> int:
        """GPU bytes of its targets at the frame's size (none before the first frame)."""
        return self.bytes_for(self.size, self.reflectors, self.glossy) if self.size else 0

    def describe(self) -> str:
        size = f" of {self.size[0]}x{self.size[1]}" if self.size else ""
        count = self.reflectors if self.per_reflector else 1
        return f"{count} x {self.image_plural}{size}, made every frame"

    def bake(self) -> int:
        """Nothing ahead of the frame: it is made in it (`make`)."""
        return 0

    def make(self, camera: PPC, diffuse: list[ObjectGeometry], reflectors: list[ObjectGeometry],
             frame: moderngl.Framebuffer) -> int:
        """Make what the reflectors read for this frame through `camera` (`frame`: the frame's
        colour and depth, drawn so far); returns the draw calls."""
        raise NotImplementedError

    def bind(self, program: moderngl.Program) -> None:
        """Nothing shared by the reflectors."""

    def bind_reflector(self, program: moderngl.Program, mirror: ObjectGeometry) -> None:
        raise NotImplementedError

    def release(self) -> None:
        raise NotImplementedError


class EyeImagesNode(Node):
    """The graph's eye-images node: the stand-in of a method seen from the eye made for the
    frame's camera, after the diffuse objects (SSR copies them) and before the reflectors."""

    stage = Pass.EYE_IMAGES
    when = "every frame (they depend on the eye, to the sub-pixel)"
    mirror_time = True

    @staticmethod
    def reads(facts: GraphFacts) -> tuple[str, ...]:
        return facts.eye_reads

    @staticmethod
    def writes(facts: GraphFacts) -> tuple[str, ...]:
        return facts.stand_in

    def run(self, frame: Frame) -> bool:
        graph = self.graph
        made = graph.seen_from_eye
        if made is None:
            return False
        before = made.made
        graph.stats.draw_calls += made.make(frame.camera, graph.world.diffuse_objects, graph.world.reflectors,
                                            frame.targets.color_framebuffer)
        graph.stats.eye_images_made += made.made - before
        return True
