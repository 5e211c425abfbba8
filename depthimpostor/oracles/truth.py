"""Ray-traced truth: each mirror pixel's reflected ray (and each glass pixel's reflected and
refracted rays) traced against the real triangles.

Primary visibility comes from the rasterizer's own frame (the renderer's reflection outputs give
each mirror pixel's reflected ray), so that outside the mirrors the truth *is* the render and
inside them only the approximation differs. The reflected rays are traced on the CPU with Embree
(embreex) against the same world-space meshes the renderer draws, the analytic planes are
intersected as in the shader, and hits are shaded with the same model as shaders/lib/shading.glsl
(albedo * (ambient + lights), smooth normals interpolated from the same vertex normals). Shadows
are the real ones: the rays the shadow maps are marched with (lights.py) traced against the real
casters. A mirror reflects on its front side alone (where its counter-clockwise faces face): a ray
that meets one from behind sees its backing, a diffuse grey (MIRROR_BACKING_ALBEDO). A glossy
mirror (roughness > 0) averages many rays importance-sampled from GGX (oracles/ggx.py).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..constants import BLEND_LAYERS, BLEND_RESTART_OFFSET, MAX_INTERNAL_REFLECTIONS, MIN_PATH_WEIGHT, NO_OBJECT, Sides
from ..geometry import ObjectGeometry
from ..lights import light_sample_points, toward_light
from ..meshes import plane_uvs
from ..scene.model import (
    CheckerMaterial, DiffuseMaterial, Environment, GlassMaterial, Material, MetallicRoughnessMaterial, MirrorMaterial, Scene,
    material_sides, single_sided,
)
from .brdf import mapped_normal, shade_metallic_roughness
from .ibl import SkyLighting, equirect_coordinates, equirect_texels, sky_frame
from .mesh_points import MeshPoints, texel, texel_alpha
from .ggx import glossy_average

if TYPE_CHECKING:
    from embreex import rtcore_scene

Array = np.ndarray


@dataclass(frozen=True, eq=False)
class TruthHits:
    hit: Array  # (n,) bool
    t: Array  # (n,)
    position: Array  # (n, 3)
    object_id: Array  # (n,) int, NO_OBJECT for the environment
    color: Array  # (n, 3), the environment's where nothing was hit
    normal: Array  # (n, 3) the unit smooth normal at the hit (0 where nothing was hit)
    backing: Array  # (n,) bool: the hit is on a mirror's back (its backing, diffuse), not its mirror side


def environment(scene: Scene, directions: Array) -> Array:
    """shaders/lib/environment.glsl in numpy: the gradient, or an equirect map's `equirect_lookup`."""
    env = scene.environment
    if env.is_map:
        return equirect_lookup(env, directions)
    norm = np.linalg.norm(directions, axis=1, keepdims=True)
    y = np.clip(np.where(norm > 1e-20, directions / np.maximum(norm, 1e-300), [0.0, 1.0, 0.0])[:, 1], -1.0, 1.0)
    up = np.asarray(env.horizon) + (np.asarray(env.zenith) - env.horizon) * np.clip(y, 0, None)[:, None]
    down = np.asarray(env.horizon) + (np.asarray(env.ground) - env.horizon) * np.clip(-y, 0, None)[:, None]
    return np.where((y >= 0.0)[:, None], up, down)


def equirect_lookup(env: Environment, directions: Array) -> Array:
    """An equirect environment's radiance along each direction, as lib/environment.glsl reads it.

    The rule, the same texels with the same filter on both sides: the direction d (any length)
    is first turned by -rotation about +Y (the sky turns by +rotation). Its longitude
    atan2(x, -z) (0 along -Z, pi/2 along +X) maps to u = longitude / 2 pi + 0.5 across the image
    and its angle from the zenith atan2(|(x, z)|, y) to v = angle / pi down it (row 0 at the
    zenith; straight up or down, where the longitude is undefined, it is 0). The texel position
    (u W - 0.5, v H - 0.5) is filtered bilinearly from the four float32 texels around it,
    columns wrapping around and rows clamped at the poles; the result is times `intensity`. The
    shader filters with texelFetch and float weights (not the sampler's 8-bit ones), so the two
    differ only by float32 rounding of the angles and weights."""
    image = env.image
    if image is None:
        raise ValueError(f"a {env.type} environment has no image")
    return env.intensity * equirect_texels(image, equirect_coordinates(sky_frame(env, directions)))


