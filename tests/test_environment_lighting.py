"""Image-based lighting from an equirect sky (issue 33 item 1, with item 5's rule: ibl.py): a metal
under a sky shows the sky; its prefilter runs once per sky, on the GPU, and only where a sky lights
a metallic-roughness material; the truth lights its hits with the same numbers."""

from __future__ import annotations

import dataclasses
import threading
from pathlib import Path

import moderngl
import numpy as np
import pytest

from conftest import SCENES, assert_finite, scene_from_toml
from depthimpostor.constants import IBL_LEVELS, Method
from depthimpostor.hdr import write_hdr
from depthimpostor.ibl import (
    SH9_FACTORS, irradiance_sh9, level_size, sh9_basis, texel_directions, uses_environment_lighting,
)
from depthimpostor.node import Pass
from depthimpostor.oracles.compare import compare, trace_direct
from depthimpostor.oracles.ibl import SkyLighting, environment_irradiance, prefiltered_level
from depthimpostor.oracles.truth import equirect_lookup
from depthimpostor.plan import plan_render
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene, load_scene
from depthimpostor.scene.model import Environment
from test_metallic_roughness import metal_scene  # noqa: F401  (the fixture, reused under a sky)


def smooth_sky(width: int = 128, height: int = 64) -> np.ndarray:
    """A sky that varies smoothly and strongly with direction: a warm glow toward +X, a blue dome, a
    dark ground, and a small bright patch (a soft sun) up toward -Z."""
    directions, _ = texel_directions(width, height)
    x, y = directions[..., 0], directions[..., 1]
    sky = (np.array([0.15, 0.25, 0.6]) * np.clip(y, 0.0, None)[..., None]
           + np.array([1.6, 1.0, 0.35]) * np.clip(x, 0.0, None)[..., None] ** 2
           + np.array([0.05, 0.04, 0.03]))
    sun = np.exp(-(np.sum((directions - np.array([0.0, 0.6, -0.8])) ** 2, axis=2)) / 0.02)
    return (sky + 6.0 * sun[..., None]).astype(np.float32)


def sky_scene(folder: Path, roughness: float, sky: str = "equirect", mirror: bool = False) -> Scene:
    """A metal sphere (white base colour, metallic 1) under the sky, no lights: all it shows is its
    ambient term; beside a mirror where asked. `sky` "gradient" gives it the default gradient sky."""
    path = folder / "sky.exr"
    with open(path, "wb") as file:
        write_hdr(file, smooth_sky(), ".exr")
    environment = '[environment]\ntype = "equirect"\npath = "sky.exr"\nrotation = 30.0\nintensity = 1.5\n' \
        if sky == "equirect" else ""
    mirror_object = ('[[objects]]\nname = "mirror"\nshape = { type = "plane", size = [4.0, 3.0] }\n'
                     'material = { type = "mirror" }\nposition = [0.0, 0.0, -1.6]\nrotation = [90.0, 0.0, 0.0]\n'
                     if mirror else "")
    text = ('[render]\nsize = [96, 96]\nambient = 0.3\nimpostor_resolution = 64\n'
            '[camera]\neye = [0.0, 0.3, 3.2]\ntarget = [0.0, 0.0, 0.0]\nfov_y = 32.0\n' + environment +
            '[[objects]]\nname = "ball"\nshape = { type = "sphere", radius = 0.8 }\n'
            f'material = {{ type = "metallic_roughness", color = [1.0, 1.0, 1.0], metallic = 1.0, roughness = {roughness} }}\n'
            + mirror_object)
    return scene_from_toml(text, base_dir=folder)


def ball_pixels(renderer: Renderer) -> tuple[np.ndarray, np.ndarray]:
    """The pixels well inside the sphere's disc (away from its silhouette), and the reflected view
    direction at each: the sphere intersected analytically through each pixel's centre."""
    camera = renderer.camera
    v, u = np.mgrid[0:camera.height, 0:camera.width] + 0.5
    d = camera.ray_direction(u.ravel(), v.ravel())
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    origin = np.asarray(camera.C, float)
    b = d @ origin
    disc = b * b - (origin @ origin - 0.8**2)
    inside = disc > 0.05 * b * b  # clear of the silhouette
    t = -b - np.sqrt(np.maximum(disc, 0.0))
    normal = (origin + d * t[:, None]) / 0.8
    reflected = d - 2.0 * np.sum(d * normal, axis=1, keepdims=True) * normal
    return inside.reshape(camera.height, camera.width), reflected


def luminance(color: np.ndarray) -> np.ndarray:
    return color @ np.array([0.2126, 0.7152, 0.0722])


