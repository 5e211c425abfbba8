"""How far a render is from the truth, per mirror pixel: colour, object and geometry.

Figures, over the mirror and glass pixels of one frame ("mirror pixels" below; a glass pixel's
reflected ray is the one measured for objects and geometry, its colour blends in the refraction):
- colour RMSE and PSNR in linear space (COLOUR_SPACE): the difference of the frame's linear float
  colour and the truth's, unclamped, divided by the larger of their luminances where that
  exceeds 1 (`colour_error`): absolute where a display shows values as they are, relative on highlights
  and HDR skies, so that an error where both pictures exceed 1 is counted without a sun's disc
  outweighing the rest of the frame; before exposure, tone mapping and sRGB encoding, which are
  for display alone (docs/colour.md): a figure does not change with them;
- the share of pixels whose reflected ray hit another object than the truth's (the environment
  counting as an object);
- over the mirror pixels that show a reflected object (in the truth), the share that show the
  wrong surface: another object, or a colour off by more than WRONG_SURFACE_COLOR_ERROR. On
  textured objects this is where an image from the mirror's centre shows the right object and the
  wrong part of it (a side it does not see), which the share of wrong objects cannot tell;
- for the hybrid method, the share of mirror pixels whose ray was traced against the real triangles;
- the geometric error where both hit the same depth-image object: the distance between the two
  hit points as a fraction of that object's bounding-sphere radius (median, 95th percentile, max).
  Analytic planes are exact by construction and are left out of this figure.

In scenes with shadows, also over the pixels seen directly (outside the mirrors), whose shadows are
approximated too: the colour RMSE against primary rays traced with real shadow rays. Without
shadows the direct view *is* the truth (the same shading, rasterized) and is not traced.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from ..constants import NO_OBJECT
from ..font import load_font
from ..lod import EyeView
from ..outputs import Outputs
from ..colour import display_encode, quantize
from ..ppc import PPC
from ..renderer import Renderer
from ..scene import Scene
from ..supersampling import SubFrame
from ..targets import ReflectionData
from .truth import SpecularTruth, TruthTracer, seen_through_blended

WORST_PIXELS = 8
#: Where colour errors are measured, as the report states it.
COLOUR_SPACE = ("linear, unclamped: the frame's float colour minus the truth's, divided by the larger of their "
                "luminances (Rec. 709) where that exceeds 1, before exposure, tone mapping and sRGB encoding")
#: Rec. 709 / sRGB primaries' luminance weights: what `colour_error` divides by above 1.
LUMINANCE_WEIGHTS = np.array([0.2126, 0.7152, 0.0722])


def colour_error(render: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Per pixel and channel, the measured colour error (COLOUR_SPACE): render - truth, divided
    by the larger luminance of the two where it exceeds 1. Where both are at most 1 (everything a
    display shows unchanged) it is the plain difference, the figure measured before HDR; above, a
    relative error, so that 1 % off a sun of 50 weighs what 1 % off a white wall does, and a sun
    shown where the truth sees a wall counts about 1, as a wall shown where it sees the sun does
    (dividing by the truth's alone made the first 50 times the second). (Clamping both to [0, 1],
    as compare did before, counted nothing where both exceed 1.)"""
    scale = np.maximum(np.maximum(truth @ LUMINANCE_WEIGHTS, render @ LUMINANCE_WEIGHTS), 1.0)
    return (render - truth) / scale[..., None]
#: A pixel showing a reflected object shows the wrong surface when its colour is off by more than
#: this in its largest channel: 8-bit rounding and shading from interpolated normals stay far below
#: it, a checker square of the wrong colour (or a side coloured like another) far above.
WRONG_SURFACE_COLOR_ERROR = 0.1
#: Mirror pixels traced at a time when someone watches the progress (the viewer's error view): small
#: enough that the bar moves a few times a second on two cores, large enough that Embree's per-call
#: cost stays negligible.
PROGRESS_CHUNK = 8192

