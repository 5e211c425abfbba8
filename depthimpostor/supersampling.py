"""Anti-aliasing (render.samples > 1): the frame drawn once per sub-pixel position of SAMPLE_OFFSETS,
with the eye camera's corner shifted so that every ray the mirror shader traces moves with its
pixel, and the linear colours averaged. Bakes do not depend on the eye and run once; glass
interiors depend on the eye's position and pixel size, which a jitter keeps, so they are made once
too. The sub-frames are kept for `compare`, which traces the truth at the same positions."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .constants import SAMPLE_OFFSETS
from .ppc import PPC
from .render_graph import RenderStats
from .targets import FrameTargets, ReflectionData


def jittered(camera: PPC, dx: float, dy: float) -> PPC:
    """`camera` with its image shifted by (dx, dy) pixels: pixel (i, j)'s centre ray is the
    original camera's ray through (i + 0.5 + dx, j + 0.5 + dy). The eye and the pixel's size stay."""
    return dataclasses.replace(camera, c=camera.c + camera.a * dx + camera.b * dy)


@dataclass(frozen=True, eq=False)
class SubFrame:
    """One sub-pixel position of a supersampled frame: its camera, linear colour (top row first),
    and the reflection data of its rays where the renderer keeps them."""

    camera: PPC | None  # None: the renderer's own camera (a frame without anti-aliasing)
    color: np.ndarray  # (h, w, 3) float32
    reflection: ReflectionData | None


def draw_supersampled(draw: Callable[[PPC], None], camera: PPC, samples: int, targets: FrameTargets,
                      stats: RenderStats, keep_reflection: bool) -> list[SubFrame]:
    """One anti-aliased frame into `targets` (`draw`: one sub-frame through a camera); returns its
    sub-frames. The stats count one frame, whose time is its sub-frames' (reading them back is not
    counted)."""
    frames, draws, mirrors = stats.frames, len(stats.draw_seconds), len(stats.mirror_seconds)
    gl_draws, gl_mirrors = len(stats.gl_draw_seconds), len(stats.gl_mirror_seconds)
    total = np.zeros((*targets.size[::-1], 4))
    kept: list[SubFrame] = []
    for dx, dy in SAMPLE_OFFSETS[samples]:
        sub_camera = jittered(camera, dx, dy)
        draw(sub_camera)
        rgba = targets.read_rgba()
        total += rgba
        kept.append(SubFrame(sub_camera, rgba[..., :3].copy(),
                             targets.read_reflection_data() if keep_reflection else None))
    targets.write_color(total / samples)
    stats.frames = frames + 1  # each sub-frame was counted in sub_frames, and as a frame
    stats.draw_seconds[draws:] = [sum(stats.draw_seconds[draws:])]
    for timed, first in ((stats.mirror_seconds, mirrors), (stats.gl_draw_seconds, gl_draws),
                         (stats.gl_mirror_seconds, gl_mirrors)):
        if timed[first:]:
            timed[first:] = [sum(timed[first:])]
    return kept
