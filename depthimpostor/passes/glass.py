"""Glass: the interior image a refracted ray is followed through to where it leaves.

A glass pixel refracts its view ray into the object (lib/glass.glsl); the ray leaves where it
next crosses the object's surface. As in Wyman's image-space refraction, that surface is taken
from an image of the glass alone seen from the viewpoint that sees it (the camera; a mirror's
centre when a bounce is baked), but the exit is then found exactly as reflected rays find their
hits, by the depth-image march: the interior image is a depth image with two layers, the front
faces and the nearest back faces, each sample holding its outward normal and window depth.
Along each line of sight the glass lies between the two, so a ray inside it leaves at the first
step where it is in front of the one or behind the other.

The image is made again for every glass object at every frame (two draws of that object alone,
like a depth pre-pass): it depends on the viewpoint, which the reflected objects' depth images
do not. Its size follows the glass's size on screen, so that a sample covers about one pixel.
What the glass does not show: objects inside it (the interior image holds the glass alone), a
second passage through a concave glass, and light reflected back at the exit when the ray can
leave (its Fresnel share there is not followed; the truth follows the same rules).
"""

from __future__ import annotations

import math

import moderngl
import numpy as np

from ..gpu.gl_state import raster_state
from ..gpu.bindings import TextureUnit, UniformBlock
from ..constants import BACKGROUND_DEPTH, DEPTH_IMAGE_DTYPE
from ..eye import eye_depth
from ..geometry import ObjectGeometry
from ..ppc import PPC, FrustumFitError
from ..gpu.shaders import ProgramCache
from ..methods.atlas import BACK_FACES, FRONT_FACES
from ..gpu.meshes import GpuMeshes
from ..node import Frame, GraphFacts, Node, Pass
from ..gpu.uniforms import bind_texture, bind_uniform_block, write

INTERIOR_PROGRAM = ("mesh.vert", "glass_interior.frag")
#: Past the other passes' units (0 to 5) and uniform-block bindings (0 to 2).
#: The interior image's side at least, in texels (a glass a few pixels wide on screen).
MIN_INTERIOR_RESOLUTION = 16


def interior_camera(eye: np.ndarray, glass: ObjectGeometry, texel_angle: float, largest: int) -> PPC | None:
    """The interior image's camera: from `eye`, the tightest frustum around the glass, with
    texels of about `texel_angle` (the tangent a screen pixel spans) and at most `largest` on a
    side. None when the eye is inside the glass's bounds (no frustum holds it)."""
    centre, _ = glass.bounding_sphere
    positions = glass.world_mesh.positions
    try:
        probe = PPC.fitted(eye, positions, centre, largest, largest)
    except FrustumFitError:
        return None
    # fitted() spans the object with width |a| per texel at focal length |c . forward|.
    span = max(np.linalg.norm(probe.a), np.linalg.norm(probe.b)) * largest / probe.focal
    resolution = int(np.clip(math.ceil(span / max(texel_angle, 1e-12)), MIN_INTERIOR_RESOLUTION, largest))
    return PPC.fitted(eye, positions, centre, resolution, resolution)


def pixel_angle(camera: PPC) -> float:
    """The tangent one pixel of `camera` spans at its image centre."""
    return float(max(np.linalg.norm(camera.a), np.linalg.norm(camera.b)) / camera.focal)


def interior_bytes(size: int) -> int:
    """GPU memory of an interior image `size` texels square: two RGBA32F layers and a depth buffer."""
    return size * size * (16 + 16 + 4)