#: Told the share of a trace done so far, in [0, 1].
Progress = Callable[[float], None]


@dataclass(frozen=True)
class Figures:
    mirror_pixels: int
    color_rmse: float
    psnr_db: float
    wrong_object_share: float
    geometric_pixels: int
    geometric_error_median: float
    geometric_error_p95: float
    geometric_error_max: float
    worst_pixels: list[dict[str, object]] = field(default_factory=list)
    # Scenes with shadows: the pixels seen directly (outside mirrors) and their colour RMSE.
    direct_pixels: int = 0
    direct_rmse: float = 0.0
    # Scenes with glass: its pixels (counted among the mirror pixels too) and their colour RMSE.
    glass_pixels: int = 0
    glass_rmse: float = 0.0
    # Mirror pixels that show a reflected object in the truth, and the share of them that show
    # the wrong surface (see the module's docstring).
    object_pixels: int = 0
    wrong_surface_share: float = 0.0
    # The hybrid method: mirror pixels whose ray was traced against the real triangles.
    retraced_pixels: int = 0
    retraced_share: float = 0.0
    # render.samples: the colour figures are on colours averaged over this many sub-pixel frames
    # (the render's and the truth's alike), the object and geometric ones of the first (compare()).
    samples: int = 1


@dataclass(frozen=True, eq=False)
class TruthFrame:
    """What the truth sees at every mirror pixel of a frame, for the rays it was traced with."""

    mirror_mask: np.ndarray  # (h, w) bool
    direction: np.ndarray  # (h, w, 3) the rays traced (to tell whether another frame's rays are the same)
    color: np.ndarray  # (h, w, 3) tinted colour inside the mirrors, 0 elsewhere
    object_id: np.ndarray  # (h, w), NO_OBJECT outside the mirrors and for the environment
    position: np.ndarray  # (h, w, 3) hit positions
    # Scenes with shadows: the truth of the pixels seen directly (NaN where not measured: mirrors,
    # and the few silhouette pixels where the rasterizer and the traced ray see different objects).
    direct: np.ndarray | None = None
    # An anti-aliased frame's: the truth of each sub-frame (this one is the first's), else ().
    sub_frames: tuple[TruthFrame, ...] = ()

    def fits(self, data: ReflectionData) -> bool:
        """Were these the rays of `data`? The same scene and camera give the same rays whatever
        the method (the mirror shader computes them before any method's code): a benchmark
        traces the truth once and reuses it."""
        return bool(np.array_equal(self.mirror_mask, data.mirror_mask)
                    and np.allclose(self.direction[data.mirror_mask], data.direction[data.mirror_mask], atol=1e-6))


@dataclass(frozen=True, eq=False)
class Comparison:
    render: np.ndarray  # (h, w, 3) linear float colours, as measured (unclamped)
    truth: np.ndarray
    mirror_mask: np.ndarray
    geometric_error: np.ndarray  # (h, w), NaN where not measured
    figures: Figures
    truth_frame: TruthFrame  # what the truth saw: another method's frame of the same rays reuses it
    direct_mask: np.ndarray  # (h, w) pixels seen directly and measured (scenes with shadows; else none)
    # The display transform of the report's images (render.tone_mapping, render.exposure); the
    # figures are measured before it.
    display: tuple[str, float] = ("none", 0.0)

    def image(self, linear: np.ndarray) -> np.ndarray:
        """Measured (linear) colours as the report shows them: through the display transform."""
        return display_encode(linear, *self.display)


def primary_rays(camera: PPC) -> tuple[np.ndarray, np.ndarray]:
    """The origins and unit directions of the rays through every pixel's centre, row by row (top first)."""
    rows, columns = np.mgrid[0:camera.height, 0:camera.width] + 0.5
    directions = camera.ray_direction(columns.ravel(), rows.ravel())
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    return np.broadcast_to(camera.C, directions.shape), directions