def material_albedo(material: Material, local_positions: Array, points: MeshPoints | None = None) -> Array:
    """shaders/lib/shading.glsl's material_albedo in numpy for traced rays (checker in the local XZ
    plane; a texture sampled at the points' UVs on level 0, bilinearly: textures.py's comparison
    rule; times the points' vertex colours)."""
    if isinstance(material, CheckerMaterial):
        cell = np.floor(local_positions[:, [0, 2]] / material.scale).astype(np.int64)
        even = ((cell[:, 0] + cell[:, 1]) & 1) == 0
        return np.where(even[:, None], material.color_a, material.color_b)
    if isinstance(material, DiffuseMaterial):
        color = np.broadcast_to(np.asarray(material.color, float), local_positions.shape).copy()
        if material.texture is not None and points is not None:
            color *= texel(material.texture, points)
        if points is not None:
            color *= points.color[:, :3]
        return color
    raise TypeError(f"{material!r} is not a diffuse material")


def material_alpha(material: Material, points: MeshPoints) -> Array:
    """shaders/lib/shading.glsl's material_alpha in numpy: the alpha at `points` (the factor's
    times the texture's, bilinear at level 0, and the vertex colour's); 1 for a material without
    alpha."""
    if not isinstance(material, MetallicRoughnessMaterial):
        return np.ones(len(points.uv))
    alpha = np.full(len(points.uv), material.alpha)
    if material.texture is not None:
        alpha *= texel_alpha(material.texture, points)
    return alpha * points.color[:, 3]


def cutoff(material: Material, images: bool = False) -> float | None:
    """The alpha under which `material` is cut away: for traced rays, glTF's MASK cutoff (a blended
    surface is composited, not cut); where one surface a texel is held (`images`: the shadow maps,
    which the truth's shadow rays stand for), its image_cutoff, blended surfaces included."""
    if not isinstance(material, MetallicRoughnessMaterial):
        return None
    return material.image_cutoff if images else material.alpha_cutoff


def material_masked(material: Material, points: MeshPoints, images: bool = False) -> Array:
    """shaders/lib/shading.glsl's material_masked in numpy: which points glTF's alphaMode MASK cuts
    away (alpha, the factor's times the texture's and the vertex colour's, under the cutoff;
    `images`: as what holds one surface a texel cuts them, blended materials too). All False for an
    opaque material."""
    limit = cutoff(material, images)
    if limit is None:
        return np.zeros(len(points.uv), bool)
    return material_alpha(material, points) < limit


def plane_tangent(item: ObjectGeometry) -> Array:
    """reflected_scene.glsl's plane_tangent: an analytic plane's tangent (local +x in the world, w
    turned by a mirroring placement)."""
    linear = item.model_matrix[:3, :3]
    return np.r_[linear[:, 0], -1.0 if np.linalg.det(linear) < 0.0 else 1.0]


#: How many cut-away surfaces (alphaMode MASK) one ray of the truth passes through at most before it
#: takes the next surface as seen: each is another Embree query of the rays still passing.
MAX_MASKED_LAYERS = 32


#: The grey albedo of a mirror's back (shaders/reflector.frag's u_backing_albedo, written from here by
#: passes/reflectors.py): dark, as the painted back of a real mirror, and a diffuse surface like any.
MIRROR_BACKING_ALBEDO = 0.2

#: A ray that leaves a surface starts this share of a length off it (a shadow ray: of its own
#: length, along the normal; a ray leaving a mirror: of the mirror's radius, along the ray):
#: Embree's float32 hit would otherwise find the surface it starts on.
RAY_START_OFFSET = 1e-4


def _embree_scene(items: Sequence[ObjectGeometry]) -> rtcore_scene.EmbreeScene:
    """An Embree scene of the objects' world-space triangles; geomID = position in `items`."""
    # Imported here: the passes import this module for its constants, and a frame needs no truth.
    from embreex import rtcore_scene
    from embreex.mesh_construction import TriangleMesh

    embree = rtcore_scene.EmbreeScene()
    for item in items:
        mesh = item.world_mesh
        TriangleMesh(embree, np.ascontiguousarray(mesh.positions[mesh.indices], dtype=np.float32))
    return embree


def shade(scene: Scene, albedo: Array, positions: Array, normals: Array,
          visibility: Callable[[int, Array, Array], Array] | None = None) -> Array:
    """shaders/lib/shading.glsl's shade in numpy; `visibility(light, positions, normals)` is the
    share of each light that reaches each point (shadows), where the scene has any."""
    irradiance = np.full(len(positions), scene.render.ambient, dtype=float)[:, None] * np.ones(3)
    for index, light in enumerate(scene.lights):
        cosine = np.clip(np.einsum("ij,ij->i", normals, toward_light(light, positions, normals)), 0.0, None)
        if visibility is not None and light.casts_shadows:
            lit = cosine > 0.0  # as the shader: no shadow ray from a surface facing away
            cosine[lit] *= visibility(index, positions[lit], normals[lit])
        irradiance += np.asarray(light.color, float) * light.intensity * cosine[:, None]
    return albedo * irradiance


