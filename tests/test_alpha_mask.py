"""glTF's alphaMode MASK (issue 33 item 3): what a masked material cuts away is not there, in the
eye's pass, every bake, the shadow maps, the traced rays and the truth alike."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import moderngl
import numpy as np
import pytest

from conftest import SCENES, assert_finite
from depthimpostor.constants import Method
from depthimpostor.oracles.compare import compare
from depthimpostor.oracles.mesh_points import MeshPoints
from depthimpostor.oracles.truth import TruthTracer, material_masked
from depthimpostor.plan import plan_render
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene, load_scene
from depthimpostor.scene.model import DiffuseMaterial, Light, MetallicRoughnessMaterial
from depthimpostor.textures import texture_from_pixels
from depthimpostor.world import World
from gltf_files import GltfWriter


def _striped(width: int = 16, stripe: int = 4) -> np.ndarray:
    """RGBA stripes across u: opaque orange and cut-away (alpha 0) blue, `stripe` texels each."""
    rgba = np.zeros((width, width, 4), np.uint8)
    opaque = (np.arange(width) // stripe) % 2 == 0
    rgba[:, opaque] = (230, 140, 30, 255)
    rgba[:, ~opaque] = (40, 60, 220, 0)
    return rgba


def _masked_scene(masked: bool, shadows: bool = False) -> Scene:
    """textured_near_mirror.toml with its plate in a striped texture whose blue stripes a
    MASK material cuts away (or, unmasked, shows); `shadows`: and a point light casting hard shadows."""
    scene = load_scene(SCENES / "textured_near_mirror.toml").with_overrides(size=(240, 135))
    texture = texture_from_pixels(_striped(), {"wrapS": 10497, "wrapT": 10497, "magFilter": 9728})
    material = MetallicRoughnessMaterial((1.0, 1.0, 1.0), texture, metallic=0.0, roughness=0.6,
                                         alpha_cutoff=0.5 if masked else None)
    objects = tuple(dataclasses.replace(o, material=material) if o.name == "edge_on_plate" else o
                    for o in scene.objects)
    lights = (Light("point", position=(0.5, 3.0, 1.5), intensity=1.2, shadows="hard"),) if shadows else ()
    return dataclasses.replace(scene, objects=objects, lights=(*scene.lights, *lights))


def test_the_truth_cuts_away_what_the_mask_says() -> None:
    """material_masked: alpha (the factor's times the texture's, bilinear at level 0) under the
    cutoff; an opaque material cuts nothing."""
    texture = texture_from_pixels(_striped(), {})
    masked = MetallicRoughnessMaterial((1.0, 1.0, 1.0), texture, alpha_cutoff=0.5)
    uvs = np.array([[1.5 / 16, 0.5], [5.5 / 16, 0.5], [9.5 / 16, 0.2]])
    assert material_masked(masked, MeshPoints.of_uvs(uvs)).tolist() == [False, True, False]
    faded = dataclasses.replace(masked, alpha=0.4)  # the factor's alpha alone is under the cutoff
    assert material_masked(faded, MeshPoints.of_uvs(uvs)).all()
    assert not material_masked(dataclasses.replace(masked, alpha_cutoff=None), MeshPoints.of_uvs(uvs)).any()


@pytest.fixture(scope="module")
def scenes() -> dict[bool, Scene]:
    return {masked: _masked_scene(masked) for masked in (True, False)}


@pytest.mark.parametrize("method", [Method.RAYTRACE, Method.HYBRID])
def test_traced_methods_see_through_the_cut_away_stripes_as_the_truth(
        ctx: moderngl.Context, scenes: dict[bool, Scene], method: Method) -> None:
    """Beside the mirror, the traced methods see what lies behind the cut-away stripes where the truth
    does (wrong object 0, colour within float noise), and the mask changes what the mirror shows."""
    renders = {}
    for masked, scene in scenes.items():
        with Renderer(ctx, scene, method=method, reflection_data=True) as renderer:
            renderer.render()
            result = compare(renderer)
        assert_finite(result.render)
        assert_finite(result.truth)
        assert result.figures.object_pixels > 500
        assert result.figures.wrong_object_share == 0.0, (masked, result.figures.wrong_object_share)
        assert result.figures.color_rmse < 1e-3, (masked, result.figures.color_rmse)
        renders[masked] = (result.render, result.mirror_mask)
    both = renders[True][1] & renders[False][1]  # the stripes hide the mirror where they are not cut
    changed = np.abs(renders[True][0] - renders[False][0]).max(axis=2)[both] > 0.05
    assert changed.sum() > 30, f"the mask changed {changed.sum()} of the mirror's pixels"


def test_depth_images_hold_what_lies_behind_the_cut_away_stripes(ctx: moderngl.Context,
                                                                  scenes: dict[bool, Scene]) -> None:
    """The bakes discard cut-away texels: the depth method's wrong surfaces stay within its usual share."""
    with Renderer(ctx, scenes[True], method=Method.DEPTH, reflection_data=True) as renderer:
        renderer.render()
        result = compare(renderer)
    assert_finite(result.render)
    assert result.figures.wrong_object_share < 0.02, result.figures.wrong_object_share


