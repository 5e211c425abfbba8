"""Bounding-volume hierarchies built on the CPU for GPU traversal: over each mesh's triangles (the
bottom level, in the mesh's own space: every distinct mesh's at once, a forest) and over the
instances' world boxes (the top level).

Median splits along the longest axis of the items' centroids: no SAH, but a balanced tree of
depth about log2(n / leaf size), whose shape depends on the item count alone (`node_count`, which
the plan's memory figure uses). Nodes are stored so that an inner node's children are adjacent
(right = left + 1); the shader reads `first` as the left child of an inner node and as the first
item of a leaf. Each node also has a skip link, the node a depth-first traversal visits after
this one's subtree, so that the shader walks the tree without a stack (a per-pixel stack array
slows every fragment of a shader that merely contains it on llvmpipe).

The build runs level by level, every range of a level split at once in numpy, not node by node
in Python: the items are sorted once along each axis, and each split keeps every range sorted on
all three (a stable partition), so that a median is a position and no level sorts again.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cache

import numpy as np

#: Triangles per leaf at most: a few triangle tests are cheaper than another level of boxes.
LEAF_TRIANGLES = 4


@dataclass(frozen=True, eq=False)
class Bvh:
    lower: np.ndarray  # (nodes, 3) float32 box corners
    upper: np.ndarray  # (nodes, 3)
    first: np.ndarray  # (nodes,) int: left child (inner) or first item (leaf)
    count: np.ndarray  # (nodes,) int: items in a leaf, 0 for an inner node
    order: np.ndarray  # (items,) the input items in leaf order
    depth: int  # levels below the root
    skip: np.ndarray  # (nodes,) int: the next node after this one's subtree, -1 after the last

    @property
    def node_count(self) -> int:
        return len(self.first)


def build_bvh(triangles: np.ndarray) -> Bvh:
    """The hierarchy of (n, 3, 3) triangles (n >= 1), LEAF_TRIANGLES a leaf."""
    return build_triangle_forest(triangles, [len(triangles)])


def build_triangle_forest(triangles: np.ndarray, sizes: Sequence[int]) -> Bvh:
    """One hierarchy per run of `sizes` consecutive triangles of (n, 3, 3) `triangles` (each
    run >= 1): a forest in one set of arrays, the root of run j at node j (build_forest)."""
    triangles = np.asarray(triangles, dtype=np.float64)
    if triangles.ndim != 3 or triangles.shape[1:] != (3, 3) or len(triangles) == 0:
        raise ValueError(f"build_bvh: expected (n >= 1, 3, 3) triangles, got {triangles.shape}")
    p0, p1, p2 = triangles[:, 0], triangles[:, 1], triangles[:, 2]  # (a corner at a time: 5x numpy's min over an axis)
    return build_forest(np.minimum(np.minimum(p0, p1), p2), np.maximum(np.maximum(p0, p1), p2), (p0 + p1 + p2) / 3.0,
                        sizes, LEAF_TRIANGLES)


def build_box_bvh(lows: np.ndarray, highs: np.ndarray, centroids: np.ndarray, leaf_size: int) -> Bvh:
    """The hierarchy of n >= 1 items given by their (n, 3) boxes and the (n, 3) points they are
    split by, at most `leaf_size` a leaf."""
    return build_forest(lows, highs, centroids, [len(lows)], leaf_size)


def build_forest(lows: np.ndarray, highs: np.ndarray, centroids: np.ndarray, sizes: Sequence[int],
                 leaf_size: int) -> Bvh:
    """One hierarchy per run of `sizes` consecutive items (given by their (n, 3) boxes and the
    (n, 3) points they are split by), at most `leaf_size` a leaf, all built at once: the root of
    run j is node j, and its items stay in its run of `order`. A thousand small meshes cost one
    build's few dozen numpy calls, not a thousand builds'."""
    items = len(lows)
    runs = np.asarray(sizes, np.int64)
    if items == 0 or leaf_size < 1 or (runs < 1).any() or runs.sum() != items:
        raise ValueError(f"build_forest: expected runs of >= 1 of the {items} items and a leaf size >= 1, "
                         f"got {runs.tolist()[:8]} and {leaf_size}")
    capacity = sum(node_count(int(run), leaf_size) for run in runs)
    lower, upper = np.zeros((capacity, 3)), np.zeros((capacity, 3))
    first, count = np.zeros(capacity, np.int64), np.zeros(capacity, np.int64)
    # The items sorted by their centroid on each axis (ties by index) within their run; every split
    # keeps each range of the three sorted (_split), so that a range's median on any axis is at its
    # middle.
    by_axis = np.stack([_sorted_in_runs(centroids[:, axis], runs) for axis in range(3)])
    # One level's ranges of by_axis: their nodes, starts and ends. A level's nodes are numbered
    # after every earlier level's, the two children of a parent side by side.
    ends = np.cumsum(runs)
    nodes, starts = np.arange(len(runs)), ends - runs
    parents_by_level: list[np.ndarray] = []
    used = len(runs)
    while len(nodes):
        leaf = ends - starts <= leaf_size
        first[nodes[leaf]], count[nodes[leaf]] = starts[leaf], (ends - starts)[leaf]
        nodes, starts, ends = nodes[~leaf], starts[~leaf], ends[~leaf]
        if not len(nodes):
            break
        middles = starts + (ends - starts) // 2
        _split(by_axis, centroids, starts, middles, ends)
        lefts = used + 2 * np.arange(len(nodes))
        used += 2 * len(nodes)
        first[nodes] = lefts
        parents_by_level.append(nodes)
        nodes = np.stack((lefts, lefts + 1), axis=1).reshape(-1)
        starts, ends = np.stack((starts, middles), axis=1).reshape(-1), np.stack((middles, ends), axis=1).reshape(-1)
    order = by_axis[0]
    _bound(lows, highs, order, first[:used], count[:used], parents_by_level, lower, upper)
    # Depth-first, left child first: the right child follows the left's subtree, and the node
    # after a right child's subtree is the one after its parent's (a root's: -1, the walk's end).
    # Level by level, every parent's skip is known before its children's.
    skip = np.full(used, -1, np.int64)
    for parents in parents_by_level:
        skip[first[parents]] = first[parents] + 1
        skip[first[parents] + 1] = skip[parents]
    return Bvh(_float32_outward(lower[:used], -np.inf), _float32_outward(upper[:used], np.inf), first[:used],
               count[:used], order.copy(), len(parents_by_level), skip)


def refit_triangle_forest(bvh: Bvh, triangles: np.ndarray) -> Bvh:
    """`bvh` (a build_triangle_forest's) over the same triangles moved to (n, 3, 3) `triangles`:
    the same tree, leaves and order, every box made again around the triangles where they are now
    (a deforming mesh's refit: its topology is the same, its vertices moved). The tree was split for
    where the triangles were, so it may fit less tightly than a new build, never wrongly."""
    triangles = np.asarray(triangles, dtype=np.float64)
    if triangles.shape != (len(bvh.order), 3, 3):
        raise ValueError(f"refit_triangle_forest: expected ({len(bvh.order)}, 3, 3) triangles, got {triangles.shape}")
    p0, p1, p2 = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    # The inner nodes a level at a time from the roots (a level's children are numbered after it).
    inner = bvh.count == 0
    is_child = np.zeros(bvh.node_count, bool)
    is_child[bvh.first[inner]] = is_child[bvh.first[inner] + 1] = True
    roots = np.flatnonzero(~is_child)
    parents_by_level, level = [], roots
    while len(level):
        inner = level[bvh.count[level] == 0]
        if not len(inner):
            break
        parents_by_level.append(inner)
        level = np.concatenate([bvh.first[inner], bvh.first[inner] + 1])
    lower, upper = np.zeros((bvh.node_count, 3)), np.zeros((bvh.node_count, 3))
    _bound(np.minimum(np.minimum(p0, p1), p2), np.maximum(np.maximum(p0, p1), p2), bvh.order, bvh.first, bvh.count,
           parents_by_level, lower, upper)
    return Bvh(_float32_outward(lower, -np.inf), _float32_outward(upper, np.inf), bvh.first, bvh.count, bvh.order,
               bvh.depth, bvh.skip)


def _float32_outward(bound: np.ndarray, toward: float) -> np.ndarray:
    """`bound` in float32, rounded toward `toward` where float32 cannot hold it, so that a box still
    holds what it bounds (a triangle's float32 corners are exact; an instance's float64 box is not)."""
    rounded = bound.astype(np.float32)
    inward = rounded > bound if toward < 0 else rounded < bound
    return np.where(inward, np.nextafter(rounded, np.float32(toward)), rounded)


def _sorted_in_runs(keys: np.ndarray, runs: np.ndarray) -> np.ndarray:
    """The indices of `keys` sorted within each run of consecutive ones (ties by index), runs kept in
    order: a stable sort by key, then a stable one by run (np.lexsort's two keys take a third longer)."""
    order = np.argsort(keys, kind="stable")
    if len(runs) == 1:
        return order
    run_of = np.repeat(np.arange(len(runs), dtype=np.int32), runs)
    return order[np.argsort(run_of[order], kind="stable")]


def _bound(lows: np.ndarray, highs: np.ndarray, order: np.ndarray, first: np.ndarray, count: np.ndarray,
           parents_by_level: list[np.ndarray], lower: np.ndarray, upper: np.ndarray) -> None:
    """Every node's box: a leaf's around its items (each leaf's item k read as its item
    min(k, count - 1): a fixed-size gather, no per-leaf loop), then the inner nodes' from their
    children's, the deepest level first."""
    leaves = np.nonzero(count)[0]
    widest = int(count.max())
    taken = first[leaves, None] + np.minimum(np.arange(widest), count[leaves, None] - 1)  # (leaves, widest)
    lower[leaves] = lows[order[taken]].min(axis=1)
    upper[leaves] = highs[order[taken]].max(axis=1)
    for parents in reversed(parents_by_level):
        lower[parents] = np.minimum(lower[first[parents]], lower[first[parents] + 1])
        upper[parents] = np.maximum(upper[first[parents]], upper[first[parents] + 1])


def _split(by_axis: np.ndarray, centroids: np.ndarray, starts: np.ndarray, middles: np.ndarray, ends: np.ndarray) -> None:
    """Split each range [start, end) of the three sorted lists at its middle, on the axis along
    which its centroids spread farthest: the items before the middle in that axis's order go left.
    Each list is then partitioned stably within each range (left items first), so that both
    halves stay sorted on every axis."""
    sizes = ends - starts
    axes = np.arange(3)
    spread = centroids[by_axis[:, ends - 1], axes[:, None]] - centroids[by_axis[:, starts], axes[:, None]]  # (3, ranges)
    axis = np.argmax(spread, axis=0)
    offsets = np.concatenate(([0], np.cumsum(sizes)[:-1]))
    positions = np.arange(sizes.sum()) - np.repeat(offsets - starts, sizes)
    range_of = np.repeat(np.arange(len(sizes)), sizes)
    rank_in_range = np.arange(len(positions)) - offsets[range_of]
    start_of, middle_of = starts[range_of], middles[range_of]
    goes_left = np.zeros(by_axis.shape[1], bool)
    goes_left[by_axis[axis[range_of], positions]] = positions < middle_of
    for sorted_items in by_axis:
        segment = sorted_items[positions]
        left = goes_left[segment]
        # Within its range, a left item's rank among the left ones, a right item's among the right.
        left_before = np.cumsum(left) - left
        left_before -= left_before[offsets][range_of]
        target = np.where(left, start_of + left_before, middle_of + rank_in_range - left_before)
        sorted_items[target] = segment


@cache  # a few dozen distinct ranges however many items: each level has at most two sizes
def node_count(items: int, leaf_size: int = LEAF_TRIANGLES) -> int:
    """The nodes `build_box_bvh` makes for that many items: its median splits halve every range
    however the items lie, so the tree's shape depends on their number alone."""
    if items <= leaf_size:
        return 1
    half = items // 2
    return 1 + node_count(half, leaf_size) + node_count(items - half, leaf_size)
