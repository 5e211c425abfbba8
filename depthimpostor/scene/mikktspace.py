"""MikkTSpace (Morten Mikkelsen, "Simulation of Wrinkled Surfaces Revisited", 2008; his
mikktspace.c, zlib licence, github.com/mmikk/MikkTSpace), ported to numpy for triangles (glTF
gives no quads) with genTangSpaceDefault's angular threshold (180 degrees). The steps and names
follow mikktspace.c, so that a reader can hold the two side by side:

1. Corners are welded where their position, normal and UV are all equal (GenerateSharedVertices-
   IndexList): a vertex is a welded class, however the file indexes it.
2. A triangle with two equal positions is degenerate: it takes no part, and its corners copy the
   tangent space of the first healthy corner of their vertex (DegenEpilogue).
3. Each healthy triangle's dP/du and dP/dv (InitTriInfo): unit vOs (along +u) and vOt, their
   magnitudes, whether its UV map keeps the orientation (ORIENT_PRESERVING: UV area > 0), and
   whether it has no UV area or gradient (GROUP_WITH_ANY: it joins its neighbours' groups and adds
   nothing to them).
4. Triangles sharing an edge (its two welded vertices, in opposite directions) are neighbours
   (BuildNeighborsFast: where more than two share an edge, the first unpaired in (edge, triangle)
   order pair up).
5. At each vertex, the triangles around it linked through neighbours of one orientation form a
   group (Build4RuleGroups, AssignRecur): a UV mirror seam or a cut fan splits a vertex. A
   GROUP_WITH_ANY triangle takes the orientation of the first group to reach it, which makes the
   only order dependency in the algorithm; it is followed here triangle by triangle, in
   mikktspace.c's order, at the vertices such triangles touch, and vectorised everywhere else.
6. Within a group, a triangle's corner takes the angle-weighted mean of the members' vOs projected
   on the vertex's normal (EvalTspace), the members being those whose projected vOs and vOt are
   both within the angular threshold of its own (GenerateTSpaces): with 180 degrees, all but
   exactly opposed ones (cos <= -1), which split their group further.
7. Corners left without a group (a GROUP_WITH_ANY triangle no group reached) and degenerate ones
   with no healthy corner to copy keep mikktspace.c's initial space: tangent +X, sign -1.

mikktspace.c computes in float32, and so does this up to the sums of EvalTspace (float64 here):
the discrete choices it makes on values (welding, degeneracy, the UV area's sign and whether it is
zero, the threshold) are made on the same float32 values in the same order of operations, so
that a triangle whose UVs lie on a line falls on the same side. The tangents agree with the C's
to float32 rounding (tests/test_mikktspace.py: within 1e-5 on six meshes, about 1e-7 in fact).
One difference is kept: mikktspace.c's BuildNeighborsFast never sorts its last run of edges by
their second vertex (its loops sort a run when the next begins, and none follows the last), so
that two triangles on an edge of that run (the edges of one vertex, the highest welded index that
is an edge's lower) can stay unpaired, in an order its quicksort's pivots decide: the C then
splits that vertex's group (2 of 300 small random meshes tried). Here every edge is paired.
"""

from __future__ import annotations

import numpy as np

Array = np.ndarray

#: mikktspace.c's NotZero: |x| > FLT_MIN, the smallest normal float32.
FLT_MIN = float(np.finfo(np.float32).tiny)
#: genTangSpaceDefault's fAngularThreshold, 180 degrees, as the cosine GenerateTSpaces compares with
#: (cos(pi) in float32 rounds to exactly -1).
THRESHOLD_COS = -1.0
ZERO = np.float32(0.0)
#: The space mikktspace.c gives a corner no group reaches: vOs = +X, bOrient false.
INITIAL_SPACE = (1.0, 0.0, 0.0, -1.0)


