"""A billboard's hit bound (methods/billboards.py's quad_hit_bounds): the sphere its rays are
listed, marked and tested by holds every point of its quad a ray can find opaque, so that a ray
skipping a quad whose bound it misses loses no hit; and it is tighter than the frustum's."""

from __future__ import annotations

import moderngl
import numpy as np

from conftest import SCENES
from depthimpostor.constants import Method
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
        for mirror_index, images in stand_in.images_by_reflector.items():
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
