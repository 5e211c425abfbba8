"""The eye's transparent pass: glTF's alphaMode BLEND objects, drawn last over the frame.

After everything opaque (the diffuse objects, the mirrors and glass with their reflections: a
blended object in front of a mirror covers part of its reflection), the blended objects are drawn
back to front by the distance from the eye to each one's bounding-sphere centre, with the depth
test on (what is opaque and nearer hides them) and depth writes off (one blended object does not
hide another drawn after it), each fragment "over" the frame: colour * alpha + frame * (1 - alpha),
glTF's non-premultiplied base colour alpha. A closed solid (gpu/batches.is_closed) is drawn twice,
its back faces and then its front faces, so that a convex one is in order within itself too.

Where this differs from the truth's exact order along each ray (oracles/truth.py composites the
hits front to back): objects sorted by their centres, not per pixel, so two blended objects that
intersect, or one large one behind a small one whose centre is farther, are blended in the wrong
order where they overlap (tests/test_alpha_blend.py measures it on two crossing quads), and
triangles within an open mesh or a concave solid are drawn in their index order. Only the scenes
with a blended material plan this pass (plan.py) or compile its variant (ALPHA_BLEND).
"""

from __future__ import annotations

import dataclasses

import moderngl
import numpy as np

from ..geometry import ObjectGeometry
from ..gpu.batches import is_closed
from ..gpu.gl_state import raster_state
from ..gpu.meshes import GpuMeshes
from ..gpu.scene_blocks import DrawnMaterials
from ..gpu.shaders import ProgramCache
from ..methods.atlas import BACK_FACES, FRONT_FACES
from ..node import Frame, GraphFacts, Node, Pass
from ..scene.model import Scene, single_sided
from .diffuse import DiffusePass

#: Blending over the frame, as glTF's BLEND says (the colour is not premultiplied by alpha).
OVER_BACK_FACES = dataclasses.replace(BACK_FACES, blend=True)
OVER_FRONT_FACES = dataclasses.replace(FRONT_FACES, blend=True)
OVER_BOTH_FACES = dataclasses.replace(FRONT_FACES, cull=None, blend=True)


def back_to_front(items: list[ObjectGeometry], eye: np.ndarray) -> list[ObjectGeometry]:
    """`items` in the order the pass draws them: the farthest bounding-sphere centre from `eye`
    first (ties in the scene's order, so that a frame is the same every time)."""
    distances = [float(np.linalg.norm(item.bounding_sphere[0] - eye)) for item in items]
    return [items[k] for k in sorted(range(len(items)), key=lambda k: (-distances[k], items[k].index))]


class TransparentPass:
    """The blended objects drawn over the frame (the diffuse program's ALPHA_BLEND variant)."""

    def __init__(self, programs: ProgramCache, scene: Scene, meshes: GpuMeshes, materials: DrawnMaterials) -> None:
        self.ctx = programs.ctx
        self.diffuse = DiffusePass(programs, scene, meshes, materials, write_depth_image=False, transparent=True)

    def draw(self, items: list[ObjectGeometry], framebuffer: moderngl.Framebuffer, view_projection: np.ndarray,
             eye: np.ndarray) -> int:
        """Draw `items` over `framebuffer`'s colour, seen from `eye`; returns the draw calls."""
        calls = 0
        framebuffer.depth_mask = False
        try:
            for item in back_to_front(items, eye):
                # (A single-sided material has no back faces: DiffusePass culls them under OVER_BOTH_FACES.)
                closed = is_closed(item) and not single_sided(item.object.material)
                states = (OVER_BACK_FACES, OVER_FRONT_FACES) if closed else (OVER_BOTH_FACES,)
                for state in states:
                    with raster_state(self.ctx, state):
                        calls += self.diffuse.draw([item], view_projection)
        finally:
            framebuffer.depth_mask = True
        return calls

    def release(self) -> None:
        self.diffuse.release()


class TransparentNode(Node):
    """The graph's transparent node: the blended objects over the frame, last of the eye's passes."""

    stage = Pass.TRANSPARENT
    when = "every frame"

    @staticmethod
    def reads(facts: GraphFacts) -> tuple[str, ...]:
        return ("frame colour", "frame depth", *facts.made("shadow maps"))

    @staticmethod
    def writes(facts: GraphFacts) -> tuple[str, ...]:
        return ("frame colour",)

    def run(self, frame: Frame) -> bool:
        graph = self.graph
        if graph.transparent is None or not graph.world.blended_objects:
            return False
        framebuffer = frame.targets.color_framebuffer
        framebuffer.use()
        graph.stats.draw_calls += graph.transparent.draw(graph.world.blended_objects, framebuffer,
                                                         frame.camera.view_projection, np.asarray(frame.camera.C))
        return True