def mikktspace(positions: Array, normals: Array, faces: Array, uvs: Array) -> Array:
    """(F, 3, 4): each triangle corner's unit tangent and sign, as genTangSpaceDefault's
    m_setTSpaceBasic gives them (bitangent = sign N x T along +v). `normals` unit. Where float32
    overflows (coordinates or UVs beyond about 1e19), mikktspace.c's tangent is not finite; here
    it is the initial space's."""
    with np.errstate(all="ignore"):
        p, n, uv = (np.asarray(a).astype(np.float32) for a in (positions, normals, uvs))
        out = _mikktspace(p, n, uv, np.asarray(faces, np.int64).reshape(-1, 3))
    return np.where(np.isfinite(out).all(axis=2, keepdims=True), out, INITIAL_SPACE)


def _mikktspace(p: Array, n: Array, uv: Array, faces: Array) -> Array:
    out = np.tile(INITIAL_SPACE, (len(faces), 3, 1))
    if len(faces) == 0:
        return out
    welded = _welded(p, n, uv)[faces]  # (F, 3) welded vertex of each corner
    corner_p = p[faces]
    degenerate = ((corner_p[:, 0] == corner_p[:, 1]).all(1) | (corner_p[:, 0] == corner_p[:, 2]).all(1)
                  | (corner_p[:, 1] == corner_p[:, 2]).all(1))
    good = np.flatnonzero(~degenerate)  # the healthy triangles, in order (DegenPrologue)
    if len(good):
        w = welded[good]
        triangles = _TriInfo(corner_p[good], uv[faces[good]])
        neighbours = _neighbours(w)
        group, orient = _groups(w, neighbours, triangles)
        out[good] = _tspaces(w, group, orient, triangles, corner_p[good], n[faces[good]])
    _copy_to_degenerate(out, welded, good, np.flatnonzero(degenerate))
    return out


def _welded(p: Array, n: Array, uv: Array) -> Array:
    """(V,) a class id per vertex: equal where position, normal and UV are all equal, as floats
    (GenerateSharedVerticesIndexList: -0 == 0, and a NaN equal to nothing)."""
    values = np.concatenate([p, n, uv], axis=1) + np.float32(0.0)  # -0 + 0 = +0: one bit pattern
    keys = np.ascontiguousarray(values, np.float32).view(np.uint64)  # the float32 bits, two a key
    classes = distinct_rows(keys)
    lone = np.isnan(values).any(axis=1)
    classes[lone] = classes.max(initial=-1) + 1 + np.arange(lone.sum())
    return classes


def distinct_rows(rows: Array) -> Array:
    """(R,) an id per row, equal for equal rows."""
    order = np.lexsort(rows.T[::-1])
    ordered = rows[order]
    fresh = np.r_[True, (ordered[1:] != ordered[:-1]).any(axis=1)] if len(rows) else np.zeros(0, bool)
    ids = np.empty(len(rows), np.int64)
    ids[order] = np.cumsum(fresh) - 1
    return ids


class _TriInfo:
    """InitTriInfo's per-triangle values (triangles only: no quad to force to one orientation), in
    float32 and in mikktspace.c's order of operations."""

    def __init__(self, p: Array, uv: Array) -> None:
        t21, t31 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
        d1, d2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
        area = t21[:, 0] * t31[:, 1] - t21[:, 1] * t31[:, 0]  # fSignedAreaSTx2
        os = t31[:, 1:2] * d1 - t21[:, 1:2] * d2  # eq 18
        ot = -t31[:, 0:1] * d1 + t21[:, 0:1] * d2  # eq 19
        self.orient = area > 0.0
        some_area = np.abs(area) > FLT_MIN
        sign = np.where(self.orient, np.float32(1.0), np.float32(-1.0))
        len_os, len_ot = _length(os), _length(ot)
        # (Divisions by zero where the area or length is: the np.where and the flag drop them.)
        self.os = np.where((some_area & (len_os > FLT_MIN))[:, None], (sign / len_os)[:, None] * os, ZERO)
        self.ot = np.where((some_area & (len_ot > FLT_MIN))[:, None], (sign / len_ot)[:, None] * ot, ZERO)
        mag_s, mag_t = len_os / np.abs(area), len_ot / np.abs(area)
        self.group_with_any = ~(some_area & (mag_s > FLT_MIN) & (mag_t > FLT_MIN))


