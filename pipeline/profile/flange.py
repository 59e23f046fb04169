"""Flange parameters of a wheel profile in the profile frame (docs/coordinate-frames.md).

Sh = highest z of the flange; Sd(h) = x of the flange flank (the side facing the tread) at
z = h, for h = 12 mm (LM wheels) and h = 10 mm (EN); qR = x_flank(10) − x_flank(Sh − 2).

Two estimators with one definition: `curve_flange_parameters` reads them off a clean,
ordered polyline by linear interpolation (reference tables, the simulator's true profiles);
`fit_flange_parameters` estimates them from measured, noisy profile points with local
least-squares fits, so no single noisy point decides a parameter.

Which failure blocks what: without the flange top (Sh), or with a top no higher than the Sd
height (no flange), the wheel is not measured (`FlangeNotFoundError`); without the flank
at 12 mm Sd is missing, without it at 10 mm Sd 10 and qR (which starts from that flank
point), and without it at Sh − 2 only qR. The measured parameters are returned either way,
with `FlangeParameters.reason` naming what is missing (docs/numbers.md, "Wheel
parameters").
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from pipeline.errors import PipelineError
from pipeline.imaging import GEOMETRY_FLOAT
from pipeline.profile.fusion import DOUBLED_DX_MM, DOUBLED_DZ_MM
from pipeline.profile.x_windows import window_minima

SD_HEIGHT_MM = 12.0
SD_EN_HEIGHT_MM = 10.0
QR_DROP_MM = 2.0
TOP_HALF_WINDOW_MM = 2.5
"""Half-width in x of the flange-top fit: a quadratic departs from the R12 top arc of LMA
by 2.5⁴/(8·12³) = 0.003 mm at its ends, well below the measurement's resolution."""
TOP_CIRCLE_HALF_WINDOW_MM = 4.0
"""Half-width in x of the circle that checks the flange top is a crest seen on both sides."""
TOP_START_DEPTH_MM = 3.0
"""The top's first quadratic takes the points within ±2.5 mm of the highest points of the
profile's one curve down to 3 mm below them: the top arc drops ≤ 1.3 mm within 4.5 mm of
its crest (R ≥ 8 mm; the start lies within 2 mm of the crest), while a glare hook or ghost
piece fused under the top lies 2.5–4.5 mm lower. Through every point of the window, such a
piece of 20–40 points (harsh field pass 5, seed 2027, V001/2/right, 1 frame per sensor)
turned the robust quadratic concave up: "not a crest" for a top seen well on both sides
(now Sh +0.070, Sd +0.096 mm; the 71 other wheels of those 9 passes unchanged)."""
TOP_CIRCLE_DEPTH_MM = 2.0
"""The top's second quadratic and circle take the points within 2 mm below the crest of a
first quadratic (through every point within ±2.5 mm) only: the top arc
drops < 1 mm over ±4 mm (R12 LMA: 0.69 mm; worn tops a little more), while a glint or spot
beside the stripe that lands in the window lies millimetres lower. On a clean pass (seed
2027, pass 2, V002/2/left) a specular spot 5 mm below the top, 1.5–4 mm beside it in x,
pulled the circle up: Sh +0.398 mm, with the band +0.000."""
WIDER_AGREEMENT = 2.0
WIDER_CORRELATION_MM = 0.5
WIDER_MIN_ERROR_MM = 0.01
TOP_WIDER_WINDOWS_MM = (3.0, 3.5, 4.0)
SD_WIDER_FITS = ((3.0, 2), (4.0, 3), (5.0, 3))
"""Wider fits where the points' scatter calls for them (`widest_agreeing`, Lepski's rule):
the top's quadratic over ±3, ±3.5 and ±4 mm after ±2.5 (`TOP_HALF_WINDOW_MM`), Sd's flank
fit over ±3 (quadratic), ±4 and ±5 mm (cubic) after ±2 (`SD_FIT_HALF_WINDOW_MM`), each kept
while its value lies within 2 standard errors of every narrower one's, the centres counted
as independent 0.5 mm apart (the texture's correlation, 3–15 px at about 0.1 mm/px), and
only where the narrowest fit's standard error is at least 0.01 mm: a clean frame's (0.001–
0.007 mm), a tabulated reference's (LMA and S1002 at Sd: 0.006–0.007) or a gauge's points
keep their narrow fits exactly, where field frames' read 0.01–0.06 mm. On
field frames the wide fits average the texture's and the grain's wander; on a real worn
profile, whose points scatter little, a wider fit that leaves the narrow one's value is not
taken, so its shape is followed (`Car7216`'s S-shaped flank reads as before; MiniProf
`whl_left_iter795`'s top, 0.17 mm above its ±2.5 mm parabola 4 mm out, is under the floor).
Measured on captured fused profiles (docs/simulator.md, "Wider fits where the points
scatter"): 3 frames per sensor, seed 2027, 72 wheels, Sh MAE / max 0.044 / 0.140 →
0.037 / 0.098 mm, Sd 0.037 / 0.194 → 0.034 / 0.163; held-out seed 2028, 1 frame, Sh
0.068 → 0.064, Sd 0.088 → 0.082; clean passes (seed 2026) Sh max 0.044 → 0.012, Sd
unchanged within 0.002."""
FLANK_HALF_WINDOW_MM = 1.0
"""Half-height in z of the flank fits (quadratic x(z) about the height)."""
SD_FIT_HALF_WINDOW_MM = 2.0
"""Half-height in z of the Sd fits (z = 12 and 10 mm): the quadratic x(z) takes the flank
points within ±2 mm of the height (with a bridged gap, also 1 mm beyond its edges). On field
frames the steep flank's centres wander by 0.1–0.3 mm over 1–2 mm of height (the dim
flange root under the lit scene's grain and the reflectance texture), so the wider fit
averages more of it; on the true LMA and S1002 outlines it departs from the flank by
≤ 0.003 mm. Against ±1 mm, same frames (seed 2027, 9 harsh passes / 3 passes with the
scene, the texture alone / 3 clean), paired |Sd error| change −0.003 ± 0.005 / −0.008 ±
0.007, −0.008 ± 0.007 / −0.0007 ± 0.0003 mm, the harsh passes' largest error 0.331 →
0.271 mm; the clean repeatability benchmark (seed 2026, 72 wheels): Sd MAE 0.007 both,
largest per-wheel Std 0.016 → 0.018, largest error 0.040 → 0.047 mm (V001/4/right). qR's
height Sh − 2 keeps ±1 mm: the top arc is 2 mm above it."""
FLANK_BRIDGE_HALF_WINDOW_MM = 3.0
MAX_FLANK_GAP_MM = 2.5
"""A flank with fewer than 5 points within ±1 mm of a height, or a gap of > 1 mm about it,
is bridged when the gap (its edges looked for within ±3 mm) is ≤ 2.5 mm of z: the
quadratic x(z) through 1 mm of points on each side of it then departs from the LMA and
S1002 flanks at Sd (12 and 10 mm) by ≤ 0.02 mm wherever the gap lies about the height
(0.012 for 2 mm, 0.029 for 3 mm); tested with 0.01 mm noise. On the simulator's worn
outlines (field wear ranges, 0.02 mm noise) a 2.5 mm gap is bridged within 0.030 mm at 12 mm
and 0.039 at 10; 3.5 mm: 0.035 and 0.155 (the root arc), the reference flank shifted in x and
z: 0.148 and 0.046; on field profiles every bridge moves Sd by up to 0.3–0.4 mm (the centres'
wave along the flank; docs/simulator.md, "Wider flank bridges"). The gap is reported
(`FlangeParameters.flank_gap_mm`); a longer one leaves Sd not measured at 12 mm,
Sd 10 and qR not measured at 10 mm, qR alone at Sh − 2."""
FLANK_WEIGHT_STRENGTH = 20.0
"""The flank fits weight each centre by its line strength s (`Centres.strength`, σ²|λ1|,
proportional to the stripe's peak above its surround): w = s / √(1 + (s / 20)²), i.e. the
inverse of a centre error σ² ∝ (1/s)² + (1/20)². A centre's shift from noise and from the
lit scene's slope under the stripe goes as 1/peak (the matched fit's first-order shift
2√2·g·s²/A, docs/simulator.md, "The glare's chords"), so a dim frame's flank reads off by
more; the texture's shift is multiplicative, the same at any peak, and the glare's stretches
(s 40–90, saturated) have their end hooks, hence the floor: above s ≈ 20 the weight levels
off. On the field benchmark's 3-frame passes the dim flank (s 7–12) of one frame often lies
0.2–0.3 mm off beside another frame's brighter stretch; the per-frame flank offset at
z = 10–14 mm correlates with 1/s (|offset| vs s: −0.44, 203 outer frames, seed 2027).
Seeds 2027 / 2028 (the floor chosen on both), 9 harsh passes × 8 wheels, Sd MAE 0.0425 →
0.0373 / 0.0447 → 0.0357 mm, largest 0.227 → 0.194 / 0.172 → 0.126 (docs/simulator.md,
"Flank fits weighted by line strength"). Without strengths (a handheld profile) the fits
are unweighted."""
MIN_FIT_POINTS = 5
OUTLIER_MADS = 3.0
OUTLIER_FLOOR_MM = 0.03
OUTLIER_PASSES = 4
"""Fit points further than 3 robust standard deviations (at least 0.03 mm) from the fit are
dropped and the fit repeated (up to 4 passes), so a stray spot cannot pull a parameter."""


