"""Every limit `render` enforces is refused by `plan` too, with the same message, before any GL
object is made (scene/limits.py lists them); the ones the scene alone decides are refused when it
is loaded. Also: culling all pairs at once, fast enough for thousands of objects."""

from __future__ import annotations

import dataclasses
import io
import re
from pathlib import Path

import moderngl
import numpy as np
import pytest
from PIL import Image
from conftest import PROJECT_ROOT, SCENES, scene_from_toml

from depthimpostor import culling
from depthimpostor import world as world_module
from depthimpostor.constants import (
    MAX_ANALYTIC_PLANES,
    MAX_LIGHTS,
    Method,
)
from depthimpostor.culling import Reach, reach, reaches
from depthimpostor.errors import SceneError
from depthimpostor.geometry import scene_geometry
from depthimpostor.methods.registry import METHODS
from depthimpostor.plan import plan_render
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene, SceneObject, SphereShape, load_scene

HEAD = """
[render]
size = [64, 36]
impostor_resolution = 16
[camera]
eye = [0.0, 2.0, 12.0]
target = [0.0, 1.0, 0.0]
[[lights]]
type = "directional"
direction = [-0.4, -1.0, -0.3]
"""
WALL_MIRROR = """
[[objects]]
name = "wall mirror"
shape = { type = "plane", size = [8.0, 4.0] }
material = { type = "mirror" }
position = [0.0, 2.0, 0.0]
rotation = [90.0, 0.0, 0.0]
"""


def balls(count: int, z: float, radius: float = 0.1, first: int = 0) -> str:
    """`count` small spheres on a grid in the plane at `z` (in front of the wall mirror when z > 0)."""
    return "".join(f'\n[[objects]]\nname = "ball {first + i}"\nshape = {{ type = "sphere", radius = {radius} }}\n'
                   f"position = [{-4.0 + (i % 20) * 0.4:.2f}, {0.2 + (i // 20) * 0.4:.2f}, {z}]\n"
                   for i in range(count))


def scene(text: str) -> Scene:
    return scene_from_toml(text, "limits.toml")


def model_scene(tmp_path: Path) -> Scene:
    """A model file within the coordinate range, scaled past it."""
    (tmp_path / "far.obj").write_text("v 0 0 0\nv 1e9 0 0\nv 0 1e9 0\nf 1 2 3\n", encoding="utf-8")
    return scene_from_toml(HEAD + WALL_MIRROR + '[[objects]]\nname = "model"\nshape = { type = "mesh", '
                           'path = "far.obj" }\nscale = 1e10\nposition = [0.0, 0.0, 2.0]\n', "limits.toml", tmp_path)


def untextured_model_scene(tmp_path: Path) -> Scene:
    """A texture on a model file whose triangles carry no texture coordinates (no `vt`)."""
    (tmp_path / "bare.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", encoding="utf-8")
    (tmp_path / "grey.png").write_bytes(_grey_png())
    return scene_from_toml(HEAD + WALL_MIRROR + '[[objects]]\nname = "model"\nshape = { type = "mesh", path = "bare.obj" }\n'
                           'material = { type = "diffuse", texture = "grey.png" }\nposition = [0.0, 0.0, 2.0]\n',
                           "limits.toml", tmp_path)


def _grey_png() -> bytes:
    buffer = io.BytesIO()
    Image.new("RGB", (2, 2), (128, 128, 128)).save(buffer, format="PNG")
    return buffer.getvalue()


def too_many_lights() -> Scene:
    written = scene(HEAD + WALL_MIRROR + balls(1, 2.0))
    return dataclasses.replace(written, lights=written.lights * (MAX_LIGHTS + 1))


def too_far() -> Scene:
    written = scene(HEAD + WALL_MIRROR + balls(1, 2.0))
    far = SceneObject("far", SphereShape(1e18), position=(1e18, 0.0, 0.0))
    return dataclasses.replace(written, objects=written.objects + (far,))


BOUNCES = HEAD.replace("impostor_resolution = 16\n", "impostor_resolution = 16\nmax_bounces = 2\n") + "".join(
    f'\n[[objects]]\nname = "m{i}"\nshape = {{ type = "sphere", radius = 0.5 }}\nmaterial = {{ type = "mirror" }}\n'
    f"position = [{2.0 * i - 1.0}, 1.0, 0.0]\n" for i in range(2)) + balls(1, 2.0)

