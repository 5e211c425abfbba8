"""What a user would pick instead, timed beside the methods (`bench --peers`, issue 35, item 3).

Two peers, each drawing the same scene through the same camera at the same size:
- **Mitsuba 3** (`pip install -e ".[peers]"`), an offline CPU path tracer: its LLVM variant
  (llvm_ad_rgb, vectorized and multi-threaded; scalar_rgb where no LLVM that Dr.Jit can use is
  found), 1 sample a pixel, exact mirrors (a conductor of reflectance `tint`), depth 3: the eye's
  ray, one mirror bounce, then the light. What it gets right is the geometry of every reflection,
  exactly; what it shades differently from this project is listed in `MitsubaPeer`'s docstring.
- **No reflections**: this project's renderer with every mirror and glass made a grey diffuse
  surface, so that no mirror pass runs. Its frame is the floor every method pays (the eye's
  diffuse pass, shadows, the environment); its mirrors show no reflection at all.

Each peer's error is the colour RMSE over the truth's mirror pixels, against the same truth as the
methods (oracles/compare.py: linear colour, unclamped: colour_error).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
import glob
import math
import os
import re
import time
from typing import TYPE_CHECKING, Any, Protocol

import moderngl
import numpy as np

from .constants import Algorithm, Method
from .oracles.compare import TruthFrame, colour_error
from .oracles.truth import environment
from .ppc import PPC
from .renderer import Renderer
from .scene import Scene
from .scene.model import CheckerMaterial, DiffuseMaterial, GlassMaterial, MirrorMaterial
from .world import World

if TYPE_CHECKING:
    from .bench import BenchRow

#: Mitsuba's variants, fastest first: the LLVM one needs a libLLVM that Dr.Jit can use (16 or later:
#: it emits instructions LLVM 15 cannot select, and LLVM aborts the process rather than raise).
MITSUBA_VARIANTS = ("llvm_ad_rgb", "scalar_rgb")
MIN_LLVM = 16
#: The environment map's size for a gradient (it varies with height alone) and for an image.
GRADIENT_MAP, IMAGE_MAP = (64, 32), (512, 256)
#: The grey of the mirrors the no-reflection peer draws as diffuse surfaces.
NO_REFLECTION_GREY = (0.5, 0.5, 0.5)


@dataclass(frozen=True)
class PeerRow:
    """One peer on one scene: its frame times, in the methods' rounds, and its error."""

    scene: str
    peer: str
    variant: str  # Mitsuba's variant; "" for the no-reflection renderer
    color_rmse: float  # over the truth's mirror pixels
    frame_ms_median: float
    frame_ms_p10: float
    frame_ms_p90: float


class Peer(Protocol):
    name: str
    seconds: list[float]  # one per frame drawn

    def render(self) -> None: ...

    def image(self) -> np.ndarray: ...  # the last frame's linear colour, (height, width, 3), top row first

    def release(self) -> None: ...


def _llvm_library() -> str | None:
    """The newest libLLVM of version MIN_LLVM or later on the library path, for Dr.Jit's LLVM variant."""
    found = []
    for path in glob.glob("/usr/lib/*/libLLVM*.so*") + glob.glob("/usr/lib/llvm-*/lib/libLLVM*.so*"):
        match = re.search(r"libLLVM(?:-|\.so\.)(\d+)", path)
        if match and int(match.group(1)) >= MIN_LLVM:
            found.append((int(match.group(1)), path))
    return max(found)[1] if found else None


def mitsuba_variant() -> str:
    """The variant to use, chosen (and Dr.Jit pointed at its LLVM) before Mitsuba is imported:
    DEPTHIMPOSTOR_MITSUBA_VARIANT where set, else llvm_ad_rgb where a usable LLVM is found."""
    chosen = os.environ.get("DEPTHIMPOSTOR_MITSUBA_VARIANT")
    if chosen:
        return chosen
    if "DRJIT_LIBLLVM_PATH" not in os.environ:
        library = _llvm_library()
        if library is None:
            return MITSUBA_VARIANTS[1]
        os.environ["DRJIT_LIBLLVM_PATH"] = library
    return MITSUBA_VARIANTS[0]


def _mitsuba() -> Any:
    variant = mitsuba_variant()
    import mitsuba  # the optional extra: `pip install -e ".[peers]"`

    mitsuba.set_variant(variant)
    return mitsuba