def primary_tracer(renderer: Renderer) -> TruthTracer:
    """A tracer of primary rays against every object the eye can see: the shadow casters (with real
    shadow rays), the others that cast no shadow (the planes drawn as meshes and the flat mirrors,
    whose backs are seen directly), and the analytic planes (intersected exactly). Each object as
    the eye's diffuse pass draws it (World.eye_drawn_for the renderer's camera: at its level of
    detail for the eye), since outside the mirrors the truth is what the rasterizer saw."""
    world = renderer.world
    casters = world.shadow_casters
    apart = {g.index for g in casters} | {g.index for g in world.analytic_planes}
    as_drawn = {g.index: g for g in world.eye_drawn_for(EyeView.of_camera(renderer.camera))}
    seen = [*casters, *(as_drawn.get(g.index, g) for g in world.geometry if g.index not in apart)]
    return TruthTracer(renderer.scene, seen, world.analytic_planes, casters, renderer.sky_lighting())


def trace_direct(renderer: Renderer, mirror_mask: np.ndarray, camera: PPC | None = None) -> np.ndarray:
    """The truth of every pixel seen directly: a primary ray through its centre (of `camera`, the
    renderer's by default, or a sub-frame's), traced against every object and shaded with real
    shadow rays. NaN where the ray meets a mirror (on its reflecting side: its back is a diffuse
    backing) or glass, or the rasterizer saw one (mirror pixels have their own truth)."""
    origins, directions = primary_rays(renderer.camera if camera is None else camera)
    hits = primary_tracer(renderer).trace(origins, directions)
    reflectors = [g.index for g in renderer.world.reflectors]
    reflecting = np.isin(hits.object_id, reflectors) & ~hits.backing
    seen_mirror = reflecting.reshape(mirror_mask.shape) | mirror_mask
    return np.where(seen_mirror[..., None], np.nan, hits.color.reshape(mirror_mask.shape + (3,)))


def trace_truth(renderer: Renderer, data: ReflectionData, camera: PPC | None = None,
                progress: Progress | None = None, viewed_from_centres: bool = False) -> TruthFrame:
    """The truth for the mirror and glass pixels of the renderer's last frame (or of one of its
    sub-frames, seen through `camera`), whose reflection outputs are `data` (and, in scenes with
    shadows, for the pixels seen directly). `progress` is told the share traced, chunk by chunk.
    `viewed_from_centres`: reflected metallic-roughness surfaces shaded as seen from their mirror's
    centre, as the baked images hold them, not for the ray (SpecularTruth.viewed_from_centres)."""
    camera = renderer.camera if camera is None else camera
    mask = data.mirror_mask
    specular = SpecularTruth(renderer.scene, renderer.world.reflected_objects, renderer.world.reflectors, renderer.world.analytic_planes,
                             renderer.world.shadow_casters, renderer.sky_lighting())
    specular.viewed_from_centres = viewed_from_centres
    origins = data.origin[mask]
    incoming = origins - camera.C
    incoming /= np.maximum(np.linalg.norm(incoming, axis=1, keepdims=True), 1e-300)
    color = np.zeros(mask.shape + (3,))
    object_id = np.full(mask.shape, NO_OBJECT, np.int64)
    position = np.zeros(mask.shape + (3,))
    # In chunks when the progress is watched (every ray is traced on its own: the chunks change nothing).
    chunk = PROGRESS_CHUNK if progress is not None else max(len(origins), 1)
    columns = [data.mirror_id[mask], origins, data.normal[mask], incoming, data.direction[mask]]
    surfaces, object_ids, positions = [], [], []
    for start in range(0, len(origins), chunk):
        ids, positions_in, normals, incoming_in, reflected = (c[start:start + chunk] for c in columns)
        surface, hits = specular.surface_color(ids, positions_in, normals, incoming_in, reflected,
                                               renderer.scene.render.max_bounces)
        surfaces.append(surface)
        object_ids.append(hits.object_id)
        positions.append(hits.position)
        if progress is not None:
            progress(min(start + chunk, len(origins)) / (len(origins) + (chunk if renderer.scene.has_shadows else 0)))
    if surfaces:
        surface = np.concatenate(surfaces)
        blended = renderer.world.blended_objects
        if blended:  # what the eye sees of the reflectors through blended objects (passes/transparent.py)
            planes = {g.index for g in renderer.world.analytic_planes}
            tracer = TruthTracer(renderer.scene, [g for g in blended if g.index not in planes],
                                 [g for g in blended if g.index in planes], renderer.world.shadow_casters,
                                 renderer.sky_lighting())
            surface = seen_through_blended(tracer, np.asarray(camera.C, float), origins, surface)
        color[mask] = surface
        object_id[mask] = np.concatenate(object_ids)
        position[mask] = np.concatenate(positions)
    direct = trace_direct(renderer, mask, camera) if renderer.scene.has_shadows else None
    if progress is not None:
        progress(1.0)
    return TruthFrame(mask, data.direction, color, object_id, position, direct)