VALUE_NAMES = ("Sd", "Sd 10", "qR")
"""The names `FlangeParameters.reason` gives its parts ("Sd: …; Sd 10: …; qR: …")."""


def missing_value_names(reason: str | None) -> list[str]:
    """The values a `FlangeParameters.reason` says were not measured, in its order:
    "Sd: …; qR: …" → ["Sd", "qR"]; none for None or a whole wheel's reason."""
    parts = (part.split(": ", 1)[0] for part in (reason or "").split("; "))
    return [name for name in parts if name in VALUE_NAMES]


class FlangeNotFoundError(PipelineError):
    """The profile does not show a flange top or flank where the parameters need them."""


@dataclass(frozen=True, slots=True)
class FlangeParameters:
    """Flange parameters of one wheel [mm].

    Attributes
    ----------
    flange_height_mm : float
        Sh, flange top above the reference point.
    flange_thickness_mm : float or None
        Sd at z = 12 mm from the back face; None when the flank there cannot be measured
        (`reason` says why): Sh is still measured.
    flange_thickness_10_mm : float or None
        Sd at z = 10 mm (EN variant); None when the flank there cannot be measured
        (`reason` says why): Sh and Sd are still measured.
    qr_mm : float or None
        qR = x_flank(10) − x_flank(Sh − 2); None when the flank near the flange top, or
        at 10 mm, cannot be measured (`reason` says why): Sh and Sd are still measured.
    flank_gap_mm : float
        Largest gap in z between the flank points below and above a height of a measured
        Sd or qR that had to be bridged (fewer than `MIN_FIT_POINTS` points within 1 mm on
        a side of it), at most `MAX_FLANK_GAP_MM`; 0 when every height had its points [mm].
    reason : str or None
        Why Sd, Sd 10 or qR was not measured, each part naming its parameter ("Sd: …",
        "Sd 10: …", "qR: …", joined by "; "); None when all four were measured.
    """

    flange_height_mm: float
    flange_thickness_mm: float | None
    flange_thickness_10_mm: float | None
    qr_mm: float | None
    flank_gap_mm: float = 0.0
    reason: str | None = None


