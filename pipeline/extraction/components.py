"""Connected components of a binary field held as row runs: the runs, their 8-connected
labels and pixel moments, and the shape figures of each component.

One implementation for every mask of the pipeline: the ridge-response mask inside a band (or
the band of all blocks, the whole frame), the classic baseline's mask and the band's seed
regions.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.extraction.blocks import BLOCK_PX, block_runs, run_starts
from pipeline.jit import kernel


@kernel
def append_runs(line, row, first, stop, runs, count, edges) -> int:
    """Write the runs of True in line[first:stop] as (row, first, stop) from runs[count];
    returns the new count. `runs` must have room (`room_for_runs`); `edges` is scratch
    (int64) of ≥ stop − first + 1 entries.

    Where the line flips is gathered first, with no branch per pixel (a lit frame's texture
    flips every few pixels, and a branch on each flip is mispredicted), then paired."""
    flips = 0
    before = False
    for c in range(first, stop):
        now = line[c]
        edges[flips] = c
        flips += now != before
        before = now
    edges[flips] = stop  # a run reaching `stop` ends there
    for k in range(0, flips, 2):
        runs[count, 0], runs[count, 1], runs[count, 2] = row, edges[k], edges[k + 1]
        count += 1
    return count


@kernel
def room_for_runs(band, height):
    """An empty (K, 3) run array with room for every run the band's rows can hold: a row
    stretch of n pixels holds at most (n + 1) // 2."""
    most = 0
    for k in range(band.shape[0]):
        rows = min(BLOCK_PX, height - band[k, 0] * BLOCK_PX)
        most += rows * (((band[k, 2] - band[k, 1]) * BLOCK_PX + 1) // 2)
    return np.empty((most, 3), np.int64)


@kernel
def find_root(parent, p):
    """The root of node `p` in a union-find forest `parent`, halving the path on the way."""
    while parent[p] != p:
        parent[p] = parent[parent[p]]
        p = parent[p]
    return p


@kernel
def union(parent, a, b) -> None:
    """Join the trees of nodes `a` and `b`, the smaller root becoming the root."""
    ra, rb = find_root(parent, a), find_root(parent, b)
    if ra != rb:
        parent[max(ra, rb)] = min(ra, rb)


@kernel
def tree_labels(parent, first):
    """Each node's label in a union-find forest: its tree's number, counted from `first`
    in the order of the trees' roots (int64, the size of `parent`), and the next unused
    label."""
    label = np.empty(parent.size, np.int64)
    count = first
    for k in range(parent.size):
        root = find_root(parent, k)
        if root == k:
            label[k] = count
            count += 1
        else:
            label[k] = label[root]
    return label, count


@kernel
def row_runs(binary, blocks):
    """Runs of True pixels along the band's rows, raster order: rows of (row, first, stop)."""
    height, width = binary.shape
    band = block_runs(blocks)
    starts = run_starts(band, blocks.shape[0])
    runs = room_for_runs(band, height)
    edges = np.empty(width + 1, np.int64)
    count = 0
    for r in range(height):
        br = r // BLOCK_PX
        for k in range(starts[br], starts[br + 1]):
            c0, c1 = band[k, 1] * BLOCK_PX, min(band[k, 2] * BLOCK_PX, width)
            count = append_runs(binary[r], r, c0, c1, runs, count, edges)
    return runs[:count].copy()


@kernel
def band_pixels(flags, blocks):
    """Rows and columns of the True pixels of `flags` inside the band's blocks, raster order."""
    runs = row_runs(flags, blocks)
    most = 0
    for k in range(runs.shape[0]):
        most += runs[k, 2] - runs[k, 1]
    rows = np.empty(most, np.int64)
    cols = np.empty(most, np.int64)
    count = 0
    for k in range(runs.shape[0]):
        for c in range(runs[k, 1], runs[k, 2]):
            rows[count], cols[count] = runs[k, 0], c
            count += 1
    return rows, cols


@kernel
def label_runs(runs):
    """8-connected components of row runs (raster order): each run's label and the moments.

    Runs of consecutive rows touch when their column spans overlap or meet at a corner.
    Union-find with the earlier run as root, so labels follow the components' first pixels.
    `moments[k]` holds the area and the sums of r, c, r², c², r·c of component k (row 0, the
    background, stays 0).
    """
    count = runs.shape[0]
    parent = np.arange(count)
    previous = 0  # first run of the previous row
    row = -1
    scan = 0  # first run of the previous row that ends at or after this run's start
    for k in range(count):
        r, c0, c1 = runs[k, 0], runs[k, 1], runs[k, 2]
        while previous < k and runs[previous, 0] < r - 1:
            previous += 1
        if r != row:
            row, scan = r, previous
        # A row's runs are sorted and disjoint: those of the previous row that end before
        # c0 touch no later run of this row either, and from the first that starts past c1
        # on none touches this one (a textured frame holds hundreds of runs a row).
        while scan < k and runs[scan, 0] == r - 1 and runs[scan, 2] < c0:
            scan += 1
        j = scan
        while j < k and runs[j, 0] == r - 1 and runs[j, 1] <= c1:
            union(parent, k, j)
            j += 1
    label, components = tree_labels(parent, 1)
    moments = np.zeros((components, 6))
    for k in range(count):
        r, c0, c1 = float(runs[k, 0]), float(runs[k, 1]), float(runs[k, 2])
        n = c1 - c0
        sum_c = n * (c0 + c1 - 1) / 2
        sum_cc = ((c1 - 1) * c1 * (2 * c1 - 1) - (c0 - 1) * c0 * (2 * c0 - 1)) / 6
        lab = label[k]
        moments[lab, 0] += n
        moments[lab, 1] += r * n
        moments[lab, 2] += sum_c
        moments[lab, 3] += r * r * n
        moments[lab, 4] += sum_cc
        moments[lab, 5] += r * sum_c
    return label, moments


@kernel
def paint_runs(runs, chosen, shape):
    """A uint8 mask (0/1) with the chosen runs set."""
    out = np.zeros(shape, np.uint8)
    for k in range(runs.shape[0]):
        if chosen[k]:
            out[runs[k, 0], runs[k, 1] : runs[k, 2]] = 1
    return out


@kernel
def label_extents(runs, label, count):
    """Bounding-box height and width [px] of each label 1..count − 1 of labelled runs:
    (count, 2) int64, row 0 (the background) 0."""
    low = np.full((count, 2), np.iinfo(np.int64).max, np.int64)
    high = np.full((count, 2), -1, np.int64)
    for k in range(runs.shape[0]):
        lab = label[k]
        low[lab, 0], high[lab, 0] = min(low[lab, 0], runs[k, 0]), max(high[lab, 0], runs[k, 0])
        low[lab, 1], high[lab, 1] = min(low[lab, 1], runs[k, 1]), max(high[lab, 1], runs[k, 2] - 1)
    out = high - low + 1
    out[0] = 0
    return out


@dataclass(frozen=True, slots=True, eq=False)
class ComponentShapes:
    """Shape figures of the labelled components 1..K (index 0 is the background)."""

    area_px: np.ndarray
    length_px: np.ndarray
    elongation: np.ndarray


def shapes_from_moments(
    area: np.ndarray,
    sum_r: np.ndarray,
    sum_c: np.ndarray,
    sum_rr: np.ndarray,
    sum_cc: np.ndarray,
    sum_rc: np.ndarray,
) -> ComponentShapes:
    """Area, equivalent bar length and elongation from each component's pixel moments.

    Notes
    -----
    With λmax the largest eigenvalue of the pixel-coordinate covariance, L = √(12·λmax) is
    the length of a uniform bar with that variance, and the elongation is L²/A.
    """
    safe = np.maximum(area, 1)
    mr, mc = sum_r / safe, sum_c / safe
    vrr = sum_rr / safe - mr**2
    vcc = sum_cc / safe - mc**2
    vrc = sum_rc / safe - mr * mc
    lam_max = 0.5 * (vrr + vcc) + np.sqrt(0.25 * (vrr - vcc) ** 2 + vrc**2)
    length = np.sqrt(12 * np.maximum(lam_max, 0))
    return ComponentShapes(area_px=area, length_px=length, elongation=length**2 / safe)


@kernel
def label_maxima(label, values, count):
    """The largest of `values` (≥ 0) per label 0..count − 1: (count,) float64, 0 where a
    label has none (np.maximum.at, a loop instead of its slow generic path)."""
    out = np.zeros(count)
    for k in range(label.size):
        out[label[k]] = max(out[label[k]], values[k])
    return out


@kernel
def _near_pairs(runs, label, consider, gap_px):
    """The pairs (a, b), a > b, of `labels_within`: (P, 2) int64.

    Each run is compared with the earlier runs of the `gap_px` rows up to its own that
    reach within `gap_px` of its columns. A row's runs are sorted and disjoint, and a row's
    runs come in column order, so where those start in each earlier row only moves on: one
    pointer per earlier row (a textured frame holds hundreds of runs a row, nearly all of
    them too far aside). Pairs already found are tracked among the considered labels only.
    """
    index = np.full(consider.size, -1, np.int64)  # label → its place among the considered
    count = 0
    for a in range(consider.size):
        if consider[a]:
            index[a] = count
            count += 1
    found = np.zeros((count, count), np.bool_)
    pairs = np.empty((64, 2), np.int64)  # doubled when full
    total = 0
    reach = int(np.floor(gap_px))
    gap2 = gap_px * gap_px
    if runs.shape[0] == 0:
        return pairs[:0]
    first_row = runs[0, 0]
    row_start = np.searchsorted(runs[:, 0], np.arange(first_row, runs[-1, 0] + 2))
    pointer = np.zeros(reach + 1, np.int64)  # per dy: the first run of row r − dy in reach
    row = first_row - 1
    for k in range(runs.shape[0]):
        r, c0, c1 = runs[k, 0], runs[k, 1], runs[k, 2]
        if r != row:
            row = r
            for dy in range(min(reach, r - first_row) + 1):
                pointer[dy] = row_start[r - dy - first_row]
        a = index[label[k]]
        if a < 0:
            continue
        for dy in range(min(reach, r - first_row) + 1):
            end = k if dy == 0 else row_start[r - dy - first_row + 1]
            j = pointer[dy]
            while j < end and runs[j, 2] - 1 < c0 - reach:
                j += 1
            pointer[dy] = j
            while j < end and runs[j, 1] <= c1 - 1 + reach:
                b = index[label[j]]
                if b >= 0 and b != a and not found[a, b]:
                    dx = max(0, runs[j, 1] - (c1 - 1), c0 - (runs[j, 2] - 1))
                    if dx * dx + dy * dy <= gap2:
                        found[a, b] = found[b, a] = True
                        if total == pairs.shape[0]:
                            more = np.empty((2 * total, 2), np.int64)
                            more[:total] = pairs
                            pairs = more
                        pairs[total, 0], pairs[total, 1] = label[k], label[j]
                        total += 1
                j += 1
    return pairs[:total]


@kernel
def _runs_near_others(runs, label, consider, gap_px):
    """Which runs can hold a pixel of a pair of `labels_within`: runs of a considered label
    whose columns, widened by the gap, meet those of another considered label's runs on the
    rows within the gap of their own. Only these are compared (a textured frame's stripe
    component, joined to the texture, holds thousands of runs, nearly all of them far from
    any other considered component)."""
    count = 0
    index = np.full(consider.size, -1, np.int64)
    for a in range(consider.size):
        if consider[a]:
            index[a] = count
            count += 1
    keep = np.zeros(runs.shape[0], np.bool_)
    if runs.shape[0] == 0 or count < 2:
        return keep
    reach = int(np.floor(gap_px))
    rows = runs[-1, 0] + 1
    # Per label and row: the first and last column of its runs on the rows within the
    # gap (none: first > last).
    first = np.full((count, rows), np.iinfo(np.int64).max, np.int64)
    last = np.full((count, rows), np.iinfo(np.int64).min, np.int64)
    for k in range(runs.shape[0]):
        a = index[label[k]]
        if a < 0:
            continue
        for r in range(max(runs[k, 0] - reach, 0), min(runs[k, 0] + reach + 1, rows)):
            first[a, r] = min(first[a, r], runs[k, 1])
            last[a, r] = max(last[a, r], runs[k, 2] - 1)
    for k in range(runs.shape[0]):
        a = index[label[k]]
        if a < 0:
            continue
        r = runs[k, 0]
        for b in range(count):
            if (
                b != a
                and first[b, r] - reach <= runs[k, 2] - 1
                and runs[k, 1] <= last[b, r] + reach
            ):
                keep[k] = True
                break
    return keep


MAX_BOXED_LABELS = 64
"""`labels_within` narrows the runs to those near another considered label
(`_runs_near_others`) when at most this many are considered (each run is tested against
each label, which holds a (labels, rows) table)."""


def labels_within(
    runs: np.ndarray, label: np.ndarray, consider: np.ndarray, gap_px: float
) -> np.ndarray:
    """Pairs of the considered labels with pixels within `gap_px` of each other (Euclidean,
    pixel centres): (P, 2) int64, each pair once, from labelled runs in raster order.

    `consider` (bool, one per label) marks the labels compared. Pairs, not a (labels,
    labels) matrix: a textured frame has thousands of labels, and zeroing that matrix
    (39 MB on the lit speed frame) cost more than finding the pairs.
    """
    if np.count_nonzero(consider) <= MAX_BOXED_LABELS:
        # A pair's pixels lie within the gap of each other's columns on rows within the gap:
        # the runs left out find none, and leaving them out keeps the raster order of the rest.
        keep = _runs_near_others(runs, label, consider, float(gap_px))
        runs, label = runs[keep], label[keep]
    return _near_pairs(runs, label, consider, float(gap_px))
