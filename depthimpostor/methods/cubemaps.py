"""The cube-map methods: per mirror, six 90-degree images from its centre showing every reflected
object, looked up by the reflected ray's direction (lib/cube_map.glsl).

The faces are depth images in all but their frusta, so they are baked into the same atlas with
the same shader; their second layer holds the id of the object each texel shows. The same cube
map serves both lookups: by direction alone (`cubemap`, the lecture's environment mapping, which
takes everything as infinitely far away) and corrected against a proxy box (`cubemap-parallax`,
what engines ship). The box is the mirror's bounds and those of everything it reflects, so that
every reflected ray starts inside it, as the correction assumes.
"""

from __future__ import annotations

import math
from functools import cached_property

import moderngl
import numpy as np

from ..errors import SceneError
from ..geometry import ObjectGeometry, bounding_spheres, world_vertex_groups
from ..ppc import PPC
from ..scene.model import Scene
from ..resolution import MIN_AUTO_RESOLUTION
from .atlas import DepthImage, mirror_centre
from ..culling import Reach, ReachTable, reaches
from .baked_images import BakedImages, ImagePlan, SecondLayer, per_object_plan
from ..gpu.uniforms import write

#: The faces in the order lib/cube_map.glsl's cube_face() numbers them: +x, -x, +y, -y, +z, -z,
#: each with an up vector not parallel to it. The lookup projects through each face's own
#: camera, so no texture-coordinate convention has to be matched.
CUBE_FACES: tuple[tuple[tuple[float, float, float], tuple[float, float, float]], ...] = (
    ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
    ((-1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
    ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
    ((0.0, -1.0, 0.0), (0.0, 0.0, 1.0)),
    ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0)),
    ((0.0, 0.0, -1.0), (0.0, 1.0, 0.0)),
)


def cube_cameras(scene: Scene, mirror: ObjectGeometry, reflected: list[ObjectGeometry], resolution: int) -> list[PPC]:
    """The six face cameras at the mirror's centre, their near and far planes around the
    reflected objects' bounding spheres.

    A point at distance d from the centre lies, in the face that holds it, at depth >= d / sqrt(3)
    along that face's axis (the corner direction is the worst): the near plane goes just inside
    that for the nearest object, and the far plane just beyond the farthest.
    """
    centre = mirror_centre(mirror)
    spheres = [item.bounding_sphere for item in reflected]
    nearest = min(float(np.linalg.norm(c - centre)) - r for c, r in spheres)
    farthest = max(float(np.linalg.norm(c - centre)) + r for c, r in spheres)
    if nearest <= 0.0:
        inside = min(reflected, key=lambda item: float(np.linalg.norm(item.bounding_sphere[0] - centre)) - item.bounding_sphere[1])
        raise SceneError(
            scene.source, scene.object_label(inside.index),
            f'object "{inside.object.name}" reaches the centre of mirror "{mirror.object.name}": a cube map '
            "taken from there would cut through it; move it away or use another method",
        )
    near, far = 0.99 * nearest / math.sqrt(3.0), 1.01 * farthest
    return [
        PPC.look_at(centre, centre + np.array(axis), up, 90.0, resolution, resolution, near, far)
        for axis, up in CUBE_FACES
    ]


def proxy_box(mirror: ObjectGeometry, reflected: list[ObjectGeometry]) -> tuple[np.ndarray, np.ndarray]:
    """The parallax correction's box: world bounds of the mirror and of what it reflects (their
    world vertices placed a mesh's objects at a time, without making each world mesh: a thousand
    objects' took seconds of the first frame)."""
    corners = [[vertices[..., axis].min() for axis in range(3)] + [vertices[..., axis].max() for axis in range(3)]
               for _, vertices in world_vertex_groups([mirror, *reflected])]
    bounds = np.array(corners, np.float32)
    return bounds[:, :3].min(axis=0), bounds[:, 3:].max(axis=0)


class CubeMapPass(BakedImages):
    """Six faces per mirror, each showing every reflected object, and the proxy boxes."""

    second_layer = SecondLayer.OBJECT_ID
    image_noun = "cube-map face"
    per_object = False

    @classmethod
    def plan_images(
        cls, scene: Scene, mirrors: list[ObjectGeometry], reflected: list[ObjectGeometry], reach: ReachTable = reaches
    ) -> dict[int, list[ImagePlan]]:
        """Six faces per mirror showing what it may reflect; "auto" gives the faces the largest
        resolution its objects' depth images would get (per_object_plan), a number of pixels needs
        no depth image fitted (at 1,000 objects those fits were a third of the start-up's plan)."""
        plan: dict[int, list[ImagePlan]] = {}
        if scene.render.auto_resolution:
            images_of = list(per_object_plan(scene, mirrors, reflected, reach).values())
            shown_by = [[image.targets[0] for image in images] for images in images_of]
            resolutions = [max((image.camera.width for image in images), default=MIN_AUTO_RESOLUTION)
                           for images in images_of]
        else:  # what per_object_plan shows: the objects `reach` finds reachable, in their order
            bounding_spheres([*mirrors, *reflected])  # objects of one mesh together: the face cameras read them
            shown_by = [[target for target, why in zip(reflected, row, strict=True) if why is Reach.REACHABLE]
                        for row in reach(mirrors, reflected)]
            resolutions = [int(scene.render.impostor_resolution)] * len(mirrors)
        for mirror, shown, resolution in zip(mirrors, shown_by, resolutions, strict=True):
            if not shown:  # it reflects nothing but the planes and the environment
                plan[mirror.index] = []
                continue
            plan[mirror.index] = [ImagePlan(tuple(shown), camera)
                                  for camera in cube_cameras(scene, mirror, shown, resolution)]
        return plan

    def refit(self, image: DepthImage, mirror: ObjectGeometry, targets: tuple[ObjectGeometry, ...]) -> PPC:
        face = self.images_by_reflector[mirror.index].index(image)
        return cube_cameras(self.scene, mirror, list(targets), image.camera.width)[face]

    def _forget_fits(self) -> None:
        self.__dict__.pop("proxies", None)  # the cached property below

    @cached_property
    def proxies(self) -> dict[int, tuple[np.ndarray, np.ndarray]]:
        """Per mirror, the parallax correction's box around it and what its faces show."""
        return {index: proxy_box(images[0].mirror, list(images[0].targets))
                for index, images in self.images_by_reflector.items() if images}

    def bind_reflector(self, program: moderngl.Program, mirror: ObjectGeometry) -> None:
        super().bind_reflector(program, mirror)
        lower, upper = self.proxies.get(mirror.index, proxy_box(mirror, []))
        write(program, "u_proxy_lower", tuple(lower))
        write(program, "u_proxy_upper", tuple(upper))
