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


def _norms(vectors: NDArray[np.float64]) -> NDArray[np.float64]:
    """np.linalg.norm(vectors, axis=1), summed as it sums them."""
    return np.sqrt(np.add.reduce(vectors * vectors, axis=1))


def image_hierarchies(records: NDArray[np.void]) -> NDArray[np.void]:
    """The two hierarchies of the images of `records` (DEPTH_IMAGE_DTYPE, the mirror's images in
    table order), over their hit bounds and then over their bounds: 2 (2n - 1) nodes."""
    return np.concatenate([image_bvh(np.asarray(records["hit_bound"], np.float64)),
                           image_bvh(np.asarray(records["bound"], np.float64))])


def image_bvh(leaves: NDArray[np.float64]) -> NDArray[np.void]:
    """The hierarchy of n images whose spheres are `leaves` ((n, 4), in table order): 2n - 1
    IMAGE_NODE_DTYPE records, depth first, their links counted from the first; none for no image.

    A node holds a run of images: its sphere, centred on the middle of their spheres' boxes, holds
    every one of them; an inner node halves its run at the median along the axis its images'
    centres spread most on (its images sorted stably along it), the first half its first child.
    Built a level at a time, every node of a level in one pass of numpy: each node's images are
    a slice of one permutation (its children's slices split its own), and its place in the depth-
    first layout follows from its parent's and its sizes (a subtree of m images has 2m - 1 nodes)."""
    count = len(leaves)
    nodes = np.zeros(max(2 * count - 1, 0), IMAGE_NODE_DTYPE)
    order = np.arange(count)  # each node's images: a slice of this, re-sorted as it is halved
    # The level's nodes: where their slices start, their sizes and their places in `nodes`.
    starts, sizes, places = np.zeros(min(count, 1), np.int64), np.full(min(count, 1), count), np.zeros(min(count, 1), np.int64)
    while len(starts):
        firsts = np.cumsum(sizes) - sizes  # where each node's run begins in this level's arrays
        node_of = np.repeat(np.arange(len(starts)), sizes)
        positions = np.arange(len(node_of)) - firsts[node_of] + starts[node_of]
        members = order[positions]
        spheres = leaves[members]
        centre, radius = _enclosing(spheres, firsts, node_of)
        nodes["sphere"][places] = np.column_stack([centre, radius])
        nodes["links"][places, 1] = places + 2 * sizes - 1  # skip: the node after this subtree
        single = sizes == 1
        nodes["links"][places[single], 0] = members[firsts[single]]
        inner = ~single
        nodes["links"][places[inner], 0] = INNER
        if not inner.any():
            break
        # Each inner node's images sorted (stably) along the axis their centres spread most on.
        centres = spheres[:, :3]
        spread = np.maximum.reduceat(centres, firsts, axis=0) - np.minimum.reduceat(centres, firsts, axis=0)
        axis = np.argmax(spread, axis=1)
        keys = centres[np.arange(len(node_of)), axis[node_of]]
        ranked = np.lexsort((keys, node_of))  # by node, then key; ties keep their order
        order[positions] = members[ranked]
        half = sizes[inner] // 2
        starts = np.stack([starts[inner], starts[inner] + half], axis=1).reshape(-1)
        places = np.stack([places[inner] + 1, places[inner] + 2 * half], axis=1).reshape(-1)
        sizes = np.stack([half, sizes[inner] - half], axis=1).reshape(-1)
    return nodes


def _enclosing(spheres: NDArray[np.float64], firsts: NDArray[np.int64], node_of: NDArray[np.int64]
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """For each run of `spheres` ((m, 4) x, y, z, r) beginning at `firsts` (`node_of`: each
    sphere's run), a sphere holding every one of its spheres, centred on their boxes' middle:
    ((runs, 3) centres, (runs,) radii)."""
    lower = np.minimum.reduceat(spheres[:, :3] - spheres[:, 3:], firsts, axis=0)
    upper = np.maximum.reduceat(spheres[:, :3] + spheres[:, 3:], firsts, axis=0)
    centre = 0.5 * (lower + upper)
    radius = np.maximum.reduceat(_norms(spheres[:, :3] - centre[node_of]) + spheres[:, 3], firsts)
    # float32 rounding of the centre and radius must not leave a member out: grown by a margin
    # far below a texel and far above float32's relative step at these distances.
    return centre, radius * (1.0 + 1e-5) + 1e-6 * np.abs(centre).max(axis=1)
