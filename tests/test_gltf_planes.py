"""glTF rectangles load as the scene's exactly intersected `plane` shape (scene/gltf_planes.py),
at the place, size and texture mapping the file gives them; other flat parts stay meshes; and the
showcase scene (whose floor and walls are such rectangles) renders through every method."""

from __future__ import annotations

import warnings
from pathlib import Path

import moderngl
import numpy as np
import pytest

from conftest import assert_finite
from depthimpostor import meshes
from depthimpostor.constants import Method
from depthimpostor.errors import SceneError
from depthimpostor.geometry import scene_geometry
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene, load_scene
from depthimpostor.scene.model import GltfShape, PlaneShape, SceneObject
from gltf_files import GltfWriter, quaternion

ROOT = Path(__file__).resolve().parent.parent


def load_quietly(path: Path) -> Scene:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_scene(path)


def rectangle_file(tmp_path: Path, uvs: list[list[float]], positions: list[list[float]] | None = None,
                   faces: list[list[int]] | None = None) -> Path:
    w = GltfWriter()
    image = np.zeros((4, 4, 4), np.uint8)
    image[..., 3] = 255
    texture = w.texture(image)
    material = w.material("Tiles", pbrMetallicRoughness={"baseColorTexture": {"index": texture}})
    p = positions or [[-1.5, -1, 0], [1.5, -1, 0], [1.5, 1, 0], [-1.5, 1, 0]]
    mesh = w.mesh(w.primitive(p, faces or [[0, 1, 2], [0, 2, 3]], uvs=uvs, material=material))
    w.node(mesh=mesh, translation=[0.5, 1.0, -2.0], rotation=quaternion((0, 1, 0), 30))
    return w.write(tmp_path / "r.glb")


def test_a_textured_rectangle_is_a_plane_with_its_texture_where_the_file_puts_it(tmp_path: Path) -> None:
    # A 3 x 2 wall facing +Z, turned 30 degrees about Y, its image repeated twice across and once up,
    # v running down the image from the top edge as glTF's UVs do.
    path = rectangle_file(tmp_path, [[0, 1], [2, 1], [2, 0], [0, 0]])
    scene = load_quietly(path)
    (obj,) = scene.objects
    assert isinstance(obj.shape, PlaneShape)
    assert obj.shape.size == pytest.approx((3.0, 2.0), abs=1e-6)
    assert obj.material.texture.scale == pytest.approx((2.0, 1.0), abs=1e-6)  # type: ignore[union-attr]
    # The plane's own mesh and UVs, placed by its transform, give the file's points and UVs.
    (geometry,) = scene_geometry(scene.objects)
    world = geometry.world_mesh
    file_corners = np.array([[-1.5, -1, 0], [1.5, -1, 0], [1.5, 1, 0], [-1.5, 1, 0]])
    turn = np.array([[np.cos(np.pi / 6), 0, np.sin(np.pi / 6)], [0, 1, 0], [-np.sin(np.pi / 6), 0, np.cos(np.pi / 6)]])
    expected = file_corners @ turn.T + (0.5, 1.0, -2.0)
    expected_uvs = np.array([[0, 1], [2, 1], [2, 0], [0, 0]])
    for point, uv in zip(expected, expected_uvs, strict=True):
        k = np.argmin(np.linalg.norm(world.positions - point, axis=1))
        assert np.linalg.norm(world.positions[k] - point) < 1e-5
        assert world.uvs[k] * obj.material.texture.scale == pytest.approx(uv, abs=1e-5)  # type: ignore[union-attr]
    # It faces the way the file's triangles wind (+Z turned 30 degrees about Y).
    normal = geometry.model_matrix[:3, :3] @ (0.0, 1.0, 0.0)
    assert normal == pytest.approx(turn @ (0.0, 0.0, 1.0), abs=1e-6)


def test_turned_uvs_keep_the_texture_the_right_way_round(tmp_path: Path) -> None:
    # The image turned a quarter (u running down the wall, v leftwards): the plane is turned about
    # its normal so that its +x runs the way u does, and each corner keeps its UV.
    path = rectangle_file(tmp_path, [[1, 1], [1, 0], [0, 0], [0, 1]])
    scene = load_quietly(path)
    (geometry,) = scene_geometry(scene.objects)
    assert isinstance(scene.objects[0].shape, PlaneShape)
    world = geometry.world_mesh
    turn = np.array([[np.cos(np.pi / 6), 0, np.sin(np.pi / 6)], [0, 1, 0], [-np.sin(np.pi / 6), 0, np.cos(np.pi / 6)]])
    corners = np.array([[-1.5, -1, 0], [1.5, -1, 0], [1.5, 1, 0], [-1.5, 1, 0]]) @ turn.T + (0.5, 1.0, -2.0)
    for point, uv in zip(corners, [[1, 1], [1, 0], [0, 0], [0, 1]], strict=True):
        k = np.argmin(np.linalg.norm(world.positions - point, axis=1))
        assert np.linalg.norm(world.positions[k] - point) < 1e-5
        assert world.uvs[k] == pytest.approx(uv, abs=1e-5)