def test_the_eye_and_the_shadows_see_through_the_stripes_as_the_truth(ctx: moderngl.Context) -> None:
    """The rasterized frame (the eye's pass discarding, the shadow map's casters discarding) equals
    the truth's primary rays and shadow rays but at edges, and where the stripes' shadow on the floor
    has gaps (the truth's floor brighter masked than unmasked), the raster has them too. (The floor
    untextured and dark: a texture far away is trilinear in the raster and level 0 in the truth, and
    a bright floor clips its shadows away.)"""
    frames = {}
    for masked in (True, False):
        scene = _masked_scene(masked, shadows=True)
        plain = DiffuseMaterial((0.3, 0.3, 0.3))
        direct = dataclasses.replace(scene, objects=tuple(dataclasses.replace(o, material=plain) if o.name == "floor"
                                                          else o for o in scene.objects if not o.is_reflector))
        with Renderer(ctx, direct) as renderer:
            renderer.render()
            raster = np.clip(renderer.read_color_float(), 0, 1)
            camera = World(direct).camera()
            v, u = np.mgrid[0:direct.render.size[1], 0:direct.render.size[0]] + 0.5
            directions = camera.ray_direction(u.ravel(), v.ravel())
            directions /= np.linalg.norm(directions, axis=1, keepdims=True)
            tracer = TruthTracer(direct, renderer.world.reflected_objects, renderer.world.analytic_planes,
                                 renderer.world.shadow_casters)
            traced = tracer.trace(np.broadcast_to(camera.C, directions.shape), directions)
        assert_finite(raster)
        truth = np.clip(traced.color.reshape(raster.shape), 0, 1)
        differs = np.abs(truth - raster).max(axis=2) > 0.05
        assert differs.mean() < 0.03, f"masked={masked}: {differs.mean():.2%} of pixels differ"
        floor = next(i for i, o in enumerate(direct.objects) if o.name == "floor")
        frames[masked] = (raster, truth, traced.object_id.reshape(raster.shape[:2]) == floor)
    (raster, truth, on_floor), (_, unmasked_truth, unmasked_floor) = frames[True], frames[False]
    gaps = on_floor & unmasked_floor & ((truth - unmasked_truth).max(axis=2) > 0.05)
    assert gaps.sum() > 20, f"{gaps.sum()} pixels of gaps in the shadow"
    agree = np.abs(truth - raster).max(axis=2)[gaps] < 0.05
    assert agree.mean() > 0.8, f"the raster shows {agree.mean():.0%} of the shadow's gaps"
    changed = np.abs(frames[True][0] - frames[False][0]).max(axis=2) > 0.05
    assert changed.mean() > 0.01  # the stripes themselves: the eye sees through the cut ones


def test_a_gltf_mask_is_read_and_not_listed_as_ignored(tmp_path: Path) -> None:
    """alphaMode MASK with alphaCutoff and the base colour factor's alpha becomes the material's mask;
    plan no longer lists it among what the loader ignores (nor BLEND: tests/test_alpha_blend.py)."""
    w = GltfWriter()
    masked = w.material("Leaf", color=(0.3, 0.8, 0.2), alphaMode="MASK", alphaCutoff=0.3)
    blended = w.material("Glassy", color=(0.3, 0.3, 0.8), alphaMode="BLEND")
    w.json["materials"][masked]["pbrMetallicRoughness"]["baseColorFactor"][3] = 0.6
    w.node(mesh=w.mesh(w.box(material=masked)))
    w.node(mesh=w.mesh(w.box(material=blended)), translation=[2.0, 0.0, 0.0])
    scene = load_scene(w.write(tmp_path / "leaf.glb"))
    material = scene.objects[0].material
    assert isinstance(material, MetallicRoughnessMaterial)
    assert material.alpha_cutoff == pytest.approx(0.3) and material.alpha == pytest.approx(0.6)
    ignored = plan_render(scene, Method.RAYTRACE).ignored_lines()
    assert ignored == []