def _sensor(camera: PPC) -> dict[str, Any]:
    """A perspective sensor of the camera's eye, view, up and vertical field of view."""
    width, height = camera.width, camera.height
    centre = camera.a * width / 2 + camera.b * height / 2 + camera.c  # the centre pixel's ray
    distance = float(np.linalg.norm(centre))
    fov_y = math.degrees(2.0 * math.atan(float(np.linalg.norm(camera.b)) * height / 2 / distance))
    eye = np.asarray(camera.C, float)
    return {
        "type": "perspective", "fov": fov_y, "fov_axis": "y",
        "to_world": _mi_transform_look_at(eye, eye + centre / distance, -np.asarray(camera.b, float)),
        "film": {"type": "hdrfilm", "width": width, "height": height, "pixel_format": "rgb",
                 "rfilter": {"type": "box"}},
        "sampler": {"type": "independent", "sample_count": 1},
    }


def _mi_transform_look_at(origin: np.ndarray, target: np.ndarray, up: np.ndarray) -> Any:
    mi = _mitsuba()
    return mi.ScalarTransform4f().look_at(origin=origin.tolist(), target=target.tolist(), up=up.tolist())


def _bsdf(material: object, mi: Any) -> dict[str, Any]:
    if isinstance(material, MirrorMaterial):
        return {"type": "conductor", "material": "none",
                "specular_reflectance": {"type": "rgb", "value": list(material.tint)}}
    if isinstance(material, GlassMaterial):
        return {"type": "dielectric", "int_ior": material.ior, "ext_ior": 1.0,
                "specular_transmittance": {"type": "rgb", "value": list(material.tint)}}
    if isinstance(material, CheckerMaterial):  # its squares' mean (see MitsubaPeer)
        colour = (np.asarray(material.color_a) + np.asarray(material.color_b)) / 2
    elif isinstance(material, DiffuseMaterial):
        colour = np.asarray(material.color)
    else:  # glTF's metallic-roughness: its base colour
        colour = np.asarray(getattr(material, "color", getattr(material, "base_color", (0.8, 0.8, 0.8))))[:3]
    return {"type": "diffuse", "reflectance": {"type": "rgb", "value": [float(v) for v in colour]}}


def _environment(scene: Scene, mi: Any) -> dict[str, Any]:
    """The scene's environment as Mitsuba's lat-long map: texel (u, v) is the direction at polar
    angle v pi from +Y and azimuth atan2(x, -z) = 2 pi u - pi (Mitsuba's envmap lookup)."""
    width, height = IMAGE_MAP if scene.environment.is_map else GRADIENT_MAP
    v, u = np.mgrid[0:height, 0:width] + 0.5
    polar, azimuth = v / height * np.pi, u / width * 2 * np.pi - np.pi
    directions = np.stack([np.sin(polar) * np.sin(azimuth), np.cos(polar), -np.sin(polar) * np.cos(azimuth)], axis=-1)
    colours = environment(scene, directions.reshape(-1, 3)).reshape(height, width, 3)
    return {"type": "envmap", "bitmap": mi.Bitmap(np.ascontiguousarray(colours, np.float32))}


def _emitters(scene: Scene, world: World) -> dict[str, Any]:
    """Each light as Mitsuba's: a directional light of irradiance pi x intensity x colour (Mitsuba's
    Lambert is albedo / pi, this project's albedo); a point light of the intensity that gives the
    same irradiance at the scene's centre (Mitsuba's falls off with the square of the distance,
    this project's does not)."""
    centres = [item.bounding_sphere[0] for item in world.geometry]
    centre = np.mean(centres, axis=0) if centres else np.zeros(3)
    emitters: dict[str, Any] = {}
    for index, light in enumerate(scene.lights):
        power = [math.pi * light.intensity * c for c in light.color]
        if light.type == "directional":
            emitters[f"light{index}"] = {"type": "directional", "direction": list(light.direction),
                                         "irradiance": {"type": "rgb", "value": power}}
        else:
            squared = float(np.sum((np.asarray(light.position) - centre) ** 2)) or 1.0
            emitters[f"light{index}"] = {"type": "point", "position": list(light.position),
                                         "intensity": {"type": "rgb", "value": [p / math.pi * squared for p in power]}}
    return emitters


