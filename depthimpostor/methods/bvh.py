"""A bounding-volume hierarchy over world-space triangles, built on the CPU for GPU traversal.

Median splits along the longest axis of the triangles' centroids: no SAH, but a balanced tree
of depth about log2(n / LEAF_TRIANGLES), which bounds the traversal stack the shader needs.
Nodes are stored so that an inner node's children are adjacent (right = left + 1); the shader
reads `first` as the left child of an inner node and as the first triangle of a leaf. Each node
also has a skip link, the node a depth-first traversal visits after this one's subtree, so that
the shader walks the tree without a stack (a per-pixel stack array slows every fragment of a
shader that merely contains it on llvmpipe).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np

#: Triangles per leaf at most: a few triangle tests are cheaper than another level of boxes.
LEAF_TRIANGLES = 4


@dataclass(frozen=True, eq=False)
class Bvh:
    lower: np.ndarray  # (nodes, 3) float32 box corners
    upper: np.ndarray  # (nodes, 3)
    first: np.ndarray  # (nodes,) int: left child (inner) or first triangle (leaf)
    count: np.ndarray  # (nodes,) int: triangles in a leaf, 0 for an inner node
    order: np.ndarray  # (triangles,) the input triangles in leaf order
    depth: int  # levels below the root
    skip: np.ndarray  # (nodes,) int: the next node after this one's subtree, -1 after the last

    @property
    def node_count(self) -> int:
        return len(self.first)


def build_bvh(triangles: np.ndarray) -> Bvh:
    """The hierarchy of (n, 3, 3) triangles (n >= 1)."""
    triangles = np.asarray(triangles, dtype=np.float64)
    if triangles.ndim != 3 or triangles.shape[1:] != (3, 3) or len(triangles) == 0:
        raise ValueError(f"build_bvh: expected (n >= 1, 3, 3) triangles, got {triangles.shape}")
    centroids = triangles.mean(axis=1)
    lows, highs = triangles.min(axis=1), triangles.max(axis=1)
    order = np.arange(len(triangles))
    capacity = 2 * len(triangles)  # a binary tree with n leaves or fewer has under 2n nodes
    lower = np.zeros((capacity, 3))
    upper = np.zeros((capacity, 3))
    first = np.zeros(capacity, np.int64)
    count = np.zeros(capacity, np.int64)
    # Work items: (node, start, end) over `order`; a node's range is split in place.
    stack = [(0, 0, len(triangles), 0)]
    used, depth = 1, 0
    while stack:
        node, start, end, level = stack.pop()
        depth = max(depth, level)
        members = order[start:end]
        lower[node], upper[node] = lows[members].min(axis=0), highs[members].max(axis=0)
        if end - start <= LEAF_TRIANGLES:
            first[node], count[node] = start, end - start
            continue
        spread = centroids[members].max(axis=0) - centroids[members].min(axis=0)
        axis = int(np.argmax(spread))
        middle = (end - start) // 2
        order[start:end] = members[np.argpartition(centroids[members, axis], middle)]
        left = used
        used += 2
        first[node], count[node] = left, 0
        stack.append((left, start, start + middle, level + 1))
        stack.append((left + 1, start + middle, end, level + 1))
    first, count = first[:used], count[:used]
    # Depth-first, left child first: the right child follows the left's subtree, and the node
    # after a right child's subtree is the one after its parent's. A child's index is larger
    # than its parent's, so one pass in index order sees every parent first.
    skip = np.full(used, -1, np.int64)
    for node in range(used):
        if count[node] == 0:
            skip[first[node]] = first[node] + 1
            skip[first[node] + 1] = skip[node]
    return Bvh(lower[:used].astype(np.float32), upper[:used].astype(np.float32), first, count, order, depth, skip)


@cache  # a few dozen distinct ranges however many triangles: each level has at most two sizes
def node_count(triangles: int) -> int:
    """The nodes `build_bvh` makes for that many triangles: its median splits halve every range
    however the triangles lie, so the tree's shape depends on their number alone."""
    if triangles <= LEAF_TRIANGLES:
        return 1
    half = triangles // 2
    return 1 + node_count(half) + node_count(triangles - half)