def _masked_hits(items: Sequence[ObjectGeometry], geometry_id: Array, primitive_id: Array, u: Array,
                 v: Array, images: bool) -> Array:
    """Which hits (on items[`geometry_id`], triangle `primitive_id`, barycentrics u, v) a masked
    material cuts away (alphaMode MASK; `images`: and a blended one, as the shadow maps cut it), at
    the UVs triangles.glsl's triangle_uv gives them."""
    cut = np.zeros(len(geometry_id), bool)
    for index, item in enumerate(items):
        material = item.object.material
        if cutoff(material, images) is None:
            continue
        chosen = np.flatnonzero(geometry_id == index)
        if not len(chosen):
            continue
        mesh = item.world_mesh
        points = MeshPoints.on_triangles(mesh, mesh.indices[primitive_id[chosen]], u[chosen], v[chosen])
        cut[chosen] = material_masked(material, points, images)
    return cut


def _back_faces_passed(items: Sequence[ObjectGeometry], geometry_id: Array, primitive_id: Array,
                       directions: Array) -> Array:
    """Which hits (on items[`geometry_id`], triangle `primitive_id`, along `directions`) are back
    faces of a single-sided material (glTF's doubleSided false: not there, so passed through), as
    triangles.glsl's nearest_in_mesh passes them: the ray along the outward face normal."""
    passed = np.zeros(len(geometry_id), bool)
    for index, item in enumerate(items):
        if not single_sided(item.object.material):
            continue
        chosen = np.flatnonzero(geometry_id == index)
        mesh = item.world_mesh
        passed[chosen] = _dot(directions[chosen], face_normals(mesh.positions, mesh.indices[primitive_id[chosen]])) >= 0.0
    return passed


def nearest_shown(embree: rtcore_scene.EmbreeScene, items: Sequence[ObjectGeometry], origins: Array,
                  directions: Array, dists: Array | None = None, images: bool = False) -> dict[str, Array]:
    """Embree's nearest hits on `items` (its geometries: geomID, primID, u, v, tfar), past the points
    a masked material cuts away (alphaMode MASK; `images`: and a blended one under
    BLEND_IMAGE_CUTOFF, as the shadow maps hold it): a ray that meets one goes on from just beyond
    it, as the shader's traversal passes it by. `dists` bounds each ray (a shadow ray's length)."""
    def run(o: Array, d: Array, bound: Array | None) -> dict[str, Array]:
        o, d = np.ascontiguousarray(o, np.float32), np.ascontiguousarray(d, np.float32)
        if bound is None:
            return dict(embree.run(o, d, output=1))
        return dict(embree.run(o, d, dists=np.ascontiguousarray(bound, np.float32), output=1))

    result = {key: np.array(value) for key, value in run(origins, directions, dists).items()}
    sided = not images and any(single_sided(i.object.material) for i in items)
    if not sided and all(cutoff(i.object.material, images) is None for i in items):
        return result
    start = np.zeros(len(origins))  # where each ray's current query began, as a ray parameter
    for _ in range(MAX_MASKED_LAYERS):
        hits = np.flatnonzero(result["geomID"] != -1)
        cut = _masked_hits(items, result["geomID"][hits], result["primID"][hits], result["u"][hits],
                           result["v"][hits], images)
        if sided:
            cut |= _back_faces_passed(items, result["geomID"][hits], result["primID"][hits], directions[hits])
        cut = hits[cut]
        if not len(cut):
            break
        # On from just past the cut point (RAY_START_OFFSET of its distance, as a ray leaving a surface).
        restart = (start[cut] + result["tfar"][cut]) * (1.0 + RAY_START_OFFSET) + RAY_START_OFFSET
        left = None if dists is None else np.maximum(dists[cut] - restart, 0.0)
        again = run(origins[cut] + directions[cut] * restart[:, None], directions[cut], left)
        start[cut] = restart
        for key in ("geomID", "primID", "u", "v", "tfar"):
            result[key][cut] = again[key]
    found = result["geomID"] != -1
    result["tfar"] = np.where(found, start + result["tfar"], result["tfar"])
    return result


