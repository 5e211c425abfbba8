"""glTF 2.0's metallic-roughness material in numpy: shaders/lib/brdf.glsl and lib/shading.glsl's
shade_metallic_roughness, function by function under the same names, for the truth's exact hits.

As in the shaders, the functions return pi times the BRDF: the scene's lights are given as the
radiance a white diffuse surface facing them shows (a diffuse material's colour is albedo * (ambient
+ sum of radiance * N.L)), so a dielectric's diffuse base is lit as a diffuse material of its
colour, less what its Fresnel term reflects.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..constants import DFG_FIT_C0, DFG_FIT_C1, DFG_FIT_EXPONENT, DFG_FIT_SCALE, DIELECTRIC_F0, MIN_ROUGHNESS
from ..scene.model import MetallicRoughnessMaterial, Scene
from ..ibl import uses_environment_lighting
from ..lights import toward_light
from .ibl import SkyLighting, environment_irradiance, environment_specular
from .mesh_points import MeshPoints, texel

Array = np.ndarray


def _dot(a: Array, b: Array) -> Array:
    return np.einsum("ij,ij->i", a, b)


def ggx_distribution(alpha: float | Array, n_dot_h: Array) -> Array:
    """GGX (Trowbridge-Reitz) normal distribution D, for alpha = roughness^2 and N.H > 0."""
    a2 = alpha * alpha
    f = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0
    return a2 / (np.pi * f * f)


def smith_visibility(alpha: float | Array, n_dot_l: Array, n_dot_v: Array) -> Array:
    """Smith's height-correlated visibility V = G / (4 |N.L| |N.V|) (the specification's form)."""
    a2 = alpha * alpha
    light = n_dot_l + np.sqrt(a2 + (1.0 - a2) * n_dot_l * n_dot_l)
    view = n_dot_v + np.sqrt(a2 + (1.0 - a2) * n_dot_v * n_dot_v)
    return 1.0 / (light * view)


def fresnel_schlick(f0: Array, v_dot_h: Array) -> Array:
    """Schlick's Fresnel reflectance at the angle whose cosine is v_dot_h, (n, 3)."""
    return f0 + (1.0 - f0) * ((1.0 - v_dot_h) ** 5)[:, None]


def _safe_unit(v: Array, fallback: Array) -> Array:
    length = np.linalg.norm(v, axis=1, keepdims=True)
    return np.where(length > 1e-20, v / np.maximum(length, 1e-300), fallback)


def metallic_roughness_brdf(c_diff: Array, f0: Array, alpha: float | Array, normal: Array, to_light: Array,
                            to_viewer: Array) -> Array:
    """Pi times the BRDF for light arriving along `to_light` (N.L > 0), leaving along `to_viewer`."""
    half_vector = _safe_unit(to_light + to_viewer, normal)
    n_dot_l = np.abs(_dot(normal, to_light))
    n_dot_v = np.abs(_dot(normal, to_viewer))
    n_dot_h = _dot(normal, half_vector)
    fresnel = fresnel_schlick(f0, np.abs(_dot(to_viewer, half_vector)))
    lobe = np.where(n_dot_h > 0.0, np.pi * ggx_distribution(alpha, np.maximum(n_dot_h, 0.0))
                    * smith_visibility(alpha, n_dot_l, n_dot_v), 0.0)
    return (1.0 - fresnel) * c_diff + fresnel * lobe[:, None]


def ambient_specular(f0: Array, roughness: float | Array, n_dot_v: Array) -> Array:
    """The specular lobe's share of a uniform environment: F0 * A + B by Karis' fit of the DFG term."""
    r = np.multiply.outer(np.broadcast_to(roughness, np.shape(n_dot_v)), DFG_FIT_C0) + np.asarray(DFG_FIT_C1)
    a004 = np.minimum(r[:, 0] * r[:, 0], np.exp2(DFG_FIT_EXPONENT * n_dot_v)) * r[:, 0] + r[:, 1]
    scale = -DFG_FIT_SCALE * a004 + r[:, 2]
    bias = DFG_FIT_SCALE * a004 + r[:, 3]
    return f0 * scale[:, None] + bias[:, None]


