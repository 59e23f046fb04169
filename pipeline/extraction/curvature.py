"""Removal of the curvature bias of Gaussian-smoothed line centres along linked polylines."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.extraction.fast_exp import fast_exp
from pipeline.extraction.normal_equations import solve_symmetric3
from pipeline.jit import kernel

WINDOW_SIGMAS = 2.0
"""Half-width of the fitting window along the polyline, in units of the point's σ."""

FIT_ROUNDS = 3
"""Curvature fits per polyline; each round fits the points corrected by the previous one."""

SUPPORT_FACTORS = (1.0, 1.5, 2.0, 3.0)
"""Window scales tried by the scatter-chosen support, in units of the point's σ."""
LEPSKI_Z = 2.5
"""A wider window is accepted while its fit stays within 2.5 standard errors of each
narrower one's."""

MATCHED_CORRELATION_PX = 1.0
"""Centres refined on their own normal (`normal_fit`) read the frame on lines about 1 px
apart: their errors are independent this far apart along the stripe (those at σB are
correlated over ≈ 2σB)."""

MIN_CORRELATION_POINTS = 8
"""Least centres of a polyline whose error correlation is measured (`_error_correlation`)."""

MIN_HALF_WINDOW_PX = 4.0
"""Least half-width of the fitting window [px]: enough points for a stable quadratic."""


BLOCK_POINTS = 128
"""Points fitted together: each window offset is one loop across them (it vectorises), and
their sums stay in the L1 cache."""

_ROWS = tuple(np.uint64(k * BLOCK_POINTS) for k in range(9))
"""Offsets of the rows of `_fit_curvatures`' sums, unsigned (constant, so no alias checks)."""


@kernel
def _any_inside(x, y, nx, ny, half, lo, hi, b0, b1, offset) -> bool:
    """Whether the window of any point b0…b1 − 1 holds its neighbour `offset` indices on,
    with a 1 µpx margin against rounding."""
    any_inside = False
    for i in range(max(b0, lo - offset), min(b1, hi - offset)):
        at, to = np.uint64(i), np.uint64(i + offset)
        u = -ny[at] * (x[to] - x[at]) + nx[at] * (y[to] - y[at])
        any_inside |= abs(u) <= half[at] + 1e-6
    return any_inside


@kernel
def _window_offsets(x, y, nx, ny, half, lo, hi, b0, b1, most) -> tuple[int, int]:
    """Least and greatest offset j − i (within ±most) that any window of points b0…b1 − 1
    holds: a cheap pass that spares the fit the rest. Each is searched from its end of the
    range inwards, so only the offsets beyond the windows are tried (most is 1.5× a
    window's half-width in points, and ±most + 1 (none held) when no window holds one)."""
    first, last = most + 1, -most - 1
    for offset in range(-most, most + 1):
        if _any_inside(x, y, nx, ny, half, lo, hi, b0, b1, offset):
            first = offset
            break
    for offset in range(most, first - 1, -1):
        if _any_inside(x, y, nx, ny, half, lo, hi, b0, b1, offset):
            last = offset
            break
    return first, last


