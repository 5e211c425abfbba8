"""Which of a mirror's many depth images a reflected ray may enter: lists of candidates by ray.

The mirror shader visits a mirror's images nearest first, by where a reflected ray enters their
bound spheres, and stops at the first entered beyond its nearest hit (lib/reflected_scene.glsl).
Finding that order by scanning every image's sphere is work per ray that grows with the object
count. But a mirror's reflected rays all start on the mirror, inside its bounding sphere (centre
c, radius R): a ray is a line of few degrees of freedom, and the images whose spheres a line can
meet can be listed ahead of time for a cell of lines. A ray then scans the short list of its
cell, in the same order, and finds the same images the full scan would (what a light-field
parametrisation of rays, or clustered shading's lists of lights per cell of the view, does).

The cells are those of a light field's two-plane parametrisation, once per cube face: a ray of
direction d whose largest component is along axis e (sign s) is written with its direction on the
face, u = d_t1 / (s d_e), v = d_t2 / (s d_e) in [-1, 1], and where its line crosses the plane
through c perpendicular to e, q = (q1, q2) (the origin p moved along d to depth 0, the depth
(p - c).e s); from an origin within the sphere, |q1|, |q2| <= 2R. Each face's (u, v) square is
cut into `directions` x `directions` cells and its (q1, q2) square into `offsets` x `offsets`.
A ray's line points at depth l are q + l (u, v), and its points lie at depth >= -R (the origin's
depth, from inside the sphere, and d points along e): a sphere of centre depth L and radius r is
listed in a cell when the box of those points over the cell's (u, v, q) and l in [max(L - r,
-R), L + r] meets the sphere's box, axis by axis (a conservative test: a few extra candidates,
never a missing one). Rays that do not start inside the sphere (a ray query's arbitrary rays)
read the last list, which holds every image.

The table (after the records, lib/baked_images.glsl's ImageCells): an ImageGrid record (the
sphere; the cells per side of a face's directions and offsets, the cell count, the image
count), then one int array: the start of each cell's list and one past the last (cells + 2
entries, the fallback list's cell included), then the lists, each in rising image order (the
order in which the scan breaks ties).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..constants import IMAGE_GRID_DTYPE

#: Per cube face (axis e and its sign, as lib/reflected_scene.glsl's image_cell numbers them:
#: 2 axis + (sign < 0)), the two other axes in the order of the face's (u, v) and (q1, q2).
FACE_AXES = ((0, 1, 2), (1, 2, 0), (2, 0, 1))
#: What float32 rounding in the shader may move a ray's (u, v) or q, and a sphere's test, against
#: the float64 build: cell edges and spheres are grown by this share of their scale.
MARGIN = 1e-5
#: The share by which the sphere that rays start in is grown past the mirror's bounding sphere.
ORIGIN_MARGIN = 1e-3


@dataclass(frozen=True)
class GridSize:
    directions: int  # cells per side of a face's (u, v) square
    offsets: int  # cells per side of its (q1, q2) square

    @property
    def cells(self) -> int:
        return 6 * self.directions**2 * self.offsets**2


def grid_size(images: int) -> GridSize:
    """The grid of a mirror of `images` images: finer where there are more to sort among.
    Measured on tools/scene_size.py's family (a ray's list, and the entries of all lists): 100
    images in 8 x 4 cells, 2.3 per ray (16,000 entries); 1,000 images in 16 x 8 cells, 10 per ray
    (1.2 million), where 8 x 4 cells leave 30 per ray."""
    return GridSize(8, 4) if images <= 256 else GridSize(16, 8)


def image_cells(spheres: NDArray[np.float64], centre: NDArray[np.float64], radius: float,
                size: GridSize | None = None) -> NDArray[np.int32]:
    """The int array of the lists (see the module's docstring) of the images whose bound spheres
    are `spheres` ((n, 4), in table order), for rays starting within the sphere (`centre`,
    `radius`)."""
    size = size if size is not None else grid_size(len(spheres))
    # Each listing as one key, cell * 2^shift + image (2^shift > every image): sorted, they run by
    # cell, then image (the lists' rising order). Sorting the keys is several times quicker than a
    # stable argsort of the cells, 32-bit keys sort in half the time, and a power of two splits
    # them again by shift and mask rather than by division.
    shift = max(len(spheres) - 1, 1).bit_length()
    key_type = np.int32 if (size.cells + 1) << shift <= np.iinfo(np.int32).max else np.int64
    faces = _face_ranges(spheres, centre, radius, size)
    lengths = [_listings(ranges) for ranges in faces]
    keys: NDArray[np.integer] = np.empty(sum(lengths) + len(spheres), key_type)
    first = 0
    for face, (ranges, length) in enumerate(zip(faces, lengths, strict=True)):
        face_keys = keys[first:first + length]
        _face_keys(ranges, size, face, shift, face_keys)
        face_keys.sort()  # (a face's cells all come before the next face's: sorted apart, in cache)
        first += length
    keys[first:] = (size.cells << shift) + np.arange(len(spheres))  # the fallback list: every image
    header = size.cells + 2
    table = np.empty(header + len(keys), np.int32)
    table[0] = header
    np.cumsum(np.bincount(keys >> shift, minlength=size.cells + 1), out=table[1:header])
    table[1:header] += header
    np.bitwise_and(keys, (1 << shift) - 1, out=table[header:], casting="unsafe")
    return table


def image_grid(centre: NDArray[np.float64], radius: float, size: GridSize, images: int) -> NDArray[np.void]:
    """The ImageGrid record the shader reads the lists by."""
    grid = np.zeros(1, IMAGE_GRID_DTYPE)
    grid["sphere"] = (*centre, radius)
    grid["size"] = (size.directions, size.offsets, size.cells, images)
    return grid


def cells_table(spheres: NDArray[np.float64], centre: NDArray[np.float64], radius: float) -> bytes:
    """The grid record and the lists, as the table holds them past its records, for rays from a
    mirror of bounding sphere (`centre`, `radius`). The sphere is grown by ORIGIN_MARGIN: a
    reflected ray starts on the mirror's surface, at the sphere's radius where the mirror is a
    sphere, and the shader's float32 test would put half of those origins outside (where they
    read the list of every image: slower, not wrong)."""
    size = grid_size(len(spheres))
    grown = radius * (1.0 + ORIGIN_MARGIN)
    return (image_grid(centre, grown, size, len(spheres)).tobytes()
            + image_cells(spheres, centre, grown, size).tobytes())


def cells_table_bytes(spheres: NDArray[np.float64], centre: NDArray[np.float64], radius: float) -> int:
    """len(cells_table(spheres, centre, radius)), counted without making the lists (what the plan
    states of a mirror's table before the renderer builds it: about 5 MiB a mirror at 1,000 images)."""
    size = grid_size(len(spheres))
    grown = radius * (1.0 + ORIGIN_MARGIN)
    # Every face's listings, and the fallback list's (every image).
    entries = sum(_listings(ranges) for ranges in _face_ranges(spheres, centre, grown, size)) + len(spheres)
    return IMAGE_GRID_DTYPE.itemsize + 4 * (size.cells + 2 + entries)


def _face_ranges(spheres: NDArray[np.float64], centre: NDArray[np.float64], radius: float,
                 size: GridSize) -> list[tuple[NDArray[np.int64], ...]]:
    """Per cube face (as image_cell numbers them), sphere and direction cell of the face's first
    and second axes: the first offset cell listing it and how many do ((n, directions) each:
    low1, count1, low2, count2). The six faces at once, each as alone (the same steps, along a
    leading axis of faces: a face at a time, a thousand spheres' took twice as long)."""
    reach = max(radius, 1e-12) * (1.0 + MARGIN)  # rays start at depth >= -R
    extent = 2.0 * reach  # |q1|, |q2| <= 2R
    offset = spheres[:, :3] - centre
    scale = np.linalg.norm(offset, axis=1) + spheres[:, 3] + reach
    r = spheres[:, 3] + MARGIN * scale
    axes = np.array([FACE_AXES[face // 2] for face in range(6)])  # (6, 3): the axis, first and second
    signs = np.array([[-1.0 if face % 2 else 1.0] for face in range(6)])
    depth = signs * offset[:, axes[:, 0]].T  # (6, n)
    near, far = np.maximum(depth - r, -reach), depth + r
    kept = (far >= -reach)[..., None]
    edges = np.linspace(-1.0, 1.0, size.directions + 1)
    lower, upper = edges[:-1] - MARGIN, edges[1:] + MARGIN
    corners = np.stack([near[..., None] * lower, near[..., None] * upper, far[..., None] * lower, far[..., None] * upper])
    highest, lowest = corners.max(axis=0), corners.min(axis=0)  # (6, n, directions)
    cell = size.offsets / (2.0 * extent)

    def q_ranges(along: NDArray[np.float64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """Per face, sphere and direction cell of one axis: the first and last offset cell listing it."""
        q_low = (along - r)[..., None] - highest
        q_high = (along + r)[..., None] - lowest
        first_cell = np.floor((q_low + extent) * cell - MARGIN).astype(np.int64)
        last_cell = np.floor((q_high + extent) * cell + MARGIN).astype(np.int64)
        return np.maximum(first_cell, 0), np.minimum(last_cell, size.offsets - 1)

    low1, high1 = q_ranges(offset[:, axes[:, 1]].T)
    low2, high2 = q_ranges(offset[:, axes[:, 2]].T)
    count1 = np.where(kept, np.maximum(high1 - low1 + 1, 0), 0)  # (6, n, directions)
    count2 = np.where(kept, np.maximum(high2 - low2 + 1, 0), 0)
    return [(low1[face], count1[face], low2[face], count2[face]) for face in range(6)]


def _listings(ranges: tuple[NDArray[np.int64], ...]) -> int:
    """How many listings a face's ranges (_face_ranges) make: image i in (its (u, q1) cells) x
    (its (v, q2) cells)."""
    _, count1, _, count2 = ranges
    return int(np.dot(count1.sum(axis=1), count2.sum(axis=1)))


def _face_keys(ranges: tuple[NDArray[np.int64], ...], size: GridSize, face: int, shift: int,
               keys: NDArray[np.integer]) -> None:
    """The key (cell * 2^shift + image: image_cells) of every listing on one cube face, image by image (so each
    cell's in rising image order), into `keys` (_listings(ranges) of them)."""
    low1, count1, low2, count2 = ranges
    d, o = size.directions, size.offsets
    # A cell's number is face d^2 o^2 + u d o^2 + q1 o + v o^2 + q2: a part from each axis's rows of
    # (image, direction cell, offset cell), image-major ...
    image1, u_cell, q1 = _rows(count1, low1)
    _, v_cell, q2 = _rows(count2, low2)
    part1 = ((((face * d + u_cell) * d * o + q1) * o) << shift) + image1
    part2 = (v_cell * o * o + q2) << shift
    # ... and every row of one paired with every row of the other for the same image.
    per_image2 = count2.sum(axis=1)
    start2 = np.cumsum(per_image2) - per_image2
    repeats = per_image2[image1]
    pair_start = np.cumsum(repeats) - repeats
    pair2 = np.repeat(start2[image1] - pair_start, repeats)
    pair2 += np.arange(len(pair2))
    np.add(np.repeat(part1, repeats), part2[pair2], out=keys, casting="unsafe")


def _rows(counts: NDArray[np.int64], lows: NDArray[np.int64]) -> tuple[NDArray[np.int64], ...]:
    """(image, direction cell, offset cell) of every listed range of `counts` ((n, directions),
    starting at `lows`), image-major."""
    flat = counts.ravel()
    owner = np.repeat(np.arange(flat.size), flat)
    within = np.arange(owner.size) - np.repeat(np.cumsum(flat) - flat, flat)
    image, direction_cell = np.divmod(owner, counts.shape[1])
    return image, direction_cell, lows.ravel()[owner] + within


def ray_cells(origins: NDArray[np.float64], directions: NDArray[np.float64], centre: NDArray[np.float64],
              radius: float, size: GridSize) -> NDArray[np.int64]:
    """The cell whose list each ray reads (lib/reflected_scene.glsl's image_cell, in numpy): the
    fallback cell `size.cells` for a ray that does not start within the sphere."""
    magnitudes = np.abs(directions)
    axis = np.argmax(magnitudes, axis=1)
    cells = np.full(len(origins), size.cells, np.int64)
    for face_axis, (a, first, second) in enumerate(FACE_AXES):
        rows = axis == face_axis
        d, p = directions[rows], origins[rows] - centre
        sign = np.where(d[:, a] >= 0.0, 1.0, -1.0)
        along = sign * d[:, a]
        u, v = d[:, first] / along, d[:, second] / along
        depth = sign * p[:, a]
        q1, q2 = p[:, first] - depth * u, p[:, second] - depth * v
        extent = 2.0 * radius
        inside = ((radius > 0.0) & (np.einsum("ij,ij->i", p, p) <= radius * radius)
                  & (np.abs(q1) <= extent) & (np.abs(q2) <= extent))
        extent = max(extent, 1e-300)  # (a zero sphere: every ray is outside it)

        def index(x: NDArray[np.float64], low: float, cells: int) -> NDArray[np.int64]:
            return np.clip(np.floor((x - low) / (-2.0 * low) * cells), 0, cells - 1).astype(np.int64)

        dc, oc = size.directions, size.offsets
        face = 2 * face_axis + (sign < 0.0)
        cell = (((face * dc + index(u, -1.0, dc)) * dc + index(v, -1.0, dc)) * oc + index(q1, -extent, oc)) * oc \
            + index(q2, -extent, oc)
        cells[np.flatnonzero(rows)] = np.where(inside, cell, size.cells)
    return cells
