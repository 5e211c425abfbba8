"""`--method ssr`: screen-space reflections, what engines reach for first (Godot, Bevy, Unity HDRP,
Unreal). The reflected ray is marched through what the eye itself saw (lib/screen_space.glsl):
the frame's colour and, per pixel, the world position and object seen, as the diffuse pass left
them before any reflector is drawn. The frame's diffuse pass writes the position and object beside
its colour (diffuse.frag's WRITE_SURFACE) into a texture of this stand-in; the eye-images node then
copies the frame's colour (the reflectors write into the frame, so they cannot read it) and builds
the min-depth pyramid of the surface the march skips empty space with (ssr_pyramid.comp), and the
reflectors read all three. Nothing is baked: what is off screen or hidden from the eye is not there to
be reflected, which is SSR's own failure and shows in `compare` against the independent truth.
"""

from __future__ import annotations

import moderngl
import numpy as np

from ..errors import ContextError
from ..geometry import ObjectGeometry
from ..gpu.bindings import ImageUnit, TextureUnit
from ..gpu.meshes import GpuMeshes
from ..gpu.scene_blocks import DrawnMaterials
from ..gpu.shaders import ProgramCache
from ..gpu.uniforms import bind_texture, write, write_matrix
from ..ppc import PPC
from ..scene.model import Scene
from .seen_from_eye import SeenFromEye


#: The compute shader building the min-depth pyramid (GL 4.3, as the hierarchical algorithm's).
SSR_PYRAMID_PROGRAM = "ssr_pyramid.comp"
REQUIRED_GL_VERSION = 430
_GROUP = 8  # ssr_pyramid.comp's local size
_R32F = 0x822E  # GL_R32F, the pyramid's image format


def pyramid_side(size: tuple[int, int]) -> int:
    """The pyramid's level 0: the least power-of-two square holding the frame, so that every
    level's cell covers exactly 2 x 2 of the level below."""
    return 1 << max(0, (max(size) - 1).bit_length())


def pyramid_levels(size: tuple[int, int]) -> int:
    return pyramid_side(size).bit_length()


