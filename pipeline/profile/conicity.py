"""Equivalent conicity of a wheelset from its rolling-radius-difference function (EN 15302).

The wheelset's kinematic (Klingel) motion on straight track, for a rolling-radius
difference Δr(y) = r_right − r_left at lateral displacement y, is

    d²y/dx² + Δr(y) / (2 e₀ r₀) = 0,

with x the distance travelled, 2e₀ the distance between the contact points and r₀ the
nominal rolling radius. For a linear Δr = 2λy it is a harmonic oscillation of wavelength
L = 2π √(e₀ r₀ / λ) (Klingel's formula). For a measured Δr the motion of amplitude ŷ is
integrated exactly and its wavelength L(ŷ) turned back into the conicity by Klingel's
formula, λₑ(ŷ) = e₀ r₀ (2π / L)²: the nonlinear evaluation of EN 15302 Annex B. Because
x scales with √(e₀ r₀), λₑ does not depend on e₀ or r₀.

Δr is a table (y_k, Δr_k) with linear interpolation between the nodes, so its potential
V(y) = ∫ Δr/2 dy is piecewise quadratic and the quarter-period integrals ∫ dy / √(2(E − V))
have closed forms on each piece (`_piece_times`): no step size, no quadrature error, and the
inverse-square-root singularities at the turning points are integrated exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.errors import PipelineError
from pipeline.imaging import GEOMETRY_FLOAT, freeze_geometry

NOMINAL_AMPLITUDE_MM = 3.0
"""EN 15302: the equivalent conicity is quoted for a wheelset amplitude ŷ = 3 mm."""
CURVE_AMPLITUDES_MM = tuple(float(a) for a in np.round(np.arange(1.0, 7.0 + 1e-9, 0.5), 2))
"""Amplitudes of the stored conicity curve, 1–7 mm in 0.5 mm steps."""
AMPLITUDE_STEP_MM = 0.01
"""Grid of `conicity_curve` (the CLI's output)."""
BISECTION_STEPS = 80
"""Bisection halvings of the turning-point bracket: 2⁻⁸⁰ of a ≤ 100 mm bracket is below the
float64 spacing of the coordinates, so the turning points are exact to rounding."""


class ConicityError(PipelineError):
    """The rolling-radius difference gives no oscillation at the asked amplitude."""


@dataclass(frozen=True, slots=True, eq=False)
class RollingRadiusDifference:
    """A wheelset's rolling-radius-difference function Δr(y), linear between nodes.

    Attributes
    ----------
    y_mm : ndarray of shape (K,), float64
        Lateral displacements of the wheelset, strictly increasing [mm].
    delta_r_mm : ndarray of shape (K,), float64
        Δr = r_right − r_left at each displacement [mm].
    """

    y_mm: np.ndarray
    delta_r_mm: np.ndarray

    def __post_init__(self) -> None:
        freeze_geometry(self, "y_mm", "delta_r_mm")
        y, d = self.y_mm, self.delta_r_mm
        if y.ndim != 1 or y.shape != d.shape or y.size < 2:
            raise ValueError(
                f"y_mm and delta_r_mm must be 1-D of equal length ≥ 2, got {y.shape}, {d.shape}"
            )
        if not (np.all(np.isfinite(y)) and np.all(np.isfinite(d))):
            raise ValueError("y_mm and delta_r_mm must be finite")
        if np.any(np.diff(y) <= 0):
            raise ValueError("y_mm must be strictly increasing")


@dataclass(frozen=True, slots=True, eq=False)
class ConicityCurve:
    """Equivalent conicity against wheelset amplitude.

    Attributes
    ----------
    amplitudes_mm : ndarray of shape (A,), float64
        Amplitudes ŷ (half the peak-to-peak lateral motion) [mm].
    conicity : ndarray of shape (A,), float64
        λₑ(ŷ) [1].
    """

    amplitudes_mm: np.ndarray
    conicity: np.ndarray

    def __post_init__(self) -> None:
        self.amplitudes_mm.flags.writeable = False
        self.conicity.flags.writeable = False


def _potential(function: RollingRadiusDifference) -> np.ndarray:
    """V at the nodes, V(y₀) = 0: the exact integral of Δr/2 of the linear interpolant."""
    y, d = function.y_mm, function.delta_r_mm
    return np.concatenate([[0.0], np.cumsum(np.diff(y) * (d[:-1] + d[1:]) / 4.0)])


def _potential_at(function: RollingRadiusDifference, nodes_v: np.ndarray, y: np.ndarray):
    """V(y) inside the table: node value plus the exact quadratic of the piece."""
    k = np.clip(np.searchsorted(function.y_mm, y, side="right") - 1, 0, function.y_mm.size - 2)
    t = y - function.y_mm[k]
    d0 = function.delta_r_mm[k]
    slope = (function.delta_r_mm[k + 1] - d0) / (function.y_mm[k + 1] - function.y_mm[k])
    return nodes_v[k] + (d0 * t + 0.5 * slope * t * t) / 2.0


def _potential_minimum(function: RollingRadiusDifference, nodes_v: np.ndarray) -> float:
    """y* of the lowest potential: the nodes and every rising zero of Δr between them."""
    y, d = function.y_mm, function.delta_r_mm
    rising = np.flatnonzero((d[:-1] < 0) & (d[1:] > 0))
    zeros = y[rising] - d[rising] * (y[rising + 1] - y[rising]) / (d[rising + 1] - d[rising])
    candidates = np.concatenate([y, zeros])
    values = np.concatenate([nodes_v, _potential_at(function, nodes_v, zeros)])
    return float(candidates[int(np.argmin(values))])


def _turning_points(function, nodes_v, amplitude_mm: np.ndarray):
    """Left turning points y₁ with V(y₁) = V(y₁ + 2ŷ), or NaN where the table is too short.

    h(y₁) = V(y₁ + 2ŷ) − V(y₁) rises with y₁ while Δr(y₁ + 2ŷ) > Δr(y₁); about the
    potential's minimum y* it is ≤ 0 at y₁ = y* − 2ŷ and ≥ 0 at y₁ = y*, so bisection on
    that bracket (clipped to the table) finds the one root.
    """
    y = function.y_mm
    y_min = _potential_minimum(function, nodes_v)
    low = np.maximum(y_min - 2 * amplitude_mm, y[0])
    high = np.minimum(y_min, y[-1] - 2 * amplitude_mm)

    def h(y1: np.ndarray) -> np.ndarray:
        return _potential_at(function, nodes_v, y1 + 2 * amplitude_mm) - _potential_at(
            function, nodes_v, y1
        )

    # Rounding of V (≈ 1e-16 of its range) must not drop a swing that ends on the table's end.
    slack = 1e-12 * (float(np.ptp(nodes_v)) + 1.0)
    supported = (low <= high) & (h(low) <= slack) & (h(np.maximum(high, low)) >= -slack)
    low, high = np.where(supported, low, np.nan), np.where(supported, high, np.nan)
    for _ in range(BISECTION_STEPS):
        middle = 0.5 * (low + high)
        right = h(middle) < 0
        low, high = np.where(right, middle, low), np.where(right, high, middle)
    return 0.5 * (low + high)


def _piece_times(g0: np.ndarray, g1: np.ndarray, length: np.ndarray, curvature: np.ndarray):
    """∫ dt / √g(t) over a piece of `length` where g = 2(E − V) is quadratic, g'' = 2·curvature.

    With S = √g₀ + √g₁ and z = a·length / S, the integral is (2/a)·arctan z for g'' < 0
    (a² = −g''/2) and (2/a)·artanh z for g'' > 0 (a² = g''/2); both tend to 2·length/S as
    a → 0. (For g = a²(h² − τ²), √gᵢ = a·h·cos φᵢ with τᵢ = h·sin φᵢ, and
    (sin φ₁ − sin φ₀)/(cos φ₀ + cos φ₁) = tan((φ₁ − φ₀)/2); likewise with sinh/cosh.)
    The form needs no difference of angles, so it keeps full precision for any a, and a
    turning point at an end (g = 0 there) costs nothing.
    """
    root_sum = np.sqrt(np.maximum(g0, 0.0)) + np.sqrt(np.maximum(g1, 0.0))
    z = np.sqrt(np.abs(curvature)) * length / root_sum
    ratio = np.ones_like(z)
    # arctan(z)/z = 1 − z²/3 + …, artanh(z)/z = 1 + z²/3 + …: the series below z = 1e-6.
    falling, rising = (curvature < 0) & (z >= 1e-6), (curvature > 0) & (z >= 1e-6)
    ratio[falling] = np.arctan(z[falling]) / z[falling]
    with np.errstate(divide="ignore"):  # z ≥ 1: g < 0 inside, an infinite time (a 2nd well)
        ratio[rising] = np.arctanh(np.minimum(z[rising], 1.0)) / z[rising]
    series = z < 1e-6
    ratio[series] = 1.0 - np.sign(curvature[series]) * z[series] ** 2 / 3.0
    return 2.0 * length / root_sum * ratio


def _half_period(function: RollingRadiusDifference, y1: float, y2: float) -> float:
    """Time from y₁ to y₂ in the scaled equation y'' = −Δr(y)/2 (x in units of √(e₀r₀))."""
    inner = function.y_mm[(function.y_mm > y1) & (function.y_mm < y2)]
    # The midpoint splits the piece that would otherwise hold both turning points (g = 0
    # at both ends, where the closed form has 0/0).
    breaks = np.unique(np.concatenate([[y1, 0.5 * (y1 + y2), y2], inner]))
    # g = 2(E − V) = −∫ Δr dy from the nearer turning point, summed piece by piece (exact
    # for linear pieces): a break close to a turning point gets its small g without the
    # cancellation of E − V(y) against the table's whole potential.
    d = np.interp(breaks, function.y_mm, function.delta_r_mm)
    pieces = np.diff(breaks) * (d[:-1] + d[1:]) / 2.0
    from_left = -np.concatenate([[0.0], np.cumsum(pieces)])
    from_right = np.concatenate([np.cumsum(pieces[::-1])[::-1], [0.0]])
    g = np.where(breaks - y1 <= y2 - breaks, from_left, from_right)
    middle = 0.5 * (breaks[:-1] + breaks[1:])
    k = np.clip(np.searchsorted(function.y_mm, middle, side="right") - 1, 0, function.y_mm.size - 2)
    slope = np.diff(function.delta_r_mm)[k] / np.diff(function.y_mm)[k]
    # g = 2(E − V) and V'' = Δr'/2, so g''/2 = −Δr'/2.
    return float(np.sum(_piece_times(g[:-1], g[1:], np.diff(breaks), -slope / 2.0)))


def equivalent_conicity(
    function: RollingRadiusDifference, amplitudes_mm: np.ndarray | float
) -> np.ndarray:
    """Equivalent conicity λₑ(ŷ) by the nonlinear evaluation of EN 15302 (Annex B).

    Parameters
    ----------
    function : RollingRadiusDifference
        Δr(y), rising with y about its zero.
    amplitudes_mm : float or ndarray of shape (A,)
        Wheelset amplitudes ŷ > 0 [mm].

    Returns
    -------
    ndarray of shape (A,), float64
        λₑ at each amplitude; NaN where the oscillation would leave the table or where Δr
        falls inside the swing.

    Raises
    ------
    ValueError
        If an amplitude is not finite and positive.
    ConicityError
        If Δr never changes sign (no restoring motion at any amplitude).

    Notes
    -----
    Turning points y₁ < y₂ with y₂ − y₁ = 2ŷ and equal potential V(y₁) = V(y₂) (energy
    conservation of y'²/2 + V(y) = E); half period T/2 = ∫ dy / √(2(E − V)) from y₁ to y₂;
    wavelength in units of √(e₀ r₀) is T, and Klingel's formula gives λₑ = (2π / T)².

    References
    ----------
    [1] EN 15302:2021, Railway applications – Wheel-rail contact geometry parameters –
        Definitions and methods for evaluation, Annex B.
    [2] W. Klingel, 'Über den Lauf der Eisenbahnwagen auf gerader Bahn', Organ für die
        Fortschritte des Eisenbahnwesens 38:113–123, 1883.

    Examples
    --------
    >>> f = RollingRadiusDifference(np.array([-10.0, 10.0]), np.array([-3.0, 3.0]))
    >>> round(float(equivalent_conicity(f, 3.0)[0]), 12)
    0.15
    """
    amplitudes = np.atleast_1d(np.asarray(amplitudes_mm, dtype=GEOMETRY_FLOAT))
    if amplitudes.ndim != 1 or not np.all(np.isfinite(amplitudes) & (amplitudes > 0)):
        raise ValueError(f"amplitudes_mm must be finite and > 0, got {amplitudes_mm!r}")
    d = function.delta_r_mm
    if not (d.min() < 0 < d.max()):
        raise ConicityError(
            f"Δr must change sign for the wheelset to oscillate, got {d.min():.4f} "
            f"to {d.max():.4f} mm"
        )
    nodes_v = _potential(function)
    y1 = _turning_points(function, nodes_v, amplitudes)
    result = np.full(amplitudes.shape, np.nan)
    for i in np.flatnonzero(np.isfinite(y1)):
        half = _half_period(function, float(y1[i]), float(y1[i] + 2 * amplitudes[i]))
        # A Δr that falls inside the swing makes a second well (E < V between the turning
        # points): no single oscillation of that amplitude, left NaN.
        if np.isfinite(half) and half > 0:
            result[i] = (np.pi / half) ** 2
    return result


def conicity_curve(
    function: RollingRadiusDifference, *, step_mm: float = AMPLITUDE_STEP_MM
) -> ConicityCurve:
    """λₑ on an amplitude grid step, 2·step, … over every amplitude the table supports.

    Parameters
    ----------
    function : RollingRadiusDifference
    step_mm : float
        Amplitude grid spacing [mm], > 0.

    Returns
    -------
    ConicityCurve
        Amplitudes whose oscillation stays inside the table, with their λₑ.
    """
    if not (np.isfinite(step_mm) and step_mm > 0):
        raise ValueError(f"step_mm must be > 0, got {step_mm}")
    span = function.y_mm[-1] - function.y_mm[0]
    grid = step_mm * np.arange(1, int(np.floor(span / 2 / step_mm + 1e-9)) + 1)
    if grid.size == 0:
        raise ConicityError(f"the Δr table spans {span:.3f} mm, less than one amplitude step")
    values = equivalent_conicity(function, grid)
    keep = np.isfinite(values)
    return ConicityCurve(np.round(grid[keep], 10), values[keep])