def _check_points(x_mm: object, z_mm: object) -> tuple[np.ndarray, np.ndarray]:
    x = np.asarray(x_mm, dtype=GEOMETRY_FLOAT)
    z = np.asarray(z_mm, dtype=GEOMETRY_FLOAT)
    if x.ndim != 1 or x.shape != z.shape:
        raise ValueError(f"x_mm and z_mm must be 1-D of equal length, got {x.shape}, {z.shape}")
    if x.size < 2 or not (np.all(np.isfinite(x)) and np.all(np.isfinite(z))):
        raise ValueError("x_mm and z_mm must hold at least 2 finite points")
    return x, z


def _crossing_after(x: np.ndarray, z: np.ndarray, start: int, height_mm: float) -> float:
    """x of the first downward crossing of z = height after index `start` (linear)."""
    above = z[start:] >= height_mm
    down = np.flatnonzero(above[:-1] & ~above[1:])
    if down.size == 0:
        raise FlangeNotFoundError(f"the profile's flank never crosses z = {height_mm:.2f} mm")
    i = start + int(down[0])
    t = (z[i] - height_mm) / (z[i] - z[i + 1])
    return float(x[i] + t * (x[i + 1] - x[i]))


def curve_flange_parameters(x_mm: np.ndarray, z_mm: np.ndarray) -> FlangeParameters:
    """Flange parameters of a clean polyline ordered along the profile (x mostly rising).

    Parameters
    ----------
    x_mm, z_mm : ndarray of shape (K,)
        Profile points in the profile frame, ordered from the back face to the field side [mm].

    Returns
    -------
    FlangeParameters
        Read off the polyline (crossings interpolated linearly): the truth of a reference
        table or a densely sampled contour, which `fit_flange_parameters` is tested against.

    Raises
    ------
    FlangeNotFoundError
        If the flank does not cross a height the parameters need.

    Examples
    --------
    >>> from pipeline.profile.reference import load_reference_profile
    >>> p = load_reference_profile("LMA")
    >>> round(curve_flange_parameters(p.x_mm, p.z_mm).flange_thickness_mm, 4)
    31.9744
    """
    x, z = _check_points(x_mm, z_mm)
    top = int(np.argmax(z))
    height = float(z[top])
    flank_12 = _crossing_after(x, z, top, SD_HEIGHT_MM)
    flank_10 = _crossing_after(x, z, top, SD_EN_HEIGHT_MM)
    flank_top = _crossing_after(x, z, top, height - QR_DROP_MM)
    return FlangeParameters(height, flank_12, flank_10, flank_10 - flank_top)


