"""Wear trends: a robust straight-line fit of one wheel parameter over its passes, and where
the line reaches a limit.

The fit is Theil–Sen (the median of pairwise slopes): one bad pass among many moves it
little, where least squares would follow it, and a wheel's history carries such passes
(a doubtful measurement, a pass before a re-profiling). The slope's confidence interval
is the rank-based one of [1]; the limit is reached, at the interval's ends, by lines
through the data's median point with those slopes.

References
----------
[1] P. K. Sen, "Estimates of the regression coefficient based on Kendall's tau", J. Am.
    Stat. Assoc. 63(324):1379-1389, 1968. doi:10.1080/01621459.1968.10480934
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import theilslopes

from pipeline.errors import PipelineError

MIN_POINTS = 3
"""Fewest passes that give a slope with an interval (two points give no spread)."""
CONFIDENCE = 0.90
"""Two-sided confidence of the slope interval."""


class TooFewPointsError(PipelineError):
    """Fewer distinct passes than a wear fit needs."""


@dataclass(frozen=True, slots=True, eq=False)
class WearFit:
    """A straight line v = intercept + rate · x with the rate's confidence interval.

    x is in the unit the caller chose (days, 1000 km); rates are in value units per x unit.
    """

    rate: float
    intercept: float
    rate_low: float
    rate_high: float
    x_median: float
    value_median: float
    points: int

    def value_at(self, x: float) -> float:
        """The fitted value at x."""
        return self.intercept + self.rate * x


@dataclass(frozen=True, slots=True, eq=False)
class LimitCrossing:
    """Where a wear line reaches a limit: x of the fit, and the earliest and latest x of
    the slope interval (None where that line never reaches it, moving away or flat)."""

    x: float | None
    x_earliest: float | None
    x_latest: float | None


def fit_wear(x: np.ndarray, values: np.ndarray) -> WearFit:
    """Fit a robust straight line to a parameter over its passes.

    Parameters
    ----------
    x : ndarray of shape (K,), float
        Where each pass was: days (or 1000 km) since any fixed origin.
    values : ndarray of shape (K,), float
        The parameter at each pass [mm]; non-finite entries are left out.

    Returns
    -------
    WearFit

    Raises
    ------
    ValueError
        If x and values differ in shape or are not 1-D.
    TooFewPointsError
        If fewer than 3 finite points at 2 or more distinct x remain.

    Examples
    --------
    >>> fit = fit_wear(np.array([0.0, 10, 20, 30]), np.array([28.0, 28.1, 28.2, 28.3]))
    >>> round(fit.rate, 6)
    0.01
    """
    x_arr = np.asarray(x, dtype=np.float64)
    v_arr = np.asarray(values, dtype=np.float64)
    if x_arr.ndim != 1 or x_arr.shape != v_arr.shape:
        raise ValueError(
            f"x and values must be 1-D of one length, got {x_arr.shape} and {v_arr.shape}"
        )
    keep = np.isfinite(x_arr) & np.isfinite(v_arr)
    x_arr, v_arr = x_arr[keep], v_arr[keep]
    if x_arr.size < MIN_POINTS or np.unique(x_arr).size < 2:
        raise TooFewPointsError(
            f"a wear fit needs {MIN_POINTS} passes at 2 or more distinct times, "
            f"got {x_arr.size} at {np.unique(x_arr).size}"
        )
    rate, intercept, low, high = theilslopes(v_arr, x_arr, alpha=CONFIDENCE)
    return WearFit(
        rate=float(rate),
        intercept=float(intercept),
        rate_low=float(low),
        rate_high=float(high),
        x_median=float(np.median(x_arr)),
        value_median=float(np.median(v_arr)),
        points=int(x_arr.size),
    )


def _reach(x0: float, v0: float, rate: float, limit: float) -> float | None:
    # the line through (x0, v0) with this rate meets the limit ahead only when moving to it
    if rate == 0 or (limit - v0) / rate < 0:
        return None
    return x0 + (limit - v0) / rate


def limit_crossing(fit: WearFit, limit: float) -> LimitCrossing:
    """Where the fitted line, and the lines of its slope interval, reach `limit`.

    Parameters
    ----------
    fit : WearFit
    limit : float
        The limit value, in the fit's value unit [mm].

    Returns
    -------
    LimitCrossing
        x of each crossing in the fit's x unit; the earliest comes from the steeper slope
        towards the limit. A line moving away from the limit, or one already beyond it at
        the data's median point, gives None.
    """
    at = _reach(fit.x_median, fit.value_at(fit.x_median), fit.rate, limit)
    ends = [
        _reach(fit.x_median, fit.value_median, rate, limit)
        for rate in (fit.rate_low, fit.rate_high)
    ]
    found = [e for e in ends if e is not None]
    earliest = min(found) if found else None
    # a slope interval that includes "not towards the limit" has no latest crossing
    latest = max(found) if len(found) == 2 else None
    return LimitCrossing(at, earliest, latest)