class TruthTracer:
    """Traces rays against the scene's reflected meshes (Embree) and analytic planes (exactly):
    the same two lists the renderer splits the scene into (`reflected_objects`, `analytic_planes`).
    Shadow rays are traced against `casters` (the renderer's `shadow_casters`), in scenes with
    shadows. Hits on glass and on a mirror's reflecting side get no colour (SpecularTruth gives
    theirs); a mirror's back is its backing, shaded as a diffuse surface."""

    def __init__(
        self, scene: Scene, meshes: Sequence[ObjectGeometry], planes: Sequence[ObjectGeometry],
        casters: Sequence[ObjectGeometry] = (), sky: SkyLighting | None = None,
    ) -> None:
        self.scene = scene
        self.sky = sky  # what the sky lights metallic-roughness hits with, where it does (ibl.py)
        self.meshes = list(meshes)
        self.planes = list(planes)
        self._plane_ids = [p.index for p in self.planes]
        self._embree = _embree_scene(self.meshes)
        self._casters = _embree_scene(casters) if scene.has_shadows and casters else None
        self._caster_items = list(casters)
        self._masked_casters = any(cutoff(c.object.material, images=True) is not None for c in casters)
        # glTF's alphaMode BLEND: the materials (by index in Scene.materials) whose hits trace composites.
        self._blended = [k for k, m in enumerate(scene.materials) if isinstance(m, MetallicRoughnessMaterial) and m.blend]

    def visibility(self, light_index: int, positions: Array, normals: Array) -> Array:
        """The share of the light's rays (lights.py: its centre for hard shadows, the disk points
        for soft ones) that reach each point unblocked by a caster."""
        light = self.scene.lights[light_index]
        centre = np.asarray(light.position, float)
        if self._casters is None or not len(positions):
            return np.ones(len(positions))
        targets = centre[None, None, :] if light.shadows == "hard" else light_sample_points(centre, light.radius, positions)
        targets = np.broadcast_to(targets, (len(positions), targets.shape[1], 3))
        span = np.linalg.norm(targets - positions[:, None, :], axis=2, keepdims=True)
        origins = positions[:, None, :] + normals[:, None, :] * (RAY_START_OFFSET * span)
        offsets = targets - origins
        lengths = np.linalg.norm(offsets, axis=2)
        directions = offsets / np.maximum(lengths, 1e-300)[..., None]
        if self._masked_casters:  # a cut-away point blocks nothing: the nearest caster not cut away
            shown = nearest_shown(self._casters, self._caster_items, origins.reshape(-1, 3), directions.reshape(-1, 3),
                                  lengths.reshape(-1), images=True)
            blocked = shown["geomID"] != -1
        else:
            blocked = self._casters.run(
                np.ascontiguousarray(origins.reshape(-1, 3), np.float32),
                np.ascontiguousarray(directions.reshape(-1, 3), np.float32),
                dists=np.ascontiguousarray(lengths.reshape(-1), np.float32), query="OCCLUDED",
            ) != -1
        return 1.0 - blocked.reshape(lengths.shape).mean(axis=1)

    def trace(self, origins: Array, directions: Array, layers: int = BLEND_LAYERS,
              viewpoints: Array | None = None) -> TruthHits:
        """The nearest hits, shaded (the environment where nothing was hit). A blended hit (glTF's
        alphaMode BLEND) covers its alpha of what the ray sees from just past it (traced on, up to
        `layers` blended surfaces; past them the next is taken whole), as lib/reflected_scene.glsl's
        trace_reflected composites: the hit's object and point are the first's. `viewpoints`: see
        trace_layer."""
        hits, alpha = self.trace_layer(origins, directions, viewpoints)
        through = np.flatnonzero(alpha < 1.0) if layers > 0 else np.zeros(0, np.int64)
        if len(through):
            restart = hits.t[through] * (1.0 + BLEND_RESTART_OFFSET) + BLEND_RESTART_OFFSET
            behind = self.trace(origins[through] + directions[through] * restart[:, None], directions[through],
                                layers - 1, None if viewpoints is None else viewpoints[through])
            share = alpha[through, None]
            hits.color[through] = share * hits.color[through] + (1.0 - share) * behind.color
        return hits

    def trace_layer(self, origins: Array, directions: Array,
                    viewpoints: Array | None = None) -> tuple[TruthHits, Array]:
        """The nearest hits, shaded, and each one's blending alpha (1 but on a blended material).
        Metallic-roughness hits are shaded for the ray that found them (seen along -direction), or,
        given `viewpoints` (a point a ray), those on meshes as seen from there: how a depth image
        baked from a mirror's centre holds them (tools/baked_view_cost.py measures what that
        costs; the planes, which every method intersects exactly, stay seen along the ray)."""
        hits, albedo, materials, points = self._intersect(origins, directions)
        alpha = np.ones(len(origins))
        for index in self._blended:
            chosen = np.flatnonzero(hits.hit & (materials == index))
            alpha[chosen] = material_alpha(self.scene.materials[index], points[chosen])
        hit = hits.hit
        # A mirror's backing is shaded with its normal facing the ray, as reflector.frag does.
        normals = np.where(hits.backing[:, None], facing(hits.normal, directions), hits.normal)
        if hit.any():
            hits.color[hit] = shade(self.scene, albedo[hit], hits.position[hit], normals[hit], self.visibility)
        # glTF's metallic-roughness materials, for the ray itself (lib/shading.glsl's shade_material:
        # the normal turned by the material's normal map first).
        for index, material in enumerate(self.scene.materials):
            if isinstance(material, MetallicRoughnessMaterial) and (chosen := hit & (materials == index)).any():
                mapped = mapped_normal(material, points[chosen], normals[chosen])
                viewers = -directions[chosen]
                if viewpoints is not None:  # the meshes the images hold; planes are intersected exactly
                    baked = ~np.isin(hits.object_id[chosen], self._plane_ids)
                    offsets = viewpoints[chosen][baked] - hits.position[chosen][baked]
                    viewers[baked] = offsets / np.maximum(np.linalg.norm(offsets, axis=1, keepdims=True), 1e-300)
                hits.color[chosen] = shade_metallic_roughness(self.scene, material, albedo[chosen], points[chosen],
                                                              hits.position[chosen], mapped, viewers,
                                                              self.visibility, self.sky)
        return hits, alpha

    def surfaces(self, origins: Array, directions: Array) -> tuple[TruthHits, Array]:
        """The nearest hits with no colour (zero), and each one's albedo (linear: factor times texel;
        a mirror's backing its grey; 0 on a mirror's reflecting side, glass, and where nothing was
        hit): the per-pixel outputs of `render --aov` (aov.py)."""
        hits, albedo, _, _ = self._intersect(origins, directions)
        hits.color[:] = 0.0
        return hits, albedo

    def intersect(self, origins: Array, directions: Array) -> TruthHits:
        """The nearest hits with no colour (zero): where a ray goes inside glass."""
        hits, _, _, _ = self._intersect(origins, directions)
        hits.color[:] = 0.0
        return hits

    def _intersect(self, origins: Array, directions: Array) -> tuple[TruthHits, Array, Array, MeshPoints]:
        """The nearest hits (no colour), each one's albedo, its material's index in Scene.materials
        (-1: a mirror's backing, glass, nothing), and the mesh's attributes there (the defaults without)."""
        count = len(origins)
        hit = np.zeros(count, bool)
        t = np.full(count, np.inf)
        object_id = np.full(count, NO_OBJECT, np.int64)
        position = np.zeros((count, 3))
        normal = np.zeros((count, 3))
        albedo = np.zeros((count, 3))
        points = MeshPoints.defaults(count)
        backing = np.zeros(count, bool)
        if self.meshes and count:
            self._trace_meshes(origins, directions, hit, t, object_id, normal, albedo, backing, points)
        self._trace_planes(origins, directions, hit, t, object_id, normal, albedo, backing, points)
        objects = self.scene.objects
        by_object = np.array([-1 if o.is_reflector else self.scene.material_index(o.material) for o in objects] + [-1])
        materials = by_object[np.where(hit, object_id, len(objects))]
        position[hit] = origins[hit] + directions[hit] * t[hit, None]
        hits = TruthHits(hit, np.where(hit, t, 0.0), position, object_id, environment(self.scene, directions), normal,
                         backing)
        return hits, albedo, materials, points

    def _trace_meshes(self, origins: Array, directions: Array, hit: Array, t: Array,
                      object_id: Array, normal: Array, albedo: Array, backing: Array, points: MeshPoints) -> None:
        result = nearest_shown(self._embree, self.meshes, origins, directions)
        geometry_id = result["geomID"]
        for index, item in enumerate(self.meshes):
            mask = geometry_id == index
            if not mask.any():
                continue
            mesh = item.world_mesh
            triangles = mesh.indices[result["primID"][mask]]
            u, v = result["u"][mask, None], result["v"][mask, None]
            smooth = (1 - u - v) * mesh.normals[triangles[:, 0]] + u * mesh.normals[triangles[:, 1]] \
                + v * mesh.normals[triangles[:, 2]]
            smooth /= np.maximum(np.linalg.norm(smooth, axis=1, keepdims=True), 1e-20)
            hit[mask] = True
            t[mask] = result["tfar"][mask]
            object_id[mask] = item.index
            normal[mask] = smooth
            where = origins[mask] + directions[mask] * t[mask, None]
            local = (np.linalg.inv(item.model_matrix) @ np.c_[where, np.ones(len(where))].T).T[:, :3]
            if isinstance(item.object.material, (DiffuseMaterial, CheckerMaterial)):
                # As triangles.glsl's triangle_point: the corners' attributes by the hit's barycentrics.
                found = MeshPoints.on_triangles(mesh, triangles, u[:, 0], v[:, 0])
                # glTF's doubleSided: a back face met is shaded turned round (triangle_hit), a
                # single-sided one's never met (nearest_shown passed it).
                turned = material_sides(item.object.material) == Sides.DOUBLE
                turn = turned & (_dot(directions[mask], face_normals(mesh.positions, triangles)) > 0.0)
                normal[mask] = np.where(turn[:, None], -smooth, smooth)
                found.turn_to_back(turn)
                points.put(mask, found)
                albedo[mask] = material_albedo(item.object.material, local, found)
            elif isinstance(item.object.material, MirrorMaterial):
                # Seen from behind: the ray runs along the outward face normal.
                behind = np.flatnonzero(mask)[_dot(directions[mask], face_normals(mesh.positions, triangles)) > 0.0]
                backing[behind] = True
                albedo[behind] = MIRROR_BACKING_ALBEDO

    def _trace_planes(self, origins: Array, directions: Array, hit: Array, t: Array,
                      object_id: Array, normal: Array, albedo: Array, backing: Array, points: MeshPoints) -> None:
        """The shader's nearest_plane_hit: the rectangle |x| <= w/2, |z| <= d/2 of local y = 0."""
        for item in self.planes:
            world_to_local = np.linalg.inv(item.model_matrix)
            o = origins @ world_to_local[:3, :3].T + world_to_local[:3, 3]
            d = directions @ world_to_local[:3, :3].T
            with np.errstate(divide="ignore", invalid="ignore"):
                t_plane = np.where(np.abs(d[:, 1]) < 1e-12, np.inf, -o[:, 1] / d[:, 1])
            local = o + d * np.where(np.isfinite(t_plane), t_plane, 0.0)[:, None]
            half = np.asarray(item.object.shape.size) / 2.0  # type: ignore[union-attr]
            inside = (np.abs(local[:, 0]) <= half[0]) & (np.abs(local[:, 2]) <= half[1])
            closer = (t_plane > 0.0) & np.isfinite(t_plane) & inside & (t_plane < t)
            size = item.object.shape.size  # type: ignore[union-attr]
            chosen = np.flatnonzero(closer)
            closer[chosen[material_masked(item.object.material, MeshPoints.of_uvs(plane_uvs(local[chosen], *size)))]] = False
            if not closer.any():
                continue
            plane_normal = item.normal_matrix @ np.array([0.0, 1.0, 0.0])
            # glTF's doubleSided: met from behind, a single-sided plane is not there, a
            # double-sided one is shaded turned round (the shader's nearest_plane_hit).
            behind = _dot(directions, np.broadcast_to(plane_normal, directions.shape)) > 0.0
            sides = material_sides(item.object.material)
            if sides == Sides.SINGLE:
                closer &= ~behind
            behind &= sides == Sides.DOUBLE
            hit[closer] = True
            t[closer] = t_plane[closer]
            object_id[closer] = item.index
            backing[closer] = False  # a plane before a mirror's back hides it
            normal[closer] = np.where(behind[closer, None], -1.0, 1.0) * plane_normal / np.linalg.norm(plane_normal)
            found = MeshPoints.of_uvs(plane_uvs(local[closer], *size))
            found.tangent[:] = plane_tangent(item)
            found.turn_to_back(behind[closer])
            points.put(closer, found)
            albedo[closer] = material_albedo(item.object.material, local[closer], found)


