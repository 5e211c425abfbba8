"""How many of the depth method's images the first frame's reflected rays can enter: the images a
first frame would need baked (results/llvmpipe/startup_time.md, third pass). Per mirror, from the
frame's reflection data: the images whose bound (the lists' sphere, `bound`) or hit bound
(`hit_bound`) some mirror pixel's ray enters, and of them those it enters no later than its hit
(tools/scene_size.py's images_per_ray rule, which the mirror shader's visits follow).

    python3 tools/first_frame_images.py --objects 1000 --size 320x180 --resolution 16
"""

from __future__ import annotations

import argparse

import numpy as np

from depthimpostor.constants import Method
from depthimpostor.gpu.context import create_context
from depthimpostor.renderer import Renderer
from scene_size import family_scene  # beside this file

RAYS_AT_ONCE = 2048


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--objects", type=int, default=1000)
    parser.add_argument("--size", default="320x180")
    parser.add_argument("--resolution", type=int, default=16)
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    scene = family_scene(args.objects).with_overrides(size=(width, height), impostor_resolution=args.resolution)
    ctx = create_context()
    with Renderer(ctx, scene, method=Method.DEPTH, reflection_data=True) as renderer:
        renderer.render()
        data = renderer.read_reflection_data()
        baked = renderer.graph.baked_images
        assert baked is not None
        for mirror_index, images in baked.images_by_reflector.items():
            pixels = data.mirror_mask & (data.mirror_id == mirror_index)
            origins, directions = data.origin[pixels], data.direction[pixels]
            hits = np.where(data.object_id[pixels] >= 0, np.linalg.norm(data.hit_position[pixels] - origins, axis=1),
                            np.inf)
            records = baked.image_records(images)
            for key in ("bound", "hit_bound"):
                spheres = np.stack([record[key] for record in records[: len(images)]]).astype(np.float64)
                entered, needed = np.zeros(len(images), bool), np.zeros(len(images), bool)
                for first in range(0, len(origins), RAYS_AT_ONCE):
                    o, d = origins[first:first + RAYS_AT_ONCE], directions[first:first + RAYS_AT_ONCE]
                    to_centre = spheres[None, :, :3] - o[:, None, :]
                    along = np.einsum("rij,rj->ri", to_centre, d)
                    miss = np.einsum("rij,rij->ri", to_centre, to_centre) - along**2
                    half = np.sqrt(np.maximum(spheres[None, :, 3] ** 2 - miss, 0.0))
                    inside = (miss <= spheres[None, :, 3] ** 2) & (along + half >= 0.0)
                    entered |= inside.any(axis=0)
                    needed |= (inside & (np.maximum(along - half, 0.0) <= hits[first:first + RAYS_AT_ONCE, None])).any(axis=0)
                print(f"mirror {mirror_index}: {int(pixels.sum())} pixels, {len(images)} images; by {key}: "
                      f"{int(entered.sum())} entered by a ray, {int(needed.sum())} no later than its hit")


if __name__ == "__main__":
    main()