def _truths(renderer: Renderer, frames: list[SubFrame], truth: TruthFrame | None,
            progress: Progress | None = None) -> list[TruthFrame]:
    """The truth of each sub-frame: `truth`'s (an earlier comparison's) where it was traced for
    the same rays, else traced now at each sub-frame's own sub-pixel positions."""
    given = (truth.sub_frames or (truth,)) if truth is not None else ()
    data = [_reflection(frame) for frame in frames]
    if len(given) == len(frames) and all(t.fits(d) for t, d in zip(given, data, strict=True)):
        return list(given)

    def part(k: int) -> Progress | None:  # the k-th sub-frame's share of the whole
        return None if progress is None else (lambda done: progress((k + done) / len(frames)))

    return [trace_truth(renderer, d, frame.camera, part(k)) for k, (frame, d) in enumerate(zip(frames, data, strict=True))]


def _reflection(frame: SubFrame) -> ReflectionData:
    if frame.reflection is None:
        raise ValueError("this renderer was made without reflection_data=True")
    return frame.reflection


def _truth_image(render: np.ndarray, data: ReflectionData, truth: TruthFrame) -> tuple[np.ndarray, np.ndarray]:
    """One (sub-)frame's truth image, and its pixels seen directly and measured (scenes with
    shadows). Outside the mirrors the truth is the render itself (primary visibility is the
    rasterizer's), unless shadows make the direct view an approximation too."""
    truth_image = np.where(data.mirror_mask[..., None], truth.color, render)
    direct = np.zeros_like(data.mirror_mask)
    if truth.direct is not None:
        direct = ~np.isnan(truth.direct[..., 0])
        truth_image = np.where(direct[..., None], np.nan_to_num(truth.direct), truth_image)
    return truth_image, direct


