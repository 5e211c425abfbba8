"""The render graph's node for deforming glTF parts (skins, morph targets), and what the plan says
of it: at each time that moves them, their meshes are made again in the mesh arena, on the GPU
(gpu/deform.py's deform.comp) where it can, else deformed on the CPU and uploaded; the triangle
methods then refit their trees over them (methods/gpu_refit.py, in the stand-in node's `follow`).
Nothing of it runs per frame: a still frame, or another frame at the same time, pays nothing."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ..gpu.deform import DEFORM_PROGRAM, deform_defines, part_rows
from ..methods.gpu_refit import REFIT_PROGRAM, refit_defines
from ..node import Frame, GraphFacts, Node, Pass
from ..scene.gltf_deform import PartMotion

if TYPE_CHECKING:
    from ..scene.model import Scene
    from ..world import World


class DeformNode(Node):
    stage = Pass.DEFORM
    when = "at each time that moves a deforming glTF part (set_time), before the stand-in's refit; not per frame"
    bakes = True

    @staticmethod
    def writes(facts: GraphFacts) -> tuple[str, ...]:
        return ("deformed meshes",)

    def stale(self) -> bool:
        return False  # its work is done as the world moves (`follow`), not in a frame

    def run(self, frame: Frame) -> bool:
        return False

    def follow(self, earlier: World, world: World) -> None:
        """What deforms has another mesh: deformed on the GPU over the one it replaces, or (what
        deform.comp cannot make) uploaded over it."""
        graph = self.graph
        graph.meshes.replace(graph.deform.follow(graph.meshes, [
            (before.local_mesh, now) for before, now in zip(earlier.geometry, world.geometry, strict=True)
            if now.local_mesh is not before.local_mesh]))


def deforming_parts(scene: Scene) -> list[PartMotion]:
    """The scene's glTF parts that deform as its animation plays (their motions, each once): a
    skin or morph targets that no animation moves stay as loaded, and need no pass."""
    return list(dict.fromkeys(obj.motion for obj in scene.objects
                              if obj.deforms and obj.moves and isinstance(obj.motion, PartMotion)))


def pose_rows(motion: PartMotion) -> int:
    """vec4 rows of the part's pose (gpu/deform.pose_texels): 4 a joint, then its weights by fours."""
    joints = len(motion.skin.joints) if motion.skin is not None else 0
    targets = len(motion.default_weights) if motion.default_weights is not None else 0
    return 4 * joints + math.ceil(targets / 4)


def deform_plan(scene: Scene, traces: bool) -> tuple[str, list[tuple[tuple[str, ...], dict[str, str], str]]]:
    """The deform pass's reason (its cost included) and its programs ((stages, defines, why)), for
    a scene with deforming parts; `traces`: the method traces a BVH (refitted over them)."""
    parts = deforming_parts(scene)
    on_gpu = [m for m in parts if m.gpu_refusal is None]
    uploaded = sum(16 * part_rows(m) for m in on_gpu)
    posed = sum(16 * pose_rows(m) for m in on_gpu)
    reason = (f"{len(parts)} deforming glTF part{'s' * (len(parts) != 1)} (skins, morph targets), made again at each "
              f"time that moves them: {len(on_gpu)} skinned and morphed into the mesh buffer by {DEFORM_PROGRAM} "
              f"({uploaded / 2**20:.2f} MiB of rest poses, influences and morph deltas uploaded once; "
              f"{posed / 2**10:.1f} KiB of joint matrices and weights a time)")
    refused = [m for m in parts if m.gpu_refusal is not None]
    if refused:
        reason += f", {len(refused)} deformed on the CPU and uploaded ({refused[0].gpu_refusal})"
    if traces:
        reason += (f"; the BVH's trees over them refitted by {REFIT_PROGRAM} (the triangles, the leaves, then a "
                   "dispatch a level; only the roots' boxes read back for the top level)")
    reason += ("; on a GL without compute shaders (4.3), all on the CPU (the world deforms every part on the CPU "
               "too, for its bounds and the truth)")
    programs: list[tuple[tuple[str, ...], dict[str, str], str]] = [((DEFORM_PROGRAM,), deform_defines(rows), "deforming parts: skins and morph targets at a time"
                 + (" (POSE_IN_STORAGE: past the uniform block's rows)" if "POSE_IN_STORAGE" in deform_defines(rows)
                    else "")) for rows in sorted({pose_rows(m) for m in on_gpu})]
    if traces:
        programs.append(((REFIT_PROGRAM,), refit_defines(), "the BVH refitted over the deformed triangles"))
    return reason, programs
