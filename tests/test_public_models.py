"""The public glTF sample models committed under tests/data/gltf/ (docs/public_models.md; the
catalogue is tools/public_models.py's): each loads and renders beside a mirror with no refusal, and
what it uses but the loader does not implement is exactly what `plan` lists as ignored, model by
model, so that a feature dropped silently (read past without being listed, or no longer read) fails
here. On two small textured models the triangle methods see what the truth sees."""

from __future__ import annotations

import importlib.util
import sys
import warnings
from pathlib import Path
from types import ModuleType

import moderngl
import numpy as np
import pytest

from conftest import PROJECT_ROOT, assert_finite
from depthimpostor.constants import Method
from depthimpostor.errors import SceneWarning
from depthimpostor.oracles.compare import compare
from depthimpostor.renderer import Renderer


def tool() -> ModuleType:
    spec = importlib.util.spec_from_file_location("public_models", PROJECT_ROOT / "tools" / "public_models.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


PUBLIC = tool()
COMMITTED = [model for model in PUBLIC.CATALOGUE if model.committed]

#: What `plan` lists as ignored in each committed model: a feature implemented leaves its model's
#: list (update it here), a feature read past without being listed fails the test.
EXPECTED_IGNORED: dict[str, tuple[str, ...]] = {
    "BoxAnimated": (),
    "RiggedSimple": (),
    "SimpleSkin": (),
    "AnimatedMorphCube": (),
    "AnimatedMorphSphere": (),
    "SimpleMorph": (),
    "MorphPrimitivesTest": (),
    "TextureTransformTest": (),
    "SimpleSparseAccessor": (),
    "BoxTextured": (),
    "BoxInterleaved": (),
    "CesiumMilkTruck": (),
    "ClearCoatTest": ("KHR_materials_clearcoat",),
    "AlphaBlendModeTest": (),
}
#: A size small enough for a test, large enough that the model and both mirrors cover pixels.
SIZE = (96, 60)


def test_the_committed_models_fit_the_issue_budget_and_cover_its_features() -> None:
    """At most 5 MB in all; a skinned and animated model, a morph target model, alpha MASK and
    BLEND, KHR_texture_transform among them (issue 33); every file the catalogue names is there."""
    folder = PROJECT_ROOT / "tests" / "data" / "gltf"
    assert sum(p.stat().st_size for p in folder.rglob("*") if p.is_file()) <= 5 * 2**20
    assert {m.name for m in COMMITTED} == set(EXPECTED_IGNORED)
    text = " ".join(m.features for m in COMMITTED)
    for feature in ("skin", "morph target", "MASK", "BLEND", "KHR_texture_transform"):
        assert feature in text
    assert all((folder / m.file).is_file() for m in COMMITTED)
    assert len(PUBLIC.CATALOGUE) >= 15


@pytest.mark.parametrize("model", COMMITTED, ids=lambda m: m.name)
def test_a_public_model_renders_beside_a_mirror_listing_what_it_ignores(ctx: moderngl.Context, model: object) -> None:
    path = PUBLIC.model_path(model, Path("."))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", SceneWarning)
        scene = PUBLIC.mirror_scene(path, SIZE)
    assert PUBLIC.ignored(scene) == EXPECTED_IGNORED[model.name]  # type: ignore[attr-defined]
    others = [str(w.message) for w in caught if "does not implement" not in str(w.message)]
    assert others == []  # no other warning: nothing else is drawn otherwise than the file says
    with Renderer(ctx, scene, method=Method.HYBRID) as renderer:
        renderer.render()
        image = renderer.read_color_float()
    assert_finite(image)
    assert image.std() > 0.01


@pytest.mark.parametrize("name", ["BoxTextured", "MorphPrimitivesTest"])
def test_the_triangle_methods_see_what_the_truth_sees_on_a_textured_model(ctx: moderngl.Context, name: str) -> None:
    """raytrace and hybrid, on a textured box and on a textured mesh its morph target moves: no
    mirror pixel shows another object than the truth's, and the colour is the truth's within float
    rounding (the same textures sampled at the same points)."""
    model = next(m for m in COMMITTED if m.name == name)
    scene = PUBLIC.mirror_scene(PUBLIC.model_path(model, Path(".")), (128, 80))
    truth = None
    for method in (Method.RAYTRACE, Method.HYBRID):
        with Renderer(ctx, scene, method=method, reflection_data=True) as renderer:
            renderer.render()
            result = compare(renderer, truth)
        truth = result.truth_frame
        figures = result.figures
        assert figures.object_pixels > 20  # the model is seen in the mirrors
        assert figures.wrong_object_share == 0.0, method
        assert figures.color_rmse < 2e-3, method
        assert np.isfinite(result.render).all()