def robust_polyfit(
    t: np.ndarray,
    v: np.ndarray,
    degree: int,
    what: str,
    start: np.ndarray | None = None,
    weights: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares polynomial v(t), refitted without outliers until the inliers settle:
    its coefficients (highest power first) and the inliers of its last fit (bool (K,)).

    `start` (bool, default all) are the first fit's points; `weights` (default none) weight
    each point's residual in the least squares (`numpy.polyfit`'s w, 1/σ), not the outlier
    test. Raises FlangeNotFoundError naming `what` when fewer than `MIN_FIT_POINTS` points
    (or consistent points) remain.
    """
    if t.size < MIN_FIT_POINTS:
        raise FlangeNotFoundError(f"too few profile points on the {what}")
    inlier = np.ones(t.size, bool) if start is None else np.asarray(start, bool).copy()
    if np.count_nonzero(inlier) < MIN_FIT_POINTS:
        raise FlangeNotFoundError(f"too few consistent profile points on the {what}")

    def fit(at: np.ndarray) -> np.ndarray:
        return np.polyfit(t[at], v[at], degree, w=None if weights is None else weights[at])

    for _ in range(OUTLIER_PASSES):
        coefficients = fit(inlier)
        residual = np.abs(v - np.polyval(coefficients, t))
        limit = max(OUTLIER_MADS * 1.4826 * float(np.median(residual[inlier])), OUTLIER_FLOOR_MM)
        if np.array_equal(residual <= limit, inlier):
            return coefficients, inlier
        inlier = residual <= limit
        if np.count_nonzero(inlier) < MIN_FIT_POINTS:
            raise FlangeNotFoundError(f"too few consistent profile points on the {what}")
    return fit(inlier), inlier


def _value_error(
    t: np.ndarray,
    v: np.ndarray,
    coefficients: np.ndarray,
    inlier: np.ndarray,
    weights: np.ndarray | None = None,
) -> float:
    """Standard error of a least-squares polynomial's value at t = 0 [mm], from the scatter
    of its inliers about it, counting them as independent only `WIDER_CORRELATION_MM` of t
    apart (neighbouring centres share the texture and the lit scene's grain); inf when the
    inliers do not outnumber the coefficients by two."""
    degree = coefficients.size - 1
    count = int(np.count_nonzero(inlier))
    if count <= degree + 2:
        return math.inf
    at = t[inlier]
    w2 = np.ones(count) if weights is None else weights[inlier] ** 2
    residual = v[inlier] - np.polyval(coefficients, at)
    variance = float((w2 * residual**2).sum()) / (count - degree - 1)
    design = np.vander(at, degree + 1)
    covariance = np.linalg.pinv(design.T @ (w2[:, None] * design)) * variance
    span = max(float(np.ptp(at)), WIDER_CORRELATION_MM)
    correlated = max(1.0, count * WIDER_CORRELATION_MM / span)
    return math.sqrt(max(float(covariance[-1, -1]), 0.0) * correlated)


def widest_agreeing(values: list[float], errors: list[float]) -> int:
    """Index of the widest of windows (narrowest first) whose value lies within
    `WIDER_AGREEMENT` standard errors of every narrower window's value (Lepski's rule), the
    narrower ones all agreeing too: the smoothing a fit can afford before the profile's own
    shape, not the points' scatter, moves it. The narrowest is kept where its own error is
    below `WIDER_MIN_ERROR_MM` (nothing to average)."""
    chosen = 0
    if not errors or errors[0] < WIDER_MIN_ERROR_MM:
        return chosen
    for k in range(1, len(values)):
        if any(abs(values[k] - values[j]) > WIDER_AGREEMENT * errors[j] for j in range(k)):
            break
        chosen = k
    return chosen


def _widest_fit(first: tuple, wider) -> tuple:
    """The widest agreeing fit (`widest_agreeing`) of `first`, a (value, error, …) tuple, and
    the fits the zero-argument callables `wider` make (narrowest first, the same tuples). A
    wider fit is made only while it can still be chosen: none below `WIDER_MIN_ERROR_MM`, none
    after one that disagrees or cannot be made (`FlangeNotFoundError`)."""
    if first[1] < WIDER_MIN_ERROR_MM:
        return first
    fits, chosen = [first], 0
    for make in wider:
        try:
            fits.append(make())
        except FlangeNotFoundError:
            break
        chosen = widest_agreeing([f[0] for f in fits], [f[1] for f in fits])
        if chosen < len(fits) - 1:
            break
    return fits[chosen]


def strength_weights(strength: np.ndarray) -> np.ndarray:
    """The flank fits' weight of centres of line strength s: s / √(1 + (s / 20)²)
    (`FLANK_WEIGHT_STRENGTH`)."""
    s = np.maximum(np.asarray(strength, dtype=GEOMETRY_FLOAT), 0.0)
    return s / np.sqrt(1.0 + (s / FLANK_WEIGHT_STRENGTH) ** 2)


LINE_START_POINTS = 400
"""Most points whose pairwise slopes `line_inliers` takes (every k-th beyond): the median of
~80k slopes, a few MB, however many frames a profile pools."""


def line_inliers(t: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The points near the Theil–Sen line v(t) (median of the pairwise slopes, median
    intercept): within `OUTLIER_MADS` robust standard deviations of its residuals (at least
    `OUTLIER_FLOOR_MM`), bool (K,).

    The start of the flank fits: the line holds with up to 29 % of the points anywhere, where
    a least-squares start is pulled by a stray piece millimetres off the flank and the
    refits can settle between the two (5 views of a field wheel: 23 of 108 points at
    z = 9–10 mm lay 9.6 mm beyond the flank, Sd 10 read 1.2 mm wide).
    """
    step = -(-t.size // LINE_START_POINTS)  # every step-th point: at most ~80k pairs
    i, j = np.triu_indices(t[::step].size, k=1)
    dt = t[::step][j] - t[::step][i]
    steep = dt != 0
    dv = v[::step][j] - v[::step][i]
    slope = float(np.median(dv[steep] / dt[steep])) if np.any(steep) else 0.0
    intercept = float(np.median(v - slope * t))
    residual = np.abs(v - (intercept + slope * t))
    return residual <= max(OUTLIER_MADS * 1.4826 * float(np.median(residual)), OUTLIER_FLOOR_MM)


def _circle(x: np.ndarray, z: np.ndarray) -> tuple[float, float, float]:
    """Algebraic least-squares circle (Kåsa): centre (x, z) and radius [mm]."""
    design = np.column_stack([x, z, np.ones_like(x)])
    a, b, c = np.linalg.lstsq(design, -(x * x + z * z), rcond=None)[0]
    cx, cz = -a / 2, -b / 2
    return float(cx), float(cz), float(np.sqrt(max(cx * cx + cz * cz - c, 0.0)))


def _check_both_sides(x: np.ndarray, x_crest: float, half_window_mm: float) -> None:
    """Raise unless ≥ MIN_FIT_POINTS points lie on each side of the crest within the window:
    a crest seen on one side only is an extrapolation, not a measurement."""
    near = x[np.abs(x - x_crest) <= half_window_mm]
    before = int(np.count_nonzero(near < x_crest))
    beyond = int(np.count_nonzero(near > x_crest))
    if before < MIN_FIT_POINTS or beyond < MIN_FIT_POINTS:
        side = "back-face" if before < MIN_FIT_POINTS else "flank"
        raise FlangeNotFoundError(
            f"the flange top is not seen on its {side} side ({before} profile points before "
            f"and {beyond} beyond x = {x_crest:.1f} mm within ±{half_window_mm:g} mm)"
        )


def _check_top_circle(x: np.ndarray, z: np.ndarray, x_top: float, z_top: float) -> None:
    """Raise unless a circle fitted within ±4 mm of the crest (x_top, z_top), to the points
    at most TOP_CIRCLE_DEPTH_MM below it, is a crest seen on both sides."""
    near = np.flatnonzero(
        (np.abs(x - x_top) <= TOP_CIRCLE_HALF_WINDOW_MM) & (z >= z_top - TOP_CIRCLE_DEPTH_MM)
    )
    if near.size < MIN_FIT_POINTS:
        raise FlangeNotFoundError("too few profile points on the flange top")
    inlier = np.ones(near.size, bool)
    for _ in range(OUTLIER_PASSES):
        cx, cz, radius = _circle(x[near[inlier]], z[near[inlier]])
        residual = np.abs(np.hypot(x[near] - cx, z[near] - cz) - radius)
        limit = max(OUTLIER_MADS * 1.4826 * float(np.median(residual[inlier])), OUTLIER_FLOOR_MM)
        if np.array_equal(residual <= limit, inlier):
            break
        inlier = residual <= limit
        if np.count_nonzero(inlier) < MIN_FIT_POINTS:
            raise FlangeNotFoundError("too few consistent profile points on the flange top")
    if cz >= z[near].max() or abs(cx - x_top) > TOP_CIRCLE_HALF_WINDOW_MM:
        raise FlangeNotFoundError(
            f"the flange top is not a crest (the circle fitted within ±"
            f"{TOP_CIRCLE_HALF_WINDOW_MM:g} mm of x = {x_top:.1f} mm is centred at x = {cx:.1f}, "
            f"z = {cz:.1f} mm)"
        )
    _check_both_sides(x[near[inlier]], cx, TOP_CIRCLE_HALF_WINDOW_MM)


def _top_curvature(
    x: np.ndarray, z: np.ndarray, x_top: float, z_floor: float, half_mm: float = TOP_HALF_WINDOW_MM
) -> tuple[float, float, float]:
    """(c2, c1, c0) of the quadratic z(x − x_top) fitted within ±half_mm (default 2.5 mm) to
    the points above z_floor; raises unless a crest."""
    near = (np.abs(x - x_top) <= half_mm) & (z >= z_floor)
    if np.count_nonzero(near) < MIN_FIT_POINTS:
        raise FlangeNotFoundError(
            f"too few profile points on the flange top ({np.count_nonzero(near)} within "
            f"±{half_mm:g} mm of x = {x_top:.1f} mm, where its crest should be)"
        )
    c2, c1, c0 = robust_polyfit(x[near] - x_top, z[near], 2, "flange top")[0]
    if c2 >= 0:
        raise FlangeNotFoundError("the flange top is not a crest (fit curvature ≥ 0)")
    return float(c2), float(c1), float(c0)


def _top_start(x: np.ndarray, z: np.ndarray) -> tuple[float, float]:
    """(x, z) where the crest is looked for: the median x and z of the highest points on the
    profile's one curve z(x), i.e. without a point more than 0.5 mm below them within ±0.2 mm
    in x [mm].

    A Steger spur rising from the flange's back or top (beside a glint) stands over the
    profile there and is left out, so it cannot take the top's windows 4–7 mm off the crest
    (clean seed-7 pass, V001/1/right: a spur 3.8 mm high at x = 11.6 mm, the crest at 15.6).
    The rule and its constants are fusion's test for a point lying above the profile
    (`fusion.DOUBLED_DX_MM`, `fusion.DOUBLED_DZ_MM`).
    """
    order = np.argsort(x, kind="stable")
    xs, zs = x[order], z[order]
    lo = np.searchsorted(xs, xs - DOUBLED_DX_MM, side="left")
    hi = np.searchsorted(xs, xs + DOUBLED_DX_MM, side="right")
    on_curve = window_minima(zs, lo, hi) >= zs - DOUBLED_DZ_MM
    xs, zs = xs[on_curve], zs[on_curve]
    highest = np.argsort(zs)[::-1][: max(MIN_FIT_POINTS, zs.size // 200)]
    return float(np.median(xs[highest])), float(np.median(zs[highest]))


def _fit_top(x: np.ndarray, z: np.ndarray) -> tuple[float, float]:
    """(x, z) of the flange top: the crest of a quadratic within ±2.5 mm over the 2 mm depth
    band below a first quadratic's crest, once a circle through ±4 mm of it confirms a crest
    seen on both sides.

    Both quadratics start at the highest points of the profile's one curve (`_top_start`).
    The first takes the points within ±2.5 mm down to `TOP_START_DEPTH_MM` below those
    points (robustly: a stray point is dropped as an outlier); the band below its crest then
    leaves out a spot millimetres below the top, which the second quadratic and the circle
    would otherwise follow. The highest points are on the one curve, so a spur standing over
    the top does not set either band (a band hung from the highest points of all held such
    a spur alone, and its quadratic was no crest).

    The height is the quadratic's, not the circle's: the circle's apex extrapolates the
    curvature of the whole ±4 mm, where on field frames each sensor's far side of the top
    (seen near its silhouette) reads 0.1–0.2 mm inside the profile and texture bends the
    centres over millimetres. Harsh passes 1–3 / 4–7 (seed 2027, 19 wheels each), Sh error
    mean and MAE: circle +0.051 / 0.061 and +0.043 / 0.079 mm, quadratic +0.010 / 0.047 and
    −0.015 / 0.059; clean passes 1–3: +0.002 / 0.003 both.

    The second quadratic then widens to ±3, ±3.5 and ±4 mm while its crest height agrees
    with the narrower ones' (`TOP_WIDER_WINDOWS_MM`, `widest_agreeing`).
    """
    x_start, z_start = _top_start(x, z)
    x_first, z_crest = _top_crest(x, z, x_start, z_start - TOP_START_DEPTH_MM)
    floor = z_crest - TOP_CIRCLE_DEPTH_MM
    x_top, z_top = _top_crest(x, z, x_first, floor)
    _check_top_circle(x, z, x_top, z_top)
    narrow = (z_top, _crest_error(x, z, x_top, floor, TOP_HALF_WINDOW_MM), x_top)
    wider = (
        functools.partial(_top_fit, x, z, x_first, floor, half_mm)
        for half_mm in TOP_WIDER_WINDOWS_MM
    )
    z_top, _, x_top = _widest_fit(narrow, wider)
    return x_top, z_top


def _top_fit(
    x: np.ndarray, z: np.ndarray, x_start: float, z_floor: float, half_mm: float
) -> tuple[float, float, float]:
    """(z, standard error, x) of the crest of the top's quadratic within ±half_mm from x_start
    (`_top_crest`, `_crest_error`) [mm]."""
    x_top, z_top = _top_crest(x, z, x_start, z_floor, half_mm)
    return z_top, _crest_error(x, z, x_top, z_floor, half_mm), x_top


def _crest_error(
    x: np.ndarray, z: np.ndarray, x_top: float, z_floor: float, half_mm: float
) -> float:
    """Standard error of the top quadratic's height at its crest x_top (`_value_error`) [mm]."""
    near = (np.abs(x - x_top) <= half_mm) & (z >= z_floor)
    u, v = x[near] - x_top, z[near]
    coefficients, inlier = robust_polyfit(u, v, 2, "flange top")
    return _value_error(u, v, coefficients, inlier)


def _top_crest(
    x: np.ndarray, z: np.ndarray, x_top: float, z_floor: float, half_mm: float = TOP_HALF_WINDOW_MM
) -> tuple[float, float]:
    """(x, z) of the crest of the top's quadratic within ±half_mm (points above z_floor),
    three Newton steps from x_top [mm]; raises unless a crest."""
    for _ in range(3):
        c2, c1, c0 = _top_curvature(x, z, x_top, z_floor, half_mm)
        step = float(np.clip(-c1 / (2 * c2), -half_mm, half_mm))
        x_top += step
    return x_top, c0 + c1 * step + c2 * step**2  # the last quadratic at the crest


def _gap_edges(dz: np.ndarray, half_window_mm: float) -> tuple[float, float]:
    """The empty interval about dz = 0 within ±half window: (highest below, lowest above),
    the window's edge where a side has no point [mm]."""
    below, above = dz[dz <= 0], dz[dz >= 0]
    low = float(below.max()) if below.size else -half_window_mm
    high = float(above.min()) if above.size else half_window_mm
    return low, high


def _fit_flank(
    x: np.ndarray,
    z: np.ndarray,
    x_top: float,
    height_mm: float,
    half_window_mm: float = FLANK_HALF_WINDOW_MM,
    strength: np.ndarray | None = None,
    wider: tuple[tuple[float, int], ...] = (),
) -> tuple[float, float]:
    """x of the flank at z = height and the gap bridged about the height (0: none) [mm].

    A quadratic x(z) is fitted to flank points (tread side of the top) within
    ±`half_window_mm` of the height. Where those within ±1 mm are fewer than
    `MIN_FIT_POINTS` or leave a gap of > 1 mm about the height, a gap of ≤
    `MAX_FLANK_GAP_MM` (edges found within ±3 mm) is bridged by the quadratic through 1 mm
    of points on each side of it (and those within the half window). With the centres'
    line strengths the fit weights them (`strength_weights`). Without a bridged gap, the
    `wider` fits ((half window [mm], degree), narrowest first) are tried after it and the
    widest agreeing one is taken (`widest_agreeing`).
    """
    flank = (x > x_top) & (x < x_top + 40.0)
    dz = z[flank] - height_mm
    what = f"flank near z = {height_mm:.2f} mm"
    near = np.abs(dz) <= FLANK_HALF_WINDOW_MM
    low, high = _gap_edges(dz[near], FLANK_HALF_WINDOW_MM)
    bridged = 0.0
    if np.count_nonzero(near) < MIN_FIT_POINTS or high - low > FLANK_HALF_WINDOW_MM:
        low, high = _gap_edges(
            dz[np.abs(dz) <= FLANK_BRIDGE_HALF_WINDOW_MM], FLANK_BRIDGE_HALF_WINDOW_MM
        )
        near = (dz >= low - FLANK_HALF_WINDOW_MM) & (dz <= high + FLANK_HALF_WINDOW_MM)
        below = int(np.count_nonzero(near & (dz <= low)))
        above = int(np.count_nonzero(near & (dz >= high)))
        bridged = high - low
        if min(below, above) < MIN_FIT_POINTS or bridged > MAX_FLANK_GAP_MM:
            raise FlangeNotFoundError(
                f"too few profile points on the {what} (a gap of {bridged:.1f} mm about it "
                f"with {below} points below and {above} above within 1 mm of its edges, where "
                f"gaps ≤ {MAX_FLANK_GAP_MM:g} mm are bridged)"
            )
    near |= np.abs(dz) <= half_window_mm
    degree = 2 if np.ptp(dz[near]) > FLANK_HALF_WINDOW_MM else 1
    narrow = _flank_fit(dz, x[flank], near, degree, strength, flank, what)
    fits = (
        functools.partial(
            _flank_fit, dz, x[flank], np.abs(dz) <= half_mm, wide_degree, strength, flank, what
        )
        for half_mm, wide_degree in (wider if bridged == 0.0 else ())
    )
    return _widest_fit(narrow, fits)[0], bridged


def _flank_fit(dz, x_flank, near, degree, strength, flank, what) -> tuple[float, float]:
    """x at dz = 0 of the robust polynomial x(dz) through the `near` flank points (weighted by
    their line strengths when given), and its standard error (`_value_error`) [mm]."""
    t, v = dz[near], x_flank[near]
    weights = None if strength is None else strength_weights(strength[flank][near])
    if weights is not None and not np.any(weights > 0):
        weights = None
    coefficients, inlier = robust_polyfit(t, v, degree, what, line_inliers(t, v), weights)
    return float(np.polyval(coefficients, 0.0)), _value_error(t, v, coefficients, inlier, weights)


def fit_flange_parameters(
    x_mm: np.ndarray, z_mm: np.ndarray, strength: np.ndarray | None = None
) -> FlangeParameters:
    """Flange parameters estimated from measured profile points by local least squares.

    Parameters
    ----------
    x_mm, z_mm : ndarray of shape (K,)
        Profile points in the profile frame, in any order [mm].
    strength : ndarray of shape (K,), optional
        Line strength of each point's centre (`Centres.strength`): the flank fits weight
        the points by it (`FLANK_WEIGHT_STRENGTH`); None fits them unweighted.

    Returns
    -------
    FlangeParameters

    Raises
    ------
    FlangeNotFoundError
        If the flange top has too few points, or its crest is not above z = 12 mm (no
        flange: before pipeline 0.12.0 the flank at 12 mm ensured it). A flank without
        points at 12 mm leaves Sd not measured, one without points at 10 mm Sd 10 and qR,
        one without points at Sh − 2 only qR (`FlangeParameters.reason` says which and why).

    Notes
    -----
    Sh: the crest of a quadratic z(x) within ±2.5 mm, over the points within 2 mm below the
    crest of a first quadratic through all of them, started at the highest points on the
    profile's one curve z(x), once a circle fitted within ±4 mm of it shows a crest seen on
    both sides (`_fit_top`), widened while the points' scatter calls for it
    (`TOP_WIDER_WINDOWS_MM`). Each flank abscissa is a quadratic x(z) fitted to points on
    the tread side of the top within ±2 mm of the Sd heights and ±1 mm of Sh − 2,
    evaluated at that height (at 12 mm widened likewise, `SD_WIDER_FITS`); a gap of
    ≤ 2.5 mm about the height with points on both sides is bridged by the fit over ±3 mm.
    Both sides of the crest must hold points: a crest seen on one side only is not
    measured.
    """
    x, z = _check_points(x_mm, z_mm)
    if strength is not None:
        strength = np.asarray(strength, dtype=GEOMETRY_FLOAT)
        if strength.shape != x.shape or not np.all(np.isfinite(strength)):
            raise ValueError(f"strength must be finite of shape {x.shape}, got {strength.shape}")
    x_top, height = _fit_top(x, z)
    if not math.isfinite(height):
        raise FlangeNotFoundError("the flange top fit failed")
    if height <= SD_HEIGHT_MM:
        # Sd and Sd 10 are defined on a flange that rises above them; a crest lower than
        # that is a bump of the tread or of a piece left, not a flange (real Sh: 25–36 mm)
        raise FlangeNotFoundError(
            f"no flange: the highest crest is at z = {height:.2f} mm, not above the Sd height "
            f"z = {SD_HEIGHT_MM:.2f} mm"
        )
    reasons: list[str] = []
    gap = 0.0

    def flank(
        height_mm: float, half_window_mm: float, name: str, wider: tuple = ()
    ) -> float | None:
        nonlocal gap
        try:
            x_flank, bridged = _fit_flank(x, z, x_top, height_mm, half_window_mm, strength, wider)
        except FlangeNotFoundError as exc:
            reasons.append(f"{name}: {exc}")
            return None
        gap = max(gap, bridged)
        return x_flank

    flank_12 = flank(SD_HEIGHT_MM, SD_FIT_HALF_WINDOW_MM, "Sd", SD_WIDER_FITS)
    flank_10 = flank(SD_EN_HEIGHT_MM, SD_FIT_HALF_WINDOW_MM, "Sd 10")
    qr = None
    if flank_10 is None:
        reasons.append(f"qR: needs the flank at z = {SD_EN_HEIGHT_MM:.2f} mm")
    else:
        flank_top = flank(height - QR_DROP_MM, FLANK_HALF_WINDOW_MM, "qR")
        qr = None if flank_top is None else flank_10 - flank_top
    return FlangeParameters(
        height, flank_12, flank_10, qr, gap, "; ".join(reasons) if reasons else None
    )