class ScreenSpacePass(SeenFromEye):
    """The frame's colour copy and the eye's surface (world position, object id + 1), frame-sized."""

    image_noun = "frame copy"
    image_plural = "frame copies (colour, and the position and object seen)"
    reads = ("frame colour",)
    writes = ("frame copy",)
    reads_frame = True

    def __init__(self, ctx: moderngl.Context, programs: ProgramCache, scene: Scene, meshes: GpuMeshes,
                 materials: DrawnMaterials, reflectors: list[ObjectGeometry]) -> None:
        super().__init__(ctx, programs, scene, meshes, materials, reflectors)
        if ctx.version_code < REQUIRED_GL_VERSION:
            raise ContextError(
                f"--method ssr builds its min-depth pyramid with compute shaders, which need OpenGL 4.3; this "
                f"context has {ctx.version_code // 100}.{ctx.version_code % 100 // 10}: use another method")
        self.pyramid_program = programs.compute(SSR_PYRAMID_PROGRAM)
        self.pyramid: moderngl.Texture | None = None
        self.camera: PPC | None = None
        self.color: moderngl.Texture | None = None
        self.surface: moderngl.Texture | None = None
        self._surface_only: moderngl.Framebuffer | None = None  # to clear the surface alone
        self._diffuse_frame: tuple[moderngl.Framebuffer, moderngl.Framebuffer] | None = None  # (frame's, with surface)

    @classmethod
    def bytes_for(cls, size: tuple[int, int], reflectors: int, glossy: bool = False) -> int:
        side = pyramid_side(size)
        pyramid = sum((side >> level) ** 2 * 4 for level in range(pyramid_levels(size)))
        # The colour copy, the surface, the pyramid; a rough mirror's copy has its mips too.
        mips = sum(max(1, size[0] >> level) * max(1, size[1] >> level) * 16
                   for level in range(1, max(size).bit_length())) if glossy else 0
        return size[0] * size[1] * (16 + 16) + pyramid + mips

    def _ensure(self, size: tuple[int, int]) -> None:
        if self.size == size:
            return
        self._release_targets()
        self.color = self.ctx.texture(size, 4, dtype="f4")
        self.surface = self.ctx.texture(size, 4, dtype="f4")
        for texture in (self.color, self.surface):
            texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._surface_only = self.ctx.framebuffer([self.surface])
        side = pyramid_side(size)
        self.pyramid = self.ctx.texture((side, side), 1, dtype="f4")
        # Allocates every level (build_pyramid overwrites them) and sets the level range texelFetch reads.
        self.pyramid.build_mipmaps(0, pyramid_levels(size) - 1)
        self.pyramid.filter = (moderngl.NEAREST_MIPMAP_NEAREST, moderngl.NEAREST)
        self.size = size

    @classmethod
    def variants(cls, scene: Scene) -> list[tuple[tuple[str, ...], dict[str, int] | None, str]]:
        return [((SSR_PYRAMID_PROGRAM,), None, "SSR: the frame's min-depth pyramid")]

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
        if self.glossy:  # a rough mirror's cone reads the copy prefiltered (lib/screen_space.glsl)
            self.color.build_mipmaps()
            self.color.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
        frame.use()
        self.camera = camera
        self._build_pyramid(camera)
        self.made += 1
        return 0

    def _build_pyramid(self, camera: PPC) -> None:
        """The min-depth pyramid of what the diffuse pass left: level 0 from the surface, each
        level from the one below, one dispatch each."""
        assert self.pyramid is not None and self.surface is not None and self.size is not None
        program = self.pyramid_program
        bind_texture(program, "u_screen_surface", self.surface, TextureUnit.SCREEN_SURFACE)
        write(program, "u_ssr_eye", tuple(camera.C))
        write_matrix(program, "u_ssr_inverse", np.asarray(camera.inverse))
        side = pyramid_side(self.size)
        for level in range(pyramid_levels(self.size)):
            self.pyramid.bind_to_image(ImageUnit.PYRAMID_SOURCE, read=True, write=False, level=max(level - 1, 0),
                                       format=_R32F)
            self.pyramid.bind_to_image(ImageUnit.PYRAMID_TARGET, read=False, write=True, level=level, format=_R32F)
            write(program, "u_level", level)
            cells = max(1, side >> level)
            program.run(-(-cells // _GROUP), -(-cells // _GROUP))
            # Image stores are not coherent with later reads: the next level reads this one
            # through imageLoad, and the mirror shader through texelFetch.
            self.ctx.memory_barrier()

    def bind_reflector(self, program: moderngl.Program, mirror: ObjectGeometry) -> None:
        if self.camera is None or self.color is None or self.surface is None:
            raise RuntimeError("the frame copy is made before the reflectors are drawn")
        bind_texture(program, "u_screen_color", self.color, TextureUnit.SCREEN_COLOR)
        bind_texture(program, "u_screen_surface", self.surface, TextureUnit.SCREEN_SURFACE)
        if self.pyramid is not None and self.size is not None:
            bind_texture(program, "u_ssr_pyramid", self.pyramid, TextureUnit.SSR_PYRAMID)
            write(program, "u_ssr_levels", pyramid_levels(self.size))
        camera = self.camera
        write(program, "u_ssr_eye", tuple(camera.C))
        write_matrix(program, "u_ssr_inverse", np.asarray(camera.inverse))
        write(program, "u_ssr_w_near", camera.w_near)
        write(program, "u_ssr_w_far", camera.w_far)
        write(program, "u_ssr_pixel", float(np.linalg.norm(camera.a)))

    def _release_targets(self) -> None:
        if self._diffuse_frame is not None:
            self._diffuse_frame[1].release()
            self._diffuse_frame = None
        for item in (self._surface_only, self.color, self.surface, self.pyramid):
            if item is not None:
                item.release()
        self.color = self.surface = self._surface_only = self.pyramid = None
        self.size = None

    def release(self) -> None:
        self._release_targets()
