"""Every `--method`, in one table: what stands in for the reflected objects, what the mirror shader
includes for it, and what it can and cannot do. The plan, the renderer, the benchmark, the viewer
and the scene's limits read a method's facts here instead of branching on its name.

Adding a method: its stand-in (a `BakedImages` subclass when it bakes images from the reflector's
centre, a `TrianglePass` subclass when it traces triangles, or a `SeenFromEye` subclass when it is
made in the frame from the eye) in a module of this package, a value
of `constants.Method` (the GLSL sees it as METHOD_<NAME>), its chunk under shaders/lib/ defining
`nearest_object_hit` for `#if METHOD == METHOD_<NAME>` in lib/reflected_scene.glsl, and a row below
(tests/test_methods.py checks that every row's chunks are the ones that branch includes).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..constants import MAX_NAMED_TRIANGLES, Algorithm, Method
from .baked_images import BakedImages
from .billboards import BillboardPass
from .cubemaps import CubeMapPass
from .hybrid import HybridPass
from .impostors import ImpostorPass
from .planar import PlanarPass
from .screen_space import ScreenSpacePass
from .seen_from_eye import SeenFromEye
from .simplified import SimplifiedPass
from .triangles import TrianglePass


@dataclass(frozen=True)
class MethodSpec:
    method: Method
    #: What it makes for the reflectors to read. Two methods with the same stand-in share it: a
    #: switch between them keeps it (the cube-map lookups) and changes the mirror variant alone.
    stand_in: type[BakedImages | TrianglePass | SeenFromEye]
    label: str  # what the viewer calls it
    glsl: tuple[str, ...]  # the chunks lib/reflected_scene.glsl includes for it, under shaders/lib/
    #: Does it march depth images, and so take an `--algorithm`?
    marches_depth_images: bool = False
    #: Can it show mirrors and glass in one another (render.max_bounces > 1)? The bounce images are
    #: depth images, marched by the mirror shader: the depth method's alone.
    bounces: bool = False
    #: At most this many reflected triangles (the hybrid method names each in a texture row).
    triangle_limit: int | None = None
    #: The triangles it traces through a BVH, when it does (TrianglePass or a subclass: which
    #: meshes, and so how much memory, is its `traced_meshes`).
    traces: type[TrianglePass] | None = None
    #: Does it need every reflector to be a flat mirror (planar reflections)? The plan refuses
    #: another by name; `bench` and `compare --method all` leave it out of such scenes.
    flat_mirrors: bool = False

    @property
    def bakes_images(self) -> bool:
        """Does it bake images (and so take an impostor resolution)?"""
        return issubclass(self.stand_in, BakedImages)

    def defines(self, algorithm: Algorithm) -> dict[str, int]:
        """Its mirror-shader variant: the method, and the algorithm where it marches depth images
        (the others have none, so that no two identical programs are compiled)."""
        return {"METHOD": int(self.method), **({"ALGORITHM": int(algorithm)} if self.marches_depth_images else {})}

    @property
    def seen_from_eye(self) -> type[SeenFromEye] | None:
        """Its stand-in, when it is made in the frame from the eye (planar, SSR: graph.py's eye-images node)."""
        return self.stand_in if issubclass(self.stand_in, SeenFromEye) else None

    @property
    def names_triangles(self) -> bool:
        """Do its depth images name the triangle each sample shows (the hybrid's exact surfaces)?"""
        return self.bakes_images and self.traces is not None

    @property
    def outputs(self) -> tuple[str, ...]:
        """What its stand-in node writes for the reflectors to read (graph.py's resource names)."""
        return ("baked images",) * self.bakes_images + ("BVH",) * (self.traces is not None) + (
            self.stand_in.writes if issubclass(self.stand_in, SeenFromEye) else ())

    @property
    def option(self) -> str:
        return self.method.option


METHODS: dict[Method, MethodSpec] = {spec.method: spec for spec in (
    MethodSpec(Method.DEPTH, ImpostorPass, "depth-image impostors", ("depth_image.glsl",),
               marches_depth_images=True, bounces=True),
    MethodSpec(Method.CUBEMAP, CubeMapPass, "cube map (direction alone)", ("cube_map.glsl",)),
    MethodSpec(Method.CUBEMAP_PARALLAX, CubeMapPass, "cube map, parallax-corrected", ("cube_map.glsl",)),
    MethodSpec(Method.BILLBOARD, BillboardPass, "billboards", ("billboard.glsl",)),
    MethodSpec(Method.SIMPLIFIED, SimplifiedPass, "simplified triangles", ("triangles.glsl",), traces=SimplifiedPass),
    MethodSpec(Method.RAYTRACE, TrianglePass, "ray-traced triangles", ("triangles.glsl",), traces=TrianglePass),
    MethodSpec(Method.HYBRID, HybridPass, "depth images, uncertain rays ray-traced",
               ("depth_image.glsl", "triangles.glsl"), marches_depth_images=True,
               triangle_limit=MAX_NAMED_TRIANGLES, traces=TrianglePass),
    MethodSpec(Method.PLANAR, PlanarPass, "planar reflections (flat mirrors)", ("planar.glsl",), flat_mirrors=True),
    MethodSpec(Method.SSR, ScreenSpacePass, "screen-space reflections", ("screen_space.glsl",)),
)}