class GlassInterior:
    """One interior image at a time (up to `size` texels square): baked for a glass object just
    before that object is drawn, then bound for its program."""

    def __init__(self, ctx: moderngl.Context, programs: ProgramCache, meshes: GpuMeshes, size: int) -> None:
        self.ctx = ctx
        self.meshes = meshes
        self.size = size
        self.program = programs.get(*INTERIOR_PROGRAM)
        self.front = ctx.texture((size, size), 4, dtype="f4")
        self.back = ctx.texture((size, size), 4, dtype="f4")
        # Linear for the normals' bilinear mix; the shader reads depths with texelFetch, unfiltered.
        for texture in (self.front, self.back):
            texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self._depth = ctx.depth_renderbuffer((size, size))
        # (framebuffer, the state that keeps its faces): a depth image's projection flips y, so
        # GL's faces are the other way round (see BAKE_CULLS_FRONT_FACES).
        self._layers = [
            (ctx.framebuffer([self.front], self._depth), FRONT_FACES),
            (ctx.framebuffer([self.back], self._depth), BACK_FACES),
        ]
        self._record = ctx.buffer(reserve=DEPTH_IMAGE_DTYPE.itemsize)
        self.camera: PPC | None = None
        self.seen_from: object = None  # what the owner made the last image for (passes/reflectors.py)
        self.bakes = 0  # interior images made (the tests check when they are)

    def bake(self, glass: ObjectGeometry, camera: PPC | None) -> int:
        """The glass's front and back layers from `camera` (None: no interior, see
        interior_camera); returns the draw calls. Leaves some other framebuffer bound."""
        self.camera = camera
        if camera is None:
            return 0
        if max(camera.width, camera.height) > self.size:
            raise ValueError(f"an interior image of {camera.width}x{camera.height} does not fit {self.size}^2")
        viewport = (0, 0, camera.width, camera.height)
        # Baked inside the eye's pass, but a depth image: OpenGL's depth, which the GLASS shader reads.
        with eye_depth(self.ctx, reversed_=False):
            self._draw_layers(glass, camera, viewport)
        self._record.write(camera.depth_image_record(glass.index, (0, 0)).tobytes())
        self.bakes += 1
        return len(self._layers)

    def _draw_layers(self, glass: ObjectGeometry, camera: PPC, viewport: tuple[int, int, int, int]) -> None:
        for framebuffer, kept in self._layers:
            framebuffer.use()
            framebuffer.viewport = viewport
            framebuffer.clear(0.0, 0.0, 0.0, BACKGROUND_DEPTH, depth=BACKGROUND_DEPTH, viewport=viewport)
            with raster_state(self.ctx, kept):
                self.meshes.draw(self.program, glass, camera.view_projection)

    def bind(self, program: moderngl.Program) -> None:
        """Point a GLASS program at the last interior image made."""
        bind_texture(program, "u_glass_front", self.front, TextureUnit.GLASS_FRONT)
        bind_texture(program, "u_glass_back", self.back, TextureUnit.GLASS_BACK)
        bind_uniform_block(program, "GlassInterior", UniformBlock.GLASS_INTERIOR)
        self._record.bind_to_uniform_block(UniformBlock.GLASS_INTERIOR)
        write(program, "u_glass_has_interior", self.camera is not None)

    def read(self) -> tuple[np.ndarray, np.ndarray]:
        """The last image's (front, back) layers: (h, w, 4) float32, texture rows in order."""
        if self.camera is None:
            raise ValueError("no interior image was made")
        height, width = self.camera.height, self.camera.width

        def layer(texture: moderngl.Texture) -> np.ndarray:
            return np.frombuffer(texture.read(), np.float32).reshape(self.size, self.size, 4)[:height, :width].copy()

        return layer(self.front), layer(self.back)

    @property
    def bytes(self) -> int:
        return interior_bytes(self.size) + self._record.size

    def release(self) -> None:
        for framebuffer, _ in self._layers:
            framebuffer.release()
        for item in (self.front, self.back, self._depth, self._record):
            item.release()


class GlassInteriorsNode(Node):
    """The graph's glass-interior node: each glass's interior image, made again where the eye or
    the glass moved (passes/reflectors.py's `make_interiors`)."""

    stage = Pass.GLASS_INTERIORS
    when = "once; a glass's again when the eye or the glass moves"
    mirror_time = True

    @staticmethod
    def writes(facts: GraphFacts) -> tuple[str, ...]:
        return ("glass interiors",)

    def run(self, frame: Frame) -> bool:
        graph = self.graph
        if graph.reflector_pass is None:
            return False
        before = self._made()
        # A glass interior depends on the eye's position and pixel size, not on a sub-pixel
        # jitter: made from the frame's own camera, so that rounding in the jittered one's
        # corner does not make it again for every sample.
        graph.stats.draw_calls += graph.reflector_pass.make_interiors(graph.world.reflectors, frame.unjittered)
        made = self._made() - before
        graph.stats.interiors_made += made
        return made > 0

    def _made(self) -> int:
        return sum(interior.bakes for interior in self.graph.glass_interiors.values())
