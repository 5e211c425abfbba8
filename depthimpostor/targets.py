"""The frame's own targets: linear float colour, the eye's depth, and the outputs a renderer was asked
for (each mirror pixel's ray and hit; the samples each reflected ray read), with their read-backs,
top row first (the eye camera's image rows; passes/present.py turns them for a window)."""

from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

from .constants import NO_OBJECT
from .eye import make_depth_buffer
from .gpu.bindings import TextureUnit
from .gpu.context import bind_default_framebuffer
from .gpu.embedding import FramePresenter
from .gpu.shaders import ProgramCache
from .passes.reflectors import REFLECTION_OUTPUTS
from .scene.model import RenderSettings


@dataclass(frozen=True)
class ReflectionData:
    """Per pixel of the last frame (top row first): what each mirror pixel's reflected ray hit."""

    mirror_mask: np.ndarray  # (h, w) bool
    mirror_id: np.ndarray  # (h, w) int: the object id of the mirror seen there, NO_OBJECT elsewhere
    origin: np.ndarray  # (h, w, 3) the reflected ray's origin on the mirror
    direction: np.ndarray  # (h, w, 3) unit reflected direction
    object_id: np.ndarray  # (h, w) int, NO_OBJECT for the environment (and outside mirrors)
    hit_position: np.ndarray  # (h, w, 3) world position of the hit (meaningless where no hit)
    normal: np.ndarray  # (h, w, 3) the reflector's unit normal, facing the eye
    retraced: np.ndarray  # (h, w) bool: the hybrid method traced this pixel's ray against the real triangles


#: Stamps run 1 .. MAX_STAMP: 2 stamp + 1 is an integer float32 holds exactly.
MAX_STAMP = 2**22


class Surfaces:
    """The visible reflector pixels' world position, normal and reflector (reflector_surface.frag),
    for the deferred mirror shader (passes/reflectors.py). Float32: the varyings, exactly."""

    def __init__(self, ctx: moderngl.Context, size: tuple[int, int], depth: moderngl.Renderbuffer | moderngl.Texture) -> None:
        self.position = ctx.texture(size, 4, dtype="f4")
        self.normal = ctx.texture(size, 4, dtype="f4")
        for texture in (self.position, self.normal):
            texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.framebuffer = ctx.framebuffer([self.position, self.normal], depth)  # the frame's depth test
        self._colours = ctx.framebuffer([self.position, self.normal])  # cleared without the frame's depth
        self.stamp = 0  # the frame's (next_frame), written beside each texel: no clear between frames

    @staticmethod
    def bytes_for(size: tuple[int, int]) -> int:
        return size[0] * size[1] * 16 * 2

    def next_frame(self) -> int:
        """A new frame's stamp. Clearing the targets for every frame costs as much as a third of
        rasterizing a curved mirror into them (two float targets of the frame's size, on llvmpipe);
        a texel whose stamp is another frame's is read as cleared. They are cleared once, at stamp
        0 (the first frame and after MAX_STAMP frames): stamps stay exact in float32."""
        if self.stamp == 0 or self.stamp == MAX_STAMP:
            self._colours.clear(0.0, 0.0, 0.0, 0.0)
            self.stamp = 0
        self.stamp += 1
        return self.stamp

    def use(self) -> None:
        self.position.use(TextureUnit.SURFACE_POSITION)
        self.normal.use(TextureUnit.SURFACE_NORMAL)

    def release(self) -> None:
        for item in (self._colours, self.framebuffer, self.position, self.normal):
            item.release()