@kernel
def _fit_curvatures(x, y, nx, ny, sigma, bounds, kappa, fit_offset, count) -> None:
    """κ of each polyline points[bounds[c]:bounds[c + 1]] (see `local_curvature`), the fitted
    curve's offset a from each point along n, and the points in each window.

    Blocks of BLOCK_POINTS points share one loop over the offsets j − i of their window:
    across the block it vectorises, and each point's sums still run over j in order. Points
    outside a window add weight 0. Indices are unsigned (no negative-index wrap-around
    test), and the sums share one array, so the compiler makes few alias checks.
    """
    half = np.empty(x.size)
    reach = np.empty(x.size, np.int64)
    exponent = np.empty(x.size)  # −1/(2σ²): the weight's exponent is u²·that, no division
    for i in range(x.size):
        exponent[i] = -0.5 / (sigma[i] * sigma[i])
        half[i] = max(WINDOW_SIGMAS * sigma[i], MIN_HALF_WINDOW_PX)
        # Centres are at least 1/1.5 px apart along a chain, so the window's points lie
        # within this many indices.
        reach[i] = int(np.ceil(half[i] * 1.5)) + 1
    sums = np.empty(9 * BLOCK_POINTS)  # rows: Σw·uᵏ (k = 0…4), Σw·uᵏ·v (k = 0…2), count
    for c in range(bounds.size - 1):
        lo, hi = bounds[c], bounds[c + 1]
        for b0 in range(lo, hi, BLOCK_POINTS):
            b1 = min(b0 + BLOCK_POINTS, hi)
            sums[:] = 0.0
            most = reach[b0:b1].max()
            first, last = _window_offsets(x, y, nx, ny, half, lo, hi, b0, b1, most)
            for offset in range(first, last + 1):
                for i in range(max(b0, lo - offset), min(b1, hi - offset)):
                    at, to = np.uint64(i), np.uint64(i + offset)
                    dx = x[to] - x[at]
                    dy = y[to] - y[at]
                    u = -ny[at] * dx + nx[at] * dy
                    v = nx[at] * dx + ny[at] * dy
                    inside = (abs(u) <= half[at]) & (abs(offset) <= reach[at])
                    w = fast_exp(u * u * exponent[at])  # branch-free: weight 0 outside
                    w = w if inside else 0.0
                    wu = w * u
                    wuu = wu * u
                    m = np.uint64(i - b0)
                    sums[m] += w
                    sums[m + _ROWS[1]] += wu
                    sums[m + _ROWS[2]] += wuu
                    sums[m + _ROWS[3]] += wuu * u
                    sums[m + _ROWS[4]] += wuu * u * u
                    sums[m + _ROWS[5]] += w * v
                    sums[m + _ROWS[6]] += wu * v
                    sums[m + _ROWS[7]] += wuu * v
                    sums[m + _ROWS[8]] += 1.0 if inside else 0.0
            for i in range(b0, b1):
                s0, s1, s2, s3, s4, t0, t1, t2, inside = sums[i - b0 :: BLOCK_POINTS]
                count[i] = inside
                if inside < 5:
                    kappa[i] = 0.0
                    fit_offset[i] = 0.0
                    continue
                # Normal equations of v = a + b·u + (κ/2)·u² with the basis (1, u, u²/2).
                fit_offset[i], _, kappa[i] = solve_symmetric3(
                    s0, s1, 0.5 * s2, s2, 0.5 * s3, 0.25 * s4, t0, t1, 0.5 * t2
                )


@kernel
def _remove_bias(x, y, nx, ny, sigma, window_sigma, bounds, rounds, x_out, y_out) -> None:
    """`rounds` fits of κ on (x_out, y_out) with windows of `window_sigma`, each moving the
    points to (x, y) − σ²κ/2·n."""
    kappa = np.empty(x.size)
    offset = np.empty(x.size)
    count = np.empty(x.size)
    for _ in range(rounds):
        _fit_curvatures(x_out, y_out, nx, ny, window_sigma, bounds, kappa, offset, count)
        for i in range(x.size):
            shift = 0.5 * sigma[i] ** 2 * kappa[i]
            x_out[i] = x[i] - shift * nx[i]
            y_out[i] = y[i] - shift * ny[i]


def local_curvature(x: np.ndarray, y: np.ndarray, nx, ny, sigma: np.ndarray) -> np.ndarray:
    """Signed curvature [1/px] of one ordered polyline at each point, positive towards +n.

    Parameters
    ----------
    x, y : ndarray of shape (K,)
        Ordered points [px].
    nx, ny : ndarray of shape (K,)
        Unit normals.
    sigma : ndarray of shape (K,)
        Scale of each point [px]; it sets the Gaussian weight of the fit (std σ along the
        line, window ±max(2σ, 4 px)), the stretch over which smoothing averages the curvature.

    Returns
    -------
    ndarray of shape (K,), float64
        κ from the weighted fit v = a + b·u + (κ/2)·u² in each point's (tangent u, normal v)
        frame; 0 where fewer than 5 points are in the window.
    """
    out = np.empty(np.size(x))
    fx, fy, fnx, fny, fsigma = (np.ascontiguousarray(a, np.float64) for a in (x, y, nx, ny, sigma))
    spare = np.empty((2, out.size))
    _fit_curvatures(fx, fy, fnx, fny, fsigma, np.array([0, out.size]), out, *spare)
    return out