def seen_through_blended(tracer: TruthTracer, eye: Array, points: Array, colors: Array) -> Array:
    """What the eye at `eye` sees at `points` (on mirrors or glass, whose colours are `colors`)
    through the blended objects between (glTF's alphaMode BLEND: `tracer` traces those alone),
    composited front to back along each eye ray, up to BLEND_LAYERS of them: the eye's transparent
    pass draws them over the reflectors (passes/transparent.py), sorted by object, not per ray."""
    offsets = points - eye
    lengths = np.linalg.norm(offsets, axis=1)
    directions = offsets / np.maximum(lengths, 1e-300)[:, None]
    color = np.zeros_like(colors)
    through = np.ones(len(points))
    start = np.zeros(len(points))  # the ray parameter each eye ray goes on from
    active = np.arange(len(points))
    for _ in range(BLEND_LAYERS):
        if not len(active):
            break
        hits, alpha = tracer.trace_layer(eye + directions[active] * start[active, None], directions[active])
        # Before the reflector's point (RAY_START_OFFSET of its distance: not the surface itself).
        front = hits.hit & (start[active] + hits.t < lengths[active] * (1.0 - RAY_START_OFFSET))
        rays, share = active[front], alpha[front]
        color[rays] += (through[rays] * share)[:, None] * hits.color[front]
        through[rays] *= 1.0 - share
        start[rays] += hits.t[front] * (1.0 + BLEND_RESTART_OFFSET) + BLEND_RESTART_OFFSET
        active = rays
    return color + through[:, None] * colors