class FrameTargets:
    def __init__(self, ctx: moderngl.Context, size: tuple[int, int], reflection_data: bool, count_samples: bool,
                 reflectors: bool) -> None:
        """`reflectors`: the frame draws reflectors, and so has their surfaces."""
        self.ctx, self.size = ctx, size
        # Float colour so that a NaN or Inf from a shader survives to be caught by a test,
        # instead of being clamped into a plausible-looking 8-bit pixel. A texture, not a
        # renderbuffer: a supersampled frame's average is written back into it.
        self.color = ctx.texture(size, 4, dtype="f4")
        self.depth = make_depth_buffer(ctx, size)
        self.reflection_outputs = [ctx.renderbuffer(size, 4, dtype="f4")
                                   for _ in range(REFLECTION_OUTPUTS if reflection_data else 0)]
        self.sample_counts = ctx.renderbuffer(size, 1, dtype="f4") if count_samples else None
        extra = [*self.reflection_outputs, *([self.sample_counts] if self.sample_counts is not None else [])]
        self.framebuffer = ctx.framebuffer([self.color, *extra], self.depth)
        # Passes with one output draw through a framebuffer with the colour alone: GL leaves
        # attachments a shader does not write undefined. Diffuse objects are drawn before mirrors,
        # so a mirror fragment that passes the depth test is the visible one and its extra
        # outputs stay consistent with the colour.
        self.color_framebuffer = ctx.framebuffer([self.color], self.depth) if extra else self.framebuffer
        self.surfaces = Surfaces(ctx, size, self.depth) if reflectors else None
        self._presenter: FramePresenter | None = None  # made when a frame is first put in a caller's framebuffer

    def present(self, programs: ProgramCache, target: moderngl.Framebuffer,
                viewport: tuple[int, int, int, int] | None, display: RenderSettings) -> None:
        """Put the frame, upright and through the display transform, into `viewport` of `target`."""
        if self._presenter is None:
            self._presenter = FramePresenter(self.ctx, programs, self.size)
        self._presenter.draw(self.color_framebuffer, target, viewport, display)

    def release_presenter(self) -> None:
        """Its program goes with the cache's (made again, with the programs of the time, when next needed)."""
        if self._presenter is not None:
            self._presenter.release()
            self._presenter = None

    def reshaped(self, size: tuple[int, int], reflectors: bool) -> FrameTargets:
        """These targets, or new ones of another size, or with the reflectors' surfaces where the
        frame now draws reflectors (or without them where it no longer does). The old are kept
        for the caller to release once the change has taken: a refused change draws on with them
        (both sets are held meanwhile: a change near the GL's memory is refused sooner)."""
        if size == self.size and (self.surfaces is not None) == reflectors:
            return self
        return FrameTargets(self.ctx, size, bool(self.reflection_outputs), self.sample_counts is not None, reflectors)

    def _read(self, components: int, attachment: int = 0) -> np.ndarray:
        width, height = self.size
        data = self.framebuffer.read(components=components, attachment=attachment, dtype="f4")
        return np.frombuffer(data, np.float32).reshape(height, width, components)

    def read_rgba(self) -> np.ndarray:
        return self._read(4)

    def read_color_float(self) -> np.ndarray:
        """(height, width, 3) float32, top row first, unclamped."""
        return self._read(3).copy()

    def write_color(self, rgba: np.ndarray) -> None:
        self.color.write(rgba.astype(np.float32).tobytes())

    def read_sample_counts(self) -> np.ndarray:
        """(height, width) samples each mirror pixel's reflected ray read (0 outside mirrors)."""
        if self.sample_counts is None:
            raise ValueError("this renderer was made without count_samples=True")
        return self._read(1, 1 + len(self.reflection_outputs))[..., 0].copy()

    def read_reflection_data(self) -> ReflectionData:
        if not self.reflection_outputs:
            raise ValueError("this renderer was made without reflection_data=True")
        origin, direction, hit, normal = (self._read(4, index).astype(np.float64) for index in range(1, 5))
        mask = origin[..., 3] > 0.5
        mirror_id = np.where(mask, np.rint(origin[..., 3]) - 1, NO_OBJECT).astype(np.int64)
        object_id = np.where(mask, np.rint(direction[..., 3]), NO_OBJECT).astype(np.int64)
        return ReflectionData(mask, mirror_id, origin[..., :3], direction[..., :3], object_id, hit[..., :3],
                              normal[..., :3], mask & (normal[..., 3] > 0.5))

    def release(self) -> None:
        self.release_presenter()
        bind_default_framebuffer(self.ctx)
        if self.surfaces is not None:
            self.surfaces.release()
        if self.color_framebuffer is not self.framebuffer:
            self.color_framebuffer.release()
        self.framebuffer.release()
        self.color.release()
        for item in (self.depth, *self.reflection_outputs):
            item.release()
        if self.sample_counts is not None:
            self.sample_counts.release()