def compare(renderer: Renderer, truth: TruthFrame | None = None, frames: list[SubFrame] | None = None,
            progress: Progress | None = None) -> Comparison:
    """Compare the renderer's last frame (made with reflection_data=True) with the truth: traced
    now, or `truth` (an earlier comparison's `truth_frame`) when it was traced for the same rays.
    `frames` are the frame's `renderer.sub_frames()`, read beforehand: given them, nothing here
    touches the GL, and the comparison can run in another thread than the context's (the viewer's
    error view, whose `progress` is told the share of the truth traced).

    An anti-aliased frame (render.samples > 1) is compared sub-frame by sub-frame at the same
    sub-pixel positions: the truth is traced for each sub-frame's rays, each side's colours are
    averaged alike, and the colour figures (RMSE, PSNR, direct and glass RMSE, worst
    pixels' colour error) are measured on the averages, over the pixels any sub-frame saw a mirror
    in (an average of linear colours: the box filter of anti-aliasing). The object and geometric figures are those of the first sub-frame alone: an average of
    object ids or hit points means nothing."""
    if frames is None:
        frames = (renderer.sub_frames() if renderer.scene.render.samples > 1
                  else [SubFrame(None, renderer.read_color_float(), renderer.read_reflection_data())])
    truths = _truths(renderer, frames, truth, progress)
    data = _reflection(frames[0])
    renders = [frame.color for frame in frames]
    images = [_truth_image(r, _reflection(f), t) for r, f, t in zip(renders, frames, truths, strict=True)]
    render = np.mean(renders, axis=0)
    truth_image = np.mean([image for image, _ in images], axis=0)
    mask = np.logical_or.reduce([_reflection(f).mirror_mask for f in frames])
    direct = np.logical_or.reduce([d for _, d in images]) & ~mask
    glass_ids = [g.index for g in renderer.world.glass]
    glass = np.logical_or.reduce([f.mirror_mask & np.isin(f.mirror_id, glass_ids) for f in map(_reflection, frames)])
    direct_pixels = int(direct.sum())
    error = colour_error(render, truth_image)
    direct_rmse = float(np.sqrt((error[direct] ** 2).mean())) if direct_pixels else 0.0
    truth_object, truth_position = truths[0].object_id, truths[0].position
    count = int(mask.sum())
    squared = (error ** 2)[mask]
    rmse = float(np.sqrt(squared.mean())) if count else 0.0
    first_mask = data.mirror_mask
    wrong = (data.object_id != truth_object) & first_mask
    first_count = int(first_mask.sum())
    glass_pixels = int(glass.sum())
    glass_rmse = float(np.sqrt((error[glass] ** 2).mean())) if glass_pixels else 0.0

    radius = {g.index: g.bounding_sphere[1] for g in renderer.world.reflected_objects}
    measured = first_mask & (data.object_id == truth_object) & np.isin(truth_object, list(radius))
    geometric = np.full(mask.shape, np.nan)
    if measured.any():
        radii = np.vectorize(radius.get)(truth_object[measured])
        geometric[measured] = np.linalg.norm(data.hit_position[measured] - truth_position[measured], axis=1) / radii
    values = geometric[measured]

    color_error = np.abs(error).max(axis=2)
    worst = _worst_pixels(renderer.scene, mask, wrong, geometric, color_error, data.object_id, truth_object)
    shows_object = first_mask & np.isin(truth_object, list(radius))
    wrong_surface = shows_object & (wrong | (color_error > WRONG_SURFACE_COLOR_ERROR))
    object_pixels = int(shows_object.sum())
    retraced = int((data.retraced & first_mask).sum())
    figures = Figures(
        mirror_pixels=count,
        color_rmse=rmse,
        psnr_db=float(20 * math.log10(1.0 / rmse)) if rmse > 0 else float("inf"),
        wrong_object_share=float(wrong.sum() / first_count) if first_count else 0.0,
        geometric_pixels=int(measured.sum()),
        geometric_error_median=float(np.median(values)) if len(values) else 0.0,
        geometric_error_p95=float(np.percentile(values, 95)) if len(values) else 0.0,
        geometric_error_max=float(values.max()) if len(values) else 0.0,
        worst_pixels=worst,
        direct_pixels=direct_pixels,
        direct_rmse=direct_rmse,
        glass_pixels=glass_pixels,
        glass_rmse=glass_rmse,
        object_pixels=object_pixels,
        wrong_surface_share=float(wrong_surface.sum() / object_pixels) if object_pixels else 0.0,
        retraced_pixels=retraced,
        retraced_share=float(retraced / first_count) if first_count else 0.0,
        samples=len(frames),
    )
    display = (renderer.scene.render.tone_mapping, renderer.scene.render.exposure)
    truth_frame = truths[0] if len(truths) == 1 else dataclasses.replace(truths[0], sub_frames=tuple(truths))
    return Comparison(render, truth_image, mask, geometric, figures, truth_frame, direct, display)