#: (name, scene, method, what the message says): every SceneError a renderer raises for a scene,
#: from the scene alone (also refused at load), the method, or what the mirrors can see.
LIMITS = [
    ("lights", lambda _: too_many_lights(), Method.DEPTH, f"at most {MAX_LIGHTS} [[lights]] tables"),
    ("reach", lambda _: too_far(), Method.DEPTH, "expected an object within 1e+18 of the origin"),
    ("model reach", model_scene, Method.DEPTH, "got one reaching 1.41e+19"),
    ("texture on a model without UVs", untextured_model_scene, Method.DEPTH, "got the mesh file"),
    ("bounces with cube maps", lambda _: scene(BOUNCES), Method.CUBEMAP, "render.max_bounces: expected 1 with --method cubemap"),
    ("bounces with billboards", lambda _: scene(BOUNCES), Method.BILLBOARD, "expected 1 with --method billboard"),
    ("object around a mirror's centre", lambda _: load_scene(SCENES / "hard" / "surrounds.toml"), Method.DEPTH,
     'object "ring" surrounds or touches the centre of mirror "mirror"'),
    ("object around a cube map's centre", lambda _: load_scene(SCENES / "hard" / "surrounds.toml"), Method.CUBEMAP,
     'reaches the centre of mirror "mirror": a cube map taken from there would cut through it'),
    ("light among its casters", lambda _: scene(HEAD.replace('type = "directional"\ndirection = [-0.4, -1.0, -0.3]',
                                                            'type = "point"\nposition = [-3.8, 0.2, 2.0]\nshadows = "hard"')
                                                + WALL_MIRROR + balls(3, 2.0)),
     Method.DEPTH, "lights[0].position: expected a light with every shadow caster on one side of it"),
]


@pytest.mark.parametrize(("name", "make", "method", "expected"), LIMITS, ids=[case[0] for case in LIMITS])
def test_plan_refuses_what_render_refuses(ctx: moderngl.Context, tmp_path: Path, name: str, make, method: Method,
                                         expected: str) -> None:
    refused = make(tmp_path)
    with pytest.raises(SceneError) as planned:
        plan_render(refused.with_overrides(size=(64, 36)), method)
    with pytest.raises(SceneError) as rendered:
        Renderer(ctx, refused.with_overrides(size=(64, 36)), method=method).release()
    assert str(planned.value) == str(rendered.value)
    assert expected in str(planned.value), str(planned.value)


def test_hybrid_refuses_more_triangles_than_a_sample_can_name(monkeypatch: pytest.MonkeyPatch,
                                                              ctx: moderngl.Context) -> None:
    """2^24 triangles are too many to build here: the limit is lowered below the scene's."""
    monkeypatch.setitem(METHODS, Method.HYBRID, dataclasses.replace(METHODS[Method.HYBRID], triangle_limit=100))
    refused = scene(HEAD + WALL_MIRROR + balls(1, 2.0))
    with pytest.raises(SceneError, match="expected at most 100 reflected triangles with --method hybrid") as planned:
        plan_render(refused, Method.HYBRID)
    with pytest.raises(SceneError) as rendered:
        Renderer(ctx, refused, method=Method.HYBRID).release()
    assert str(planned.value) == str(rendered.value)


#: Where the package raises SceneError outside the scene loader, and how many times: each raise is
#: walked above or is a limit of the GL itself (texture sizes, compared with the context: not a
#: property of the scene). A new one needs a case in LIMITS, and the check before planning.
RAISES = {
    "methods/cubemaps.py": 1,  # object around a cube map's centre
    "methods/atlas.py": 2,  # a frustum around an object; the atlas past GL_MAX_TEXTURE_SIZE (GL)
    "methods/planar.py": 1,  # a curved mirror or glass with --method planar (the plan: tests/test_eye_methods.py)
    "passes/shadows.py": 1,  # light among its casters
    "methods/triangles.py": 1,  # BVH texture past GL_MAX_TEXTURE_SIZE (GL)
    "gpu/scene_blocks.py": 1,  # lights: the loader and the plan refuse them first
    # lights, reach, bounces per method, named triangles; a texture on a shape without UVs (at load:
    # tests/test_textures.py); a texture on a model file without UVs (once loaded). Planes past 8,
    # traced objects past 64 and image textures have no limit of their own (tests/test_many_planes.py,
    # tests/test_image_records.py, tests/test_instances.py, tests/test_many_textures.py)
    "scene/limits.py": 6,
    # render --video's arguments (the frames past MAX_VIDEO_FRAMES, a GIF frame past 655.35 s among
    # them), refused before any work as cli.py's are: walked in tests/test_video.py
    "video.py": 5,
    # An unknown AOV name (render --aov, a batch job's aov), refused before any work: tests/test_aov.py
    "aov.py": 1,
    # A batch file that is no TOML, two frames writing one file: tests/test_batch.py
    "batch/jobs.py": 2,
    # --workers without Ray installed, --address with --workers 0: tests/test_batch.py
    "batch/run.py": 2,
}


