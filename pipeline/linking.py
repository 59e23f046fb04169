"""Linking of line centre points into ordered polylines (after Steger's linking)."""

from __future__ import annotations

import numpy as np

MIN_POLYLINE_POINTS = 3
"""Chains shorter than this are isolated points or noise pairs and are dropped."""

MIN_LENGTH_SIGMAS = 2.0
"""Chains shorter than this many σ (of their own scale) are dropped: a line seen at scale σ
is at least about 2σ long; shorter chains are side lobes of bends and noise."""

MAX_NORMAL_TURN_RAD = np.deg2rad(30.0)
"""Largest angle between the normals of two linked points."""

_OFFSETS = np.array(
    [(dr, dc) for dr in range(-2, 3) for dc in range(-2, 3) if (dr, dc) != (0, 0)], np.int64
)
"""Neighbour pixels searched: the 5×5 window, so a one-pixel gap is bridged."""


def _best_neighbours(rows, cols, x, y, nx, ny, shape) -> tuple[np.ndarray, np.ndarray]:
    """Index of the cheapest neighbour ahead (+tangent) and behind (−tangent), −1 if none.

    Notes
    -----
    Steger's linking cost: distance plus the normal's turn; here also the offset across the
    line, so a parallel neighbour never wins over one ahead. A neighbour qualifies when it
    lies within 45° of the tangent and its normal turns by at most MAX_NORMAL_TURN_RAD.
    """
    count = rows.size
    index_map = np.full(shape, -1, np.int64)
    index_map[rows, cols] = np.arange(count)
    nr = rows[:, None] + _OFFSETS[None, :, 0]
    nc = cols[:, None] + _OFFSETS[None, :, 1]
    inside = (nr >= 0) & (nr < shape[0]) & (nc >= 0) & (nc < shape[1])
    j = np.where(inside, index_map[np.clip(nr, 0, shape[0] - 1), np.clip(nc, 0, shape[1] - 1)], -1)
    jj = np.maximum(j, 0)
    dx = x[jj] - x[:, None]
    dy = y[jj] - y[:, None]
    along = -ny[:, None] * dx + nx[:, None] * dy
    across = nx[:, None] * dx + ny[:, None] * dy
    turn = np.arccos(np.clip(np.abs(nx[:, None] * nx[jj] + ny[:, None] * ny[jj]), 0, 1))
    valid = (j >= 0) & (np.abs(across) < np.abs(along)) & (turn <= MAX_NORMAL_TURN_RAD)
    cost = np.hypot(dx, dy) + 2 * np.abs(across) + turn
    ahead = np.where(valid & (along > 0), cost, np.inf)
    behind = np.where(valid & (along < 0), cost, np.inf)

    def pick(costs: np.ndarray) -> np.ndarray:
        k = np.argmin(costs, axis=1)
        chosen = j[np.arange(count), k]
        return np.where(np.isfinite(costs[np.arange(count), k]), chosen, -1)

    return pick(ahead), pick(behind)


def _walk_chains(neighbours: np.ndarray) -> list[list[int]]:
    """Split a graph of degree ≤ 2 (neighbours: (K, 2), −1 = none) into ordered chains."""
    degree = (neighbours >= 0).sum(axis=1)
    visited = np.zeros(len(neighbours), bool)
    chains = []
    starts = list(np.flatnonzero(degree <= 1)) + list(np.flatnonzero(degree == 2))
    for start in starts:
        if visited[start]:
            continue
        chain = [int(start)]
        visited[start] = True
        current = start
        while True:
            nxt = [int(n) for n in neighbours[current] if n >= 0 and not visited[n]]
            if not nxt:
                break
            current = nxt[0]
            visited[current] = True
            chain.append(current)
        chains.append(chain)
    return chains


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
    ahead, behind = _best_neighbours(rows, cols, x, y, nx, ny, shape)
    count = rows.size
    picks = np.stack([ahead, behind], axis=1)
    idx = np.arange(count)
    mutual = np.zeros((count, 2), bool)
    for k in range(2):
        j = picks[:, k]
        ok = j >= 0
        jj = np.maximum(j, 0)
        mutual[:, k] = ok & ((ahead[jj] == idx) | (behind[jj] == idx))
    neighbours = np.where(mutual, picks, -1)
    chains = []
    for chain in _walk_chains(neighbours):
        if len(chain) < MIN_POLYLINE_POINTS:
            continue
        length = np.hypot(np.diff(x[chain]), np.diff(y[chain])).sum()
        if length < MIN_LENGTH_SIGMAS * sigma_px[chain].max():
            continue
        first, last = chain[0], chain[-1]
        if (x[last], y[last]) < (x[first], y[first]):
            chain.reverse()
        chains.append(np.asarray(chain, np.int64))
    return chains
