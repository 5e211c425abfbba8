"""The validated scene: frozen dataclasses, defaults as the file format states them.

The defaults here are the only copy: the loader reads a missing field's value from these classes.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
from fractions import Fraction
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol, TypeVar

import numpy as np

from depthimpostor.colour import TONE_MAPPINGS
from depthimpostor.constants import BLEND_IMAGE_CUTOFF, MAX_ANALYTIC_PLANES, SAMPLE_OFFSETS, Sides
from depthimpostor.meshes import Mesh
from depthimpostor.scene.fields import (
    RESOLUTION, SIZE, TRIANGLE_TARGET, UNIT, At, Bounds, Reader, Vec3, choice, number, word_or,
)

T = TypeVar("T")
ZERO: Vec3 = (0.0, 0.0, 0.0)

#: `impostor_resolution = "auto"`: the renderer picks each depth image's resolution itself.
AUTO_RESOLUTION = "auto"
#: What `impostor_resolution` may be, in the file and on the command line alike.
IMPOSTOR_RESOLUTION: Reader[int | str] = word_or(AUTO_RESOLUTION, RESOLUTION)
#: What `tone_mapping` and `exposure` may be, in the file and on the command line alike: 2^20 is
#: past any useful scale of a frame (and 2^exposure stays a finite float).
TONE_MAPPING = choice(TONE_MAPPINGS)
EXPOSURE = number(Bounds(-20.0, 20.0))
#: What `samples` may be, in the file and on the command line alike: the counts with a pattern.
SAMPLES = Reader(f"one of: {', '.join(str(n) for n in SAMPLE_OFFSETS)} (samples per pixel)",
                 lambda v: v if isinstance(v, int) and not isinstance(v, bool) and v in SAMPLE_OFFSETS else None)


@dataclass(frozen=True)
class RenderSettings:
    size: tuple[int, int] = (960, 540)  # output width, height in pixels
    impostor_resolution: int | str = 256  # depth-image width and height, or AUTO_RESOLUTION
    # color = albedo * (ambient + sum of lights' intensity * color * max(0, N.L))
    ambient: float = 0.15
    # The `simplified` method: each reflected object decimated to at most this many triangles.
    simplified_triangles: int = 500
    # MiB the baked images of one frame may take (their atlas, every layer and the depth buffer
    # they are baked with): where the per-object images at impostor_resolution would need more,
    # every image gets the largest side that fits (methods/baked_images.py budgeted_side; `plan`
    # says so). A thousand objects around two mirrors at 256^2 would need 2.6 GiB.
    image_memory: int = 1024
    # Width and height of each shadow map (a depth image from a light with shadows).
    shadow_resolution: int = 512
    # Mirror bounces a camera ray may make: at 1 a mirror does not appear in another mirror;
    # at k the depth images of bounce k show mirrors with their reflections of bounce k - 1.
    max_bounces: int = 1
    # The display transform of images written or shown (depthimpostor/colour.py, docs/colour.md):
    # the frame stays linear; 8-bit output is 2^exposure times it, tone mapped, sRGB encoded.
    tone_mapping: str = "none"  # "none" (clamped), "aces" or "reinhard"
    exposure: float = 0.0  # stops
    # Anti-aliasing: the frame is drawn once per sub-pixel position of SAMPLE_OFFSETS[samples] and
    # the linear colours averaged (renderer.py; docs/colour.md). 1 is one ray per pixel centre.
    samples: int = 1

    @property
    def auto_resolution(self) -> bool:
        """Is the depth images' resolution left to the renderer (`impostor_resolution = "auto"`)?"""
        return self.impostor_resolution == AUTO_RESOLUTION


@dataclass(frozen=True)
class Camera:
    eye: Vec3 = (0.0, 1.6, 5.0)
    target: Vec3 = (0.0, 0.6, 0.0)
    up: Vec3 = (0.0, 1.0, 0.0)
    fov_y: float = 45.0  # vertical, degrees