def test_every_refusal_outside_the_loader_is_walked() -> None:
    package = PROJECT_ROOT / "depthimpostor"
    found = {}
    for path in sorted(package.rglob("*.py")):
        name = str(path.relative_to(package))
        if name.startswith(("scene/loader", "scene/fields", "scene/model", "scene/gltf")) or name in ("cli.py", "errors.py"):
            continue
        count = len(re.findall(r"\bSceneError\(", path.read_text("utf-8")))
        if count:
            found[name] = count
    assert found == RAISES


def test_planes_past_the_exact_ones_are_drawn_as_meshes_not_refused(ctx: moderngl.Context, tmp_path: Path) -> None:
    """Nine planes were refused at load ("expected at most 8 planes that are not mirrors"): now the
    8 largest are intersected exactly and the ninth, the smallest, is a reflected object, which
    the plan and the renderer agree on (its depth image, the 8 planes in the mirror shader)."""
    planes = "".join(f'\n[[objects]]\nname = "floor {i}"\nshape = {{ type = "plane", size = [{4.0 - 0.1 * i}, 1.0] }}\n'
                     f"position = [0.0, {0.01 * i}, {2.0 + i}]\n" for i in range(MAX_ANALYTIC_PLANES + 1))
    path = tmp_path / "planes.toml"
    path.write_text(HEAD + WALL_MIRROR + planes, encoding="utf-8")
    planed = load_scene(path).with_overrides(size=(64, 36))
    assert planed.analytic_plane_indices == frozenset(range(1, MAX_ANALYTIC_PLANES + 1))
    plan = plan_render(planed)
    assert [image.label for image in plan.images] == ["wall mirror -> floor 8"]
    with Renderer(ctx, planed) as renderer:
        assert renderer.plan == plan
        renderer.render()
        assert renderer.stats.depth_images_baked == 1
        assert {stages[1]: dict(defines) for stages, defines in renderer.programs.keys
                if stages[1] == "reflector.frag"}["reflector.frag"]["PLANE_COUNT"] == str(MAX_ANALYTIC_PLANES)


@pytest.mark.parametrize(("field", "value", "path"), [
    ('shape = { type = "sphere", radius = 1e308 }', "", "objects[1].shape.radius"),
    ('shape = { type = "sphere", radius = 1.0 }', "position = [1e308, 0.0, 0.0]", "objects[1].position"),
    ('shape = { type = "box", size = [1.0, 2e18, 1.0] }', "", "objects[1].shape.size"),
    ('shape = { type = "sphere", radius = 1.0 }', "scale = 1e19", "objects[1].scale"),
    ('shape = { type = "sphere", radius = 1e17 }', "scale = 20.0", "objects[1]"),
    ('shape = { type = "sphere", radius = 1.0 }', ("position = [9e17, 0.0, 0.0]\nanimation = { type = \"orbit\", "
     "centre = [-9e17, 0.0, 0.0], axis = [0.0, 1.0, 0.0], degrees_per_second = 10.0 }"), "objects[1]"),
])
def test_overflowing_geometry_is_refused_at_load(tmp_path: Path, field: str, value: str, path: str) -> None:
    """1e308 ended in `ValueError: Mesh: positions and normals must be finite` (a traceback)."""
    file = tmp_path / "far.toml"
    file.write_text(HEAD + WALL_MIRROR + f'[[objects]]\nname = "far"\n{field}\n{value}\n', encoding="utf-8")
    with pytest.raises(SceneError) as refused:
        load_scene(file)
    assert refused.value.source == str(file) and refused.value.path == path
    assert "1e+18" in str(refused.value) and "float32" in str(refused.value)


