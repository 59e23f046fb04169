"""Linking of line centre points into ordered polylines (after Steger's linking)."""

from __future__ import annotations

import numpy as np

from pipeline.jit import kernel

MIN_POLYLINE_POINTS = 3
"""Chains shorter than this are isolated points or noise pairs and are dropped."""

MIN_LENGTH_SIGMAS = 2.0
"""Chains shorter than this many σ (of their own scale) are dropped: a line seen at scale σ
is at least about 2σ long; shorter chains are side lobes of bends and noise."""

MAX_NORMAL_TURN_RAD = np.deg2rad(30.0)
"""Largest angle between the normals of two linked points."""

NEIGHBOUR_REACH_PX = 2
"""Neighbour pixels searched: the 5×5 window, so a one-pixel gap is bridged."""

_SURE_TURN_DOT = np.cos(MAX_NORMAL_TURN_RAD) - 1e-9
"""|n_i·n_j| below this turns the normal by more than MAX_NORMAL_TURN_RAD for certain (the
margin is far above arccos's rounding), so arccos is evaluated only above it."""


@kernel
def _in_row_major_order(rows, cols) -> bool:
    """Whether the points are sorted by (row, col) already (np.nonzero's order)."""
    for k in range(1, rows.size):
        if rows[k] < rows[k - 1] or (rows[k] == rows[k - 1] and cols[k] <= cols[k - 1]):
            return False
    return True


@kernel
def _best_neighbours(rows, cols, x, y, nx, ny, order, height, ahead, behind) -> None:
    """Index of the cheapest neighbour ahead (+tangent) and behind (−tangent), −1 if none.

    `order` sorts the points by (row, col); rows outside [0, height) are never searched.

    Notes
    -----
    Steger's linking cost: distance plus the normal's turn; here also the offset across the
    line, so a parallel neighbour never wins over one ahead. A neighbour qualifies when it
    lies within 45° of the tangent and its normal turns by at most MAX_NORMAL_TURN_RAD.
    Neighbours are visited row by row, column by column, and the first of equal costs wins.
    The points are taken in `order`, so the first candidate of each window row, (r + dr,
    c − reach), only moves forward: one pointer per dr, no search.
    """
    count = order.size
    sorted_rows = rows[order]
    sorted_cols = cols[order]
    first = np.zeros(2 * NEIGHBOUR_REACH_PX + 1, np.int64)
    for q in range(count):
        i = order[q]
        xi, yi, nxi, nyi = x[i], y[i], nx[i], ny[i]
        best_ahead = np.inf
        best_behind = np.inf
        found_ahead = -1
        found_behind = -1
        low = sorted_cols[q] - NEIGHBOUR_REACH_PX
        high = sorted_cols[q] + NEIGHBOUR_REACH_PX
        for k in range(2 * NEIGHBOUR_REACH_PX + 1):
            r = sorted_rows[q] + k - NEIGHBOUR_REACH_PX
            if r < 0 or r >= height:
                continue
            p = first[k]
            while p < count and (
                sorted_rows[p] < r or (sorted_rows[p] == r and sorted_cols[p] < low)
            ):
                p += 1
            first[k] = p
            while p < count and sorted_rows[p] == r and sorted_cols[p] <= high:
                j = order[p]
                p += 1
                if j == i:
                    continue
                dx = x[j] - xi
                dy = y[j] - yi
                along = -nyi * dx + nxi * dy
                across = nxi * dx + nyi * dy
                if abs(across) >= abs(along):
                    continue
                best = best_ahead if along > 0 else best_behind
                floor = max(abs(dx), abs(dy)) + 2 * abs(across)
                if floor >= best:
                    continue
                dot = abs(nxi * nx[j] + nyi * ny[j])
                if dot < _SURE_TURN_DOT:
                    continue
                turn = np.arccos(min(dot, 1.0))
                if turn > MAX_NORMAL_TURN_RAD or floor + turn >= best:
                    continue
                cost = np.hypot(dx, dy) + 2 * abs(across) + turn
                if along > 0 and cost < best_ahead:
                    best_ahead = cost
                    found_ahead = j
                elif along < 0 and cost < best_behind:
                    best_behind = cost
                    found_behind = j
        ahead[i] = found_ahead
        behind[i] = found_behind


@kernel
def _pairwise_sum(values) -> float:
    """Sum of `values` in NumPy's pairwise order (`ndarray.sum` of a contiguous float64
    array: 8 partial sums in blocks of up to 128 values), so equal to it bit for bit."""
    n = values.size
    if n < 8:
        total = 0.0
        for value in values:
            total += value
        return total
    if n <= 128:
        partial = values[:8].copy()
        k = 8
        while k < n - n % 8:
            for m in range(8):
                partial[m] += values[k + m]
            k += 8
        total = ((partial[0] + partial[1]) + (partial[2] + partial[3])) + (
            (partial[4] + partial[5]) + (partial[6] + partial[7])
        )
        for m in range(k, n):
            total += values[m]
        return total
    half = n // 2 - n // 2 % 8
    return _pairwise_sum(values[:half]) + _pairwise_sum(values[half:])


