"""Levels of detail in baked images (lod.py, "Baked images"): each object drawn into a depth image,
billboard or cube-map face at the coarsest level whose chordal error stays under LOD_TEXEL_ERROR
texels of that image; reflectors, and the hybrid method's images, at the full meshes. And the
closed solids' back faces culled in the bakes' surface pass."""

from __future__ import annotations

from typing import Any

import moderngl
import numpy as np
import pytest
from conftest import assert_finite, scene_from_toml

import depthimpostor.lod as lod
from depthimpostor.constants import Method
from depthimpostor.gpu import gl_state
from depthimpostor.gpu.gl_state import RasterState
from depthimpostor.methods.atlas import FRONT_FACES
from depthimpostor.geometry import ObjectGeometry, mesh_for_shape, tessellation
from depthimpostor.lod import LOD_TEXEL_ERROR, BakeDetail, chordal_error, image_levels, texels_per_unit
from depthimpostor.methods.cubemaps import CUBE_FACES
from depthimpostor.ppc import PPC
from depthimpostor.renderer import Renderer
from depthimpostor.scene.model import Scene

HEAD = """
[render]
size = [160, 90]
impostor_resolution = 128
[camera]
eye = [0.0, 1.2, 4.0]
target = [0.0, 1.0, 0.0]
[[lights]]
type = "directional"
direction = [-0.4, -1.0, -0.3]
"""


def ball(name: str, radius: float, position: tuple[float, float, float], material: str) -> str:
    return (f'[[objects]]\nname = "{name}"\nshape = {{ type = "sphere", radius = {radius} }}\n'
            f"material = {material}\nposition = {[round(float(v), 4) for v in position]}\n")


CHECKER = '{ type = "checker", color_a = [0.9, 0.3, 0.1], color_b = [0.1, 0.2, 0.8], scale = 0.05 }'
MIRROR = '{ type = "mirror" }'


def scene_of(*objects: str) -> Scene:
    return scene_from_toml(HEAD + "".join(objects))


def geometry(scene: Scene) -> list[ObjectGeometry]:
    return [ObjectGeometry(i, obj, mesh_for_shape(obj.shape)) for i, obj in enumerate(scene.objects)]


def filling_camera(item: ObjectGeometry, eye: tuple[float, float, float], side: int) -> PPC:
    """A side^2 depth image from `eye` fitted to `item` (as the depth method fits its images)."""
    return PPC.fitted(eye, item.world_mesh.positions, item.bounding_sphere[0], side, side)


def test_a_sphere_filling_its_image_keeps_its_mesh_at_128_and_a_reflector_at_any_size() -> None:
    items = geometry(scene_of(ball("ball", 0.12, (0.0, 0.8, 0.0), CHECKER), ball("mirror", 0.12, (0.0, 0.8, 0.0), MIRROR)))
    shape = items[0].object.shape
    for side, level in ((128, 0), (64, 1), (16, 2)):
        camera = filling_camera(items[0], (3.0, 0.8, 0.0), side)
        # A texel is about 2 r / side where the sphere is nearest: at 128^2, 48 x 24 would sag by
        # 0.14 of it, past LOD_TEXEL_ERROR (an eighth); at 64^2 by 0.07, and 24 x 12 by 0.27.
        assert image_levels([camera, camera], items) == [level, 0]
        per_unit = texels_per_unit([camera], *(np.array([part]) for part in items[0].bounding_sphere))[0]
        assert chordal_error(shape, level) * per_unit <= LOD_TEXEL_ERROR < chordal_error(shape, level + 1) * per_unit
    assert tessellation(shape, 1) == (48, 24)
    camera = filling_camera(items[0], (3.0, 0.8, 0.0), 64)
    drawn = BakeDetail().drawn([(camera, items)])[0]
    assert len(drawn[0].local_mesh.indices) == 48 * 2 * (24 - 1) and drawn[1] is items[1]
    assert np.array_equal(drawn[0].model_matrix, items[0].model_matrix) and drawn[0].index == items[0].index


def test_a_cube_face_bakes_small_far_spheres_coarser_and_its_corners_finer_than_its_centre() -> None:
    items = geometry(scene_of(ball("near", 0.12, (0.0, 0.0, 1.5), CHECKER), ball("far", 0.12, (0.0, 0.0, 6.0), CHECKER),
                              ball("corner", 0.12, (1.5, 1.5, 1.5), CHECKER)))
    axis, up = CUBE_FACES[4]  # +z
    face = PPC.look_at((0.0, 0.0, 0.0), axis, up, 90.0, 128, 128, 0.5, 20.0)
    near, far, corner = image_levels([face] * 3, items)
    assert 1 <= near < far  # a few dozen texels across, a few: both coarser than the full 96 x 48
    assert corner < far
    # A texel covers less off the axis: a length at distance d covers F / (d cos^2 theta) texels
    # (F = 64 for 128 texels over 90 degrees), 3 times the centre's at the face's corner.
    d = 2.0
    per_unit = texels_per_unit([face] * 2, np.array([[0.0, 0.0, d], [d, d, d] / np.sqrt(3.0)]), np.zeros(2))
    assert per_unit[0] == pytest.approx(64.0 / d) and per_unit[1] == pytest.approx(3.0 * 64.0 / d)
    assert texels_per_unit([face], np.zeros((1, 3)), np.array([1.0]))[0] == np.inf  # a sphere holding the eye


