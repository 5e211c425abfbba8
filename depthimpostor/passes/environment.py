"""The camera view's background: the environment seen along each pixel's ray; and, for an
equirect environment, its image, which every program that reads the environment samples, and,
where it lights metallic-roughness surfaces (ibl.py), its prefiltered specular levels below it,
made once per sky by the graph's first node."""

from __future__ import annotations

import moderngl
import numpy as np

from ..constants import IBL_LEVELS
from ..gpu.bindings import TextureUnit
from ..gpu.context import bind_default_framebuffer
from ..gpu.gl_state import NO_DEPTH_TEST, raster_state
from ..ibl import level_row, level_size, map_bytes, map_size, uses_environment_lighting
from ..ppc import PPC
from ..scene.model import Environment, Scene
from ..gpu.shaders import ProgramCache
from ..gpu.uniforms import environment_defines, write
from ..node import Frame, GraphFacts, Node, Pass

ENVIRONMENT_PROGRAM = ("fullscreen.vert", "environment.frag")
PREFILTER_PROGRAM = ("fullscreen.vert", "env_prefilter.frag")


def environment_map_bytes(scene: Scene) -> int:
    """GPU memory of an equirect environment's texture (RGB32F, no mipmaps; RGBA32F with its
    prefiltered levels below it where it lights the scene's materials); 0 for the others."""
    environment: Environment = scene.environment
    if environment.image is None:
        return 0
    if uses_environment_lighting(scene):
        return map_bytes(environment.image)
    return int(environment.image.shape[0] * environment.image.shape[1] * 12)


