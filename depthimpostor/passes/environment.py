"""The camera view's background: the environment seen along each pixel's ray; and, for an
equirect environment, its image, which every program that reads the environment samples."""

from __future__ import annotations

import moderngl
import numpy as np

from ..gpu.bindings import TextureUnit
from ..gpu.gl_state import NO_DEPTH_TEST, raster_state
from ..ppc import PPC
from ..scene.model import Environment, Scene
from ..gpu.shaders import ProgramCache
from ..gpu.uniforms import environment_defines, write
from ..node import Frame, GraphFacts, Node, Pass

ENVIRONMENT_PROGRAM = ("fullscreen.vert", "environment.frag")


def environment_map_bytes(environment: Environment) -> int:
    """GPU memory of an equirect environment's texture (RGB32F, no mipmaps); 0 for the others."""
    return 0 if environment.image is None else int(environment.image.shape[0] * environment.image.shape[1] * 12)


class EnvironmentPass:
    def __init__(self, ctx: moderngl.Context, programs: ProgramCache, scene: Scene) -> None:
        self.ctx = ctx
        # The sky's colours and map settings: the cache writes them.
        self.program = programs.get(*ENVIRONMENT_PROGRAM, environment_defines(scene))
        self.vertex_array = ctx.vertex_array(self.program, [])
        image = scene.environment.image
        self.map: moderngl.Texture | None = None
        if image is not None:
            # 32-bit float: the truth reads these very values (lib/environment.glsl filters them itself).
            self.map = ctx.texture((image.shape[1], image.shape[0]), 3, np.ascontiguousarray(image, np.float32).tobytes(),
                                   dtype="f4")
            self.map.filter = (moderngl.NEAREST, moderngl.NEAREST)

    def use(self) -> None:
        """Bind the map where every program that reads the environment looks for it."""
        if self.map is not None:
            self.map.use(TextureUnit.ENVIRONMENT_MAP)

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
