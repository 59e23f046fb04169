"""Equivalent conicity by EN 15302's nonlinear evaluation against closed-form cases."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from pipeline.profile.conicity import (
    ConicityError,
    RollingRadiusDifference,
    conicity_curve,
    equivalent_conicity,
)


def two_slope_conicity(inner: float, outer: float, knee_mm: float, amplitude_mm: float) -> float:
    """λₑ of Δr = 2·inner·y for |y| ≤ knee, slope 2·outer beyond, by solving the motion in
    closed form: harmonic with ω² = inner inside, shifted harmonic with ω² = outer outside.

    Both arcs are written as arctan2 of the amplitude's excess d over the knee: the
    textbook arcsin(knee / R) and arccos(shift / (d + shift)) take arguments that round to
    within 1e-16 of 1 for an amplitude just past the knee, where their slope is 1e8 and they
    lose half their digits (inner 0.25, outer 0.125, knee 0.5, amplitude 0.5 + 1 ulp: 2.7e-8
    off). Against this form in 80-bit arithmetic, over 2,000 draws (half of them 1e-16 to
    10 mm past the knee): this form within 7e-16, `equivalent_conicity` within 1.3e-12."""
    if amplitude_mm <= knee_mm:
        return inner
    excess = amplitude_mm - knee_mm
    # R² − knee² with R the amplitude of the inner harmonic through the same energy.
    beyond_knee = 2 * knee_mm * excess + outer / inner * excess**2
    inside = np.arctan2(knee_mm, np.sqrt(beyond_knee)) / np.sqrt(inner)
    shift = inner * knee_mm / outer
    outside = np.arctan2(np.sqrt(excess * (excess + 2 * shift)), shift) / np.sqrt(outer)
    return float((2 * np.pi / (4 * (inside + outside))) ** 2)


def two_slope(inner: float, outer: float, knee_mm: float, nodes: np.ndarray):
    y = np.unique(np.concatenate([nodes, [-knee_mm, knee_mm]]))
    beyond = np.sign(y) * (2 * inner * knee_mm + 2 * outer * (np.abs(y) - knee_mm))
    return RollingRadiusDifference(y, np.where(np.abs(y) <= knee_mm, 2 * inner * y, beyond))


@settings(max_examples=60, deadline=None)
@given(
    conicity=st.floats(0.01, 1.0),
    offset_mm=st.floats(-0.5, 0.5),
    nodes=st.integers(2, 400),
    amplitude_mm=st.floats(0.005, 7.0),
)
def test_linear_delta_r_gives_its_conicity_at_every_amplitude(
    conicity, offset_mm, nodes, amplitude_mm
):
    # Δr = 2λ(y − y₀) on any node spacing: a harmonic motion about y₀ of conicity λ.
    y = np.linspace(-10.0, 10.0, nodes) + 0.37 * np.sin(np.arange(nodes)) / nodes
    function = RollingRadiusDifference(y, 2 * conicity * (y - offset_mm))
    value = equivalent_conicity(function, amplitude_mm)[0]
    assert value == pytest.approx(conicity, rel=1e-9)


@settings(max_examples=60, deadline=None)
@example(inner=0.25, outer=0.125, knee_mm=0.5, amplitude_mm=0.5000000000000001, extra_nodes=[])
@given(
    inner=st.floats(0.02, 0.3),
    outer=st.floats(0.05, 1.0),
    knee_mm=st.floats(0.5, 4.0),
    amplitude_mm=st.floats(0.1, 9.0),
    extra_nodes=st.lists(st.floats(-9.9, 9.9), max_size=30),
)
def test_two_slope_delta_r_matches_its_closed_form(
    inner, outer, knee_mm, amplitude_mm, extra_nodes
):
    # Extra nodes on the straight pieces change nothing: the evaluation is exact per piece.
    nodes = np.concatenate([[-10.0, 10.0], extra_nodes])
    function = two_slope(inner, outer, knee_mm, nodes)
    value = equivalent_conicity(function, amplitude_mm)[0]
    expected = two_slope_conicity(inner, outer, knee_mm, amplitude_mm)
    assert value == pytest.approx(expected, rel=1e-9)


@settings(max_examples=40, deadline=None)
@given(
    coefficients=st.tuples(st.floats(0.02, 0.5), st.floats(-1.0, 1.0), st.floats(0.0, 0.01)),
    shift_mm=st.floats(-2.0, 2.0),
    gain=st.floats(0.1, 10.0),
    amplitude_mm=st.floats(0.2, 6.0),
)
def test_conicity_follows_shifts_mirrors_and_gain_of_delta_r(
    coefficients, shift_mm, gain, amplitude_mm
):
    a, ratio, c = coefficients
    b = ratio * a / 10  # |b| < a/9 keeps Δr' = 2a + 2by + 3cy² > 0 on ±9 mm: one well
    y = np.linspace(-9.0, 9.0, 181)
    base = RollingRadiusDifference(y, 2 * a * y + b * y**2 + c * y**3)
    value = equivalent_conicity(base, amplitude_mm)[0]
    shifted = RollingRadiusDifference(y + shift_mm, base.delta_r_mm)
    mirrored = RollingRadiusDifference(-y[::-1], -base.delta_r_mm[::-1])
    scaled = RollingRadiusDifference(y, gain * base.delta_r_mm)
    assert equivalent_conicity(shifted, amplitude_mm)[0] == pytest.approx(value, rel=1e-9)
    assert equivalent_conicity(mirrored, amplitude_mm)[0] == pytest.approx(value, rel=1e-9)
    assert equivalent_conicity(scaled, amplitude_mm)[0] == pytest.approx(gain * value, rel=1e-9)


def test_duffing_delta_r_matches_an_ode_integration():
    # Δr/2 = 0.15y + 0.01y³ sampled finely: against a direct RK45 period at ŷ = 3 mm.
    from scipy.integrate import solve_ivp

    y = np.linspace(-10, 10, 20001)
    function = RollingRadiusDifference(y, 0.3 * y + 0.02 * y**3)

    def crossing(_t, state):
        return state[1]

    crossing.direction = 1.0
    motion = solve_ivp(
        lambda _t, s: [s[1], -(0.15 * s[0] + 0.01 * s[0] ** 3)],
        (0, 100),
        [-3.0, 0.0],
        events=crossing,
        rtol=1e-12,
        atol=1e-12,
    )
    period = motion.t_events[0][1] - motion.t_events[0][0]
    expected = (2 * np.pi / period) ** 2
    assert equivalent_conicity(function, 3.0)[0] == pytest.approx(expected, rel=1e-6)


def test_curve_covers_the_amplitudes_the_table_supports():
    y = np.array([-4.0, 6.0])
    curve = conicity_curve(RollingRadiusDifference(y, 0.4 * (y - 1.0)))
    # About the zero at y = 1, the swing fits between −4 and 6: ŷ ≤ 5 mm.
    assert curve.amplitudes_mm[0] == 0.01
    assert curve.amplitudes_mm[-1] == 5.0
    assert np.allclose(np.diff(curve.amplitudes_mm), 0.01)
    assert np.allclose(curve.conicity, 0.2, rtol=1e-12)


def test_amplitude_beyond_the_table_is_nan():
    function = RollingRadiusDifference(np.array([-3.0, 3.0]), np.array([-1.0, 1.0]))
    values = equivalent_conicity(function, [2.0, 3.0, 3.5])
    assert values[:2] == pytest.approx([1 / 6, 1 / 6])
    assert np.isnan(values[2])


def test_delta_r_without_a_zero_is_an_error():
    function = RollingRadiusDifference(np.array([-3.0, 3.0]), np.array([0.1, 1.0]))
    with pytest.raises(ConicityError, match="must change sign"):
        equivalent_conicity(function, 1.0)


@pytest.mark.parametrize(
    ("y", "d", "match"),
    [
        ([0.0, 0.0], [0.0, 1.0], "strictly increasing"),
        ([0.0], [0.0], "equal length ≥ 2"),
        ([0.0, np.nan], [0.0, 1.0], "finite"),
    ],
)
def test_bad_tables_are_rejected(y, d, match):
    with pytest.raises(ValueError, match=match):
        RollingRadiusDifference(np.array(y), np.array(d))


def test_amplitudes_must_be_positive():
    function = RollingRadiusDifference(np.array([-3.0, 3.0]), np.array([-1.0, 1.0]))
    with pytest.raises(ValueError, match="amplitudes_mm must be finite and > 0"):
        equivalent_conicity(function, [1.0, 0.0])