class EnvironmentPass:
    def __init__(self, ctx: moderngl.Context, programs: ProgramCache, scene: Scene) -> None:
        self.ctx = ctx
        # The sky's colours and map settings: the cache writes them.
        self.program = programs.get(*ENVIRONMENT_PROGRAM, environment_defines(scene))
        self.vertex_array = ctx.vertex_array(self.program, [])
        image = scene.environment.image
        self.image = image
        self.map: moderngl.Texture | None = None
        # Where the sky lights metallic-roughness surfaces: its prefilter's program, and whether it ran.
        self.prefilter_program: moderngl.Program | None = None
        self.prefiltered = False
        self._read_back: np.ndarray | None = None
        if image is not None and uses_environment_lighting(scene):
            # RGBA: the prefilter draws its levels into the rows below the image, and a
            # three-component float texture is not one GL must be able to draw into.
            self.map = ctx.texture(map_size(image), 4, dtype="f4")
            rgba = np.concatenate([image, np.ones((*image.shape[:2], 1), np.float32)], axis=2)
            self.map.write(np.ascontiguousarray(rgba, np.float32).tobytes(), viewport=(0, 0, image.shape[1], image.shape[0]))
            self.map.filter = (moderngl.NEAREST, moderngl.NEAREST)
            self.prefilter_program = programs.get(*PREFILTER_PROGRAM, None)
            write(self.prefilter_program, "u_source", TextureUnit.ENVIRONMENT_SOURCE)
        elif image is not None:
            # 32-bit float: the truth reads these very values (lib/environment.glsl filters them itself).
            self.map = ctx.texture((image.shape[1], image.shape[0]), 3, np.ascontiguousarray(image, np.float32).tobytes(),
                                   dtype="f4")
            self.map.filter = (moderngl.NEAREST, moderngl.NEAREST)

    def use(self) -> None:
        """Bind the map where every program that reads the environment looks for it."""
        if self.map is not None:
            self.map.use(TextureUnit.ENVIRONMENT_MAP)

    def serves(self, scene: Scene) -> bool:
        """Is it what `scene` would make (the same sky image, lighting its materials or not alike)?
        The sky's colours, intensity and rotation are the Lights block's, not its own."""
        return (scene.environment.image is self.image
                and (self.prefilter_program is not None) == (self.image is not None and uses_environment_lighting(scene)))

    def prefilter(self) -> int:
        """Draw the sky's prefiltered specular levels into its texture, below its image (once per
        sky: the ENVIRONMENT_LIGHTING node runs it at the first frame); the draw calls made. The
        image is read from a mipmapped copy of it (trilinear, wrapping across), let go at the end."""
        program, image, target = self.prefilter_program, self.image, self.map
        if program is None or image is None or target is None:
            return 0
        source = self.ctx.texture((image.shape[1], image.shape[0]), 3,
                                  np.ascontiguousarray(image, np.float32).tobytes(), dtype="f4")
        framebuffer = self.ctx.framebuffer(color_attachments=[target])
        vertex_array = self.ctx.vertex_array(program, [])
        try:
            source.build_mipmaps()
            source.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
            source.repeat_x, source.repeat_y = True, False  # longitude wraps; the poles clamp
            source.use(TextureUnit.ENVIRONMENT_SOURCE)
            framebuffer.use()
            with raster_state(self.ctx, NO_DEPTH_TEST):
                for level in range(1, IBL_LEVELS + 1):
                    width, height = level_size(level)
                    origin = (0, level_row(level, image.shape[0]))
                    framebuffer.viewport = (*origin, width, height)
                    write(program, "u_level", level)
                    write(program, "u_origin", origin)
                    vertex_array.render(moderngl.TRIANGLES, vertices=3)
        finally:
            bind_default_framebuffer(self.ctx)  # before the prefilter's own framebuffer is let go
            vertex_array.release()
            framebuffer.release()
            source.release()
        self.prefiltered = True
        self._read_back = None
        return IBL_LEVELS

    def read_back(self) -> np.ndarray | None:
        """The sky's texture as the shaders read it, (rows, columns, 3) float32 (its image, and its
        prefiltered levels below it), read once (the prefilter run first where it has not): what
        the truth samples (oracles/ibl.py); None where the sky lights no material."""
        if self.prefilter_program is None or self.map is None:
            return None
        if not self.prefiltered:
            self.prefilter()
        if self._read_back is None:
            width, height = self.map.size
            texels = np.frombuffer(self.map.read(), np.float32).reshape(height, width, 4)
            self._read_back = np.ascontiguousarray(texels[..., :3])
        return self._read_back

    def draw(self, camera: PPC) -> None:
        write(self.program, "u_camera_a", tuple(camera.a))
        write(self.program, "u_camera_b", tuple(camera.b))
        write(self.program, "u_camera_c", tuple(camera.c))
        with raster_state(self.ctx, NO_DEPTH_TEST):
            self.vertex_array.render(moderngl.TRIANGLES, vertices=3)

    def release(self) -> None:
        self.vertex_array.release()
        if self.map is not None:
            self.map.release()


class EnvironmentNode(Node):
    """The graph's environment node: the sky behind everything, first of the eye's passes."""

    stage = Pass.ENVIRONMENT
    when = "every frame"

    @staticmethod
    def reads(facts: GraphFacts) -> tuple[str, ...]:
        return ("frame colour",)

    @staticmethod
    def writes(facts: GraphFacts) -> tuple[str, ...]:
        return ("frame colour",)

    def run(self, frame: Frame) -> bool:
        self.graph.environment.draw(frame.camera)
        return True


class EnvironmentLightingNode(Node):
    """The graph's prefilter node: an equirect sky's prefiltered specular levels, made at the first
    frame and kept (the sky's intensity and rotation are applied where they are read, so that no
    change of them makes it again); a new sky is a new scene, and a new graph."""

    stage = Pass.ENVIRONMENT_LIGHTING
    when = "once per sky"
    bakes = True

    @staticmethod
    def writes(facts: GraphFacts) -> tuple[str, ...]:
        return ("environment lighting",)

    def stale(self) -> bool:
        return not self.graph.environment.prefiltered

    def run(self, frame: Frame) -> bool:
        self.graph.stats.draw_calls += self.graph.environment.prefilter()
        return True
