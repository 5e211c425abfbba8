"""A bake spread over frames (issue 32: start 1,000 objects in under 2 s): where a frame's bake may
draw no more than a budget of triangles (the viewer's, Renderer's bake_budget), the hybrid method
traces the rays that enter the images it has not baked yet (Unseen.PENDING) and bakes them over
the next frames. Every frame on the way is the exact one where it traced, and the last is the frame
of baking every entered image at once."""

from __future__ import annotations

from pathlib import Path

import moderngl
import numpy as np
import pytest
from test_startup_bakes import textured_ring

from depthimpostor.constants import BACKGROUND_DEPTH, DEPTH_IMAGE_DTYPE, Method
from depthimpostor.methods.atlas import ImpostorAtlas
from depthimpostor.methods.baked_images import BakedImages
from depthimpostor.renderer import ReflectionData, Renderer
from depthimpostor.scene import Scene


def first_frame(ctx: moderngl.Context, scene: Scene, method: Method) -> tuple[np.ndarray, ReflectionData, int]:
    """The frame a renderer without a budget makes first, its reflection data and its bakes."""
    with Renderer(ctx, scene, method=method, reflection_data=True) as renderer:
        renderer.render()
        baked = renderer.graph.baked_images
        return renderer.read_color_float(), renderer.read_reflection_data(), baked.bakes if baked is not None else 0


@pytest.fixture
def unbaked_reads_empty(monkeypatch: pytest.MonkeyPatch) -> None:
    """The atlas's texels read as "nothing here, seen" until baked (llvmpipe's zeros read as a
    surface at the near plane, which the hybrid does not trust, and traces past: an image read
    before its bake would go unnoticed): a ray that reads an image not baked yet misses its object."""
    make = ImpostorAtlas._make_textures

    def made_empty(self: ImpostorAtlas, size: tuple[int, int]) -> None:
        make(self, size)
        if self.depth is not None:
            self.depth.write(np.full((size[1], size[0], 2), BACKGROUND_DEPTH, np.float32).tobytes())

    monkeypatch.setattr(ImpostorAtlas, "_make_textures", made_empty)


def pending_in_records(baked: BakedImages) -> set[int]:
    """The slots whose records, as the mirrors' buffers hold them, say "not baked yet"."""
    flagged = set()
    for index, buffer in baked.uniform_buffers.items():
        images = baked.images_at(index, baked.final_level)
        records = np.frombuffer(buffer.read(size=len(images) * DEPTH_IMAGE_DTYPE.itemsize), DEPTH_IMAGE_DTYPE)
        flagged |= {image.slot for image, record in zip(images, records, strict=True) if record["surface"][3] != 0.0}
    return flagged