def test_depth_images_bake_coarser_levels_and_the_hybrids_keep_the_full_meshes(ctx: moderngl.Context) -> None:
    scene = scene_of(ball("mirror", 0.8, (0.0, 0.8, 0.0), MIRROR),
                     ball("ball", 0.3, (1.6, 0.8, 1.0), CHECKER)).with_overrides(impostor_resolution=64)
    triangles = {}
    for method in (Method.DEPTH, Method.BILLBOARD, Method.CUBEMAP, Method.HYBRID):
        with Renderer(ctx, scene, method=method) as renderer:
            baked = renderer.graph.baked_images
            assert baked is not None
            images = [image for image in baked.depth_images if not image.level]
            triangles[method] = [len(item.local_mesh.indices) for drawn in baked.drawn(images) for item in drawn]
    full = 96 * 2 * (48 - 1)
    assert triangles[Method.DEPTH] == triangles[Method.BILLBOARD] == [48 * 2 * (24 - 1)]
    assert all(count < full // 4 for count in triangles[Method.CUBEMAP])  # 0.3 across, 1.9 away: 64^2 over 90 degrees
    assert triangles[Method.HYBRID] == [full]  # its samples name the full mesh's triangles


def test_baked_levels_barely_change_the_reflection(ctx: moderngl.Context, monkeypatch: pytest.MonkeyPatch) -> None:
    """Round checkered objects close to a mirror sphere, in 64^2 depth images (48 x 24 each): the
    depth method's frame with its images baked at their levels is the frame baked at full meshes,
    but for pixels at the reflected silhouettes (which move by under an eighth of a texel)."""
    objects = [ball("mirror", 1.0, (0.0, 1.0, 0.0), MIRROR)]
    objects += [ball(f"ball{k}", 0.3, (1.6 * np.cos(0.6 * k + 0.3), 1.0 + 0.5 * np.sin(2 * k), 1.6 * np.sin(0.6 * k + 0.3)),
                     CHECKER) for k in range(5)]
    scene = scene_of(*objects).with_overrides(size=(320, 180), impostor_resolution=64)
    frames = []
    for levels in (image_levels, lambda cameras, items: [0] * len(items)):
        monkeypatch.setattr(lod, "image_levels", levels)
        with Renderer(ctx, scene, method=Method.DEPTH) as renderer:
            renderer.render()
            frames.append(renderer.read_color_float())
            assert_finite(frames[-1])
    difference = np.abs(frames[0] - frames[1]).max(axis=-1)
    assert (difference > 0.0).any()  # the levels are in use
    # On llvmpipe: 0.3 % of the frame's pixels change, 0.05 % by more than 0.1 (pixels at the
    # reflected balls' silhouettes).
    assert (difference > 0.1).mean() < 0.002


def test_the_surface_pass_culls_closed_solids_back_faces_and_changes_no_frame(
        ctx: moderngl.Context, monkeypatch: pytest.MonkeyPatch) -> None:
    """A closed solid seen from outside hides each back face behind a front face of its own: the
    bakes' visible-surface pass culls them (as the frame's batch does), and the frame is the same
    to the bit as with every back face drawn (tools/frames.py: no shipped frame changes)."""
    objects = [ball("mirror", 1.0, (0.0, 1.0, 0.0), MIRROR)]
    objects += [ball(f"ball{k}", 0.3, (1.6 * np.cos(0.6 * k + 0.3), 1.0 + 0.5 * np.sin(2 * k), 1.6 * np.sin(0.6 * k + 0.3)),
                     CHECKER) for k in range(5)]
    scene = scene_of(*objects).with_overrides(size=(320, 180), impostor_resolution=64)
    applied: list[RasterState] = []  # the states set while a bake's surface pass draws
    apply = gl_state._apply
    monkeypatch.setattr(gl_state, "_apply", lambda context, state: (applied.append(state), apply(context, state))[1])
    for method in (Method.DEPTH, Method.CUBEMAP):
        frames = []
        for culls in (True, False):
            with Renderer(ctx, scene, method=method) as renderer:
                baked = renderer.graph.baked_images
                assert baked is not None
                baked.culls_back_faces = culls
                surfaces = baked._bake_surfaces
                seen: list[RasterState] = []

                def recorded(*args: Any, surfaces: Any = surfaces, seen: list[RasterState] = seen) -> int:
                    applied.clear()
                    draws: int = surfaces(*args)
                    seen.extend(applied)
                    return draws

                monkeypatch.setattr(baked, "_bake_surfaces", recorded)
                renderer.render()
                frames.append(renderer.read_color_float())
                assert (FRONT_FACES in seen) == culls
        assert np.array_equal(frames[0], frames[1])