def test_a_metal_under_the_sky_shows_the_sky_as_the_truth_does(ctx: moderngl.Context, tmp_path: Path) -> None:
    """Metallic 1, roughness 0.3: the sphere is no longer a flat constant-ambient disc; its
    brightness follows the sky along each pixel's reflected ray, and equals the truth's (the same
    shading at the exact hit) within float noise."""
    scene = sky_scene(tmp_path, 0.3)
    assert uses_environment_lighting(scene)
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        render = renderer.read_color_float()
        truth = trace_direct(renderer, np.zeros(render.shape[:2], bool))
        inside, reflected = ball_pixels(renderer)
    assert_finite(render)
    assert_finite(truth)
    ball = render[inside]
    assert len(ball) > 1000
    sky_seen = luminance(equirect_lookup(scene.environment, reflected[inside.ravel()]))
    assert np.corrcoef(luminance(ball), sky_seen)[0, 1] > 0.9
    assert luminance(ball).std() > 0.3 * luminance(ball).mean()  # far from flat
    error = np.abs(render - truth)[inside]
    assert np.max(error) < 1e-3 * max(1.0, float(truth[inside].max())), np.max(error)


def test_without_a_sky_the_metal_keeps_the_constant_ambient(ctx: moderngl.Context, tmp_path: Path) -> None:
    """A gradient sky: no prefilter in the plan, no ENVIRONMENT_LIGHTING variant, the sphere lit by
    render.ambient as before (and the truth agrees); an equirect sky over diffuse materials alone
    (hdr_sky.toml) prefilters nothing either."""
    scene = sky_scene(tmp_path, 0.3, sky="gradient")
    plan = plan_render(scene)
    assert not plan.runs(Pass.ENVIRONMENT_LIGHTING)
    assert not any("ENVIRONMENT_LIGHTING" in dict(v.key[1]) for v in plan.variants)
    with Renderer(ctx, scene) as renderer:
        renderer.render()
        assert renderer.sky_lighting() is None
        assert "environment prefilter" not in renderer.stats.passes
        render = renderer.read_color_float()
        truth = trace_direct(renderer, np.zeros(render.shape[:2], bool))
        inside, _ = ball_pixels(renderer)
    assert np.abs(render - truth)[inside].max() < 1e-4
    diffuse_only = load_scene(SCENES / "hdr_sky.toml")
    assert diffuse_only.environment.is_map and not uses_environment_lighting(diffuse_only)
    assert not plan_render(diffuse_only).runs(Pass.ENVIRONMENT_LIGHTING)


def test_the_prefilter_runs_once_per_sky_and_the_plan_says_what_it_costs(ctx: moderngl.Context,
                                                                          tmp_path: Path) -> None:
    """Planned with its reason and cost; run at the first frame, not again for later frames, a
    camera move, another method, another time or an edit of the scene that keeps its sky (the
    sky's intensity applies where it is read: the frame brightens, nothing is prefiltered again)."""
    scene = sky_scene(tmp_path, 0.3, mirror=True)
    plan = plan_render(scene)
    assert plan.runs(Pass.ENVIRONMENT_LIGHTING)
    reason = next(p.reason for p in plan.passes if p.stage is Pass.ENVIRONMENT_LIGHTING)
    assert "once per sky" in reason and "M in all" in reason and "ms" in reason
    assert "environment prefilter" in plan.format()
    with Renderer(ctx, scene) as renderer:
        for _ in range(3):
            renderer.render()
        renderer.set_method(Method.RAYTRACE)
        renderer.render()
        renderer.set_time(1.0)
        renderer.render()
        before = renderer.read_color_float()
        brighter = dataclasses.replace(scene.environment, intensity=2.0 * scene.environment.intensity)
        renderer.set_scene(dataclasses.replace(scene, environment=brighter))
        renderer.render()
        after = renderer.read_color_float()
        assert renderer.stats.passes["environment prefilter"] == 1
        assert renderer.stats.frames == 6
    assert after.mean() > 1.5 * before.mean()


def ggx_convolution(sky: np.ndarray, roughness: float, normals: np.ndarray) -> np.ndarray:
    """What a prefiltered level stands for, summed over every texel of `sky` by its solid angle: the
    sky through the GGX lobe of `roughness` about each normal with the view along it (the split
    sum's N = V = R), each direction L weighted by its density D(h) / 4 times N.L."""
    height, width = sky.shape[:2]
    directions, solid_angle = texel_directions(width, height)
    directions = directions.reshape(-1, 3)
    weights = np.repeat(solid_angle, width)
    radiance = sky.reshape(-1, 3).astype(np.float64)
    alpha2 = roughness**4
    result = np.zeros((len(normals), 3))
    for k, n in enumerate(normals):
        n_dot_l = directions @ n
        h = directions + n
        n_dot_h = (h @ n) / np.linalg.norm(h, axis=1)
        f = n_dot_h**2 * (alpha2 - 1.0) + 1.0
        weight = np.where(n_dot_l > 0.0, alpha2 / (np.pi * f * f) / 4.0 * n_dot_l, 0.0) * weights
        result[k] = weight @ radiance / weight.sum()
    return result


