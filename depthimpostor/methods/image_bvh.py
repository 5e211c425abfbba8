"""A bounding-sphere hierarchy over one mirror's depth images, for mirrors that own many.

The mirror shader visits a mirror's images nearest first, by where a reflected ray enters their
bound spheres, and stops at the first entered beyond its nearest hit (lib/reflected_scene.glsl).
Finding that order scans every image's bound: per ray, work that grows with the object count
(tools/scene_size.py measured the mirror pass growing as objects^0.64 from 10 to 1,000). Where a
mirror's record table is a storage buffer (more images than a uniform block holds:
constants.depth_image_defines), the table also holds this hierarchy, and the shader walks it
instead: a node whose sphere the ray does not enter before its nearest hit so far is skipped with
everything under it, so that a ray tests a few dozen spheres where it tested a thousand.

Nodes are laid out depth first, each with the index of the node after its subtree (`skip`), so
that the walk needs no stack (as methods/bvh.py lays out the triangles' boxes). A leaf holds one
image. The table holds two hierarchies: one over the images' `hit_bound` spheres, which the
variants that look for hits alone test, then one over their `bound` spheres, which the variants
that track unseen space test (constants.DEPTH_IMAGE_FIELDS). One over both would be no use: a
`bound` holds the image's whole frustum from the mirror's centre, so that every reflected ray
starts inside most of them (tools/scene_size.py's 1,000 objects: a ray entered 40 % of the leaves).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..constants import IMAGE_NODE_DTYPE

#: The node links' "image" entry of an inner node.
INNER = -1


def _enclosing(spheres: NDArray[np.float64]) -> NDArray[np.float64]:
    """A sphere (x, y, z, r) holding every one of `spheres` ((n, 4)): centred on their boxes' middle."""
    lower = (spheres[:, :3] - spheres[:, 3:]).min(axis=0)
    upper = (spheres[:, :3] + spheres[:, 3:]).max(axis=0)
    centre = 0.5 * (lower + upper)
    radius = float((np.linalg.norm(spheres[:, :3] - centre, axis=1) + spheres[:, 3]).max())
    # float32 rounding of the centre and radius must not leave a member out: grown by a margin
    # far below a texel and far above float32's relative step at these distances.
    return np.array([*centre, radius * (1.0 + 1e-5) + 1e-6 * float(np.abs(centre).max())])


def image_hierarchies(records: NDArray[np.void]) -> NDArray[np.void]:
    """The two hierarchies of the images of `records` (DEPTH_IMAGE_DTYPE, the mirror's images in
    table order), over their hit bounds and then over their bounds: 2 (2n - 1) nodes."""
    return np.concatenate([image_bvh(np.asarray(records["hit_bound"], np.float64)),
                           image_bvh(np.asarray(records["bound"], np.float64))])


def image_bvh(leaves: NDArray[np.float64]) -> NDArray[np.void]:
    """The hierarchy of n images whose spheres are `leaves` ((n, 4), in table order): 2n - 1
    IMAGE_NODE_DTYPE records, depth first, their links counted from the first; none for no image."""
    count = len(leaves)
    if count == 0:
        return np.zeros(0, IMAGE_NODE_DTYPE)
    nodes = np.zeros(2 * count - 1, IMAGE_NODE_DTYPE)
    next_free = 0

    def build(members: NDArray[np.int64]) -> None:
        nonlocal next_free
        index = next_free
        next_free += 1
        nodes[index]["sphere"] = _enclosing(leaves[members])
        if len(members) == 1:
            nodes[index]["links"] = (int(members[0]), 0, 0, 0)
        else:
            # Halves by the median along the axis the members' centres spread most on.
            centres = leaves[members, :3]
            axis = int(np.argmax(centres.max(axis=0) - centres.min(axis=0)))
            ordered = members[np.argsort(centres[:, axis], kind="stable")]
            half = len(ordered) // 2
            build(ordered[:half])
            build(ordered[half:])
            nodes[index]["links"] = (INNER, 0, 0, 0)
        nodes[index]["links"][1] = next_free  # skip: the node after this subtree

    build(np.arange(count))
    return nodes
