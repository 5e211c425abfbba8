"""The hybrid method: depth images first, and the real triangles for the rays they cannot answer.

Every reflected ray is marched through the mirror's depth images as the depth method marches it,
and the march records where its answer starts to rest on what the images do not hold (a side of
an object hidden from the mirror's centre, space behind an object, a silhouette passed too close:
shaders/lib/depth_image.glsl, "What the image does not hold"). A ray whose answer rests on nothing
unseen keeps it; the others, and only they, are traced through the ray-traced method's BVH of the
real triangles, in the same pass (docs/methods_and_results.md, "`--method hybrid`", says why not in a second one).
"""

from __future__ import annotations

import moderngl

from ..gpu.bindings import TextureUnit
from ..geometry import ObjectGeometry
from ..scene.model import Scene
from ..gpu.scene_blocks import DrawnMaterials
from ..gpu.shaders import ProgramCache
from .baked_images import ImagePlan
from .impostors import ImpostorPass
from ..gpu.meshes import GpuMeshes
from .triangles import TrianglePass
from ..gpu.uniforms import bind_texture

#: The atlas's triangle ids, after the BVH's textures (methods/triangles.py).


class HybridPass(ImpostorPass):
    """The depth method's images (and pyramids, with the hierarchical algorithm), each sample
    naming the triangle it shows, beside the ray-traced method's BVH of the same objects."""

    keeps_triangle_ids = True
    keeps_beyond = True
    lists_over_bounds = True
    traces_pending = True  # a ray entering an image not baked yet is traced (Unseen.PENDING)

    def __init__(self, ctx: moderngl.Context, programs: ProgramCache, scene: Scene, meshes: GpuMeshes,
                 materials: DrawnMaterials, mirrors: list[ObjectGeometry], reflected: list[ObjectGeometry],
                 image_plans: dict[int, list[ImagePlan]] | None = None) -> None:
        super().__init__(ctx, programs, scene, meshes, materials, mirrors, reflected, image_plans)
        try:
            self.triangles = TrianglePass(ctx, scene, reflected, places=True)
        except BaseException:
            super().release()
            raise

    @property
    def bytes(self) -> int:
        return super().bytes + self.triangles.bytes

    def describe(self) -> str:
        return f"{super().describe()}, and {self.triangles.describe()} for the rays they cannot answer"

    def move(self, geometry: dict[int, ObjectGeometry], moved: set[int], stale_targets: set[int]) -> None:
        """Images as the depth method moves them; the BVH's instances as the ray-traced method moves them."""
        super().move(geometry, moved, stale_targets)
        self.triangles.move(geometry)

    def bind(self, program: moderngl.Program) -> None:
        super().bind(program)
        self.triangles.bind(program)
        if self.atlas.triangles is not None:
            bind_texture(program, "u_impostor_triangles", self.atlas.triangles, TextureUnit.TRIANGLE_IDS)

    def release(self) -> None:
        self.triangles.release()
        super().release()
