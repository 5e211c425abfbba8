"""Baking depth images: every reflected object, seen from the centre of every mirror.

Each (mirror, object) pair gets a depth image whose frustum is fitted to that object alone, so
that all of the image's pixels and all of its depth precision go to it. All depth images live in
one atlas pair (RGBA8 colour; RG32F OpenGL depths of the visible surface and of the nearest back
face behind it), one tile each; each mirror gets a uniform buffer listing its own depth images,
which is all the mirror shader needs.

The back layer costs a second, depth-only draw per image. Without it the depth image knows the
surface but not what lies behind it, and a ray passing behind a silhouette must either be joined
to it by a false "rubber sheet" or fall through the object's hidden side (a hole): see
docs/numerical_robustness.md.

The atlas and the records are in methods/atlas.py; what the cube-map and billboard methods share
with this one (planning, the per-mirror uniform buffers, the bake loop) in methods/baked_images.py.
"""

from __future__ import annotations


import moderngl

from ..geometry import ObjectGeometry
from ..culling import ReachTable, reachable_targets, reaches
from ..resolution import scene_view
from ..scene.model import Scene
from ..gpu.scene_blocks import DrawnMaterials
from ..gpu.shaders import ProgramCache
from ..gpu.meshes import GpuMeshes
from .pyramid import DepthPyramid



from .bounces import BounceBaker
from .baked_images import BakedImages, ImagePlan, SecondLayer, image_camera, largest_side, per_object_plan


class ImpostorPass(BakedImages):
    """The depth-image method: one depth image per mirror and reflected object, with a frustum
    fitted to that object alone, and the back-face layer; with the hierarchical algorithm, the
    min/max depth pyramid of every image too, built after each bake."""

    second_layer = SecondLayer.BACK_FACE
    keeps_back_colors = True
    image_noun = "depth image"

    pyramid: DepthPyramid | None = None
    bounces: BounceBaker | None = None

    def __init__(self, ctx: moderngl.Context, programs: ProgramCache, scene: Scene, meshes: GpuMeshes,
                 materials: DrawnMaterials, mirrors: list[ObjectGeometry], reflected: list[ObjectGeometry],
                 image_plans: dict[int, list[ImagePlan]] | None = None) -> None:
        super().__init__(ctx, programs, scene, meshes, materials, mirrors, reflected, image_plans)
        if self.final_level > 1 and len(mirrors) > 1:
            from .bounces import BounceBaker  # bounces.py builds on this module's classes

            self.bounces = BounceBaker(self, scene)

    @classmethod
    def plan_images(
        cls, scene: Scene, mirrors: list[ObjectGeometry], reflected: list[ObjectGeometry], reach: ReachTable = reaches
    ) -> dict[int, list[ImagePlan]]:
        """Per mirror, one depth image per reflected object it may show and, for each bounce k
        from 2 to render.max_bounces, one of every other mirror it may show, showing its bounce
        k - 1 reflections."""
        plan = per_object_plan(scene, mirrors, reflected, reach, cls.texel_bytes())
        if scene.render.max_bounces == 1:
            return plan
        view = scene_view(scene)
        largest = largest_side(scene, len(mirrors), sum(len(images) for images in plan.values()), cls.texel_bytes())
        for mirror in mirrors:
            others = reachable_targets(mirror, [other for other in mirrors if other is not mirror], reach)
            cameras = [image_camera(scene, view, mirror, other, largest) for other in others]
            plan[mirror.index] += [
                ImagePlan((other,), camera, level)
                for level in range(2, scene.render.max_bounces + 1) for other, camera in zip(others, cameras, strict=False)
            ]
        return plan

    def use_pyramid(self, wanted: bool) -> None:
        """Keep a depth pyramid (the hierarchical algorithm's) or free it. A new one is built at
        once from the images already baked (the images themselves are not baked again)."""
        if wanted and self.pyramid is None:
            self.pyramid = DepthPyramid(self.ctx, self.programs, self.atlas.pyramid_layout, self.tiles_by_place())
            if self.bakes:
                self.pyramid.build(self.atlas.depth_layers())
        elif not wanted and self.pyramid is not None:
            self.pyramid.release()
            self.pyramid = None

    @property
    def bytes(self) -> int:
        return super().bytes + (self.pyramid.bytes if self.pyramid is not None else 0)

    def describe(self) -> str:
        return super().describe() + (" with depth pyramids" if self.pyramid is not None else "")

    def bake_bounces(self) -> int:
        """The stale images of reflectors in reflectors (the render graph's bounce node: after
        `bake`, which bakes the others); returns the draw calls."""
        return self.bounces.bake() if self.bounces is not None else 0

    def build_pyramids(self) -> None:
        """The min/max pyramids of every image, from the atlas as baked (the graph's pyramid node)."""
        if self.pyramid is not None:
            self.pyramid.build(self.atlas.depth_layers())

    def bind(self, program: moderngl.Program) -> None:
        super().bind(program)
        if self.pyramid is not None:
            self.pyramid.bind(program)

    def release(self) -> None:
        self.use_pyramid(False)
        if self.bounces is not None:
            self.bounces.release()
        super().release()