@dataclass(frozen=True)
class Environment:
    """What a reflected ray that hits nothing sees.

    A "gradient" blends zenith, horizon and ground (`color` is its horizon); a "constant" one has
    zenith = horizon = ground = color, so a shader can treat both alike. An "equirect" one is an
    HDR image (`image`, read from `path`) of every direction, longitude across and latitude down,
    times `intensity`, turned `rotation` degrees about +Y (shaders/lib/environment.glsl and
    truth.equirect_lookup state the lookup).
    """

    type: str = "gradient"
    color: Vec3 = (0.9, 0.9, 0.95)
    zenith: Vec3 = (0.35, 0.55, 0.9)
    horizon: Vec3 = (0.9, 0.9, 0.95)
    ground: Vec3 = (0.3, 0.28, 0.25)
    path: Path | None = None  # "equirect": the image file, resolved and absolute
    intensity: float = 1.0
    rotation: float = 0.0  # degrees, counter-clockwise about +Y seen from above
    # "equirect": (height, width, 3) float32 linear RGB, row 0 at the zenith, read-only. Not compared:
    # the path names it, and arrays have no single truth value.
    image: np.ndarray | None = dataclasses.field(default=None, compare=False, repr=False)

    @property
    def is_map(self) -> bool:
        """Is it an image (the shaders' ENVIRONMENT_MAP variant) rather than colours?"""
        return self.image is not None


def _vec3(v: np.ndarray) -> Vec3:
    x, y, z = (float(c) for c in v[:3])
    return (x, y, z)


@dataclass(frozen=True)
class Animation:
    """A steady turn about a line along `axis`: "rotate" turns a thing about its own position (an
    object about its local origin, a directional light's direction), "orbit" carries it round `centre`.

    `axis` is kept at unit length (whatever length it is given); the turn is right-handed, like
    `axis_rotation`: positive angles are counter-clockwise looking down the axis toward the origin.
    Time 0 is the scene as written.
    """

    type: str  # "rotate" or "orbit"
    axis: Vec3
    degrees_per_second: float  # never 0 from a scene file; negative turns the other way
    centre: Vec3 | None = None  # the orbit's centre; None for "rotate"

    def __post_init__(self) -> None:
        # hypot, not sqrt of a sum of squares: a tiny axis (1e-200) would square to 0 and divide by it.
        length = math.hypot(*self.axis)
        if not length > 0.0:  # the loader refuses such an axis; this guards code that builds one itself
            raise ValueError(f"Animation.axis: expected 3 numbers, not all zero, got {self.axis}")
        object.__setattr__(self, "axis", tuple(float(c) / length for c in self.axis))

    def angle(self, time: float) -> float:
        """Degrees turned at `time` seconds, in [0, 360): the turn repeats every full circle. Taken
        exactly (floats are rationals), so that a far time (1e308 s, whose product with the rate
        overflows to Inf, and whose cosine is then a domain error) still gives its true angle."""
        return float(Fraction(self.degrees_per_second) * Fraction(time) % 360)

    def pivot_of(self, position: Sequence[float]) -> Vec3:
        """The point the turn's line passes through for a thing at `position`."""
        return self.centre if self.centre is not None else _vec3(np.asarray(position, dtype=np.float64))

    def rotation(self, time: float) -> np.ndarray:
        """The 3x3 turn at `time` (Rodrigues' formula: c I + s [k]x + (1 - c) k k^T for unit axis k)."""
        radians = math.radians(self.angle(time))
        c, s = math.cos(radians), math.sin(radians)
        k = np.array(self.axis)
        cross = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
        return c * np.eye(3) + s * cross + (1.0 - c) * np.outer(k, k)

    def matrix(self, time: float, pivot: Sequence[float]) -> np.ndarray:
        """The 4x4 float64 rigid transform for column vectors turning by angle(time) about the line
        through `pivot` along `axis`: T(pivot) @ R @ T(-pivot)."""
        if self.angle(time) == 0.0:
            # Exactly the identity (cos 0 and sin 0 are exact, but p - R p need not be), so that a
            # scene at time 0 is bit for bit the scene as written.
            return np.eye(4)
        r, p = self.rotation(time), np.asarray(pivot, dtype=np.float64)
        m = np.eye(4)
        m[:3, :3] = r
        m[:3, 3] = p - r @ p
        return m


@dataclass(frozen=True)
class Light:
    """A "directional" light (`direction` is where it travels) or a "point" light at `position`.

    The vector a type does not use is (0, 0, 0). A point light may cast `shadows`: "hard" ones of
    its centre, or "soft" ones of a sphere of `radius` about it (an area light). A point light's
    `animation` can only orbit (one turned about itself stays put); a directional light's can only
    rotate its direction (it has no position to orbit).
    """

    type: str
    direction: Vec3 = ZERO
    position: Vec3 = ZERO
    color: Vec3 = (1.0, 1.0, 1.0)
    intensity: float = 1.0
    shadows: str = "none"  # "none", "hard" or "soft"
    radius: float = 0.0  # soft shadows' light radius; 0 otherwise
    animation: Animation | None = None

    @property
    def casts_shadows(self) -> bool:
        return self.shadows != "none"

    @property
    def moves(self) -> bool:
        return self.animation is not None

    def at(self, time: float) -> Light:
        """This light at `time` seconds: a point light's position, or a directional light's direction,
        turned by its animation. Call it on the light as written (the result keeps the animation,
        so that `moves` still says it moves, and turning it again would turn it twice)."""
        if self.animation is None:
            return self
        if self.type == "point":
            pivot = self.animation.pivot_of(self.position)
            position = self.animation.matrix(time, pivot) @ (*self.position, 1.0)
            return dataclasses.replace(self, position=_vec3(position))
        direction = self.animation.matrix(time, ZERO)[:3, :3] @ self.direction  # a direction has no pivot
        return dataclasses.replace(self, direction=_vec3(direction))