class MitsubaPeer:
    """The scene converted for Mitsuba 3 and drawn by its path tracer, one sample a pixel.

    Converted as they are: every object's world-space triangles and smooth normals, the camera,
    mirrors (exact, tinted), glass (a smooth dielectric), directional lights and the environment
    (as a lat-long map). Shaded otherwise, and so part of its error: diffuse surfaces are lit by the
    environment map (a path tracer's sky light, with its occlusion) instead of this project's flat
    `render.ambient`; a checker is its squares' mean colour and a texture its material's colour
    factor; a point light falls off with distance; and one sample a pixel is noisy.
    """

    name = "mitsuba"

    def __init__(self, scene: Scene, world: World, camera: PPC) -> None:
        self.mi = mi = _mitsuba()
        self.variant = str(mi.variant())
        shapes: dict[str, Any] = {}
        for item in world.geometry:
            mesh = item.world_mesh
            shape = mi.Mesh(f"object{item.index}", vertex_count=len(mesh.positions), face_count=len(mesh.indices),
                            has_vertex_normals=True, has_vertex_texcoords=False)
            parameters = mi.traverse(shape)
            parameters["vertex_positions"] = np.ascontiguousarray(mesh.positions, np.float32).ravel()
            parameters["vertex_normals"] = np.ascontiguousarray(mesh.normals, np.float32).ravel()
            parameters["faces"] = np.ascontiguousarray(mesh.indices, np.uint32).ravel()
            parameters.update()
            shape.set_bsdf(mi.load_dict(_bsdf(item.object.material, mi)))
            shapes[f"object{item.index}"] = shape
        self.scene = mi.load_dict({
            "type": "scene",
            "integrator": {"type": "path", "max_depth": 3, "rr_depth": 100},
            "sensor": _sensor(camera),
            "environment": _environment(scene, mi),
            **_emitters(scene, world),
            **shapes,
        })
        self.seconds: list[float] = []
        self._image: np.ndarray | None = None
        self._seed = 0

    def render(self) -> None:
        start = time.perf_counter()
        image = self.mi.render(self.scene, spp=1, seed=self._seed)
        self._image = np.array(image)  # waits for the frame (Dr.Jit evaluates lazily)
        self.seconds.append(time.perf_counter() - start)
        self._seed += 1

    def image(self) -> np.ndarray:
        if self._image is None:
            raise RuntimeError("no frame rendered yet")
        return self._image[..., :3].astype(np.float32)

    def release(self) -> None:
        self.scene = None


def without_reflectors(scene: Scene) -> Scene:
    """`scene` with every mirror and glass object a grey diffuse surface: nothing for a mirror pass."""
    objects = tuple(dataclasses.replace(o, material=DiffuseMaterial(color=NO_REFLECTION_GREY))
                    if o.is_reflector else o for o in scene.objects)
    return dataclasses.replace(scene, objects=objects)


class NoReflectionPeer:
    """This project's renderer on the scene without reflectors: the diffuse pass alone."""

    name = "no reflections"

    def __init__(self, ctx: moderngl.Context, scene: Scene) -> None:
        self.renderer = Renderer(ctx, without_reflectors(scene), Algorithm.OPTIMIZED, method=Method.DEPTH)
        self.seconds = self.renderer.stats.draw_seconds

    def render(self) -> None:
        self.renderer.render()

    def image(self) -> np.ndarray:
        return self.renderer.read_color_float()

    def release(self) -> None:
        self.renderer.release()


def make_peers(ctx: moderngl.Context, scene: Scene, world: World, camera: PPC) -> list[Peer]:
    return [MitsubaPeer(scene, world, camera), NoReflectionPeer(ctx, scene)]


def mirror_rmse(image: np.ndarray, truth: TruthFrame) -> float:
    """Colour RMSE over the truth's mirror pixels, as compare measures a method's."""
    mask = truth.mirror_mask
    if not mask.any():
        return 0.0
    return float(np.sqrt((colour_error(image, truth.color)[mask] ** 2).mean()))


def peers_markdown(rows: Sequence[BenchRow], peer_rows: Sequence[PeerRow], header: Sequence[str]) -> str:
    """Per scene: every method's and peer's frame and mirror error, and each peer's frame time as a
    ratio to each one's (above 1: the peer is slower)."""
    lines = [f"{line}  " for line in header] + [""]
    for scene in dict.fromkeys(row.scene for row in peer_rows):
        peers = [row for row in peer_rows if row.scene == scene]
        lines += [f"### {scene}", "", "| drawn by | frame ms (median, p10-p90) | colour RMSE in the mirrors | "
                  + " | ".join(f"{peer.peer} frame / this frame" for peer in peers) + " |",
                  "|---|---:|---:|" + "---:|" * len(peers)]
        entries = [(_method_label(row), row.frame_ms_median, row.frame_ms_p10, row.frame_ms_p90, row.color_rmse)
                   for row in rows if row.scene == scene]
        entries += [(f"**{peer.peer}**" + (f" ({peer.variant})" if peer.variant else ""), peer.frame_ms_median,
                     peer.frame_ms_p10, peer.frame_ms_p90, peer.color_rmse) for peer in peers]
        for label, median, p10, p90, rmse in entries:
            ratios = " | ".join(f"{peer.frame_ms_median / median:.2f}" for peer in peers)
            lines.append(f"| {label} | {median:.1f} ({p10:.1f}-{p90:.1f}) | {rmse:.4f} | {ratios} |")
        lines.append("")
    return "\n".join(lines)


def _method_label(row: BenchRow) -> str:
    algorithm = "" if row.algorithm == "-" else f" {row.algorithm}"
    resolution = f", images {row.resolution}" if row.resolution else ""
    return f"`{row.method}`{algorithm}{resolution}"