def test_the_prefiltered_levels_are_the_ggx_convolution_and_roughness_1_is_the_irradiance(
        ctx: moderngl.Context, tmp_path: Path) -> None:
    """What the truth reads back is what it stands for: each level the sky through its GGX lobe
    (against a numpy sum over every texel: within a few per cent, the GPU's mip-filtered
    IBL_SAMPLES samples); at roughness 1 the lobe weighted by N.L is the cosine lobe, and the roughest level
    approaches the irradiance of the nine terms."""
    scene = sky_scene(tmp_path, 0.3)
    env = scene.environment
    rng = np.random.default_rng(3)
    normals = rng.normal(size=(40, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    with Renderer(ctx, scene) as renderer:
        sky = renderer.sky_lighting()
    assert sky is not None and np.isfinite(sky.texture).all()
    plain = dataclasses.replace(env, rotation=0.0, intensity=1.0)  # the levels are in the image's frame
    assert env.image is not None
    for level in (1, 3, IBL_LEVELS):
        gpu = prefiltered_level(plain, sky, level, normals)
        exact = ggx_convolution(env.image, level / IBL_LEVELS, normals)
        error = np.abs(gpu - exact).max(axis=1)
        # Within 3 % at the median; the worst, where the coarse mips of the sky's bright parts
        # leak into dim directions, within 5 % of the level's brightest.
        assert np.median(error / exact.max(axis=1)) < 0.03, (level, np.median(error / exact.max(axis=1)))
        assert error.max() < 0.05 * exact.max(), (level, error.max() / exact.max())
    roughest = prefiltered_level(plain, sky, IBL_LEVELS, normals)
    irradiance = environment_irradiance(plain, sky, normals)
    error = np.abs(roughest - irradiance).max(axis=1)
    assert np.median(error / irradiance.max(axis=1)) < 0.04 and error.max() < 0.05 * irradiance.max()
    assert level_size(IBL_LEVELS)[0] >= 16


def test_the_nine_terms_light_a_uniform_sky_exactly() -> None:
    """A sky of radiance 1 everywhere: a white diffuse surface of any normal shows 1 (the nine
    terms' constants and band factors), whatever the sky's rotation."""
    sky = np.ones((32, 64, 3), np.float32)
    terms = irradiance_sh9(sky)
    np.testing.assert_allclose(terms[0], 1.0, rtol=1e-12)
    # Band 1 vanishes by symmetry; band 2's quadratic terms within 1e-3 (each row's texel centres
    # stand for the whole row: an error of the order of 1 / rows^2).
    np.testing.assert_allclose(terms[1:], 0.0, atol=1e-3)
    env = Environment("equirect", path=Path("sky.exr"), rotation=40.0, image=sky)
    normals = np.eye(3)
    lit = environment_irradiance(env, SkyLighting.of(env, np.zeros((1, 1, 3))), normals)
    np.testing.assert_allclose(lit, 1.0, atol=2e-3)


def test_the_nine_terms_are_every_texel_by_its_solid_angle() -> None:
    """The separable projection equals the plain sum of every texel's radiance times its solid
    angle times each basis polynomial at its centre (times the constants), on a random sky."""
    sky = np.random.default_rng(5).random((24, 40, 3)).astype(np.float32)
    directions, solid_angle = texel_directions(40, 24)
    weighted = sky.astype(np.float64) * solid_angle[:, None, None]
    plain = sh9_basis(directions.reshape(-1, 3)).T @ weighted.reshape(-1, 3) * SH9_FACTORS[:, None]
    np.testing.assert_allclose(irradiance_sh9(sky), plain, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("method", [Method.RAYTRACE, Method.HYBRID, Method.DEPTH])
def test_metals_seen_in_a_mirror_take_the_sky_as_the_truth_does(ctx: moderngl.Context, tmp_path: Path,
                                                                 metal_scene: Scene, method: Method) -> None:  # noqa: F811
    """Beside a mirror, under the sky: the traced hits on metals (textured, with occlusion maps) are
    lit by the sky for the reflected ray itself, as the truth lights them: colour within float
    noise (8.7e-6 RMSE measured), no wrong object. The depth images are baked lit by the sky too, as
    seen from the mirror's centre: their colour error stays that of the view from there (0.048
    measured, 0.042 on the same scene under the constant ambient), where a bake lit by the constant
    ambient would miss the sky's light on every metal the mirror shows."""
    path = tmp_path / "sky.exr"
    with open(path, "wb") as file:
        write_hdr(file, smooth_sky(), ".exr")
    lit = dataclasses.replace(metal_scene, environment=Environment(
        "equirect", path=path, intensity=0.8, rotation=-60.0, image=smooth_sky()))
    with Renderer(ctx, lit, method=method, reflection_data=True) as renderer:
        renderer.render()
        assert renderer.stats.passes["environment prefilter"] == 1
        result = compare(renderer)
        # Given the frame's sub-frames, read here, compare touches no GL (the viewer's error view
        # traces in another thread): the sky's levels are read with them.
        frames = renderer.sub_frames()
        elsewhere: list[object] = []
        thread = threading.Thread(target=lambda: elsewhere.append(compare(renderer, frames=frames)))
        thread.start()
        thread.join()
    assert [getattr(c, "figures", c) for c in elsewhere] == [result.figures]
    assert_finite(result.render)
    assert_finite(result.truth)
    if method is Method.DEPTH:
        assert result.figures.wrong_object_share < 0.01 and result.figures.color_rmse < 0.06, result.figures
        return
    assert result.figures.wrong_object_share == 0.0
    assert result.figures.color_rmse < 1e-3, result.figures.color_rmse
