"""`--method ssr`: screen-space reflections, what engines reach for first (Godot, Bevy, Unity HDRP,
Unreal). The reflected ray is marched through what the eye itself saw (lib/screen_space.glsl):
the frame's colour and, per pixel, the world position and object seen, as the diffuse pass left
them before any reflector is drawn. The frame's diffuse pass writes the position and object beside
its colour (diffuse.frag's WRITE_SURFACE) into a texture of this stand-in; the eye-images node then
copies the frame's colour (the reflectors write into the frame, so they cannot read it), and the
reflectors read both. Nothing is baked: what is off screen or hidden from the eye is not there to
be reflected, which is SSR's own failure and shows in `compare` against the independent truth.
"""

from __future__ import annotations

import moderngl
import numpy as np

from ..geometry import ObjectGeometry
from ..gpu.bindings import TextureUnit
from ..gpu.meshes import GpuMeshes
from ..gpu.shaders import ProgramCache
from ..gpu.uniforms import bind_texture, write, write_matrix
from ..ppc import PPC
from ..scene.model import Scene
from .seen_from_eye import SeenFromEye


class ScreenSpacePass(SeenFromEye):
    """The frame's colour copy and the eye's surface (world position, object id + 1), frame-sized."""

    image_noun = "frame copy"
    image_plural = "frame copies (colour, and the position and object seen)"
    reads = ("frame colour",)
    writes = ("frame copy",)
    reads_frame = True

    def __init__(self, ctx: moderngl.Context, programs: ProgramCache, scene: Scene, meshes: GpuMeshes,
                 reflectors: list[ObjectGeometry]) -> None:
        super().__init__(ctx, programs, scene, meshes, reflectors)
        self.camera: PPC | None = None
        self.color: moderngl.Texture | None = None
        self.surface: moderngl.Texture | None = None
        self._surface_only: moderngl.Framebuffer | None = None  # to clear the surface alone
        self._diffuse_frame: tuple[moderngl.Framebuffer, moderngl.Framebuffer] | None = None  # (frame's, with surface)

    @classmethod
    def bytes_for(cls, size: tuple[int, int], reflectors: int) -> int:
        return size[0] * size[1] * (16 + 16)  # the colour copy and the surface

    def _ensure(self, size: tuple[int, int]) -> None:
        if self.size == size:
            return
        self._release_targets()
        self.color = self.ctx.texture(size, 4, dtype="f4")
        self.surface = self.ctx.texture(size, 4, dtype="f4")
        for texture in (self.color, self.surface):
            texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._surface_only = self.ctx.framebuffer([self.surface])
        self.size = size

    def diffuse_framebuffer(self, frame: moderngl.Framebuffer, size: tuple[int, int]) -> moderngl.Framebuffer:
        """The framebuffer the frame's diffuse pass draws through: the frame's colour and depth
        (`frame`), and this stand-in's surface, cleared (0: nothing seen, the sky)."""
        self._ensure(size)
        assert self._surface_only is not None and self.surface is not None
        self._surface_only.clear(0.0, 0.0, 0.0, 0.0)
        if self._diffuse_frame is None or self._diffuse_frame[0] is not frame:
            if self._diffuse_frame is not None:
                self._diffuse_frame[1].release()
            combined = self.ctx.framebuffer([frame.color_attachments[0], self.surface], frame.depth_attachment)
            self._diffuse_frame = (frame, combined)
        return self._diffuse_frame[1]

    def make(self, camera: PPC, diffuse: list[ObjectGeometry], reflectors: list[ObjectGeometry],
             frame: moderngl.Framebuffer) -> int:
        """Copy the frame's colour, as the diffuse pass left it."""
        self._ensure((camera.width, camera.height))
        assert self.color is not None
        self.ctx.copy_framebuffer(self.color, frame)
        frame.use()
        self.camera = camera
        self.made += 1
        return 0

    def bind_mirror(self, program: moderngl.Program, mirror: ObjectGeometry) -> None:
        if self.camera is None or self.color is None or self.surface is None:
            raise RuntimeError("the frame copy is made before the reflectors are drawn")
        bind_texture(program, "u_screen_color", self.color, TextureUnit.SCREEN_COLOR)
        bind_texture(program, "u_screen_surface", self.surface, TextureUnit.SCREEN_SURFACE)
        camera = self.camera
        write(program, "u_ssr_eye", tuple(camera.C))
        write_matrix(program, "u_ssr_inverse", np.asarray(camera.inverse))
        write(program, "u_ssr_w_near", camera.w_near)
        write(program, "u_ssr_w_far", camera.w_far)

    def _release_targets(self) -> None:
        if self._diffuse_frame is not None:
            self._diffuse_frame[1].release()
            self._diffuse_frame = None
        for item in (self._surface_only, self.color, self.surface):
            if item is not None:
                item.release()
        self.color = self.surface = self._surface_only = None
        self.size = None

    def release(self) -> None:
        self._release_targets()