@kernel
def _shorter_than(x, y, chain, limit, steps) -> bool:
    """Whether the polyline through the points `chain` is shorter than `limit` [px], decided
    as `np.hypot(np.diff(x[chain]), np.diff(y[chain])).sum() < limit` is; `steps` is scratch.

    A chain whose sum of max(|dx|, |dy|) per step, a lower bound of its length, exceeds
    `limit` by 1e-6 (relative) is long: both sums err by at most (n − 1)·2⁻⁵³ relatively, so
    this needs no hypot. The rest are summed in NumPy's pairwise order.
    """
    floor = 0.0
    for k in range(chain.size - 1):
        a, b = chain[k], chain[k + 1]
        floor += max(abs(x[b] - x[a]), abs(y[b] - y[a]))
    if floor > limit * (1 + 1e-6):
        return False
    for k in range(chain.size - 1):
        a, b = chain[k], chain[k + 1]
        steps[k] = np.hypot(x[b] - x[a], y[b] - y[a])
    return _pairwise_sum(steps[: chain.size - 1]) < limit


@kernel
def _walk_chains(ahead, behind, x, y, sigma, position, ends) -> int:
    """Split the mutual links into ordered chains and keep those long enough: `position`
    lists the kept points chain by chain, `ends[c]` is where chain c ends; returns the count.

    A link i–j is kept when each picked the other (ahead or behind), so every point has at
    most two links. Chains start at the ends (degree ≤ 1) in index order, then closed loops.
    A chain is kept with at least MIN_POLYLINE_POINTS points and a length [px] of at least
    MIN_LENGTH_SIGMAS times its largest σ (NaN σ keeps it), and runs from the end with the
    smaller x (then y).
    """
    count = ahead.size
    links = np.full((count, 2), -1, np.int64)
    for i in range(count):
        for k, j in enumerate((ahead[i], behind[i])):
            if j >= 0 and (ahead[j] == i or behind[j] == i):
                links[i, k] = j
    visited = np.zeros(count, np.bool_)
    steps = np.empty(count, np.float64)
    listed = 0
    kept = 0
    for degree_limit in (1, 2):
        for start in range(count):
            degree = (links[start, 0] >= 0) + (links[start, 1] >= 0)
            if visited[start] or degree > degree_limit:
                continue
            begin = listed
            current = start
            while current >= 0:
                visited[current] = True
                position[listed] = current
                listed += 1
                following = -1
                for j in links[current]:
                    if j >= 0 and not visited[j]:
                        following = j
                        break
                current = following
            size = listed - begin
            if size < MIN_POLYLINE_POINTS:
                listed = begin
                continue
            largest = sigma[position[begin]]
            for k in range(begin, listed):
                s = sigma[position[k]]
                if s > largest:
                    largest = s
                elif s != s:
                    largest = np.nan
                    break
            if _shorter_than(x, y, position[begin:listed], MIN_LENGTH_SIGMAS * largest, steps):
                listed = begin
                continue
            first, last = position[begin], position[listed - 1]
            if x[last] < x[first] or (x[last] == x[first] and y[last] < y[first]):
                position[begin:listed] = position[begin:listed][::-1].copy()
            ends[kept] = listed
            kept += 1
    return kept


def link_points(
    rows: np.ndarray,
    cols: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    nx: np.ndarray,
    ny: np.ndarray,
    sigma_px: np.ndarray,
    shape: tuple[int, int],
) -> list[np.ndarray]:
    """Link centre points (one per pixel) into ordered polylines.

    Parameters
    ----------
    rows, cols : ndarray of shape (K,), int
        Pixel holding each centre point (unique pairs).
    x, y : ndarray of shape (K,), float
        Sub-pixel centre [px] (x = column, y = row).
    nx, ny : ndarray of shape (K,), float
        Unit normals (sign arbitrary).
    sigma_px : ndarray of shape (K,), float
        Scale each point was found at [px].
    shape : tuple of int
        Image shape (M, N).

    Returns
    -------
    list of ndarray of int64
        Polylines as ordered indices into the K points; chains of fewer than
        MIN_POLYLINE_POINTS points or shorter than MIN_LENGTH_SIGMAS times their largest σ
        are left out. Each chain runs so its first point has the smaller
        x (then y) of its two ends.

    Notes
    -----
    Each point picks its best neighbour ahead and behind; a link is kept only when both
    points picked each other, so every point has at most two links and the graph splits
    into simple chains (a closed loop is cut at an arbitrary point).
    """
    if rows.size == 0:
        return []
    rows = np.asarray(rows, np.int64)
    cols = np.asarray(cols, np.int64)
    if _in_row_major_order(rows, cols):
        order = np.arange(rows.size)
    else:
        order = np.lexsort((cols, rows))
    fx, fy, fnx, fny, fsigma = (
        np.ascontiguousarray(a, np.float64) for a in (x, y, nx, ny, sigma_px)
    )
    ahead = np.empty(rows.size, np.int64)
    behind = np.empty(rows.size, np.int64)
    _best_neighbours(rows, cols, fx, fy, fnx, fny, order, shape[0], ahead, behind)
    position = np.empty(rows.size, np.int64)
    ends = np.empty(rows.size, np.int64)
    kept = _walk_chains(ahead, behind, fx, fy, fsigma, position, ends)
    bounds = [0, *ends[:kept].tolist()]
    return [position[a:b] for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
