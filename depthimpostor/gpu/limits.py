"""What a GL context can hold, checked before anything is allocated.

A texture or renderbuffer over the context's size limits, or one its driver cannot allocate,
does not fail where it is made: GL records an error and the framebuffer built on it is
incomplete, which moderngl reports as "the framebuffer is not complete" long after the setting
that caused it. So the renderer checks its plan first (`check_fits`): every surface it will make
against GL_MAX_TEXTURE_SIZE, GL_MAX_RENDERBUFFER_SIZE and GL_MAX_VIEWPORT_DIMS, the largest
allocation the driver is known to make, and the whole against a memory budget (the driver's,
or `--max-memory`). A refusal names the setting to change. The scene's image textures
(texture_layout.py) are checked against GL_MAX_TEXTURE_SIZE, GL_MAX_ARRAY_TEXTURE_LAYERS and
GL_MAX_UNIFORM_BLOCK_SIZE too, a refusal naming the image (`_check_textures`).

The limits come from one function, `context_limits`, which reads them from the context once and
keeps them in `ctx.extra`; `use_limits` puts others there (the CLI's `--max-memory`, and tests,
which must not allocate 16384^2 to see a refusal).
"""

from __future__ import annotations

import dataclasses
import numbers
import re
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import moderngl

from ..constants import MATERIAL, MATERIAL_BLOCK_RECORDS, STORAGE_GL_VERSION, TEXTURE_RECORD
from ..errors import GpuLimitError
from ..host_memory import available_memory
from ..methods.atlas import atlas_grid
from ..plan import RenderPlan
from ..scene.model import Scene
from ..texture_layout import texture_layout
from .scene_blocks import materials_bytes
from .uniforms import materials_in_storage

MIB = 2**20

#: The key of the limits in a context's `extra` dict.
_EXTRA_KEY = "gpu_limits"

#: Mesa's software rasterizers keep textures in the machine's memory: their budget is the memory
#: the machine has available.
_SOFTWARE_RENDERERS = ("llvmpipe", "softpipe", "swrast", "lavapipe")
#: llvmpipe addresses a resource with signed 32-bit offsets (Mesa's lp_limits.h:
#: LP_MAX_TEXTURE_SIZE, 2 GiB); a texture made through GL also gets room for its mipmaps (a
#: third more), so that a 1.5 GiB RG32F texture already fails where a 2 GiB renderbuffer does not.
#: 1 GiB is the largest texture that leaves a margin for either.
_LLVMPIPE_TEXTURE_BYTES = 2**30
_LLVMPIPE_RENDERBUFFER_BYTES = 2**31


@dataclass(frozen=True)
class GpuLimits:
    max_texture_size: int  # GL_MAX_TEXTURE_SIZE: a texture's side, in texels
    max_renderbuffer_size: int  # GL_MAX_RENDERBUFFER_SIZE
    max_viewport: tuple[int, int]  # GL_MAX_VIEWPORT_DIMS
    max_array_texture_layers: int = 256  # GL_MAX_ARRAY_TEXTURE_LAYERS (GL 3.3's least)
    max_uniform_block_size: int = 16384  # GL_MAX_UNIFORM_BLOCK_SIZE, in bytes (GL 3.3's least)
    max_texture_bytes: int | None = None  # one texture's bytes, where the driver is known to cap it
    max_renderbuffer_bytes: int | None = None
    memory: int | None = None  # bytes the renderer may allocate in all; None: unknown, not checked
    memory_source: str = "unknown"  # where `memory` comes from, for messages

    def with_memory(self, memory: int, source: str) -> GpuLimits:
        return dataclasses.replace(self, memory=memory, memory_source=source)


def _read_limits(ctx: moderngl.Context) -> GpuLimits:
    info = ctx.info
    renderer = str(info.get("GL_RENDERER", "")).lower()
    viewport = info.get("GL_MAX_VIEWPORT_DIMS", (info["GL_MAX_TEXTURE_SIZE"],) * 2)
    limits = GpuLimits(int(info["GL_MAX_TEXTURE_SIZE"]), int(info["GL_MAX_RENDERBUFFER_SIZE"]),
                       (int(viewport[0]), int(viewport[1])), int(info["GL_MAX_ARRAY_TEXTURE_LAYERS"]),
                       int(info["GL_MAX_UNIFORM_BLOCK_SIZE"]))
    if "llvmpipe" in renderer:
        limits = dataclasses.replace(limits, max_texture_bytes=_LLVMPIPE_TEXTURE_BYTES,
                                     max_renderbuffer_bytes=_LLVMPIPE_RENDERBUFFER_BYTES)
    if any(name in renderer for name in _SOFTWARE_RENDERERS):
        available = available_memory()
        if available is not None:
            limits = limits.with_memory(available, "the machine's available memory (a software renderer)")
    # A GPU's own memory is not in core GL; without --max-memory it is left to the driver.
    return limits


