"""The lowest or highest z of the profile points within an x window: the range queries of
fusion's and the flange top's single-curve tests (`fusion._doubled`, `flange._top_start`).

A sparse table (the minimum of every run of 2^j sorted points) answers each window with
two reads, exactly: K·log2(K) work, where a loop over the windows costs the sum of their
lengths, which on a fused profile's back face (thousands of points at x ≈ 0 within
±0.2 mm of each other) is K² (3-frame field wheels: 88 ms of the flange top's start).
"""

from __future__ import annotations

import numpy as np


def window_minima(values: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """min(values[lo[i]:hi[i]]) for each i, exactly; +inf where the slice is empty.

    Parameters
    ----------
    values : ndarray of shape (K,), float
        Values in the order the slices index (e.g. z of points sorted by x) [any unit].
    lo, hi : ndarray of int, same shape
        Slice bounds, 0 ≤ lo, hi ≤ K.

    Returns
    -------
    ndarray, float64, the shape of `lo`
    """
    values = np.asarray(values, np.float64)
    lo, hi = np.asarray(lo, np.int64), np.asarray(hi, np.int64)
    out = np.full(lo.shape, np.inf)
    length = hi - lo
    some = length > 0
    if not np.any(some):
        return out
    # level[j][i] = min(values[i : i + 2^j])
    levels = [values]
    span = 1
    while 2 * span <= int(length.max()):
        previous = levels[-1]
        levels.append(np.minimum(previous[:-span], previous[span:]))
        span *= 2
    # floor(log2(length)): frexp gives length = m·2^e with m in [0.5, 1), exact for ints
    power = np.frexp(length[some].astype(np.float64))[1] - 1
    first, last = lo[some], hi[some]
    found = np.empty(first.size)
    for j in np.unique(power):
        at = power == j
        level = levels[int(j)]
        found[at] = np.minimum(level[first[at]], level[last[at] - (1 << int(j))])
    out[some] = found
    return out


def window_maxima(values: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """max(values[lo[i]:hi[i]]) for each i, exactly; −inf where the slice is empty (see
    `window_minima`)."""
    return -window_minima(-np.asarray(values, np.float64), lo, hi)