@pytest.mark.parametrize(("uvs", "positions", "faces"), [
    # UVs that shear across the rectangle: no plane mapping gives them.
    ([[0, 1], [1, 1], [1.5, 0], [0.5, 0]], None, None),
    # The image mirrored (u right to left, v top to bottom): a turned plane cannot show it so.
    ([[1, 1], [0, 1], [0, 0], [1, 0]], None, None),
    # An integer offset: the plane's UVs start at 0 at a corner.
    ([[1, 2], [2, 2], [2, 1], [1, 1]], None, None),
    # A flat quadrilateral that is not a rectangle.
    ([[0, 0]] * 4, [[0, 0, 0], [2, 0, 0], [2, 1, 0], [0, 2, 0]], [[0, 1, 2], [0, 2, 3]]),
])
def test_other_flat_parts_stay_meshes(tmp_path: Path, uvs: list[list[float]], positions: object, faces: object) -> None:
    scene = load_quietly(rectangle_file(tmp_path, uvs, positions, faces))  # type: ignore[arg-type]
    assert isinstance(scene.objects[0].shape, GltfShape)


def test_a_subdivided_rectangle_is_one_plane() -> None:
    from depthimpostor.scene.gltf_planes import find_rectangle
    grid = meshes.plane(4.0, 2.0, subdivisions=5)
    found = find_rectangle(grid)
    assert found is not None and found.uv_scale == (1.0, 1.0)
    assert sorted(found.size) == pytest.approx([2.0, 4.0])


def test_the_showcase_loads_its_room_as_planes_and_renders_through_every_method(ctx: moderngl.Context) -> None:
    scene = load_quietly(ROOT / "scenes" / "showcase.toml")
    planes = {o.name for o in scene.objects if isinstance(o.shape, PlaneShape)}
    assert planes == {"room/Floor", "room/Back wall", "room/Left wall", "room/Mirror"}
    assert any(o.is_glass for o in scene.objects) and any(o.is_mirror for o in scene.objects)
    small = scene.with_overrides(size=(96, 54), impostor_resolution=32)
    for method in Method:  # the baking methods refused the room while its floor was a mesh
        if method == Method.PLANAR:  # flat mirrors alone: the glass ball is refused by name
            with pytest.raises(SceneError, match='"room/Glass ball" is glass'):
                Renderer(ctx, small, method=method)
            continue
        with Renderer(ctx, small, method=method) as renderer:
            renderer.render()
            assert_finite(renderer.read_color_float())


def place_in_toml(tmp_path: Path, placement: str) -> Scene:
    path = rectangle_file(tmp_path, [[0, 1], [2, 1], [2, 0], [0, 0]])
    (tmp_path / "s.toml").write_text(f'[[objects]]\nname = "wall"\nshape = {{ type = "gltf", path = "{path.name}" }}\n'
                                     f"{placement}\n")
    return load_quietly(tmp_path / "s.toml")


def test_a_toml_placement_moves_the_plane_as_it_moves_the_mesh(tmp_path: Path) -> None:
    # The same corners and UVs as the file's rectangle under the object's own matrix.
    scene = place_in_toml(tmp_path, "position = [1.0, 2.0, 3.0]\nrotation = [20.0, -70.0, 35.0]\nscale = 1.5")
    (obj,) = scene.objects
    assert isinstance(obj.shape, PlaneShape)
    outer = SceneObject("placement", obj.shape, position=(1.0, 2.0, 3.0), rotation=(20.0, -70.0, 35.0),
                        scale=(1.5, 1.5, 1.5)).model_matrix()
    expected = meshes.Mesh(*_rectangle_world(), None).transformed(outer)
    (geometry,) = scene_geometry(scene.objects)
    for point in expected.positions:
        assert np.linalg.norm(geometry.world_mesh.positions - point, axis=1).min() < 1e-5
    assert obj.shape.size == pytest.approx((4.5, 3.0), abs=1e-5)
    assert geometry.model_matrix[:3, :3] @ (0.0, 1.0, 0.0) == pytest.approx(expected.normals[0], abs=1e-6)


def _rectangle_world() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """rectangle_file's corners in its file's world space (turned 30 degrees about Y, moved)."""
    turn = np.array([[np.cos(np.pi / 6), 0, np.sin(np.pi / 6)], [0, 1, 0], [-np.sin(np.pi / 6), 0, np.cos(np.pi / 6)]])
    corners = np.array([[-1.5, -1, 0], [1.5, -1, 0], [1.5, 1, 0], [-1.5, 1, 0]]) @ turn.T + (0.5, 1.0, -2.0)
    return corners, np.tile(turn @ (0.0, 0.0, 1.0), (4, 1)), np.array([[0, 1, 2], [0, 2, 3]])


@pytest.mark.parametrize("placement", ['scale = [1.0, 2.0, 1.0]',
                                       'animation = { type = "rotate", axis = [0.0, 1.0, 0.0], degrees_per_second = 30.0 }'])
def test_a_non_uniform_scale_or_an_animation_keeps_the_mesh(tmp_path: Path, placement: str) -> None:
    (obj,) = place_in_toml(tmp_path, placement).objects
    assert isinstance(obj.shape, GltfShape)


def test_the_showcase_walls_share_one_texture_slot() -> None:
    scene = load_quietly(ROOT / "scenes" / "showcase.toml")
    walls = [o for o in scene.objects if o.name in ("room/Back wall", "room/Left wall")]
    assert walls[0].material.texture is walls[1].material.texture  # type: ignore[union-attr]
    assert len(scene.textures) == 3  # wood (4 x 4 repeats), tiles (4 x 0.8), the crates' arrow