@kernel
def _lepski(offsets, counts, scatter, correlation, factors):
    """Per point, the widest of the windows `factors` (F,) whose fit (`offsets` (F, K), on
    `counts` points) and those of every narrower one pass Lepski's test, all narrower ones
    passing too (see `_scatter_windows`): that factor and its fit, (K,) each."""
    chosen = np.empty(offsets.shape[1])
    fitted = np.empty(offsets.shape[1])
    for i in range(offsets.shape[1]):
        chosen[i], fitted[i] = factors[0], offsets[0, i]
        admissible = True
        for k in range(1, factors.size):
            for j in range(k):
                count = np.maximum(counts[j, i], 1.0)
                independent = np.maximum(count / np.maximum(correlation[i], 1.0), 1.0)
                limit = LEPSKI_Z * scatter[i] * np.sqrt(2.0 / independent)
                admissible &= np.abs(offsets[k, i] - offsets[j, i]) <= limit
            if admissible:
                chosen[i], fitted[i] = factors[k], offsets[k, i]
    return chosen, fitted


def _scatter_windows(
    x, y, nx, ny, sigma, bounds, correlation_px=None, first=None, *, measured=False
) -> tuple[np.ndarray, np.ndarray]:
    """Window scale per point chosen from the measured centre scatter σl (Lepski's rule),
    and each point's fitted offset along n [px] on its chosen window.

    `correlation_px` (K,) is how far apart along the stripe the centres' errors are
    independent [px]; default 2σ. `first`, when given, is the (offset, count, scatter) of
    the fits at the first window (SUPPORT_FACTORS[0] × σ) of these points, already made
    (`LocalFits`, σl included: the spread of those same offsets). With
    `measured`, each polyline's correlation is at least the one its centres show
    (`_error_correlation`): texture under the stripe moves neighbouring centres together.

    σl of each polyline is the robust spread (1.4826 × MAD) of the points about their local
    fits at the base window. Each point's window grows through `SUPPORT_FACTORS` × σ while
    the fitted curve stays within LEPSKI_Z·σl·√(2/N) of its fit on every smaller window
    (N the independent centres in that window: the points over the `correlation_px` the
    smoothing correlates them along the stripe): wider where texture makes the centres scatter and
    the stripe is smooth, no wider where its shape changes. A point's fit depends only on
    its own window, so the fit on the chosen window is the one made while choosing it.
    """
    offsets, counts = np.empty((2, len(SUPPORT_FACTORS), x.size))
    for f, factor in enumerate(SUPPORT_FACTORS):
        if first is not None and f == 0:
            offsets[0], counts[0] = first[0], first[1]
        else:
            kappa = np.empty(x.size)
            _fit_curvatures(x, y, nx, ny, sigma * factor, bounds, kappa, offsets[f], counts[f])
    scatter = _spread(offsets[0], bounds) if first is None else first[2]
    correlation = 2.0 * sigma if correlation_px is None else correlation_px
    if measured:
        correlation = np.maximum(correlation, _error_correlation(offsets[0], bounds))
    factors = np.array(SUPPORT_FACTORS)
    chosen, fitted = _lepski(offsets, counts, scatter, np.ascontiguousarray(correlation), factors)
    return sigma * chosen, fitted