def context_limits(ctx: moderngl.Context) -> GpuLimits:
    """The limits of `ctx`: read from it on first use, or those `use_limits` gave it."""
    extra = ctx.extra if isinstance(ctx.extra, dict) else {}
    limits = extra.get(_EXTRA_KEY)
    if not isinstance(limits, GpuLimits):
        limits = _read_limits(ctx)
        use_limits(ctx, limits)
    return limits


def use_limits(ctx: moderngl.Context, limits: GpuLimits) -> None:
    """Check what `ctx` is asked to hold against `limits` from now on."""
    ctx.extra = {**(ctx.extra if isinstance(ctx.extra, dict) else {}), _EXTRA_KEY: limits}


def checked_memory(max_memory: object, name: str = "max_memory") -> int:
    """A memory budget given through the Python API: a positive whole number of bytes (a numpy
    integer too). Raises ValueError naming `name` for anything else (a string, NaN, 0, -1, 1.5)."""
    if isinstance(max_memory, bool) or not isinstance(max_memory, numbers.Integral) or int(max_memory) <= 0:
        raise ValueError(f"{name}: expected a positive integer number of bytes (such as 2**30 for 1 GiB), "
                         f"got {max_memory!r}")
    return int(max_memory)


def limit_memory(ctx: moderngl.Context, max_memory: int | None) -> None:
    """`--max-memory`: the budget of everything the renderer allocates, instead of the driver's.
    Raises ValueError for a budget that is not a positive integer of bytes (`checked_memory`)."""
    if max_memory is not None:
        use_limits(ctx, context_limits(ctx).with_memory(checked_memory(max_memory), "--max-memory"))


_MEMORY = re.compile(r"^\s*(?P<number>\d+(?:\.\d+)?)\s*(?P<unit>[kmgt]?)(?:i?b)?\s*$", re.IGNORECASE)


def parse_memory(text: str) -> int:
    """`--max-memory`: 512M, 1.5G, 2GiB, 800MB (binary units: 1M = 2^20 bytes); a bare number is MiB.
    Raises ValueError for anything else."""
    match = _MEMORY.match(text)
    if match is None or float(match["number"]) <= 0:
        raise ValueError(f"expected a positive size such as 512M, 1.5G or 2GiB, got {text!r}")
    power = "kmgt".index(match["unit"].lower()) + 1 if match["unit"] else 2
    size = int(float(match["number"]) * 1024**power)
    if size < 1:  # 0.0001K: under a byte
        raise ValueError(f"expected a positive size such as 512M, 1.5G or 2GiB, got {text!r} (under one byte)")
    return size


#: What sizes an equirect environment's texture.
_MAP_SETTING = "the size of environment.path's image"


@dataclass(frozen=True)
class Surface:
    """One texture or renderbuffer the plan calls for: its size, its largest texel, and the setting
    that decides its size."""

    name: str
    size: tuple[int, int]
    texel_bytes: int
    setting: str
    renderbuffer: bool = False

    @property
    def bytes(self) -> int:
        return self.size[0] * self.size[1] * self.texel_bytes


def surfaces(scene: Scene, plan: RenderPlan) -> list[Surface]:
    """The largest allocation of each kind the plan makes: the frame (RGBA32F colour; its other
    outputs are as large or smaller), glass interiors (RGBA32F, as large as the frame's larger
    side), the atlas of baked images (RG32F depth layers) and the shadow maps (RG32F)."""
    found = [Surface("frame's colour buffer", scene.render.size, 16, "--size", renderbuffer=True)]
    image = scene.environment.image
    if image is not None:
        found.append(Surface("environment map", (image.shape[1], image.shape[0]), 12, _MAP_SETTING))
    if "glass interiors" in plan.memory:
        side = max(scene.render.size)
        found.append(Surface("glass interior image", (side, side), 16, "--size"))
    if plan.images:
        side = max(max(image.width, image.height) for image in plan.images)
        columns, rows = atlas_grid(len(plan.images))
        found.append(Surface(f"atlas of {len(plan.images)} baked images of {side}x{side}",
                             (columns * side, rows * side), 8, "--impostor-res"))
    if scene.has_shadows:
        columns, rows = atlas_grid(len(scene.shadowed_lights))
        side = scene.render.shadow_resolution
        found.append(Surface(f"atlas of {len(scene.shadowed_lights)} shadow maps",
                             (columns * side, rows * side), 8, "render.shadow_resolution"))
    return found


