"""Shared fixtures: one GL context for the whole session, GL errors checked after every test,
and the test models found through DEPTHIMPOSTOR_MODEL_PATH (or a procedural stand-in)."""

from __future__ import annotations

import sys
import warnings
from collections.abc import Iterator
from importlib.metadata import version
from pathlib import Path

import moderngl
import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, settings

from depthimpostor.constants import Method
from depthimpostor.gpu.context import create_context
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene
from depthimpostor.scene.loader import parse_scene

if sys.version_info >= (3, 11):
    import tomllib
else:  # as depthimpostor.scene.loader reads scene files on 3.10
    import tomli as tomllib

# The fuzzer (test_fuzz.py) draws batches of 2048 rays: 50 batches by default, over 100,000 rays
# in CI; `pytest --hypothesis-profile=long` runs 2,000 batches (4 million rays) drawn afresh each run.
# The default's batches are the same every run (derandomize): a run that explores found a ray the
# GPU and the reference place 0.46 px apart (a grazing hit along an image's last column, open:
# test_gpu_and_reference_agree_on_hard_rays with @reproduce_failure('6.155.2',
# b'AXicc2R1ZBggyI5FjAmKGcGYUcP+aU617e+lxgPmyFFIKcQWzVjEnJitHBkBkgZWZg==')), which would have
# failed one CI run in many at random; the long profile keeps exploring, and what it finds is a
# bug to fix, not a flaky test.
_FUZZ = {"deadline": None, "print_blob": True, "suppress_health_check": [HealthCheck.too_slow, HealthCheck.data_too_large]}
settings.register_profile("ci", max_examples=50, derandomize=True, **_FUZZ)
settings.register_profile("long", max_examples=2000, **_FUZZ)
settings.load_profile("ci")

SHARED_MODELS = Path(__file__).resolve().parents[2] / "shared" / "data" / "models"
PROJECT_ROOT = Path(__file__).resolve().parents[1]
SCENES = PROJECT_ROOT / "scenes"


@pytest.hookimpl(hookwrapper=True)  # around xdist's own, which reads the groups into the test ids
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> Iterator[None]:
    """The tests of a module that holds a module-scoped fixture (its baked images, its reference
    marches, its Xvfb) run in one xdist worker (pyproject's --dist loadgroup), so that the
    fixture is made once: shared out test by test, both workers made it (25 s of the suite's
    CPU, the largest 14 s). Tests already in a group keep theirs.

    Afterwards, in a worker, a warning if xdist did not take the groups: it passes a test's group
    on by appending "@group" to the test's id, which pytest 9.2 no longer reads (pytest-xdist
    issue #1386), and nothing else says so: the suite just took 80 to 100 s more CPU."""
    for item in items:
        fixtures = getattr(item, "_fixtureinfo", None)
        if item.get_closest_marker("xdist_group") is not None or fixtures is None:
            continue
        if any(definitions[-1].scope == "module" for definitions in fixtures.name2fixturedefs.values()):
            item.add_marker(pytest.mark.xdist_group(item.nodeid.split("::")[0]))
    yield
    if getattr(config.option, "loadgroup", False):  # set in xdist's workers under --dist loadgroup
        # A group is what follows the last "@" after any "]", as xdist reads it.
        lost = [item.nodeid for item in items if item.get_closest_marker("xdist_group") is not None
                and item.nodeid.rfind("@") <= item.nodeid.rfind("]")]
        if lost:
            warnings.warn(pytest.PytestWarning(
                f"--dist loadgroup did not group: {len(lost)} tests of an xdist_group ({lost[0]} the first) have no "
                f"@group in their ids (pytest {pytest.__version__} with pytest-xdist {version('pytest-xdist')}: "
                "pytest-xdist issue #1386), so each group's fixtures, Xvfb and Ray start in both workers (80 to "
                "100 s more CPU); pyproject.toml's [test] extra installs a pytest below 9.2"), stacklevel=1)


@pytest.fixture(scope="session")
def ctx() -> Iterator[moderngl.Context]:
    context = create_context()
    yield context
    context.release()


@pytest.fixture(autouse=True)
def no_gl_errors(request: pytest.FixtureRequest) -> Iterator[None]:
    """Fail any test that leaves a GL error behind (only for tests that use the context)."""
    if "ctx" not in request.fixturenames:
        yield
        return
    context: moderngl.Context = request.getfixturevalue("ctx")
    assert context.error == "GL_NO_ERROR", "a GL error was pending before the test"
    yield
    assert context.error == "GL_NO_ERROR"


@pytest.fixture(scope="session")
def model_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The folder holding stanford-bunny.obj: the shared test models, or a procedural stand-in."""
    if (SHARED_MODELS / "stanford-bunny.obj").is_file():
        return SHARED_MODELS
    folder = tmp_path_factory.mktemp("models")
    stand_in = trimesh.creation.icosphere(subdivisions=3, radius=0.08)
    stand_in.apply_translation([0.0, 0.1, 0.0])
    stand_in.export(folder / "stanford-bunny.obj")
    return folder


@pytest.fixture(autouse=True)
def _models_on_path(monkeypatch: pytest.MonkeyPatch, model_path: Path) -> None:
    monkeypatch.setenv("DEPTHIMPOSTOR_MODEL_PATH", str(model_path))


def assert_finite(image: np.ndarray) -> None:
    bad = ~np.isfinite(image)
    assert not bad.any(), f"{int(bad.sum())} NaN or Inf values in the image"


def scene_from_toml(text: str, source: str = "test scene", base_dir: Path = Path(".")) -> Scene:
    """A scene written inline in a test, validated as a scene file would be (model and texture
    paths resolved against `base_dir`)."""
    return parse_scene(tomllib.loads(text), source, base_dir)


def assert_a_move_draws_a_fresh_frame(ctx: moderngl.Context, scene: Scene, method: Method, seconds: float) -> None:
    """A renderer that drew `scene` at time 0 and then at `seconds` (its objects moved: what it
    keeps, it updated) draws what a renderer made at `seconds` draws, and the move shows."""
    with Renderer(ctx, scene, method=method) as renderer:
        renderer.render()
        before = renderer.read_color_float()
        renderer.set_time(seconds)
        renderer.render()
        moved = renderer.read_color_float()
    with Renderer(ctx, scene, method=method) as fresh:
        fresh.set_time(seconds)
        fresh.render()
        np.testing.assert_allclose(moved, fresh.read_color_float(), atol=1e-6)
    assert_finite(moved)
    assert np.abs(moved - before).max() > 0.1  # the move shows in the mirror