def remove_curvature_bias(
    x: np.ndarray,
    y: np.ndarray,
    nx,
    ny,
    sigma,
    polylines: tuple[np.ndarray, ...],
    *,
    scatter_support: bool = False,
    rounds: int = FIT_ROUNDS,
) -> tuple[np.ndarray, np.ndarray]:
    """Move each centre by σ²κ/2 away from its centre of curvature.

    Parameters
    ----------
    x, y, nx, ny, sigma : ndarray of shape (K,)
        Centres [px], unit normals and scales [px].
    polylines : tuple of ndarray of int
        Disjoint ordered index arrays into the points.
    scatter_support : bool
        Choose each point's fitting window from the measured centre scatter σl (paper
        eq. (2)) instead of σ alone (`_scatter_windows`), and put the point on its fitted
        curve: texture-robust centres, averaged along the stripe over the support the
        scatter calls for.
    rounds : int
        Fits of κ, each on the points the previous one corrected (FIT_ROUNDS).

    Returns
    -------
    x, y : ndarray of shape (K,), float64
        Corrected centres; points in no polyline are unchanged.

    Notes
    -----
    Smoothing a line of radius R with a Gaussian of scale σ moves the maximum of its profile
    towards the centre of curvature by σ²/(2R) to first order, for any symmetric profile:
    the blurred profile of a ring is ∝ r^(−1/2)·exp(−(r−R)²/2σt²)·(1 + (r−R)s²/(2Rσt²)), whose
    maximum sits at r = R − σ²/(2R). At σ = 7.5 px and R = 100 px that is 0.28 px.
    κ is fitted again on the corrected points (FIT_ROUNDS in all): where neighbouring points
    were found at different scales their biases differ, and the raw points show a step
    that the first fit mistakes for curvature.
    """
    x_out = x.astype(np.float64, copy=True)
    y_out = y.astype(np.float64, copy=True)
    if not polylines:
        return x_out, y_out
    order, bounds, fx, fy, fnx, fny, fsigma = _chained(polylines, x, y, nx, ny, sigma)
    window = _scatter_windows(fx, fy, fnx, fny, fsigma, bounds)[0] if scatter_support else fsigma
    cx, cy = fx.copy(), fy.copy()
    _remove_bias(fx, fy, fnx, fny, fsigma, window, bounds, rounds, cx, cy)
    if scatter_support:
        offset = _fitted_offsets(cx, cy, fnx, fny, window, bounds)
        cx, cy = cx + offset * fnx, cy + offset * fny
    x_out[order], y_out[order] = cx, cy
    return x_out, y_out


def _chained(polylines: tuple[np.ndarray, ...], *arrays) -> tuple:
    """The polylines' points in order: their index, the chains' bounds in it, and each array
    taken in that order (contiguous float64)."""
    order = np.concatenate(polylines)
    bounds = np.cumsum([0] + [chain.size for chain in polylines])
    return order, bounds, *(np.ascontiguousarray(a[order], np.float64) for a in arrays)