def planned_bytes(plan: RenderPlan) -> int:
    """The memory the plan says its images take: the one figure of it the checks read."""
    return sum(plan.memory.values())


def _mib(value: int) -> str:
    return f"{value / MIB:.0f} MiB" if value >= 10 * MIB else f"{value / MIB:.2f} MiB"


def _check_surface(surface: Surface, limits: GpuLimits, backend: str) -> None:
    width, height = surface.size
    kind = "renderbuffer" if surface.renderbuffer else "texture"
    side = limits.max_renderbuffer_size if surface.renderbuffer else limits.max_texture_size
    name = "GL_MAX_RENDERBUFFER_SIZE" if surface.renderbuffer else "GL_MAX_TEXTURE_SIZE"
    if max(width, height) > side:
        raise GpuLimitError(f"the {surface.name} would be {width}x{height}, over this GL's {name} of {side}; "
                            f"lower {surface.setting}")
    if surface.renderbuffer and (width > limits.max_viewport[0] or height > limits.max_viewport[1]):
        raise GpuLimitError(f"the {surface.name} would be {width}x{height}, over this GL's GL_MAX_VIEWPORT_DIMS of "
                            f"{limits.max_viewport[0]}x{limits.max_viewport[1]}; lower {surface.setting}")
    cap = limits.max_renderbuffer_bytes if surface.renderbuffer else limits.max_texture_bytes
    if cap is not None and surface.bytes > cap:
        raise GpuLimitError(f"the {surface.name} would take {_mib(surface.bytes)} ({width}x{height}), over the "
                            f"{_mib(cap)} that {backend} allocates for one {kind}; lower {surface.setting}")


def check_fits(ctx: moderngl.Context, scene: Scene, plan: RenderPlan) -> None:
    """Raise GpuLimitError, naming the setting to change, if `ctx` cannot hold what `plan` (of
    `scene`; its memory counts every allocation, the frame and its extra outputs included)
    allocates. Called before any of it is made."""
    limits = context_limits(ctx)
    backend = str(ctx.info.get("GL_RENDERER", "this GL")).split(" (")[0]
    for surface in surfaces(scene, plan):
        _check_surface(surface, limits, backend)
    _check_textures(scene, limits, backend)
    _check_materials(scene, limits, ctx.version_code)
    if limits.memory is None:
        return
    total = planned_bytes(plan)
    if total > limits.memory:
        largest, size, setting = _largest_share(plan)
        raise GpuLimitError(f"the frame and its images need {_mib(total)}, over the {_mib(limits.memory)} of "
                            f"{limits.memory_source} (the most: {largest}, {_mib(size)}); lower {setting} or raise "
                            "--max-memory")


def _check_materials(scene: Scene, limits: GpuLimits, version_code: int) -> None:
    """The scene's distinct materials against where every pass reads them from (lib/shading.glsl's
    MaterialRecords): a uniform block within GL_MAX_UNIFORM_BLOCK_SIZE, or past a uniform block's
    guaranteed records (MATERIAL_BLOCK_RECORDS) a storage buffer, which needs GL 4.3 and is
    bounded by memory alone."""
    if materials_in_storage(scene):
        if version_code < STORAGE_GL_VERSION:
            raise GpuLimitError(f"the scene's {len(scene.materials)} distinct materials are read from a storage buffer "
                                f"past {MATERIAL_BLOCK_RECORDS}, which needs OpenGL 4.3; this context has "
                                f"{version_code // 100}.{version_code % 100 // 10}: use a newer driver, or at most "
                                f"{MATERIAL_BLOCK_RECORDS} distinct materials")
        return
    needed = materials_bytes(scene)
    if needed > limits.max_uniform_block_size:
        most = limits.max_uniform_block_size // MATERIAL.dtype.itemsize
        raise GpuLimitError(f"the scene's {len(scene.materials)} distinct materials need a record block of {needed} "
                            f"bytes, over this GL's GL_MAX_UNIFORM_BLOCK_SIZE of {limits.max_uniform_block_size} "
                            f"(at most {most} materials); use fewer distinct materials")


def texture_name(scene: Scene, slot: int) -> str:
    """A texture as a message names it: the first object that shows it, and its image."""
    texture = scene.textures[slot]
    index = next(i for i, obj in enumerate(scene.objects) if getattr(obj.material, "texture", None) is texture)
    return f"objects[{index}].material.texture ({texture.name or 'an image'})"


