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


@kernel
def _best_neighbours(rows, cols, x, y, nx, ny, order, row_start, ahead, behind) -> None:
    """Index of the cheapest neighbour ahead (+tangent) and behind (−tangent), −1 if none.

    `order` sorts the points by (row, col) and `row_start[r]` is where row r begins in it.

    Notes
    -----
    Steger's linking cost: distance plus the normal's turn; here also the offset across the
    line, so a parallel neighbour never wins over one ahead. A neighbour qualifies when it
    lies within 45° of the tangent and its normal turns by at most MAX_NORMAL_TURN_RAD.
    Neighbours are visited row by row, column by column, and the first of equal costs wins.
    """
    sorted_cols = cols[order]
    height = row_start.size - 1
    for i in range(rows.size):
        best_ahead = np.inf
        best_behind = np.inf
        ahead[i] = -1
        behind[i] = -1
        for dr in range(-NEIGHBOUR_REACH_PX, NEIGHBOUR_REACH_PX + 1):
            r = rows[i] + dr
            if r < 0 or r >= height:
                continue
            lo, hi = row_start[r], row_start[r + 1]
            p = lo + np.searchsorted(sorted_cols[lo:hi], cols[i] - NEIGHBOUR_REACH_PX)
            while p < hi and sorted_cols[p] <= cols[i] + NEIGHBOUR_REACH_PX:
                j = order[p]
                p += 1
                if j == i:
                    continue
                dx = x[j] - x[i]
                dy = y[j] - y[i]
                along = -ny[i] * dx + nx[i] * dy
                across = nx[i] * dx + ny[i] * dy
                turn = np.arccos(min(abs(nx[i] * nx[j] + ny[i] * ny[j]), 1.0))
                if abs(across) >= abs(along) or turn > MAX_NORMAL_TURN_RAD:
                    continue
                cost = np.hypot(dx, dy) + 2 * abs(across) + turn
                if along > 0 and cost < best_ahead:
                    best_ahead = cost
                    ahead[i] = j
                elif along < 0 and cost < best_behind:
                    best_behind = cost
                    behind[i] = j


@kernel
def _walk_chains(ahead, behind, chain_of, position) -> None:
    """Split the mutual links into ordered chains: `position` lists the points chain by chain,
    `chain_of[k]` is the chain of the k-th listed point.

    A link i–j is kept when each picked the other (ahead or behind), so every point has at
    most two links. Chains start at the ends (degree ≤ 1) in index order, then closed loops.
    """
    count = ahead.size
    links = np.full((count, 2), -1, np.int64)
    for i in range(count):
        for k, j in enumerate((ahead[i], behind[i])):
            if j >= 0 and (ahead[j] == i or behind[j] == i):
                links[i, k] = j
    visited = np.zeros(count, np.bool_)
    listed = 0
    chain = 0
    for degree_limit in (1, 2):
        for start in range(count):
            degree = (links[start, 0] >= 0) + (links[start, 1] >= 0)
            if visited[start] or degree > degree_limit:
                continue
            current = start
            while current >= 0:
                visited[current] = True
                position[listed] = current
                chain_of[listed] = chain
                listed += 1
                following = -1
                for j in links[current]:
                    if j >= 0 and not visited[j]:
                        following = j
                        break
                current = following
            chain += 1


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
    order = np.lexsort((cols, rows))
    row_start = np.searchsorted(rows[order], np.arange(shape[0] + 1))
    ahead = np.empty(rows.size, np.int64)
    behind = np.empty(rows.size, np.int64)
    fx, fy, fnx, fny = (np.ascontiguousarray(a, np.float64) for a in (x, y, nx, ny))
    _best_neighbours(rows, cols, fx, fy, fnx, fny, order, row_start, ahead, behind)
    chain_of = np.empty(rows.size, np.int64)
    position = np.empty(rows.size, np.int64)
    _walk_chains(ahead, behind, chain_of, position)
    bounds = np.flatnonzero(np.diff(chain_of)) + 1
    chains = []
    for chain in np.split(position, bounds):
        if chain.size < MIN_POLYLINE_POINTS:
            continue
        length = np.hypot(np.diff(x[chain]), np.diff(y[chain])).sum()
        if length < MIN_LENGTH_SIGMAS * sigma_px[chain].max():
            continue
        first, last = chain[0], chain[-1]
        if (x[last], y[last]) < (x[first], y[first]):
            chain = chain[::-1].copy()
        chains.append(chain)
    return chains
