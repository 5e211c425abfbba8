"""glTF's doubleSided (issue 33 item 1; docs/scene_format.md, "Faces"): a single-sided material's
back faces are not there, a double-sided one's are shaded turned round, in the eye's passes, the
bakes, the traced hits and the truth alike. The test surfaces are a glTF rectangle (placed as an
analytic plane) and a glTF triangle (a mesh: the BVH's and the depth images'), both facing away
from the eye and from the mirror, lit from behind."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import moderngl
import numpy as np
import pytest

from conftest import assert_finite, scene_from_toml
from depthimpostor.constants import Method, Sides
from depthimpostor.errors import SceneError
from depthimpostor.gpu.uniforms import material_records
from depthimpostor.oracles.compare import compare
from depthimpostor.renderer import Renderer
from depthimpostor.scene import PlaneShape, Scene
from depthimpostor.scene.gltf import read_gltf
from depthimpostor.scene.model import material_sides
from gltf_files import GltfWriter

# In the plane x = -1, whose front faces -X (away from the eye, at x = 2.5, and from the mirror's
# reflected eye) when `toward` is false.
RECTANGLE = np.array([[-1.0, 0.4, 0.0], [-1.0, 0.4, -1.0], [-1.0, 1.4, -1.0], [-1.0, 1.4, 0.0]])
TRIANGLE = np.array([[-1.0, 0.3, 0.3], [-1.0, 0.3, 1.2], [-1.0, 1.3, 0.75]])


def _faces(positions: np.ndarray, faces: np.ndarray, toward: bool) -> tuple[np.ndarray, np.ndarray]:
    """`faces` wound so that the front faces +X (`toward` the eye) or -X, and its normals."""
    a, b, c = (positions[faces[0, k]] for k in range(3))
    if (np.cross(b - a, c - a)[0] > 0.0) != toward:
        faces = faces[:, ::-1]
    return faces, np.tile([1.0 if toward else -1.0, 0.0, 0.0], (len(positions), 1))


def _sheets(path: Path, double_sided: bool, toward: bool) -> Path:
    w = GltfWriter()
    m = w.material("Sheet", color=(0.8, 0.35, 0.2), roughness=0.6, doubleSided=double_sided)
    for positions, faces in ((RECTANGLE, np.array([[0, 1, 2], [0, 2, 3]])), (TRIANGLE, np.array([[0, 1, 2]]))):
        wound, normals = _faces(positions, faces, toward)
        w.node(mesh=w.mesh(w.primitive(positions, wound, normals, material=m)))
    return w.write(path)


SCENE = """
[render]
size = [200, 120]
impostor_resolution = 128
ambient = 0.2

[camera]
eye = [2.5, 1.2, 3.5]
target = [-0.5, 0.9, -1.5]
fov_y = 50.0

[[lights]]
type = "directional"
direction = [-1.0, -0.6, -0.2]

[[objects]]
name = "floor"
shape = { type = "plane", size = [20.0, 20.0] }
material = { type = "diffuse", color = [0.5, 0.5, 0.5] }

[[objects]]
name = "mirror"
shape = { type = "plane", size = [6.0, 2.6] }
material = { type = "mirror", tint = [0.95, 0.95, 0.95] }
position = [0.0, 1.3, -2.0]
rotation = [90.0, 0.0, 0.0]
"""

SHEETS = """
[[objects]]
name = "sheets"
shape = { type = "gltf", path = "sheets.glb" }
"""

#: The variants: (double_sided, toward the eye), and None: no sheets at all.
VARIANTS = [(True, False), (True, True), (False, False), None]


@pytest.fixture(scope="module")
def scenes(tmp_path_factory: pytest.TempPathFactory) -> dict[tuple[bool, bool] | None, Scene]:
    made: dict[tuple[bool, bool] | None, Scene] = {}
    for variant in VARIANTS:
        folder = tmp_path_factory.mktemp("sheets")
        if variant is None:
            made[variant] = scene_from_toml(SCENE, str(folder / "scene.toml"), folder)
            continue
        _sheets(folder / "sheets.glb", *variant)
        made[variant] = scene_from_toml(SCENE + SHEETS, str(folder / "scene.toml"), folder)
    return made


def test_the_file_says_which_faces_are_there(scenes: dict[tuple[bool, bool] | None, Scene]) -> None:
    """doubleSided read from the file into the material record; the rectangle is a plane, the
    triangle a mesh (both paths are tested); TOML's materials keep both faces as the front."""
    for variant in ((True, False), (False, False)):
        scene = scenes[variant]
        assert variant is not None
        sheets = [o for o in scene.objects if o.name.startswith("sheets")]
        assert len(sheets) == 2 and sum(isinstance(o.shape, PlaneShape) for o in sheets) == 1
        sides = Sides.DOUBLE if variant[0] else Sides.SINGLE
        assert {material_sides(o.material) for o in sheets} == {sides}
        records = material_records(scene)
        assert records["double_sided"][scene.material_index(sheets[0].material)] == sides
    floor = scenes[None].objects[0]
    assert material_sides(floor.material) == Sides.AS_FRONT