@dataclass(frozen=True)
class PlaneShape:
    size: tuple[float, float]  # width along local X, depth along local Z; the plane faces +Y


@dataclass(frozen=True)
class BoxShape:
    size: Vec3


@dataclass(frozen=True)
class SphereShape:
    radius: float


@dataclass(frozen=True)
class CylinderShape:
    radius: float
    height: float


@dataclass(frozen=True)
class TorusShape:
    major: float
    minor: float


@dataclass(frozen=True)
class TorusKnotShape:
    p: int
    q: int
    radius: float
    tube: float


@dataclass(frozen=True)
class MeshShape:
    path: Path  # resolved and absolute
    written: str  # as written in the scene file, for messages


class ShapeMotion(Protocol):
    """How a glTF part moves by its file's animation, skin or morph targets (scene/gltf_deform.py's
    PartMotion): rigidly, `matrix(time)` acting on its mesh before the object's own placement, or,
    where it `deforms`, as another mesh at each time (`mesh_at`, in the file's world space)."""

    @property
    def deforms(self) -> bool: ...

    def matrix(self, time: float) -> np.ndarray: ...

    def mesh_at(self, time: float) -> Mesh: ...


@dataclass(frozen=True)
class GltfShape:
    """One part of a glTF file: the triangles of one mesh node drawn with one of the file's
    materials (scene/gltf.py). `mesh` is in the file's world space, the node's transforms (and its
    parents') already applied, so that the object's own position, rotation and scale act on top.
    Which node, mesh and material it is: the object's `origin`. `motion`: how the file moves it
    (its mesh is then the part at time 0 where it deforms); None where it stays as written."""

    path: Path  # the file, resolved and absolute
    mesh: Mesh  # compared and hashed by identity (Mesh has eq=False): one part, one mesh
    motion: ShapeMotion | None = dataclasses.field(default=None, compare=False)


@dataclass(frozen=True)
class GltfOrigin:
    """Where in a glTF file an object comes from: the triangles of node `node`'s mesh drawn with
    one material (a node whose mesh has several materials makes one object of each). Names are ""
    where the file gives none. Messages name the object by it (`Scene.object_label`), as the file's
    author knows it, rather than by its place in the scene's list of objects."""

    file: str  # as the scene names it: the path given on the command line, or in the TOML scene
    node: int
    node_name: str
    mesh: int
    mesh_name: str
    primitives: tuple[int, ...]  # those of the mesh drawn with `material`, in the file's order
    material: int | None  # None: glTF's default material (primitives without one)
    material_name: str
    placed_by: int | None = None  # the TOML scene's [[objects]] entry that places the file; None: the file is the scene
    # What the file uses that the loader does not implement (gltf_file.ignored_features): the same
    # for every part of a file, for `plan` to list; not part of where the object comes from.
    ignored: tuple[str, ...] = dataclasses.field(default=(), compare=False)

    def describe(self) -> str:
        """`node 12 "Cylinder.003" (mesh 5 "piston", primitive 0, material 2 "steel")`."""
        def named(kind: str, index: int, name: str) -> str:
            return f"{kind} {index}" + (f" {json.dumps(name)}" if name else "")

        primitives = (f"primitive {self.primitives[0]}" if len(self.primitives) == 1
                      else f"primitives {', '.join(str(p) for p in self.primitives)}")
        material = "the default material" if self.material is None else named("material", self.material, self.material_name)
        return f"{named('node', self.node, self.node_name)} ({named('mesh', self.mesh, self.mesh_name)}, {primitives}, {material})"


Shape = PlaneShape | BoxShape | SphereShape | CylinderShape | TorusShape | TorusKnotShape | MeshShape | GltfShape


#: A texture's UV transform when it has none (Texture.uv_rows of the identity).
IDENTITY_UV_ROWS = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))


