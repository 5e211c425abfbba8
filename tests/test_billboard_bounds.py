"""A billboard's hit bound (methods/billboards.py's quad_hit_bounds): the sphere its rays are
listed, marked and tested by holds every point of its quad a ray can find opaque, so that a ray
skipping a quad whose bound it misses loses no hit; and it is tighter than the frustum's."""

from __future__ import annotations

import moderngl
import numpy as np
import pytest

from conftest import SCENES
from depthimpostor.constants import Method
from depthimpostor.methods.billboards import quad_hit_bounds
from depthimpostor.ppc import depth_image_records, fit_frusta
from depthimpostor.renderer import Renderer
from depthimpostor.scene import load_scene


def test_every_opaque_texel_of_a_billboard_lies_in_its_hit_bound(ctx: moderngl.Context) -> None:
    scene = load_scene(SCENES / "textured_near_mirror.toml").with_overrides(size=(160, 90), impostor_resolution=64)
    with Renderer(ctx, scene, method=Method.BILLBOARD) as renderer:
        renderer.render()
        stand_in = renderer.graph.stand_in
        atlas = stand_in.atlas
        width, height = atlas.color.size
        rgba = np.frombuffer(atlas.color.read(), np.uint8).reshape(height, width, 4)
        checked = tighter = 0
        for images in stand_in.images_by_reflector.values():
            records = stand_in.image_records(images)
            for row, image in enumerate(images):
                if image.slot in stand_in.stale:
                    continue  # not baked this frame: no texel to check
                camera, (x0, y0) = image.camera, image.tile_origin
                alpha = rgba[y0:y0 + camera.height, x0:x0 + camera.width, 3]
                v, u = np.nonzero(alpha)
                if not len(u):
                    continue
                quad_w = float(camera.camera_coordinates(np.asarray(image.target.bounding_sphere[0])[None])[0, 2])
                # Every corner of every opaque texel's square on the quad's plane.
                corners = np.concatenate([camera.unproject(u + du, v + dv, np.full(len(u), quad_w))
                                          for du in (0.0, 1.0) for dv in (0.0, 1.0)])
                centre, radius = records["hit_bound"][row][:3], records["hit_bound"][row][3]
                assert np.linalg.norm(corners - centre, axis=1).max() <= radius, image.label
                tighter += radius < records["bound"][row][3]
                checked += 1
        assert checked >= 3 and tighter == checked


@pytest.mark.parametrize("seed", range(4))
def test_a_thin_object_near_the_mirrors_centre_keeps_its_whole_quad_in_its_bound(seed: int) -> None:
    """A rod near the mirror's centre: its frustum is thin, the cone's section r d / sqrt(d^2 - r^2)
    is no tighter than the frustum's bound, and the bound falls back to the frustum's, not to the
    depth image's hit bound (the rod's sphere and a texel), which the rod's points on the quad's
    plane reach past (a reviewer's case: 264 of 20,000 such rods before the fix)."""
    rng = np.random.default_rng(seed)
    broken = 0
    for _ in range(500):
        d = rng.uniform(1.05, 3.0)
        centre = np.array([0.0, 0.0, d])
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        ends = [centre + axis, centre - axis * rng.uniform(0.2, 1.0)]
        points = np.array(ends + [centre + 0.02 * rng.normal(size=3)])
        radius = float(np.linalg.norm(points - centre, axis=1).max())
        fit = fit_frusta(np.zeros(3), points[None], centre[None])[0]
        if fit is None:
            continue
        camera = fit.camera(64, 64)
        records = depth_image_records([camera], [0], [(0, 0)], [(0, 0, 0)], [(centre, radius)])
        quad_hit_bounds(records, [camera], [(centre, radius)])
        bound = records["hit_bound"][0]
        quad_w = float(camera.camera_coordinates(centre[None])[0, 2])
        seen = camera.camera_coordinates(points)
        on_quad = camera.unproject(seen[:, 0] / seen[:, 2], seen[:, 1] / seen[:, 2], np.full(len(points), quad_w))
        broken += np.linalg.norm(on_quad - bound[:3], axis=1).max() > bound[3]
    assert broken == 0
