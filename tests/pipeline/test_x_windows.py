"""The sparse-table window extremes equal the slices' own min and max, on every window."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.profile.x_windows import window_maxima, window_minima

values_strategy = st.lists(
    st.floats(-1e6, 1e6, allow_nan=False, width=64), min_size=1, max_size=300
).map(np.array)


@settings(max_examples=200, deadline=None)
@given(values=values_strategy, data=st.data())
def test_every_window_gets_its_own_min_and_max(values: np.ndarray, data) -> None:
    n = values.size
    bounds = st.integers(0, n)
    pairs = data.draw(st.lists(st.tuples(bounds, bounds), min_size=1, max_size=50))
    lo = np.array([min(a, b) for a, b in pairs])
    hi = np.array([max(a, b) for a, b in pairs])
    low, high = window_minima(values, lo, hi), window_maxima(values, lo, hi)
    for i, (a, b) in enumerate(zip(lo, hi, strict=True)):
        if b > a:
            assert low[i] == values[a:b].min()
            assert high[i] == values[a:b].max()
        else:
            assert low[i] == np.inf and high[i] == -np.inf


def test_the_windows_of_sorted_points_within_a_reach() -> None:
    """As `flange._top_start` uses it: the lowest z within ±0.2 mm in x of each point,
    thousands of points at one x (a back face) among them."""
    rng = np.random.default_rng(5)
    x = np.sort(np.concatenate([np.zeros(3000), rng.uniform(0, 130, 5000)]))
    z = rng.normal(0, 10, x.size)
    lo = np.searchsorted(x, x - 0.2, side="left")
    hi = np.searchsorted(x, x + 0.2, side="right")
    expected = np.array([z[a:b].min() for a, b in zip(lo, hi, strict=True)])
    np.testing.assert_array_equal(window_minima(z, lo, hi), expected)