def _object_names(scene: Scene, index: int, key: str) -> dict[str, object]:
    """objects[index] as a report row names it: its index (`key`), its name and its label
    (Scene.object_label: a glTF part's node, mesh and material); NO_OBJECT is the environment."""
    if index == NO_OBJECT:
        return {key: index, f"{key}_name": "environment", f"{key}_label": "environment"}
    return {key: index, f"{key}_name": scene.objects[index].name, f"{key}_label": scene.object_label(index)}


def _worst_pixels(
    scene: Scene, mask: np.ndarray, wrong: np.ndarray, geometric: np.ndarray, color_error: np.ndarray,
    render_object: np.ndarray, truth_object: np.ndarray,
) -> list[dict[str, object]]:
    """The pixels to look at first: wrong objects, then the largest geometric and colour errors."""
    rows: list[dict[str, object]] = []
    score = np.where(mask, color_error, -1.0) + np.where(wrong, 10.0, 0.0) + np.nan_to_num(geometric, nan=0.0)
    for flat in np.argsort(score, axis=None)[::-1][:WORST_PIXELS]:
        y, x = np.unravel_index(flat, mask.shape)
        if not mask[y, x]:
            break
        rows.append({
            "x": int(x), "y": int(y),
            **_object_names(scene, int(render_object[y, x]), "object"),
            **_object_names(scene, int(truth_object[y, x]), "truth_object"),
            "color_error": round(float(color_error[y, x]), 4),
            "geometric_error": None if np.isnan(geometric[y, x]) else round(float(geometric[y, x]), 4),
        })
    return rows


def heat_map(comparison: Comparison, limit: float = 0.25) -> np.ndarray:
    """Per-pixel colour error inside the mirrors (and the pixels seen directly, in scenes with
    shadows), black -> red -> yellow -> white at `limit`; the rest of the frame in dim grey for
    context."""
    error = np.clip(np.abs(colour_error(comparison.render, comparison.truth)).max(axis=2) / limit, 0.0, 1.0)
    heat = np.stack([np.clip(3 * error, 0, 1), np.clip(3 * error - 1, 0, 1), np.clip(3 * error - 2, 0, 1)], axis=2)
    context = np.clip(comparison.render.mean(axis=2, keepdims=True), 0.0, 1.0) * 0.35
    return np.where((comparison.mirror_mask | comparison.direct_mask)[..., None], heat, context)


def write_report(comparison: Comparison, folder: Path, settings: dict[str, object], out: Outputs) -> list[Path]:
    """The report's images and JSON, written through `out` (in place once all of them are). The
    difference image is a chart: its false colours are written as they are, not encoded."""
    images = {
        "render.png": comparison.image(comparison.render), "truth.png": comparison.image(comparison.truth),
        "difference.png": quantize(heat_map(comparison)),
    }
    written = [out.image(folder / name, image) for name, image in images.items()]
    report = {"settings": settings, "colour_space": COLOUR_SPACE, "figures": asdict(comparison.figures)}
    written.append(out.text(folder / "report.json", json.dumps(report, indent=2) + "\n"))
    return written