def _check_textures(scene: Scene, limits: GpuLimits, backend: str) -> None:
    """The scene's image textures against the GL's limits (they have none of their own), each
    refusal naming the first image past the limit and what to change."""
    if not scene.textures:
        return
    layout = texture_layout(scene)
    for slot, image in enumerate(layout.image_of):
        height, width = layout.images[image].shape[:2]
        if max(width, height) > limits.max_texture_size:
            raise GpuLimitError(f"the image texture {texture_name(scene, slot)} is {width}x{height}, over this GL's "
                                f"GL_MAX_TEXTURE_SIZE of {limits.max_texture_size}; use a smaller image")
    for array in layout.arrays:
        width, height = array.size
        if len(array.images) > limits.max_array_texture_layers:
            first = texture_name(scene, layout.slot_of_image(array.images[limits.max_array_texture_layers]))
            raise GpuLimitError(f"the image texture {first} would be layer {limits.max_array_texture_layers + 1} of "
                                f"the texture array of the scene's {len(array.images)} images of about {width}x{height}, "
                                f"over this GL's GL_MAX_ARRAY_TEXTURE_LAYERS of {limits.max_array_texture_layers}; "
                                "use fewer distinct images")
        if limits.max_texture_bytes is not None and array.bytes > limits.max_texture_bytes:
            first = texture_name(scene, layout.slot_of_image(array.images[0]))
            raise GpuLimitError(f"the texture array of the scene's {len(array.images)} images of {width}x{height} "
                                f"(from {first} on) would take {_mib(array.bytes)}, over the "
                                f"{_mib(limits.max_texture_bytes)} that {backend} allocates for one texture; use fewer "
                                "or smaller images")
    width, height = layout.atlas_size
    atlas = f"the atlas of the scene's {len(layout.images)} images that traced rays read would be {width}x{height}"
    if max(width, height) > limits.max_texture_size:
        raise GpuLimitError(f"{atlas}, over this GL's GL_MAX_TEXTURE_SIZE of {limits.max_texture_size}; use fewer "
                            "or smaller images")
    if limits.max_texture_bytes is not None and layout.atlas_bytes > limits.max_texture_bytes:
        raise GpuLimitError(f"{atlas} ({_mib(layout.atlas_bytes)}), over the {_mib(limits.max_texture_bytes)} that "
                            f"{backend} allocates for one texture; use fewer or smaller images")
    if layout.records_bytes > limits.max_uniform_block_size:
        first = texture_name(scene, limits.max_uniform_block_size // TEXTURE_RECORD.dtype.itemsize)
        raise GpuLimitError(f"the scene's {len(layout.textures)} image textures (the first past it: {first}) need "
                            f"a record block of {layout.records_bytes} bytes, over this GL's GL_MAX_UNIFORM_BLOCK_SIZE "
                            f"of {limits.max_uniform_block_size}; use fewer distinct textures")


#: The setting that sizes each of the plan's memory figures (by its name in `RenderPlan.memory`);
#: the baked images (depth images, cube-map faces, billboards, their pyramids) are sized by the
#: impostor resolution.
_MEMORY_SETTINGS = {"shadow maps": "render.shadow_resolution", "glass interiors": "--size",
                    "frame colour and depth": "--size", "reflection outputs": "--size", "sample counts": "--size",
                    "meshes": "the scene's meshes (fewer or smaller objects)", "environment map": _MAP_SETTING,
                    "textures": "the scene's image textures (fewer or smaller images)"}


def _largest_share(plan: RenderPlan) -> tuple[str, int, str]:
    """The largest of the plan's memory figures, its bytes, and the setting that sizes it."""
    name, size = max(plan.memory.items(), key=lambda item: item[1], default=("", 0))
    return name, size, _MEMORY_SETTINGS.get(name, "--impostor-res")


@contextmanager
def allocating(ctx: moderngl.Context, setting: str) -> Iterator[None]:
    """Where GL objects are made after `check_fits`: a framebuffer the driver still cannot complete
    (out of memory, a limit no query tells) is refused as the checks would refuse it, naming
    `setting`, and the GL error it left is cleared."""
    try:
        yield
    except moderngl.Error as error:
        if "framebuffer is not complete" not in str(error):
            raise
        gl_error = ctx.error  # reading it clears it: the session goes on without it
        raise GpuLimitError(f"this GL could not make a framebuffer ({error}; {gl_error}); lower {setting}"
                            " or raise --max-memory") from None