def _dot(a: Array, b: Array) -> Array:
    """vdot, summed left to right as mikktspace.c does (in the arrays' float32)."""
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def _length(v: Array) -> Array:
    return np.sqrt(_dot(v, v))


def _unit(v: Array) -> Array:
    """Normalize where VNotZero holds (some component above FLT_MIN), else v as it is."""
    some = (np.abs(v) > FLT_MIN).any(axis=1)
    return np.where(some[:, None], (v.dtype.type(1.0) / _length(v))[:, None] * v, v)


def _projected(v: Array, n: Array) -> Array:
    """v less its component along the unit normal n, normalised: GenerateTSpaces' "project"."""
    return _unit(v - _dot(n, v)[:, None] * n)


def _neighbours(w: Array) -> Array:
    """(G, 3): the triangle across each edge k (corners k, k + 1), or -1 (BuildNeighborsFast)."""
    count = len(w)
    a, b = w.ravel(), w[:, [1, 2, 0]].ravel()  # each directed edge, slot 3 f + k
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    slot = np.arange(3 * count)
    order = np.lexsort((slot, hi, lo))  # by (i0, i1, face) as the three sorts leave them
    lo_o, hi_o = lo[order], hi[order]
    start = np.r_[True, (lo_o[1:] != lo_o[:-1]) | (hi_o[1:] != hi_o[:-1])]
    starts = np.flatnonzero(start)
    sizes = np.diff(np.r_[starts, len(order)])
    neighbours = np.full(3 * count, -1, np.int64)
    # Two triangles on an edge (most): neighbours where they run it in opposite directions.
    pair = starts[sizes == 2]
    first, second = order[pair], order[pair + 1]
    opposite = (a[first] == b[second]) & (b[first] == a[second])
    neighbours[first[opposite]], neighbours[second[opposite]] = second[opposite] // 3, first[opposite] // 3
    # More (a non-manifold edge): mikktspace.c's greedy pairing, in order.
    for s, size in zip(starts[sizes > 2], sizes[sizes > 2], strict=True):
        run = order[s: s + size]
        for i, x in enumerate(run):
            if neighbours[x] >= 0:
                continue
            for y in run[i + 1:]:
                if neighbours[y] < 0 and a[x] == b[y] and b[x] == a[y]:
                    neighbours[x], neighbours[y] = y // 3, x // 3
                    break
    return neighbours.reshape(count, 3)


def _fan_links(w: Array, neighbours: Array) -> tuple[Array, Array]:
    """(3G,) each corner's fan neighbours at its vertex, as corner ids (-1: none): across the
    edge leaving it (AssignRecur's neigh_indexL) and the edge arriving at it (neigh_indexR)."""
    links = []
    for edge in (neighbours.ravel(), neighbours[:, [2, 0, 1]].ravel()):
        there = np.maximum(edge, 0)
        k = np.argmax(w[there] == w.ravel()[:, None], axis=1)
        links.append(np.where(edge >= 0, 3 * there + k, -1))
    return links[0], links[1]


def _groups(w: Array, neighbours: Array, tri: _TriInfo) -> tuple[Array, Array]:
    """(3G,) each corner's group id (-1: none) and (G,) each triangle's orientation, which a
    GROUP_WITH_ANY triangle takes from the first group reaching it (Build4RuleGroups)."""
    left, right = _fan_links(w, neighbours)
    orient = tri.orient.copy()
    any_corner = np.repeat(tri.group_with_any, 3)
    # Vertices touched by a GROUP_WITH_ANY triangle: followed in mikktspace.c's order below.
    ordered_vertex = np.zeros(int(w.max()) + 1, bool)
    ordered_vertex[w.ravel()[any_corner]] = True
    ordered = ordered_vertex[w.ravel()]
    group = _components(left, right, np.repeat(orient, 3), ~ordered)
    _ordered_groups(group, orient, any_corner, left, right, np.flatnonzero(ordered & ~any_corner))
    return group, orient