def test_a_model_past_float32_is_refused_naming_the_file(tmp_path: Path) -> None:
    from depthimpostor.meshes import MeshError, load_mesh_file

    (tmp_path / "huge.obj").write_text("v 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n", encoding="utf-8")
    with pytest.raises(MeshError, match=r"huge\.obj: expected vertex coordinates of magnitude at most 1e\+18"):
        load_mesh_file(tmp_path / "huge.obj")


# ---------------------------------------------------------------------------- culling at scale


def test_culling_all_pairs_at_once_equals_each_pair(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every mirror's triangles stacked and the objects taken in small chunks give each pair's answer."""
    text = HEAD + WALL_MIRROR + """
[[objects]]
name = "ball mirror"
shape = { type = "sphere", radius = 0.7 }
material = { type = "mirror" }
position = [3.0, 1.0, 3.0]
[[objects]]
name = "glass"
shape = { type = "sphere", radius = 0.5 }
material = { type = "glass" }
position = [-3.0, 1.0, 3.0]
[[objects]]
name = "turning mirror"
shape = { type = "plane", size = [1.0, 1.0] }
material = { type = "mirror" }
position = [0.0, 1.0, 5.0]
animation = { type = "rotate", axis = [0.0, 1.0, 0.0], degrees_per_second = 10.0 }
""" + balls(40, 2.0) + balls(40, -2.0, first=40) + """
[[objects]]
name = "inside the ball mirror"
shape = { type = "sphere", radius = 0.2 }
position = [3.0, 1.1, 3.0]
[[objects]]
name = "orbiting"
shape = { type = "box", size = [0.2, 0.4, 0.2] }
position = [0.0, 1.0, -2.0]
scale = [1.0, 3.0, 0.5]
animation = { type = "orbit", centre = [0.0, 0.0, 0.0], axis = [0.0, 1.0, 0.0], degrees_per_second = 10.0 }
"""
    geometry = scene_geometry(scene(text).objects)
    reflectors = [g for g in geometry if g.object.is_reflector]
    targets = [g for g in geometry if not g.object.is_reflector]
    monkeypatch.setattr(culling, "_CHUNK_ELEMENTS", 3 * 2 * 7)  # the wall's 2 triangles, 7 objects a chunk
    table = reaches(reflectors, targets)
    assert table == [[reach(reflector, target) for target in targets] for reflector in reflectors]
    wall, ball_mirror, glass, turning = table
    assert wall.count(Reach.BEHIND) >= 40 and set(wall) == {Reach.BEHIND, Reach.REACHABLE}
    assert Reach.OUTSIDE_DIRECTIONS in ball_mirror  # the balls inside it
    assert set(glass) == set(turning) == {Reach.REACHABLE}


def test_two_thousand_objects_are_culled_in_batches_not_pair_by_pair(monkeypatch: pytest.MonkeyPatch) -> None:
    """Their plan took 39.5 s, 35.5 of them culling one pair at a time; 10,000 were refused after
    179 s. The world culls a reflector's targets in one call (the full meshes', then again the
    pairs of objects given a coarser level); the time itself is tools/startup_time.py's to measure,
    not a test's."""
    calls: list[tuple[int, int]] = []
    original = world_module.reaches
    monkeypatch.setattr(world_module, "reaches",
                        lambda reflectors, targets: calls.append((len(reflectors), len(targets))) or original(reflectors, targets))
    many = scene(HEAD + WALL_MIRROR.replace("[8.0, 4.0]", "[20.0, 8.0]") + balls(50, 2.0) + balls(1950, -2.0, first=50))
    plan = plan_render(many)
    assert 1 <= len(calls) <= 2 and all(targets >= 1950 for _, targets in calls), calls
    assert len(plan.images) == 50 and len(plan.skipped) == 1950
    # Ten thousand, a hundred of them in front of the mirror: past the 64 records of a uniform
    # block, which was a limit (the records go to a storage buffer: lib/baked_images.glsl).
    assert len(plan_render(scene(HEAD + WALL_MIRROR + balls(100, 2.0) + balls(9900, -2.0, first=100))).images) == 100


def test_equal_shapes_share_one_mesh() -> None:
    geometry = scene_geometry(scene(HEAD + balls(30, 2.0)).objects)
    assert len({id(g.local_mesh) for g in geometry}) == 1
    centres = np.array([g.bounding_sphere[0] for g in geometry])
    assert len(np.unique(centres.round(6), axis=0)) == 30  # each still where it stands
