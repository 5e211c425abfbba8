"""Per-pixel outputs beside the colour (`render --aov`, `batch`'s `aov`): arbitrary output variables
for datasets (mirror segmentation, reflection removal) and for looking at what a method did.

Each AOV is one or more float32 channels of one OpenEXR file (`frame.aov.exr` beside `frame.png`),
which also holds the frame's linear colour as R, G, B. Three sources, each named in AOVS:
- the **primary surface** (depth, normal, albedo, object_id) comes from the truth's tracer
  (oracles/truth.py) for the ray through each pixel's centre: exact, the same rays the rasterizer
  samples (it may differ from the picture at a silhouette pixel, where the rasterizer's coverage
  rule and the ray disagree);
- the **method's** reflection outputs (reflector_id, reflected_object_id, reflected_distance,
  uncertain) are what the renderer wrote for its own frame (`reflection_data=True`), as `compare`
  reads them;
- the **truth's** (truth_reflected_object_id, error) come from `compare`, which traces every mirror
  pixel's reflected ray against the real triangles.

Ids are the scene's object indices (`objects[i]` in the scene file, the order of Scene.objects), and
NO_OBJECT (-1) where there is none: float32 holds every index below 2**24 exactly. A frame drawn
with `render.samples` > 1 gives the first sub-frame's ids, rays and surfaces, and the error of the
averaged colours (as compare's figures).
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO

import numpy as np

from .constants import NO_OBJECT
from .errors import SceneError
from .oracles.compare import Comparison, TruthFrame, colour_error, compare, primary_rays, primary_tracer
from .outputs import Outputs, Writer
from .ppc import PPC
from .renderer import Renderer
from .supersampling import SubFrame
from .targets import ReflectionData

#: The suffix of the AOV file beside a colour frame: `frame.png` -> `frame.aov.exr`.
AOV_SUFFIX = ".aov.exr"


@dataclass(frozen=True)
class Aov:
    channels: tuple[str, ...]  # the EXR channel names (a vector's as name.X/Y/Z or name.R/G/B)
    source: str  # "surface", "method" or "truth": what has to be computed for it
    meaning: str  # its units and its value where there is nothing to say (docs/batch.md's table)


def _vector(name: str, axes: str) -> tuple[str, ...]:
    return tuple(f"{name}.{axis}" for axis in axes)


#: Every AOV by the name `--aov` takes, in the order they are written.
AOVS: dict[str, Aov] = {
    "depth": Aov(("depth",), "surface", "distance from the eye's plane along the optical axis (z-depth) to the "
                 "first surface, in scene units; 0 where the ray meets no object (the environment)"),
    "normal": Aov(_vector("normal", "XYZ"), "surface", "the first surface's unit smooth normal in world space, "
                  "turned to face the eye; 0 for the environment"),
    "albedo": Aov(_vector("albedo", "RGB"), "surface", "the first surface's linear base colour (factor times texel); "
                  "0 on a mirror's reflecting side, on glass and for the environment; a mirror's backing its grey"),
    "object_id": Aov(("object_id",), "surface", "the object the eye sees first (mirrors included); -1: the environment"),
    "reflector_id": Aov(("reflector_id",), "method", "the mirror or glass object seen at the pixel (the method's "
                        "frame): the mirror-segmentation mask is reflector_id >= 0; -1 elsewhere"),
    "reflected_object_id": Aov(("reflected_object_id",), "method", "the object the method's reflected ray found; -1 "
                               "for the environment and outside mirrors"),
    "reflected_distance": Aov(("reflected_distance",), "method", "distance from the mirror point to the method's "
                              "reflected hit, in scene units; 0 for the environment and outside mirrors"),
    "uncertain": Aov(("uncertain",), "method", "1 where the method flagged its answer uncertain and traced the ray "
                     "against the real triangles instead (the hybrid's re-traced band), else 0"),
    "truth_reflected_object_id": Aov(("truth_reflected_object_id",), "truth", "the object the exact reflected ray "
                                     "hits (ray-traced truth); -1 for the environment and outside mirrors"),
    "error": Aov(("error",), "truth", "the largest channel of the absolute colour error as compare measures it (render - truth in "
                 "linear colour, unclamped, divided by the larger luminance of the two where that exceeds 1), over mirror pixels (and pixels seen directly in scenes with shadows); 0 "
                 "elsewhere, where the render is the truth"),
}


def parse_aovs(names: Sequence[str], file: str = "command line", field: str = "--aov") -> tuple[str, ...]:
    """The AOVs named (each once, in AOVS's order); SceneError naming `file` and `field` for an unknown one."""
    unknown = [name for name in names if name not in AOVS]
    if unknown:
        raise SceneError(file, field, f"expected AOVs among {', '.join(AOVS)}, got {', '.join(map(repr, unknown))}")
    return tuple(name for name in AOVS if name in names)


def aov_path(colour: Path) -> Path:
    """The AOV file beside a colour frame: `frame.png` -> `frame.aov.exr`."""
    return colour.with_name(colour.name[: len(colour.name) - len(colour.suffix)] + AOV_SUFFIX)


def needs_reflection_data(names: Sequence[str]) -> bool:
    """Does any of these AOVs need the renderer's reflection outputs (`reflection_data=True`)?"""
    return any(AOVS[name].source in ("method", "truth") for name in names)


def _ids(values: np.ndarray) -> np.ndarray:
    return values.astype(np.float32)


def _surface(renderer: Renderer, camera: PPC, shape: tuple[int, int]) -> dict[str, np.ndarray]:
    """depth, normal, albedo and object_id of the primary rays through `camera`'s pixel centres."""
    origins, directions = primary_rays(camera)
    hits, albedo = primary_tracer(renderer).surfaces(origins, directions)
    depth = np.where(hits.hit, hits.t * (directions @ camera.forward), 0.0)
    facing = np.where((np.einsum("ij,ij->i", hits.normal, directions) > 0.0)[:, None], -hits.normal, hits.normal)
    return {
        "depth": depth.reshape(shape),
        "normal": facing.reshape(shape + (3,)),
        "albedo": np.where(hits.hit[:, None], albedo, 0.0).reshape(shape + (3,)),
        "object_id": _ids(hits.object_id.reshape(shape)),
    }


def _method(data: ReflectionData) -> dict[str, np.ndarray]:
    found = data.mirror_mask & (data.object_id != NO_OBJECT)
    distance = np.linalg.norm(data.hit_position - data.origin, axis=2)
    return {
        "reflector_id": _ids(data.mirror_id),
        "reflected_object_id": _ids(data.object_id),
        "reflected_distance": np.where(found, distance, 0.0),
        "uncertain": data.retraced.astype(np.float32),
    }


def _truth(comparison: Comparison) -> dict[str, np.ndarray]:
    measured = comparison.mirror_mask | comparison.direct_mask
    error = np.abs(colour_error(comparison.render, comparison.truth)).max(axis=2)
    return {
        "truth_reflected_object_id": _ids(comparison.truth_frame.object_id),
        "error": np.where(measured, error, 0.0),
    }


def compute_aovs(renderer: Renderer, names: Sequence[str],
                 truth: TruthFrame | None = None) -> tuple[dict[str, np.ndarray], dict[str, float] | None]:
    """The AOVs `names` of the renderer's last frame, each (h, w) or (h, w, 3) float32, by name;
    and where the truth was traced for them, the frame's figures against it (FIGURES). The renderer
    must have been made with reflection_data=True where any needs it (needs_reflection_data);
    `truth` is an earlier frame's truth for the same rays, reused."""
    frames: list[SubFrame] = renderer.sub_frames()
    first = frames[0]
    camera = first.camera if first.camera is not None else renderer.camera
    height, width = first.color.shape[:2]
    sources = {AOVS[name].source for name in names}
    values: dict[str, np.ndarray] = {}
    figures = None
    if "surface" in sources:
        values |= _surface(renderer, camera, (height, width))
    if "method" in sources:
        values |= _method(_reflection(first))
    if "truth" in sources:
        comparison = compare(renderer, truth, frames)
        values |= _truth(comparison)
        figures = {name: getattr(comparison.figures, name) for name in FIGURES}
    return {name: np.ascontiguousarray(values[name], dtype=np.float32) for name in names}, figures


#: The figures against the truth (oracles/compare.py's Figures) a frame with truth AOVs reports.
FIGURES = ("mirror_pixels", "color_rmse", "psnr_db", "wrong_object_share", "wrong_surface_share",
           "geometric_error_median", "geometric_error_p95")


def _reflection(frame: SubFrame) -> ReflectionData:
    if frame.reflection is None:
        raise ValueError("these AOVs need a renderer made with reflection_data=True")
    return frame.reflection


def exr_channels(colour: np.ndarray, aovs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The EXR's channels: the linear colour as R, G, B, and each AOV's channels (AOVS[name].channels)."""
    channels = {name: np.ascontiguousarray(colour[..., k], dtype=np.float32) for k, name in enumerate("RGB")}
    for name, image in aovs.items():
        names = AOVS[name].channels
        planes = [image] if len(names) == 1 else [image[..., k] for k in range(len(names))]
        channels |= {channel: np.ascontiguousarray(plane, dtype=np.float32) for channel, plane in zip(names, planes, strict=True)}
    return channels


def _exr_writer(channels: dict[str, np.ndarray]) -> Writer:
    def write(file: IO[bytes]) -> None:
        import OpenEXR

        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
        buffer = io.BytesIO()
        with OpenEXR.File(header, channels) as exr:
            exr.write(buffer)
        file.write(buffer.getvalue())
    return write


def write_aovs(out: Outputs, path: Path, colour: np.ndarray, aovs: dict[str, np.ndarray]) -> Path:
    """The AOV file `path` (.aov.exr), written through `out` (atomically, with the colour frame)."""
    return out.write(path, _exr_writer(exr_channels(colour, aovs)))


def read_aovs(path: Path) -> dict[str, np.ndarray]:
    """An AOV file's channels by their names ("R", "depth", "normal.X", ...), each (h, w) float32."""
    import OpenEXR

    with OpenEXR.File(str(path), separate_channels=True) as exr:
        return {name: np.asarray(channel.pixels, dtype=np.float32) for name, channel in exr.channels().items()}