def ambient_light(scene: Scene, c_diff: Array, f0: Array, roughness: Array, normals: Array, to_viewer: Array,
                  occlusion: Array, sky: SkyLighting | None) -> Array:
    """lib/shading.glsl's ambient_light: the sky's irradiance through the diffuse base and its
    prefiltered radiance along the reflected view through the specular lobe where it lights the
    scene (`sky`: ibl.py's rule), a uniform environment of the constant ambient otherwise."""
    n_dot_v = np.abs(_dot(normals, to_viewer))
    if uses_environment_lighting(scene):
        if sky is None:
            raise ValueError(f"{scene.source}: its equirect sky lights metallic-roughness surfaces: the truth needs "
                             "the sky's prefiltered levels (oracles/ibl.py's SkyLighting)")
        reflected = 2.0 * _dot(normals, to_viewer)[:, None] * normals - to_viewer  # GLSL's reflect(-v, n)
        env = scene.environment
        return occlusion[:, None] * (c_diff * environment_irradiance(env, sky, normals)
                                     + environment_specular(env, sky, reflected, roughness)
                                     * ambient_specular(f0, roughness, n_dot_v))
    return scene.render.ambient * occlusion[:, None] * (c_diff + ambient_specular(f0, roughness, n_dot_v))


def shade_metallic_roughness(scene: Scene, material: MetallicRoughnessMaterial, base_color: Array, points: MeshPoints,
                             positions: Array, normals: Array, to_viewer: Array,
                             visibility: Callable[[int, Array, Array], Array] | None = None,
                             sky: SkyLighting | None = None) -> Array:
    """lib/shading.glsl's shade_metallic_roughness: (n, 3) colours of surfaces of `material` whose
    colour at the point is `base_color`, at the mesh points `points` (its maps sampled at their
    UVs as traced rays sample them: level 0, bilinear), seen along `to_viewer` (unit, from the
    surface); `visibility(light, positions, normals)` the share of each light that reaches each point;
    `sky` what an equirect sky lights it with (ambient_light)."""
    count = len(positions)
    metallic = np.full(count, material.metallic)
    roughness = np.full(count, material.roughness)
    occlusion = np.ones(count)
    emissive = np.broadcast_to(np.asarray(material.emissive, float), (count, 3))
    if material.metallic_roughness_texture is not None:  # glTF: roughness in G, metalness in B
        values = texel(material.metallic_roughness_texture, points)
        roughness, metallic = roughness * values[:, 1], metallic * values[:, 2]
    if material.occlusion_texture is not None:
        occlusion = 1.0 + material.occlusion_strength * (texel(material.occlusion_texture, points)[:, 0] - 1.0)
    if material.emissive_texture is not None:
        emissive = emissive * texel(material.emissive_texture, points)
    c_diff = base_color * (1.0 - metallic)[:, None]
    f0 = DIELECTRIC_F0 * (1.0 - metallic)[:, None] + base_color * metallic[:, None]
    alpha = np.maximum(roughness, MIN_ROUGHNESS) ** 2
    color = ambient_light(scene, c_diff, f0, roughness, normals, to_viewer, occlusion, sky)
    for index, light in enumerate(scene.lights):
        to_light = toward_light(light, positions, normals)
        cosine = _dot(normals, to_light)
        lit = cosine > 0.0
        if not lit.any():
            continue
        weight = cosine[lit]
        if visibility is not None and light.casts_shadows:
            weight = weight * visibility(index, positions[lit], normals[lit])
        radiance = np.asarray(light.color, float) * light.intensity
        color[lit] += metallic_roughness_brdf(c_diff[lit], f0[lit], alpha[lit], normals[lit], to_light[lit],
                                              to_viewer[lit]) * radiance * weight[:, None]
    return color + emissive


def mapped_normal(material: MetallicRoughnessMaterial, points: MeshPoints, normals: Array) -> Array:
    """lib/shading.glsl's mapped_normal: the unit shading normals turned by the material's normal
    map (RGB * 2 - 1, x and y times normal_scale) in the frame of the points' tangents (made
    perpendicular to the normals), bitangents w N x T, and the normals. As they are without a map."""
    if material.normal_texture is None:
        return normals
    tangent = points.tangent[:, :3] - normals * _dot(normals, points.tangent[:, :3])[:, None]
    any_side = np.where((np.abs(normals[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    tangent = _safe_unit(tangent, _safe_unit(np.cross(normals, any_side), any_side))
    bitangent = np.where(points.tangent[:, 3:] < 0.0, -1.0, 1.0) * np.cross(normals, tangent)
    values = texel(material.normal_texture, points) * 2.0 - 1.0
    values[:, :2] *= material.normal_scale
    return _safe_unit(tangent * values[:, :1] + bitangent * values[:, 1:2] + normals * values[:, 2:], normals)