def _dot(a: Array, b: Array) -> Array:
    return np.einsum("ij,ij->i", a, b)


def face_normals(positions: Array, triangles: Array) -> Array:
    """The geometric normals (not unit) of `triangles` (rows of vertex indices): outward for the
    counter-clockwise winding every mesh has (meshes.py), whatever its vertex normals say."""
    p0, p1, p2 = (positions[triangles[:, k]] for k in range(3))
    return np.cross(p1 - p0, p2 - p0)


def facing(normals: Array, directions: Array) -> Array:
    """GLSL's faceforward(n, d, n): each normal turned against its ray."""
    return np.where((_dot(normals, directions) < 0.0)[:, None], normals, -normals)


def reflect(directions: Array, normals: Array) -> Array:
    """GLSL's reflect()."""
    return directions - 2.0 * _dot(directions, normals)[:, None] * normals


def refract(directions: Array, normals: Array, eta: float) -> Array:
    """GLSL's refract(): zero where the ray is reflected in full (total internal reflection)."""
    cosine = _dot(normals, directions)
    k = 1.0 - eta * eta * (1.0 - cosine * cosine)
    refracted = eta * directions - (eta * cosine + np.sqrt(np.clip(k, 0.0, None)))[:, None] * normals
    return np.where((k < 0.0)[:, None], 0.0, refracted)