@kernel
def _spread(offsets: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """Per point, 1.4826 × the median absolute deviation of its polyline's `offsets` (NaN
    where the polyline holds a NaN, as np.median)."""
    scatter = np.empty(offsets.size)
    for c in range(bounds.size - 1):
        lo, hi = bounds[c], bounds[c + 1]
        a = offsets[lo:hi]
        if np.isnan(a).any():
            scatter[lo:hi] = np.nan
            continue
        scatter[lo:hi] = 1.4826 * np.median(np.abs(a - np.median(a)))
    return scatter


@kernel
def _error_correlation(offsets: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """Per point, the centres over which its polyline's errors are correlated: (1 + ρ)/(1 − ρ),
    ρ the lag-1 autocorrelation of the `offsets` from the local fits (clipped to 0–0.98;
    1 for polylines under MIN_CORRELATION_POINTS or holding a NaN).

    An AR(1) sequence of lag-1 correlation ρ has (1 + ρ)/(1 − ρ) times the variance of
    white noise in a long mean, so a window of N centres holds about N(1 − ρ)/(1 + ρ)
    independent ones. Under sensor noise alone neighbouring matched centres share little
    (ρ ≈ 0.2 on varying-noise10 and noise-peak120: 1.5); under a lit, textured scene the
    texture (correlated over 5 px) moves them together (ρ ≈ 0.8 at 1 px before the fit).
    """
    out = np.ones(offsets.size)
    for c in range(bounds.size - 1):
        lo, hi = bounds[c], bounds[c + 1]
        if hi - lo < MIN_CORRELATION_POINTS:
            continue
        a = offsets[lo:hi]
        if np.isnan(a).any():
            continue
        d = a - a.mean()
        power = (d * d).sum()
        if power <= 0.0:
            continue
        rho = min(max((d[1:] * d[:-1]).sum() / power, 0.0), 0.98)
        out[lo:hi] = (1.0 + rho) / (1.0 - rho)
    return out


@dataclass(frozen=True, slots=True, eq=False)
class LocalFits:
    """Each centre's local quadratic fit along its polyline; arrays (K,) in the points'
    order, NaN (count 0) for points in no polyline.

    `offset` is the fitted curve's offset a from the point along n [px], `count` the points
    in its window, `scatter` σl, the robust spread (1.4826 × MAD) of its polyline's offsets.
    """

    offset: np.ndarray
    count: np.ndarray
    scatter: np.ndarray


def local_fits(x, y, nx, ny, support_px, polylines: tuple[np.ndarray, ...]) -> LocalFits:
    """The centres' local quadratic fits v = a + b·u + (κ/2)·u² along their polylines
    (Gaussian weight of std `support_px` along the stripe, window ±max(2·support, 4 px))."""
    offset, count, scatter = (np.full(np.size(x), np.nan) for _ in range(3))
    if polylines:
        order, bounds, fx, fy, fnx, fny, fs = _chained(polylines, x, y, nx, ny, support_px)
        kappa, fitted, inside = (np.empty(fx.size) for _ in range(3))
        _fit_curvatures(fx, fy, fnx, fny, fs, bounds, kappa, fitted, inside)
        offset[order], count[order] = fitted, inside
        scatter[order] = _spread(fitted, bounds)
    return LocalFits(offset=offset, count=np.nan_to_num(count), scatter=scatter)


def centre_scatter(x, y, nx, ny, support_px, polylines: tuple[np.ndarray, ...]) -> np.ndarray:
    """σl per point [px]: the robust spread (1.4826 × MAD) of its polyline's centres about
    their local quadratic fits (Gaussian weight of std `support_px` along the stripe).

    Points in no polyline get NaN.
    """
    return local_fits(x, y, nx, ny, support_px, polylines).scatter


def _fitted_offsets(x, y, nx, ny, window, bounds) -> np.ndarray:
    kappa, offset, count = (np.empty(x.size) for _ in range(3))
    _fit_curvatures(x, y, nx, ny, window, bounds, kappa, offset, count)
    return offset


def smooth_along(
    x: np.ndarray,
    y: np.ndarray,
    nx,
    ny,
    support_px,
    polylines: tuple[np.ndarray, ...],
    *,
    fits: LocalFits | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Centres moved onto their local quadratic fit along the polyline (no bias removed).

    Parameters
    ----------
    x, y, nx, ny : ndarray of shape (K,)
        Centres [px] free of curvature bias (e.g. `normal_fit.matched_offsets`' refined
        ones) and unit normals.
    support_px : ndarray of shape (K,)
        Base standard deviation of each fit's Gaussian weight along the stripe [px] (window
        ±max(2·support, 4 px)); widened up to 3× where the measured centre scatter σl calls
        for it (`_scatter_windows`, the centres taken as independent MATCHED_CORRELATION_PX
        apart, or farther where their errors are measured to be correlated).
    polylines : tuple of ndarray of int
        Disjoint ordered index arrays into the points.
    fits : LocalFits, optional
        `local_fits` of these same points at `support_px`, if already made (they are the
        base window's fits and σl, not made again).

    Returns
    -------
    x, y : ndarray of shape (K,), float64
        Each point moved along its normal onto the curve v = a + b·u + (κ/2)·u² fitted in
        its tangent/normal frame; points in no polyline and fits of < 5 points unchanged.

    Notes
    -----
    A weighted quadratic fit is exact on a parabola, so it follows the stripe's curvature;
    with a Gaussian weight of std σt its value at the point has 1.69× the variance of the
    weighted mean (the equivalent kernel K(u)·(3 − u²/σt²)/2), i.e. that of a mean over
    2√π·σt/1.69 px of independent centres.
    """
    x_out = x.astype(np.float64, copy=True)
    y_out = y.astype(np.float64, copy=True)
    if not polylines:
        return x_out, y_out
    order, bounds, fx, fy, fnx, fny, fs = _chained(polylines, x, y, nx, ny, support_px)
    first = None if fits is None else (fits.offset[order], fits.count[order], fits.scatter[order])
    _, fitted = _scatter_windows(
        fx, fy, fnx, fny, fs, bounds, np.full(fx.size, MATCHED_CORRELATION_PX), first, measured=True
    )
    offset = np.nan_to_num(fitted)
    x_out[order], y_out[order] = fx + offset * fnx, fy + offset * fny
    return x_out, y_out