def _frame(ctx: moderngl.Context, scene: Scene, method: Method) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The eye's frame, and compare's render and truth (mirror pixels)."""
    with Renderer(ctx, scene, method=method, reflection_data=True) as renderer:
        renderer.render()
        frame = renderer.read_color_float()
        result = compare(renderer)
    for image in (frame, result.render, result.truth):
        assert_finite(image)
    if method in (Method.RAYTRACE, Method.HYBRID):
        figures = result.figures
        assert figures.wrong_object_share == 0.0 and figures.color_rmse < 1e-3, (scene.source, method, figures)
    mirror = np.where(result.mirror_mask[..., None], result.truth, 0.0)
    return frame, np.where(result.mirror_mask[..., None], result.render, 0.0), mirror


def _differing(a: np.ndarray, b: np.ndarray, tolerance: float = 0.02) -> int:
    return int((np.abs(a - b).max(axis=2) > tolerance).sum())


@pytest.mark.parametrize("method", [Method.RAYTRACE, Method.HYBRID, Method.DEPTH, Method.PLANAR])
def test_a_back_face_is_turned_when_double_sided_and_not_there_when_single_sided(
        ctx: moderngl.Context, scenes: dict[tuple[bool, bool] | None, Scene], method: Method) -> None:
    """Seen from behind, in the eye, in the mirror and in the truth: the double-sided sheets look as
    the same sheets wound to face the eye (their back faces shaded turned round, lit by the light
    behind them), and the single-sided ones as no sheets at all. The sheets show (a few hundred
    pixels in the eye and in the mirror), so that a sheet drawn unturned or not culled would fail."""
    frames = {variant: _frame(ctx, scene, method) for variant, scene in scenes.items()}
    double, turned, single, none = (frames[v] for v in VARIANTS)
    # frame, mirror render, mirror truth: each shows the sheets (against the scene without them).
    for k, least in ((0, 300), (1, 150), (2, 150)):
        assert _differing(turned[k], none[k], 0.05) > least, (method, k, _differing(turned[k], none[k], 0.05))
    # The eye and the truth, exactly; the depth method's mirror within its sampling (its images hold
    # a sheet turned away from the mirror's centre on both layers).
    allowed = 40 if method in (Method.DEPTH, Method.PLANAR) else 0
    assert _differing(double[0], turned[0]) == 0, method
    assert _differing(single[0], none[0]) == 0, method
    assert _differing(double[1], turned[1]) <= allowed, (method, _differing(double[1], turned[1]))
    assert _differing(single[1], none[1]) <= allowed, (method, _differing(single[1], none[1]))
    assert _differing(double[2], turned[2]) == 0 and _differing(single[2], none[2]) == 0


def test_toml_says_double_sided_and_a_wrong_value_is_refused(tmp_path: Path) -> None:
    """TOML's double_sided: true or false as glTF's, unwritten both faces as the front; anything
    else refused in one line naming the field (a glTF file's doubleSided likewise)."""
    objects = ""
    for k, value in enumerate(("true", "false", None)):
        written = "" if value is None else f", double_sided = {value}"
        objects += (f'\n[[objects]]\nname = "b{k}"\nshape = {{ type = "box", size = [1.0, 1.0, 1.0] }}\n'
                    f'material = {{ type = "diffuse", color = [0.5, 0.5, 0.5]{written} }}\n')
    scene = scene_from_toml(objects, "s.toml")
    assert [material_sides(o.material) for o in scene.objects] == [Sides.DOUBLE, Sides.SINGLE, Sides.AS_FRONT]
    with pytest.raises(SceneError, match=r'^s.toml: objects\[0\].material.double_sided: expected true or false, got "yes"$'):
        scene_from_toml(objects.replace("double_sided = true", 'double_sided = "yes"'), "s.toml")
    w = GltfWriter()
    w.node(mesh=w.mesh(w.box(material=w.material("M", doubleSided="yes"))))
    path = w.write(tmp_path / "x.glb")
    with pytest.raises(SceneError, match=r'materials\[0\].doubleSided: expected true or false, got "yes"$'):
        read_gltf(path, "x.glb")


@pytest.mark.parametrize("toward", [True, False])
def test_a_mirroring_placement_turns_which_face_is_the_front(
        ctx: moderngl.Context, scenes: dict[tuple[bool, bool] | None, Scene], toward: bool) -> None:
    """The single-sided triangle reflected in its own plane (x -> -2 - x: a model matrix of
    determinant -1 that leaves it where it was): its winding's front turns with the matrix, on the
    screen (face_class 2, diffuse.frag's v_mirrored), in the traced instances and in the truth. The
    one wound away from the eye now faces it (drawn as the one wound toward it, unmirrored), and the
    one wound toward it is not there (as no sheet at all)."""
    def triangle_alone(scene: Scene, mirrored: bool) -> Scene:
        kept = [o for o in scene.objects if not (o.name.startswith("sheets") and isinstance(o.shape, PlaneShape))]
        if mirrored:
            kept = [dataclasses.replace(o, position=(-2.0, 0.0, 0.0), scale=(-1.0, 1.0, 1.0))
                    if o.name.startswith("sheets") else o for o in kept]
        return dataclasses.replace(scene, objects=tuple(kept))

    folder = Path(scenes[(True, False)].source).parent.parent
    source = _single_sided(folder / f"wound_{toward}", toward)
    placed = _frame(ctx, triangle_alone(source, True), Method.RAYTRACE)
    reference = _frame(ctx, triangle_alone(_single_sided(folder / "reference", True), False) if not toward
                       else scenes[None], Method.RAYTRACE)
    for k in range(3):
        assert _differing(placed[k], reference[k]) == 0, (toward, k, _differing(placed[k], reference[k]))


def _single_sided(folder: Path, toward: bool) -> Scene:
    folder.mkdir(exist_ok=True)
    _sheets(folder / "sheets.glb", False, toward)
    return scene_from_toml(SCENE + SHEETS, str(folder / "scene.toml"), folder)
