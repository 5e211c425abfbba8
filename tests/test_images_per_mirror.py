"""A mirror with many depth images (scenes/images_per_mirror/boxes_64.toml): the mirror shader
visits the images nearest first, by where the ray enters their bounds (DepthImage.bound, or
hit_bound where only hits are looked for), and stops where the next is entered beyond the nearest
hit so far (lib/reflected_scene.glsl). The frame must be the one a visit of every image gives, and
the visits fewer.

The comparison visits every image: a bound of infinite radius is entered at t = 0 by every ray, so
that every image is visited, in the order of the records (as before the bounds; the marches still
end at the step past the nearest hit so far, which tools/frames.py check holds against frames
recorded before any of this: 0 changed).
"""

from __future__ import annotations

from pathlib import Path

import moderngl
import numpy as np
import pytest

from conftest import assert_finite
from depthimpostor.constants import Algorithm, Method
from depthimpostor.methods.atlas import record_table, write_table
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene, load_scene

SCENE = Path(__file__).resolve().parent.parent / "scenes" / "images_per_mirror" / "boxes_64.toml"
SIZE = (320, 180)


def scene() -> Scene:
    return load_scene(SCENE).with_overrides(size=SIZE, impostor_resolution=64)


def visit_every_image(renderer: Renderer) -> None:
    """Give every image of every mirror a bound that every ray enters at t = 0."""
    baked = renderer.graph.baked_images
    assert baked is not None
    for index, buffer in baked.uniform_buffers.items():
        images = baked.images_at(index, baked.final_level)
        records = baked.image_records(images).copy()
        for bound in ("bound", "hit_bound"):
            records[bound][:, 3] = 1e18  # squared, still a float32 (3.4e38 at most)
        # As the stand-in lays its table out (past 64 records, with the lists over these bounds).
        write_table(buffer, record_table(records, len(images), baked.record_capacity,
                                         images[0].mirror.bounding_sphere, baked.lists_over_bounds))


def frame_and_samples(ctx: moderngl.Context, method: Method, algorithm: Algorithm, every_image: bool
                      ) -> tuple[np.ndarray, np.ndarray]:
    with Renderer(ctx, scene(), algorithm, method=method, count_samples=True) as renderer:
        renderer.render()  # the first frame bakes and writes the records
        if every_image:
            visit_every_image(renderer)
            renderer.render()
        return renderer.read_color_float(), renderer.read_sample_counts()


@pytest.mark.parametrize(("method", "algorithm"), [(Method.DEPTH, Algorithm.OPTIMIZED),
                                                   (Method.DEPTH, Algorithm.HIERARCHICAL),
                                                   (Method.HYBRID, Algorithm.OPTIMIZED)])
def test_the_early_stop_changes_no_pixel_and_skips_images_behind_the_hit(
        ctx: moderngl.Context, method: Method, algorithm: Algorithm) -> None:
    ordered, ordered_samples = frame_and_samples(ctx, method, algorithm, every_image=False)
    every, every_samples = frame_and_samples(ctx, method, algorithm, every_image=True)
    assert_finite(ordered)
    mirror = every_samples > 0
    assert mirror.sum() > 500  # the mirror is in view, and its rays meet images
    # The nearest hit over all images is the same hit; ties between two images at one t (which the
    # order of the visits decides) are float noise.
    assert np.abs(ordered - every).max() < 1e-5
    # A ray reads no more than when it visits every image (the images it marches are some of those,
    # each marched alike), and the rays that meet an image behind their hit (or behind the floor,
    # for the depth method) skip it: a few percent of the rays here, whose march there is saved.
    assert np.all(ordered_samples <= every_samples)
    assert (ordered_samples < every_samples).sum() > 0.05 * mirror.sum()