def format_table(figures: Figures) -> str:
    rows = [
        ("mirror and glass pixels" if figures.glass_pixels else "mirror pixels", f"{figures.mirror_pixels}"),
        ("colour RMSE (linear)", f"{figures.color_rmse:.4f}"),
        ("PSNR", f"{figures.psnr_db:.2f} dB"),
        ("wrong object", f"{100 * figures.wrong_object_share:.3f} % of mirror pixels"),
        ("wrong surface", (f"{100 * figures.wrong_surface_share:.2f} % of the {figures.object_pixels} mirror pixels "
                           "that show an object")),
        ("geometric error, median", f"{100 * figures.geometric_error_median:.3f} % of the object's radius"),
        ("geometric error, 95th pct", f"{100 * figures.geometric_error_p95:.3f} %"),
        ("geometric error, max", f"{100 * figures.geometric_error_max:.3f} %"),
        ("pixels measured (geometry)", f"{figures.geometric_pixels}"),
    ]
    if figures.samples > 1:
        rows.append(("samples per pixel", f"{figures.samples}: colour figures on the averaged colours of render and "
                     "truth, object and geometric figures of the first sample's rays"))
    if figures.retraced_pixels:
        rows.append(("re-traced rays", f"{100 * figures.retraced_share:.2f} % of mirror pixels ({figures.retraced_pixels})"))
    if figures.glass_pixels:
        rows.append(("of which glass: RMSE", f"{figures.glass_rmse:.4f} over {figures.glass_pixels} pixels"))
    if figures.direct_pixels:
        rows.append(("seen directly (shadows): RMSE", f"{figures.direct_rmse:.4f} over {figures.direct_pixels} pixels"))
    width = max(len(name) for name, _ in rows)
    lines = [f"{name:<{width}}  {value}" for name, value in rows]
    lines.append("worst pixels (x, y: object / truth object, colour error, geometric error):")
    lines += [
        f"  {p['x']:>4}, {p['y']:>4}: {p['object_name']} / {p['truth_object_name']}, {p['color_error']}, "
        f"{p['geometric_error']}"
        for p in figures.worst_pixels
    ]
    return "\n".join(lines)


def mirror_crop(mask: np.ndarray, margin: int = 4) -> tuple[slice, slice]:
    """Rows and columns around every mirror pixel (the whole frame if there is none)."""
    rows, columns = np.nonzero(mask)
    if not len(rows):
        return slice(None), slice(None)
    height, width = mask.shape
    return (slice(max(rows.min() - margin, 0), min(rows.max() + margin + 1, height)),
            slice(max(columns.min() - margin, 0), min(columns.max() + margin + 1, width)))


#: Height of the label strip under each picture of a side-by-side sheet, in pixels.
LABEL_HEIGHT = 22


def side_by_side(comparisons: dict[str, Comparison]) -> np.ndarray:
    """Each method's mirror pixels and the truth's, cropped to the mirrors, in one labelled row
    (uint8). The truth is the same for every method (the same rays): the first one's is shown."""
    first = next(iter(comparisons.values()))
    rows, columns = mirror_crop(first.mirror_mask)
    pictures = {name: c.render for name, c in comparisons.items()} | {"truth (Embree)": first.truth}
    tiles = [first.image(picture[rows, columns]) for picture in pictures.values()]
    height, width = tiles[0].shape[:2]
    sheet = Image.new("RGB", (len(tiles) * (width + 2), height + LABEL_HEIGHT), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    font = load_font(14)
    for index, (name, tile) in enumerate(zip(pictures, tiles, strict=False)):
        sheet.paste(Image.fromarray(tile), (index * (width + 2), 0))
        draw.text((index * (width + 2) + 4, height + 3), name, fill=(0, 0, 0), font=font)
    return np.asarray(sheet)


def markdown_table(rows: dict[str, tuple[str, Figures]], refused: dict[str, str] | None = None) -> str:
    """One row per method: what it keeps, and its figures against the truth; a method that
    refused the scene (`refused`: why), a row saying so."""
    lines = [
        "| method | stand-in | wrong object | wrong surface | colour RMSE | PSNR | geometric error, median / 95th pct |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for name, (stand_in, f) in rows.items():
        lines.append(
            f"| `{name}` | {stand_in} | {100 * f.wrong_object_share:.2f} % | {100 * f.wrong_surface_share:.2f} % | "
            f"{f.color_rmse:.4f} | "
            f"{f.psnr_db:.1f} dB | {100 * f.geometric_error_median:.2f} % / {100 * f.geometric_error_p95:.1f} % |"
        )
    lines += [f"| `{name}` | refused: {why} | | | | | |" for name, why in (refused or {}).items()]
    return "\n".join(lines) + "\n"