def _components(left: Array, right: Array, orient: Array, free: Array) -> Array:
    """(3G,) the connected components (by their least corner) of the `free` corners linked to a
    fan neighbour of the same orientation; -1 for the others."""
    parent = np.arange(len(left))
    edges = []
    for link in (left, right):
        ok = free & (link >= 0)
        a, b = np.flatnonzero(ok), link[ok]
        same = orient[a] == orient[b]
        edges.append((a[same], b[same]))
    a, b = np.concatenate([e[0] for e in edges]), np.concatenate([e[1] for e in edges])
    while len(a):
        # Hook each edge's larger root under its smaller, then flatten the trees (pointer jumping).
        ra, rb = parent[a], parent[b]
        differ = ra != rb
        if not differ.any():
            break
        np.minimum.at(parent, np.maximum(ra, rb)[differ], np.minimum(ra, rb)[differ])
        while True:
            jumped = parent[parent]
            if np.array_equal(jumped, parent):
                break
            parent = jumped
    return np.where(free, parent, -1)


def _ordered_groups(group: Array, orient: Array, any_corner: Array, left: Array, right: Array, seeds: Array) -> None:
    """Build4RuleGroups at the vertices a GROUP_WITH_ANY triangle touches, seed by seed in
    mikktspace.c's order (group ids from len(group) up, so that they meet no component's):
    a group reaches around its vertex through neighbours of its orientation; a GROUP_WITH_ANY
    triangle none of whose corners has a group yet takes the orientation of the first to reach it."""
    next_id = len(group)
    for seed in seeds:
        if group[seed] >= 0:
            continue
        mine = bool(orient[seed // 3])
        group[seed] = next_id
        stack = [c for c in (right[seed], left[seed]) if c >= 0]
        while stack:
            c = stack.pop()
            t = c // 3
            if group[c] >= 0:
                continue
            if any_corner[c] and (group[3 * t: 3 * t + 3] < 0).all():
                orient[t] = mine
            if bool(orient[t]) != mine:
                continue
            group[c] = next_id
            stack.extend(d for d in (right[c], left[c]) if d >= 0)
        next_id += 1


def _tspaces(w: Array, group: Array, orient: Array, tri: _TriInfo, p: Array, n: Array) -> Array:
    """(G, 3, 4): GenerateTSpaces and EvalTspace for the healthy triangles' corners."""
    count = len(w)
    result = np.tile(INITIAL_SPACE, (3 * count, 1))
    corner = np.flatnonzero(group >= 0)
    if not len(corner):  # every triangle GROUP_WITH_ANY: no group
        return result.reshape(count, 3, 4)
    t, k = corner // 3, corner % 3
    normal = n.reshape(-1, 3)[corner]
    os, ot = _projected(tri.os[t], normal), _projected(tri.ot[t], normal)
    here = p[t, k]
    before, after = _projected(p[t, (k + 2) % 3] - here, normal), _projected(p[t, (k + 1) % 3] - here, normal)
    # fAngle = (float) acos(fCos): the angle of the corner, the weight of its triangle's vOs.
    angle = np.arccos(np.clip(_dot(before, after), -1.0, 1.0).astype(np.float64)).astype(np.float32)
    healthy = ~tri.group_with_any[t]
    weighted = np.where(healthy, angle, np.float32(0.0)).astype(np.float64)[:, None] * os
    present = np.zeros(int(group.max()) + 1, bool)
    present[group[corner]] = True
    member = (np.cumsum(present) - 1)[group[corner]]  # the groups numbered 0, 1, ...
    summed = _sums(member, weighted)
    tangent = _unit(summed)[member]
    # Groups where two members' projected vOs or vOt are opposed (cos <= THRESHOLD_COS): each of
    # their corners averages only the members within the threshold of its own (its subgroup).
    torn = np.flatnonzero(_may_split(member, os, ot, healthy, summed)[member])
    if len(torn):
        tangent[torn] = _subgroups(torn, member, os, ot, healthy, weighted)
    result[corner, :3] = tangent
    result[corner, 3] = np.where(orient[t], 1.0, -1.0)
    return result.reshape(count, 3, 4)


#: A group whose members' projected vectors all point within this cosine of their mean's side has
#: no two opposed (u and -u have cosines with any vector that sum to 0): it need not be split.
SAME_SIDE_COS = 1e-3


def _sums(member: Array, values: Array) -> Array:
    """(groups, 3): the sums of the (N, 3) values over each group's members, in float64."""
    return np.stack([np.bincount(member, weights=values[:, j]) for j in range(3)], axis=1)


def _may_split(member: Array, os: Array, ot: Array, healthy: Array, weighted_os: Array) -> Array:
    """(groups,) whether a group may hold two healthy members whose projected vOs (or vOt) are
    opposed: some unit one not well on the side of the group's sum of them (weighted_os for vOs)
    (the few groups that are get checked pair by pair)."""
    flagged = np.zeros(len(weighted_os), bool)
    for v, sums in ((os, weighted_os), (ot, None)):
        v64 = v.astype(np.float64) * healthy[:, None]
        mean = (_sums(member, v64) if sums is None else sums)[member]
        unit = np.abs(np.einsum("ij,ij->i", v64, v64) - 1.0) < 1e-3
        aside = np.einsum("ij,ij->i", v64, mean) <= SAME_SIDE_COS * np.sqrt(np.einsum("ij,ij->i", mean, mean))
        flagged[member[unit & aside]] = True
    return flagged


def _subgroups(torn: Array, member: Array, os: Array, ot: Array, healthy: Array, weighted: Array) -> Array:
    """(len(torn), 3): the EvalTspace of each corner's subgroup (GenerateTSpaces): the members of its
    group within the threshold of it (all of them for a GROUP_WITH_ANY corner, or with one), over
    every pair of members of the torn groups."""
    order = torn[np.argsort(member[torn], kind="stable")]
    g = member[order]
    starts = np.flatnonzero(np.r_[True, g[1:] != g[:-1]])
    sizes = np.diff(np.r_[starts, len(g)])
    per_corner = np.repeat(sizes, sizes)  # each corner meets every member of its group
    a = np.repeat(np.arange(len(order)), per_corner)
    offset = np.arange(len(a)) - np.repeat(np.cumsum(per_corner) - per_corner, per_corner)
    b = np.repeat(np.repeat(starts, sizes), per_corner) + offset
    ca, cb = order[a], order[b]
    joined = (~healthy[ca] | ~healthy[cb] | (ca == cb)
              | ((_dot(os[ca], os[cb]) > THRESHOLD_COS) & (_dot(ot[ca], ot[cb]) > THRESHOLD_COS)))
    contribution = weighted[cb] * joined[:, None]
    summed = _sums(a, contribution)
    result = np.empty((len(torn), 3))
    result[np.searchsorted(torn, order)] = _unit(summed)
    return result


def _copy_to_degenerate(out: Array, welded: Array, good: Array, degenerate: Array) -> None:
    """DegenEpilogue: a degenerate triangle's corner copies the space of the first healthy corner
    of its welded vertex (the initial space where there is none)."""
    if not len(degenerate) or not len(good):
        return
    healthy = welded[good].ravel()
    earliest = np.full(int(welded.max()) + 1, len(healthy), np.int64)
    np.minimum.at(earliest, healthy, np.arange(len(healthy)))
    wanted = welded[degenerate]
    found = earliest[wanted] < len(healthy)
    source = earliest[wanted]
    flat = out[good].reshape(-1, 4)
    copied = out[degenerate]
    copied[found] = flat[source[found]]
    out[degenerate] = copied