@dataclass(frozen=True, eq=False)
class Texture:
    """An image texture: a glTF material's baseColorTexture or other map, or a TOML `texture`. A
    base colour is the material's colour times the texel (decoded from sRGB to linear), at the
    mesh's `uvs` through the texture's transform (`uv_rows`: `scale`, then a glTF file's
    KHR_texture_transform offset and rotation). Compared by identity: a scene's distinct textures
    are its texture slots."""

    image: np.ndarray = dataclasses.field(repr=False)  # (H, W, 4) uint8 RGBA as stored (sRGB), row 0 the top
    sampler: dict[str, int]  # the glTF sampler: magFilter, minFilter, wrapS, wrapT where given
    mean_color: Vec3  # the mean of the image's RGB decoded to linear
    scale: tuple[float, float] = (1.0, 1.0)  # UV multipliers: how many times the image repeats across u and v
    name: str = ""  # what messages call it: the image file's name, or the glTF file's image
    # KHR_texture_transform's offset and rotation (radians, counter-clockwise in UV space), applied
    # after `scale`: uv' = T(offset) R(rotation) S(scale) uv, as the extension defines it.
    offset: tuple[float, float] = (0.0, 0.0)
    rotation: float = 0.0
    # Colour, stored sRGB-encoded (decoded to linear when sampled: a base colour, an emissive map);
    # False: data stored as it is (a metallic-roughness, normal or occlusion map).
    srgb: bool = True
    # The mesh's UV set it reads: 0 (TEXCOORD_0, `uvs`) or 1 (TEXCOORD_1, `uvs1`): glTF's texCoord.
    uv_set: int = 0

    @property
    def uv_rows(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """The UV transform's two rows (u' = a u + b v + c, v' = d u + e v + f): its texture record's
        uv_u and uv_v (lib/material_texture.glsl) and the truth's (textures.texture_bilinear)."""
        cos, sin = math.cos(self.rotation), math.sin(self.rotation)
        (su, sv), (ou, ov) = self.scale, self.offset
        return (cos * su, sin * sv, ou), (-sin * su, cos * sv, ov)

    @property
    def wrap(self) -> tuple[int, int]:
        """The (s, t) wrap modes: GL enums, REPEAT where the sampler gives none (glTF's default)."""
        return self.sampler.get("wrapS", 10497), self.sampler.get("wrapT", 10497)


@dataclass(frozen=True)
class DiffuseMaterial:
    color: Vec3 = (0.8, 0.8, 0.8)
    # An image texture (the per-vertex UVs are the object's mesh.uvs): the albedo is `color` times
    # its texel. Compared by identity.
    texture: Texture | None = None
    # glTF's doubleSided (docs/scene_format.md, "Faces"): True, both faces are drawn, a back face
    # shaded with its normal (and normal map's frame) turned toward the viewer; False, a back face
    # is not there (the eye's passes and the bakes cull it, a ray meeting it from behind passes
    # through). A glTF material says (false where it is not written). None (TOML's and code's
    # default, as their surfaces always were): both faces there, a back face shaded as the front.
    double_sided: bool | None = dataclasses.field(default=None, kw_only=True)


@dataclass(frozen=True)
class MetallicRoughnessMaterial(DiffuseMaterial):
    """glTF 2.0's material model (its specification's Appendix B: lib/brdf.glsl): `color` (times
    the `texture`'s texel) is the base colour, `metallic` mixes a dielectric (a diffuse base under a
    clear coat of F0 = 0.04) with a metal (F0 the base colour), `roughness` is the perceptual
    roughness of both lobes (alpha = roughness^2), `emissive` the light it gives off. A diffuse
    material for everything that only needs a colour (what a reflected ray's image holds, the
    panel's edits): its shading alone depends on the viewer."""

    metallic: float = 1.0
    roughness: float = 1.0
    emissive: Vec3 = (0.0, 0.0, 0.0)
    # glTF's alphaMode MASK: where alpha (the base colour factor's times the texture's) is under
    # `alpha_cutoff`, the surface is not there (every pass and the truth). None: opaque.
    alpha: float = 1.0
    alpha_cutoff: float | None = None
    # glTF's alphaMode BLEND: the surface covers `alpha` (times the texture's) of what lies behind
    # it: the eye's transparent pass blends it over, traced rays and the truth composite it
    # (BLEND_LAYERS), and what holds one surface a texel (baked images, shadow maps) holds it where
    # alpha >= BLEND_IMAGE_CUTOFF (docs/scene_format.md, "Transparency"). Never with alpha_cutoff.
    blend: bool = False
    # glTF's other maps (linear data but the emissive map, which is colour): metalness in B and
    # roughness in G (times the factors), ambient occlusion in R (mixed in by occlusion_strength:
    # it darkens the ambient term alone), and the emission times `emissive`.
    metallic_roughness_texture: Texture | None = None
    occlusion_texture: Texture | None = None
    occlusion_strength: float = 1.0
    emissive_texture: Texture | None = None
    # glTF's normalTexture: a tangent-space normal (RGB = (x, y, z) * 0.5 + 0.5, linear data) that
    # turns the shading normal (not the geometry: lib/shading.glsl's mapped_normal), its x and y
    # times normal_scale. It reads the mesh's tangents (the file's, or generated: scene/tangents.py).
    normal_texture: Texture | None = None
    normal_scale: float = 1.0

    @property
    def maps(self) -> tuple[Texture | None, Texture | None, Texture | None, Texture | None]:
        """The metallic-roughness, occlusion, emissive and normal maps, in the material record's order."""
        return self.metallic_roughness_texture, self.occlusion_texture, self.emissive_texture, self.normal_texture

    @property
    def masked(self) -> bool:
        """Can parts of it be cut away (alphaMode MASK)?"""
        return self.alpha_cutoff is not None

    @property
    def image_cutoff(self) -> float | None:
        """The cutoff of what holds one surface a texel (baked images, shadow maps): a mask's own,
        BLEND_IMAGE_CUTOFF for a blended material, None where nothing is cut."""
        return BLEND_IMAGE_CUTOFF if self.blend else self.alpha_cutoff


def material_textures(material: object) -> tuple[Texture, ...]:
    """Every image texture a material reads: its base colour's, then a metallic-roughness
    material's other maps."""
    texture = getattr(material, "texture", None)
    found = [texture] if isinstance(texture, Texture) else []
    if isinstance(material, MetallicRoughnessMaterial):
        found += [m for m in material.maps if m is not None]
    return tuple(found)


@dataclass(frozen=True)
class CheckerMaterial:
    color_a: Vec3
    color_b: Vec3
    scale: float = 1.0  # the side of one square, in world units
    double_sided: bool | None = dataclasses.field(default=None, kw_only=True)  # as DiffuseMaterial's


@dataclass(frozen=True)
class MirrorMaterial:
    """A metal mirror: `tint` what it multiplies the light it reflects by; `roughness` in [0, 1]
    its GGX roughness (alpha = roughness^2): 0 a perfect mirror (one reflected ray), above it a
    glossy one (docs/methods_and_results.md, "Glossy mirrors")."""

    tint: Vec3 = (1.0, 1.0, 1.0)
    roughness: float = 0.0

    @property
    def is_rough(self) -> bool:
        return self.roughness > 0.0


@dataclass(frozen=True)
class GlassMaterial:
    """A clear dielectric: `ior` its index of refraction (air's is 1), `tint` what the light it
    transmits is multiplied by (the reflected part is not tinted)."""

    ior: float = 1.5
    tint: Vec3 = (1.0, 1.0, 1.0)


Material = DiffuseMaterial | CheckerMaterial | MirrorMaterial | GlassMaterial


def material_sides(material: Material) -> Sides:
    """Which faces of `material`'s surfaces are there and how a back face is shaded (its
    double_sided). Mirrors and glass: both, as the front (a mirror's back is its backing, shaded
    by its own rule; glass has an inside)."""
    sided = material.double_sided if isinstance(material, (DiffuseMaterial, CheckerMaterial)) else None
    return Sides.AS_FRONT if sided is None else Sides.DOUBLE if sided else Sides.SINGLE


def single_sided(material: Material) -> bool:
    """Is `material` single-sided (glTF's doubleSided false): are its back faces not there?"""
    return material_sides(material) == Sides.SINGLE


def axis_rotation(axis: int, degrees: float) -> np.ndarray:
    """The right-handed 3x3 rotation about X, Y or Z (0, 1, 2) for column vectors: X by 90 takes +Y to +Z."""
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    i, j = ((1, 2), (2, 0), (0, 1))[axis]  # the plane the rotation turns, in right-handed order
    r = np.eye(3)
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


@dataclass(frozen=True)
class SceneObject:
    name: str
    shape: Shape
    material: Material = DiffuseMaterial()
    position: Vec3 = ZERO
    rotation: Vec3 = ZERO  # degrees about X, then Y, then Z
    scale: Vec3 = (1.0, 1.0, 1.0)
    animation: Animation | None = None
    origin: GltfOrigin | None = None  # the node, mesh and material of a glTF file it is; None: written in TOML or code

    @property
    def moves(self) -> bool:
        """Does it move: a TOML animation, or its glTF file's (gltf_deform.py)?"""
        return self.animation is not None or self.motion is not None

    @property
    def motion(self) -> ShapeMotion | None:
        """How its glTF file moves it (GltfShape.motion), or None."""
        return self.shape.motion if isinstance(self.shape, GltfShape) else None

    @property
    def deforms(self) -> bool:
        """Is its mesh another at each time (a glTF skin or morph targets), not only its transform?"""
        return self.motion is not None and self.motion.deforms

    @property
    def is_mirror(self) -> bool:
        return isinstance(self.material, MirrorMaterial)

    @property
    def is_glass(self) -> bool:
        return isinstance(self.material, GlassMaterial)

    @property
    def is_diffuse_plane(self) -> bool:
        """A plane that is neither a mirror nor glass (a floor, a wall, a glTF rectangle): one the
        scene may intersect exactly rather than through a stand-in (Scene.analytic_plane_indices)."""
        return isinstance(self.shape, PlaneShape) and not self.is_reflector

    @property
    def plane_area(self) -> float:
        """The world area of a plane shape (the model matrix's scale acts before its rotation, so
        the rectangle's sides are scaled by scale.x and scale.z alone); 0 for other shapes."""
        if not isinstance(self.shape, PlaneShape):
            return 0.0
        return abs(self.shape.size[0] * self.scale[0] * self.shape.size[1] * self.scale[2])

    @property
    def is_blended(self) -> bool:
        """Does it cover a share of what lies behind it (glTF's alphaMode BLEND)? The eye draws it
        in the transparent pass, after everything opaque."""
        return isinstance(self.material, MetallicRoughnessMaterial) and self.material.blend

    @property
    def is_reflector(self) -> bool:
        """Does what it shows depend on rays traced from its surface (a mirror, glass)? Such an
        object is drawn by the reflector pass and gets depth images of the others."""
        return self.is_mirror or self.is_glass

    def model_matrix(self, time: float = 0.0) -> np.ndarray:
        """Local to world at `time` seconds, 4x4 float64 for column vectors: A(time) @ T @ Rz @ Ry @ Rx @ S
        (@ G(time) for a glTF part its file moves rigidly: GltfShape.motion), so the file's motion acts
        first, then scale, and the animation A (the identity without one, or at time 0) last."""
        m = placement_matrices([self])[0]
        motion = self.motion
        if motion is not None and not motion.deforms:
            m = m @ motion.matrix(time)
        if self.animation is None:
            return m
        return self.animation.matrix(time, self.animation.pivot_of(self.position)) @ m


def placement_matrices(objects: Sequence[SceneObject]) -> np.ndarray:
    """T @ Rz @ Ry @ Rx @ S of each of `objects`, (n, 4, 4) float64: where its position, rotation and
    scale put it, before what moves it (SceneObject.model_matrix, the one object's case, and a still
    object's whole model matrix). All at once: numpy's stacked matmul makes each matrix's BLAS call
    as one matrix's `@` does, so an object's matrix is the same to the bit in any company (a thousand
    objects' one by one, three np.eye and three products each, took 40 ms of a start)."""
    count = len(objects)
    # turns[axis]: the turn about that axis (as axis_rotation makes one) of every object.
    turns = np.zeros((3, count, 3, 3))
    for axis in range(3):
        radians = [math.radians(o.rotation[axis]) for o in objects]
        c = np.array([math.cos(r) for r in radians], np.float64)
        s = np.array([math.sin(r) for r in radians], np.float64)
        i, j = ((1, 2), (2, 0), (0, 1))[axis]
        turns[axis, :, axis, axis] = 1.0
        turns[axis, :, i, i], turns[axis, :, i, j], turns[axis, :, j, i], turns[axis, :, j, j] = c, -s, s, c
    scales = np.zeros((count, 3, 3))
    scales[:, [0, 1, 2], [0, 1, 2]] = np.array([o.scale for o in objects], np.float64).reshape(count, 3)
    models = np.zeros((count, 4, 4))
    models[:, 3, 3] = 1.0
    models[:, :3, :3] = turns[2] @ turns[1] @ turns[0] @ scales
    models[:, :3, 3] = np.array([o.position for o in objects], np.float64).reshape(count, 3)
    return models


@dataclass(frozen=True)
class Scene:
    source: str  # the file it came from, for messages
    render: RenderSettings
    camera: Camera
    environment: Environment
    lights: tuple[Light, ...]
    objects: tuple[SceneObject, ...]

    @property
    def animated(self) -> bool:
        """Does anything move (an object or a light with an animation)?"""
        return any(o.moves for o in self.objects) or any(light.moves for light in self.lights)

    def lights_at(self, time: float) -> tuple[Light, ...]:
        """The lights at `time` seconds, in the same order as `lights`."""
        return tuple(light.at(time) for light in self.lights)

    @property
    def mirrors(self) -> tuple[SceneObject, ...]:
        return tuple(o for o in self.objects if o.is_mirror)

    @property
    def has_rough_mirrors(self) -> bool:
        """Does a mirror have roughness > 0? Only then do the reflectors' GLOSSY variant and the
        baked images' colour mips exist (a perfect mirror's frame is the same program's as ever)."""
        return any(isinstance(o.material, MirrorMaterial) and o.material.is_rough for o in self.objects)

    @property
    def glass(self) -> tuple[SceneObject, ...]:
        return tuple(o for o in self.objects if o.is_glass)

    @property
    def reflectors(self) -> tuple[SceneObject, ...]:
        """Mirrors and glass: the objects whose pixels trace rays into the others."""
        return tuple(o for o in self.objects if o.is_reflector)

    @functools.cached_property
    def analytic_plane_indices(self) -> frozenset[int]:
        """The diffuse planes every method intersects exactly (lib/reflected_scene.glsl's
        nearest_plane_hit, from a uniform array of MAX_ANALYTIC_PLANES), by object index: the one
        place that decides it (world.py, plan.py, the passes and the truth read it).

        An exact plane is an optimisation, never a limit: it is what a floor around a mirror needs
        (no pinhole image from the mirror's centre holds a plane it stands on), and it pays most
        where a plane is large (one exact rectangle test per reflected ray, where a depth image of
        a large floor or wall seen at a grazing angle is coarse). So the MAX_ANALYTIC_PLANES
        largest by world area are chosen, ties by object order (a stable sort: the choice is the
        same at every load), and every other diffuse plane is an ordinary mesh object: drawn,
        baked, traced and seen by the truth as a box is. A scene of at most MAX_ANALYTIC_PLANES
        planes has them all exact. Computed once: the fields are frozen (and an animation turns
        a plane without changing its area)."""
        planes = [i for i, o in enumerate(self.objects) if o.is_diffuse_plane]
        largest = sorted(planes, key=lambda i: -self.objects[i].plane_area)[:MAX_ANALYTIC_PLANES]
        return frozenset(largest)

    @property
    def analytic_planes(self) -> tuple[SceneObject, ...]:
        """The planes every method intersects exactly (analytic_plane_indices), in the order the shaders list them."""
        return tuple(o for i, o in enumerate(self.objects) if i in self.analytic_plane_indices)

    @property
    def mesh_planes(self) -> tuple[SceneObject, ...]:
        """The diffuse planes left to be drawn as meshes (past the MAX_ANALYTIC_PLANES largest)."""
        return tuple(o for i, o in enumerate(self.objects) if o.is_diffuse_plane and i not in self.analytic_plane_indices)

    @property
    def shadowed_lights(self) -> tuple[int, ...]:
        """Indices of the lights that cast shadows (each gets a shadow map)."""
        return tuple(i for i, light in enumerate(self.lights) if light.casts_shadows)

    @property
    def shadow_casters(self) -> tuple[SceneObject, ...]:
        """What casts shadows: every object but the planes (floors and walls only receive them),
        exact or drawn as meshes alike, so that which planes are exact changes no shadow."""
        return tuple(o for o in self.objects if not isinstance(o.shape, PlaneShape))

    @property
    def has_shadows(self) -> bool:
        """Does any light cast a shadow on anything? Only then do shadow maps and the shaders'
        SHADOWS variant exist."""
        return bool(self.shadowed_lights and self.shadow_casters)

    @functools.cached_property
    def _entries(self) -> tuple[int, ...]:
        """Each object's [[objects]] entry in a TOML scene: a glTF file placed by one entry makes
        several objects, so that the entries after it are numbered apart from the objects."""
        entries, entry = [], -1
        for obj in self.objects:
            placed_by = obj.origin.placed_by if obj.origin is not None else None
            entry = placed_by if placed_by is not None else entry + 1
            entries.append(entry)
        return tuple(entries)

    def object_label(self, index: int, field: str = "") -> str:
        """How a message names objects[index] (and its `field`, a dotted path of the TOML format):
        `objects[3].material` for an object written in TOML; a glTF file's node, mesh, primitives
        and material for one of its parts (GltfOrigin.describe), after the TOML entry that places
        the file where one does: `objects[0] (room.glb) node 12 "Cylinder.003" (mesh 5 ...)`."""
        origin = self.objects[index].origin
        suffix = f".{field}" if field else ""
        if origin is None:
            return f"objects[{self._entries[index]}]{suffix}"
        part = origin.describe() + (f" {field}" if field else "")
        return part if origin.placed_by is None else f"objects[{origin.placed_by}] ({origin.file}) {part}"

    @functools.cached_property
    def textures(self) -> tuple[Texture, ...]:
        """The distinct image textures of the objects' materials (by identity), in object order, a
        material's base colour texture before its other maps: texture slot k is the k-th (record k
        of gpu/textures.py's table: its array, layer, wraps, transform). Computed once: the fields
        are frozen."""
        seen: dict[int, Texture] = {}
        for obj in self.objects:
            for texture in material_textures(obj.material):
                seen.setdefault(id(texture), texture)
        return tuple(seen.values())

    @functools.cached_property
    def _texture_slots(self) -> dict[int, int]:
        return {id(texture): k for k, texture in enumerate(self.textures)}

    def texture_slot(self, material: Material) -> int:
        """The slot of the material's (base colour) texture, or -1 for a material without one."""
        return self.slot_of(getattr(material, "texture", None))

    def slot_of(self, texture: Texture | None) -> int:
        """The slot of one of the scene's textures, or -1 for none."""
        return -1 if texture is None else self._texture_slots[id(texture)]

    @functools.cached_property
    def materials(self) -> tuple[Material, ...]:
        """The distinct materials of the objects that are shaded (neither mirrors nor glass), in
        object order: material index k is the k-th (record k of lib/shading.glsl's MaterialRecords
        table, which every pass reads: gpu/scene_blocks.py). Equal materials share one record."""
        return tuple(dict.fromkeys(o.material for o in self.objects if not o.is_reflector))

    @functools.cached_property
    def _material_indices(self) -> dict[Material, int]:
        return {material: k for k, material in enumerate(self.materials)}

    def material_index(self, material: Material) -> int:
        """The index of a shaded object's material in the MaterialRecords table."""
        return self._material_indices[material]

    @functools.cached_property
    def diffuse_objects(self) -> tuple[SceneObject, ...]:
        """What the diffuse pass draws and a first bounce sees: everything but mirrors and glass
        (kept: each program's defines ask, 14 times over a thousand objects at a renderer's start)."""
        return tuple(o for o in self.objects if not o.is_reflector)

    def with_roughness(self, roughness: float) -> Scene:
        """This scene with every mirror's roughness set to `roughness` (tools/glossy_table.py's
        family of glossy scenes), checked as the file's field is."""
        value = At("command line", "").key("roughness").read(roughness, number(UNIT))
        objects = tuple(dataclasses.replace(o, material=dataclasses.replace(o.material, roughness=value))
                        if isinstance(o.material, MirrorMaterial) else o for o in self.objects)
        return dataclasses.replace(self, objects=objects)

    def with_overrides(self, size: tuple[int, int] | None = None, impostor_resolution: int | str | None = None,
                       simplified_triangles: int | None = None, tone_mapping: str | None = None,
                       exposure: float | None = None, samples: int | None = None,
                       source: str = "command line") -> Scene:
        """This scene with render settings from the command line, checked as strictly as the file's.
        Another `source` (the Python API's function) names each value by its argument, not its option;
        numpy numbers and arrays are taken as the Python numbers and lists they hold."""
        at = At(source, "")

        def read(option: str, argument: str, value: object, reader: Reader[T]) -> T:
            return at.key(option if source == "command line" else argument).read(_plain(value), reader)

        render = self.render
        if size is not None:
            render = dataclasses.replace(render, size=read("--size", "size", size, SIZE))
        if impostor_resolution is not None:
            resolution = read("--impostor-res", "impostor_resolution", impostor_resolution, IMPOSTOR_RESOLUTION)
            render = dataclasses.replace(render, impostor_resolution=resolution)
        if simplified_triangles is not None:
            target = read("--simplified-triangles", "simplified_triangles", simplified_triangles, TRIANGLE_TARGET)
            render = dataclasses.replace(render, simplified_triangles=target)
        if tone_mapping is not None:
            render = dataclasses.replace(render, tone_mapping=read("--tone-mapping", "tone_mapping", tone_mapping,
                                                                   TONE_MAPPING))
        if exposure is not None:
            render = dataclasses.replace(render, exposure=read("--exposure", "exposure", exposure, EXPOSURE))
        if samples is not None:
            render = dataclasses.replace(render, samples=read("--samples", "samples", samples, SAMPLES))
        return dataclasses.replace(self, render=render)


def _plain(value: object) -> object:
    """A numpy scalar or array as the Python number or list it holds (a size of np.int64s reads as
    one of ints); anything else as it is."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return type(value)(_plain(item) for item in value)
    return value.item() if isinstance(value, np.generic) else value
