"""The camera view's background: the environment seen along each pixel's ray."""

from __future__ import annotations

import moderngl

from ..gl_state import NO_DEPTH_TEST, raster_state
from ..ppc import PPC
from ..scene.model import Scene
from ..shaders import ProgramCache
from .uniforms import write

ENVIRONMENT_PROGRAM = ("fullscreen.vert", "environment.frag")


class EnvironmentPass:
    def __init__(self, ctx: moderngl.Context, programs: ProgramCache, scene: Scene) -> None:
        self.ctx = ctx
        self.program = programs.get(*ENVIRONMENT_PROGRAM)  # the sky's colours: the cache writes them
        self.vertex_array = ctx.vertex_array(self.program, [])

    def draw(self, camera: PPC) -> None:
        write(self.program, "u_camera_a", tuple(camera.a))
        write(self.program, "u_camera_b", tuple(camera.b))
        write(self.program, "u_camera_c", tuple(camera.c))
        with raster_state(self.ctx, NO_DEPTH_TEST):
            self.vertex_array.render(moderngl.TRIANGLES, vertices=3)

    def release(self) -> None:
        self.vertex_array.release()
