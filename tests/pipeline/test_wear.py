"""Wear fits against known wear: simulated histories with a true rate, noise and bad passes."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.profile.wear import TooFewPointsError, fit_wear, limit_crossing

TRUE_RATE_MM_PER_DAY = 0.012
"""Flange height growth of a wheel whose tread wears 4.4 mm a year."""
START_MM, LIMIT_MM = 30.0, 36.0
TRUE_CROSSING_DAYS = (LIMIT_MM - START_MM) / TRUE_RATE_MM_PER_DAY


def history(rng: np.random.Generator, passes: int, noise_mm: float, bad: int = 0):
    days = np.sort(rng.uniform(0, 200, passes))
    values = START_MM + TRUE_RATE_MM_PER_DAY * days + rng.normal(0, noise_mm, passes)
    values[rng.choice(passes, bad, replace=False)] += 3.0  # doubtful measurements
    return days, values


def test_rate_and_limit_date_of_a_noisy_history_with_bad_passes_are_found() -> None:
    rng = np.random.default_rng(17)
    hits = 0
    errors, least_squares = [], []
    for _ in range(200):
        days, values = history(rng, passes=20, noise_mm=0.1, bad=2)
        fit = fit_wear(days, values)
        least_squares.append(np.polyfit(days, values, 1)[0] / TRUE_RATE_MM_PER_DAY - 1)
        crossing = limit_crossing(fit, LIMIT_MM)
        errors.append(fit.rate / TRUE_RATE_MM_PER_DAY - 1)
        assert crossing.x is not None and crossing.x_earliest is not None
        if crossing.x_earliest <= TRUE_CROSSING_DAYS <= (crossing.x_latest or np.inf):
            hits += 1
    # two 3-mm outliers in twenty: least squares is off by ~20 %, Theil–Sen stays near truth
    assert np.median(np.abs(errors)) < 0.05, np.median(np.abs(errors))
    assert max(np.abs(errors)) < 0.3
    assert np.median(np.abs(least_squares)) > 0.15
    # the 90 % slope interval holds the true date in 87 % of clean histories and 84 % of
    # these (400 each): the lines pivot on the median point, whose own spread is left out
    assert hits / 200 >= 0.78, hits


def test_exact_line_gives_the_exact_rate_and_crossing() -> None:
    days = np.array([0.0, 30.0, 60.0, 90.0])
    fit = fit_wear(days, START_MM + TRUE_RATE_MM_PER_DAY * days)
    crossing = limit_crossing(fit, LIMIT_MM)
    assert fit.rate == pytest.approx(TRUE_RATE_MM_PER_DAY, rel=1e-12)
    assert crossing.x == pytest.approx(TRUE_CROSSING_DAYS, rel=1e-9)
    assert crossing.x_earliest == pytest.approx(TRUE_CROSSING_DAYS, rel=1e-9)


def test_a_lower_limit_is_reached_by_a_falling_parameter_and_never_by_a_rising_one() -> None:
    days = np.array([0.0, 50.0, 100.0, 150.0, 200.0])
    falling = fit_wear(days, 32.0 - 0.02 * days)  # flange thickness wearing thin
    assert limit_crossing(falling, 22.0).x == pytest.approx(500.0)
    rising = fit_wear(days, 32.0 + 0.02 * days)
    assert limit_crossing(rising, 22.0).x is None


def test_a_flat_history_never_reaches_the_limit() -> None:
    fit = fit_wear(np.array([0.0, 1.0, 2.0, 3.0]), np.full(4, 30.0))
    crossing = limit_crossing(fit, LIMIT_MM)
    assert fit.rate == 0.0
    assert crossing.x is None and crossing.x_latest is None


@pytest.mark.parametrize(
    ("x", "values", "match"),
    [
        ([0.0, 1.0], [1.0, 2.0], "needs 3 passes"),
        ([5.0, 5.0, 5.0], [1.0, 2.0, 3.0], "2 or more distinct"),
        ([0.0, 1.0, np.nan, 3.0], [1.0, 2.0, 3.0, np.nan], "got 2 at"),
    ],
)
def test_too_few_passes_are_refused_in_words(x, values, match) -> None:
    with pytest.raises(TooFewPointsError, match=match):
        fit_wear(np.array(x), np.array(values))


def test_mismatched_inputs_are_refused() -> None:
    with pytest.raises(ValueError, match="1-D of one length"):
        fit_wear(np.zeros(3), np.zeros(4))