def schlick(cosine: Array, ior: float) -> Array:
    """Schlick's approximation of the Fresnel reflectance from air into a dielectric."""
    f0 = ((ior - 1.0) / (ior + 1.0)) ** 2
    return f0 + (1.0 - f0) * (1.0 - np.clip(cosine, 0.0, 1.0)) ** 5


class SpecularTruth:
    """What mirrors and glass show, traced with Embree under the rules the renderer follows:
    at most render.max_bounces mirror or glass surfaces along a camera ray (a passage through
    glass is one), and glass as lib/glass.glsl has it (Schlick at the entry, Snell both ways,
    MAX_INTERNAL_REFLECTIONS, the interior holding the glass alone)."""

    def __init__(self, scene: Scene, meshes: Sequence[ObjectGeometry], reflectors: Sequence[ObjectGeometry],
                 planes: Sequence[ObjectGeometry], casters: Sequence[ObjectGeometry], sky: SkyLighting | None = None) -> None:
        self.reflectors = {r.index: r for r in reflectors}
        self.last = TruthTracer(scene, meshes, planes, casters, sky)
        # Built once for every bounce but the last (an Embree scene is a BVH build).
        self.with_reflectors = (
            TruthTracer(scene, [*meshes, *reflectors], planes, casters, sky)
            if scene.render.max_bounces > 1 and reflectors else None
        )
        self.interiors = {r.index: TruthTracer(scene, [r], []) for r in reflectors if r.object.is_glass}
        self.radius = {r.index: r.bounding_sphere[1] for r in reflectors}
        #: Where each reflector's metallic-roughness hits are seen from: None, along the ray (the
        #: truth); or, set by tools/baked_view_cost.py, from the reflector's centre, where the
        #: depth images are baked from (methods/atlas.mirror_centre).
        self.viewed_from_centres = False

    def trace(self, origins: Array, directions: Array, leaving: Array, bounces: int) -> TruthHits:
        """What rays leaving the reflectors `leaving` (object ids) see with `bounces` bounces
        left: at the last, the mirrors and glass are not there; before it, they show what their
        own rays see with one bounce fewer."""
        # Each ray starts a ten-thousandth of its reflector's radius along its way: float32
        # Embree would otherwise find the surface it leaves.
        start = origins + directions * (RAY_START_OFFSET * np.array([self.radius[i] for i in leaving]))[:, None]
        viewpoints = (np.array([self.reflectors[int(i)].bounding_sphere[0] for i in leaving]).reshape(-1, 3)
                      if self.viewed_from_centres else None)
        if bounces <= 1 or self.with_reflectors is None:
            return self.last.trace(start, directions, viewpoints=viewpoints)
        hits = self.with_reflectors.trace(start, directions, viewpoints=viewpoints)
        # A mirror's backing is a diffuse surface, shaded by the tracer already.
        on = np.isin(hits.object_id, list(self.reflectors)) & ~hits.backing
        if on.any():
            normals = facing(hits.normal[on], directions[on])
            hits.color[on] = self.surface_color(hits.object_id[on], hits.position[on], normals, directions[on],
                                                reflect(directions[on], normals), bounces - 1)[0]
        return hits

    def surface_color(self, ids: Array, positions: Array, normals: Array, incoming: Array, reflected: Array,
                      bounces: int) -> tuple[Array, TruthHits]:
        """The colour of reflector points seen along `incoming` (unit normals facing it), and what
        their `reflected` rays hit: a mirror's tint times it; glass's Fresnel blend."""
        seen = self.trace(positions, reflected, ids, bounces)
        color = np.zeros_like(seen.color)
        for index in np.unique(ids):
            mine = ids == index
            material = self.reflectors[int(index)].object.material
            if isinstance(material, MirrorMaterial):
                reflected_color = seen.color[mine]
                if material.is_rough:  # many rays about the reflected one (oracles/ggx.py)
                    reflected_color = self._glossy(int(index), material.roughness, positions[mine], normals[mine],
                                                   incoming[mine], reflected_color, bounces)
                color[mine] = np.asarray(material.tint) * reflected_color
            elif isinstance(material, GlassMaterial):
                fresnel = schlick(-_dot(incoming[mine], normals[mine]), material.ior)[:, None]
                refracted = refract(incoming[mine], normals[mine], 1.0 / material.ior)
                transmitted = self._transmitted(int(index), material.ior, positions[mine], refracted, bounces)
                color[mine] = fresnel * seen.color[mine] + (1.0 - fresnel) * np.asarray(material.tint) * transmitted
        return color, seen

    def _glossy(self, index: int, roughness: float, positions: Array, normals: Array, incoming: Array,
                central: Array, bounces: int) -> Array:
        """What glossy mirror `index` reflects at each point: the GGX average of GGX_SAMPLES rays,
        each traced as the perfect mirror's one ray is."""
        def radiance(pixels: Array, directions: Array) -> Array:
            return self.trace(positions[pixels], directions, np.full(len(pixels), index), bounces).color

        return glossy_average(incoming, normals, roughness, central, radiance)

    def _transmitted(self, index: int, ior: float, entry: Array, direction: Array, bounces: int) -> Array:
        """lib/glass.glsl's glass_transmitted: each ray followed inside glass `index` (Embree,
        against that object alone); at each surface the share 1 - F leaves, F reflects inside."""
        color = np.zeros_like(entry)
        active = np.arange(len(entry))
        weight = np.ones(len(entry))
        p, d = entry, direction
        offset = RAY_START_OFFSET * self.radius[index]

        def leave(rays: Array, origins: Array, directions: Array, share: Array) -> None:
            seen = self.trace(origins, directions, np.full(len(rays), index), bounces)
            color[rays] += share[:, None] * seen.color

        for _ in range(MAX_INTERNAL_REFLECTIONS + 1):
            followed = weight[active] >= MIN_PATH_WEIGHT
            active, p, d = active[followed], p[followed], d[followed]
            if not len(active):
                break
            inside = self.interiors[index].intersect(p + d * offset, d)
            # No surface ahead (an open mesh, a grazing float32 miss): leave unbent, as the shader.
            missed = ~inside.hit
            if missed.any():
                leave(active[missed], p[missed], d[missed], weight[active[missed]])
            active, q, outward, d = active[~missed], inside.position[~missed], inside.normal[~missed], d[~missed]
            inward = facing(outward, d)
            out = refract(d, inward, ior)
            escapes = np.any(out != 0.0, axis=1)
            reflectance = np.ones(len(active))
            reflectance[escapes] = schlick(-_dot(out[escapes], inward[escapes]), ior)
            leaves = reflectance < 1.0
            if leaves.any():
                leave(active[leaves], q[leaves], out[leaves], weight[active[leaves]] * (1.0 - reflectance[leaves]))
            weight[active] *= reflectance
            p, d = q, reflect(d, inward)
        return color  # what is still inside carries no light