def test_a_budgeted_hybrid_frame_traces_what_is_not_baked_and_the_next_frames_bake_it(
        ctx: moderngl.Context, tmp_path: Path, unbaked_reads_empty: None) -> None:
    scene = textured_ring(tmp_path, 300)
    eager, eager_data, eager_bakes = first_frame(ctx, scene, Method.HYBRID)
    traced, traced_data, _ = first_frame(ctx, scene, Method.RAYTRACE)
    mirror = eager_data.mirror_mask
    assert mirror.sum() > 400 and 50 < eager_bakes < 300  # the frame enters some of the images
    with Renderer(ctx, scene, method=Method.HYBRID, reflection_data=True) as probe:
        sphere = max(len(g.local_mesh.indices) for g in probe.world.reflected_objects)
    budget = 3 * sphere * 12  # twelve spheres' images, three layers each: about ten frames
    with Renderer(ctx, scene, method=Method.HYBRID, reflection_data=True, bake_budget=budget) as renderer:
        baked = renderer.graph.baked_images
        assert baked is not None
        frames, bakes = [], [0]
        while True:
            renderer.render()
            colour, data = renderer.read_color_float(), renderer.read_reflection_data()
            assert np.isfinite(colour).all()
            assert pending_in_records(baked) == baked.stale  # surface.w: what the shader skips and traces
            frames.append((colour, data, len(baked.pending)))
            bakes.append(baked.bakes)
            if not baked.needs_bake or len(frames) > 40:
                break
    assert 5 <= len(frames) <= 40, len(frames)
    assert bakes[-1] == eager_bakes  # the images the eager frame bakes, no more
    for before, after in zip(bakes, bakes[1:], strict=False):
        assert 1 <= after - before <= budget // (3 * 12)  # a box's image draws 12 triangles a layer
    # The first frame: more of the mirror's rays traced than the images leave, and fewer as the
    # images come in; every frame on the way the exact answer (the ray tracer's, as the eager
    # frame is in this scene), none read from an image not baked yet.
    assert frames[0][2] > 0
    shares = [float(data.retraced[mirror].mean()) for _, data, _ in frames]  # of the mirror's rays traced
    assert shares[0] > shares[-1] == float(eager_data.retraced[mirror].mean())
    assert all(later <= earlier for earlier, later in zip(shares, shares[1:], strict=False))
    np.testing.assert_array_equal(eager_data.object_id[mirror], traced_data.object_id[mirror])
    for colour, data, _ in frames:
        np.testing.assert_array_equal(data.object_id[mirror], traced_data.object_id[mirror])
        assert np.abs(colour - traced).max() <= 1.0 / 255.0 + 1e-6
    # The last is the eager frame, its records saying nothing it enters is pending (its rays traced
    # only where the images cannot answer).
    colour, data, pending = frames[-1]
    np.testing.assert_array_equal(colour, eager)
    np.testing.assert_array_equal(data.retraced, eager_data.retraced)
    assert pending == len(baked.stale) and not baked.stale & (baked.due or set())


def test_a_budget_leaves_a_method_that_cannot_trace_baking_what_its_frame_enters(
        ctx: moderngl.Context, tmp_path: Path) -> None:
    """The depth method has nothing but its images to answer with: its first frame bakes every
    image it enters, budget or not, and is the same frame."""
    scene = textured_ring(tmp_path, 300)
    eager, _, eager_bakes = first_frame(ctx, scene, Method.DEPTH)
    with Renderer(ctx, scene, method=Method.DEPTH, bake_budget=1) as renderer:
        renderer.render()
        baked = renderer.graph.baked_images
        assert baked is not None and baked.bakes == eager_bakes and not baked.pending
        np.testing.assert_array_equal(renderer.read_color_float(), eager)


ORBITER = """
[[objects]]
name = "orbiter"
shape = { type = "box", size = [0.3, 0.3, 0.3] }
material = { type = "checker", color_a = [0.9, 0.2, 0.2], color_b = [0.1, 0.1, 0.1], scale = 0.05 }
position = [1.6, 0.3, 0.0]
animation = { type = "orbit", centre = [0.0, 0.3, 0.0], axis = [0.0, 1.0, 0.0], degrees_per_second = 30.0 }
"""


def test_a_budget_holds_while_the_world_moves(ctx: moderngl.Context, tmp_path: Path, unbaked_reads_empty: None) -> None:
    """An animated scene: each frame's moved object's images are stale again, and the frame still
    bakes within its budget the images its rays enter (no frame bakes every image no ray entered),
    tracing the rest: each frame shows what the ray tracer's does."""
    scene = textured_ring(tmp_path, 300, ORBITER)
    with Renderer(ctx, scene, method=Method.HYBRID, reflection_data=True) as probe:
        sphere = max(len(g.local_mesh.indices) for g in probe.world.reflected_objects)
    budget = 3 * sphere * 4
    with Renderer(ctx, scene, method=Method.RAYTRACE, reflection_data=True) as traced, \
            Renderer(ctx, scene, method=Method.HYBRID, reflection_data=True, bake_budget=budget) as renderer:
        baked = renderer.graph.baked_images
        assert baked is not None
        before = 0
        for frame in range(6):
            for each in (traced, renderer):
                each.set_time(0.5 * frame)
                each.render()
            truth, data = traced.read_reflection_data(), renderer.read_reflection_data()
            np.testing.assert_array_equal(data.object_id[truth.mirror_mask], truth.object_id[truth.mirror_mask])
            assert 1 <= baked.bakes - before <= budget // (3 * 12) and baked.deferred > 0
            assert pending_in_records(baked) == baked.stale
            before = baked.bakes
