"""Tread and rim parameters of a wheel profile: tread hollow, flange angle, rim width.

Definitions (the profile frame of docs/coordinate-frames.md: x from the back face, z up
towards the flange tip; docs/numbers.md says where each value is used):

- Tread hollow: the largest depth of the tread below the straight line (a straight edge)
  through the profile at x = 60 mm and x = 120 mm, over 60–120 mm. A straight edge across
  the tread is how hollow treads are gauged in service (e.g. the AAR Field Manual, Rule 41,
  "tread worn hollow"); the two points are this system's choice: they keep the edge off the
  flange root and the field-side chamfer of LMA and S1002. The new profiles are slightly
  concave there and read 0.045 mm (LMA) and 0.117 mm (S1002).
- Flange angle: the steepest angle to the horizontal of the flange flank, from lines x(z)
  fitted over 10 mm of height (z ± 5 mm) centred from z = 6 mm to Sh − 6 mm, on the flank
  resampled every 0.25 mm of height (gaps up to 2.5 mm bridged, as for Sd and qR). It
  enters Nadal's derailment limit Y/Q = (tan δ − μ)/(1 + μ tan δ) [1]. Where the flank's
  points leave a longer gap, the steepest part may be in it, so the angle is not measured
  (with the reason).
- Rim width: x of the field-side face, where the outer sensor sees that face; otherwise the
  wheel's rim width is not measured, with the reason.

The same functions read the measured points and the simulator's true outline, so the truth
follows the same definitions.

References
----------
[1] M. J. Nadal, 'Théorie de la stabilité des locomotives, part 2: mouvement de lacet',
    Annales des Mines 10:232–255, 1896.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.errors import PipelineError
from pipeline.profile.flange import MAX_FLANK_GAP_MM
from pipeline.profile.wheelset import (
    FIELD_FACE_MM,
    WheelCurve,
    local_quadratics,
    outline_running_surface,
    surface_quadratics,
)

HOLLOW_EDGE_X_MM = (60.0, 120.0)
HOLLOW_HALF_WINDOW_MM = 5.0
HOLLOW_STEP_MM = 0.5
"""A measured profile's tread hollow is read on its own surface (`hollow_surface`): local
quadratics over ±5 mm of the tread every 0.5 mm from 60 to 120 mm, not the running surface
the contact search needs (±1.5 mm every 0.1 mm; about 10 times the work over the whole
curve at ±5 mm): the hollow is the largest depth below the straight edge, and the
largest of a noisy curve is biased deep. A hollow spans tens of millimetres, so the wider
quadratics follow it: on the MiniProf files the hollow moves by −0.010…+0.003 mm (±8 mm:
−0.025…+0.047), on the clean passes (seed 2026) its MAE goes 0.008 → 0.009 mm. Field passes,
3 frames per sensor (docs/simulator.md, "The tread hollow on a smoother surface"), MAE /
largest per-wheel Std [mm]: seed 2027 0.046 / 0.054 → 0.028 / 0.041, held-out seed 2028
0.045 / 0.056 → 0.030 / 0.050."""
FLANK_HALF_HEIGHT_MM = 5.0
FLANK_MARGIN_MM = 6.0
FLANK_STEP_MM = 0.25
FLANK_SMOOTH_MM = 1.0
FLANK_FOOT_MM = 0.5
"""Flank windows: z ± 5 mm, centred every 0.25 mm from 6 mm to Sh − 6 mm, on x(z) resampled
every 0.25 mm by local quadratics over ±1 mm of the flank's points above z = 0.5 mm (below,
the tread). Centres from 5, 6 or 7 mm, points above 0.5 or 1 mm: the same figures. On 9
simulated passes (seed 2026; 8 wheels, worn flanks with a steep step) the largest per-wheel
Std, the largest error against the truth and the values not measured (of 72): this 0.198°,
0.35°, 22; z ± 4 mm 0.201°, 0.63°, 22; z ± 3 mm 0.253°, 0.79°, 22; lines on the raw points
over z ± 3 mm with gaps ≤ 1 mm (the definition before) 0.250°, 0.49°, 28; one line over a
fixed band Sh − 17…Sh − 11 mm 1.73°, 4.9°, 2 (a band that holds the worn step in some
passes and not in others)."""
MIN_FACE_POINTS = 20
FACE_BAND_MM = 1.5


class TreadNotFoundError(PipelineError):
    """The profile lacks the tread or flank points a parameter needs."""


@dataclass(frozen=True, slots=True)
class TreadParameters:
    """Tread and rim parameters of one wheel.

    Attributes
    ----------
    tread_hollow_mm : float or None
        Depth below the 60–120 mm straight edge [mm].
    flange_angle_deg : float or None
        Steepest flank angle to the horizontal [°].
    rim_width_mm : float or None
        Back face to field face [mm].
    reason : str or None
        Why any of them is None ("; "-separated, each naming its parameter).
    """

    tread_hollow_mm: float | None
    flange_angle_deg: float | None
    rim_width_mm: float | None
    reason: str | None


def hollow_surface(x_mm: np.ndarray, z_mm: np.ndarray) -> WheelCurve:
    """The tread z(x) the hollow of measured points is read on: robust local quadratics over
    ±`HOLLOW_HALF_WINDOW_MM` every `HOLLOW_STEP_MM` across the straight edge's span
    (`surface_quadratics`), nodes without enough points left out.

    Raises
    ------
    TreadNotFoundError
        If fewer than two nodes have points.
    """
    a, b = HOLLOW_EDGE_X_MM
    grid = np.linspace(a, b, int(round((b - a) / HOLLOW_STEP_MM)) + 1)
    values = surface_quadratics(x_mm, z_mm, grid, np.full(grid.size, HOLLOW_HALF_WINDOW_MM))
    good = np.isfinite(values)
    if np.count_nonzero(good) < 2:
        raise TreadNotFoundError("no tread points from 60 to 120 mm for the hollow")
    return WheelCurve(grid[good], values[good])


def tread_hollow(curve: WheelCurve) -> float:
    """Largest depth of the running surface below the 60–120 mm straight edge [mm].

    Raises
    ------
    TreadNotFoundError
        If the curve does not span 60–120 mm.
    """
    a, b = HOLLOW_EDGE_X_MM
    if curve.x_mm[0] > a or curve.x_mm[-1] < b:
        raise TreadNotFoundError(
            f"the tread is seen from x = {curve.x_mm[0]:.1f} to {curve.x_mm[-1]:.1f} mm, "
            f"the hollow needs {a:.0f}–{b:.0f} mm"
        )
    inside = (curve.x_mm > a) & (curve.x_mm < b)
    x = np.concatenate([[a], curve.x_mm[inside], [b]])
    z = np.interp(x, curve.x_mm, curve.z_mm)
    edge = z[0] + (z[-1] - z[0]) * (x - a) / (b - a)
    return float(max(np.max(edge - z), 0.0))


def flange_angle(x_mm: np.ndarray, z_mm: np.ndarray, flange_height_mm: float) -> float:
    """Steepest flank angle [°]: the largest slope of lines x(z) over 10 mm of flank height.

    Parameters
    ----------
    x_mm, z_mm : ndarray of shape (K,)
        Profile points (any order), flange and tread [mm].
    flange_height_mm : float
        Sh [mm]: the windows' centres run from 6 mm to Sh − 6 mm.

    Returns
    -------
    float
        δ, the angle to the horizontal of the steepest window's line [°], below 90°.

    Raises
    ------
    TreadNotFoundError
        If the flank leaves a gap of more than 2.5 mm in height, or overhangs.

    Notes
    -----
    The flank's points (field side of the flange top, above z = 0.5 mm) are resampled as
    x(z) every 0.25 mm of height by robust local quadratics over z ± 1 mm (`local_quadratics`), and
    heights without points are bridged linearly up to `MAX_FLANK_GAP_MM` (the bridging of
    the flank by the flange parameters); the least-squares slope of that uniform x(z) over
    each window z ± 5 mm is then one correlation, and δ = atan(−dz/dx) of the steepest.
    Every window has the same weight at every height, so the gaps a dim steep flank leaves
    in one pass and not the next do not move the windows' lines.
    """
    flank = (x_mm > x_mm[int(np.argmax(z_mm))]) & (z_mm >= FLANK_FOOT_MM)
    order = np.argsort(z_mm[flank], kind="stable")
    fz, fx = z_mm[flank][order], x_mm[flank][order]
    low, high = FLANK_MARGIN_MM, flange_height_mm - FLANK_MARGIN_MM
    if high <= low:
        raise TreadNotFoundError(f"the flange is {flange_height_mm:.1f} mm high, too low for δ")
    count = int(round(FLANK_HALF_HEIGHT_MM / FLANK_STEP_MM))
    grid = np.arange(low - FLANK_HALF_HEIGHT_MM, high + FLANK_HALF_HEIGHT_MM + 1e-9, FLANK_STEP_MM)
    values = local_quadratics(fz, fx, grid, np.full(grid.size, FLANK_SMOOTH_MM))
    seen = np.flatnonzero(np.isfinite(values))
    if seen.size < 2 * count + 1:
        raise TreadNotFoundError("too few flank points for the flange angle")
    # Unseen heights between (or beyond) the seen nodes: a run longer than the bridge is a gap.
    edges = np.concatenate([[-1], seen, [grid.size]])
    runs = (np.diff(edges) - 1) * FLANK_STEP_MM
    if runs.max() > MAX_FLANK_GAP_MM:
        k = int(np.argmax(runs))
        below = grid[edges[k]] if edges[k] >= 0 else grid[0]
        above = grid[edges[k + 1]] if edges[k + 1] < grid.size else grid[-1]
        raise TreadNotFoundError(
            f"the flank shows no points from z = {below:.1f} to {above:.1f} mm "
            f"(gaps ≤ {MAX_FLANK_GAP_MM} mm are bridged)"
        )
    x = np.interp(grid, grid[seen], values[seen])
    offsets = FLANK_STEP_MM * np.arange(-count, count + 1)
    slopes = np.correlate(x, offsets / np.sum(offsets * offsets), mode="valid")
    angles = np.degrees(np.arctan2(1.0, -slopes))  # dx/dz < 0 down the flank
    # Windows reaching past the first or last seen height would read a made-up flat x.
    starts = np.arange(angles.size)
    inside = (starts >= seen[0]) & (starts + 2 * count <= seen[-1])
    if not np.any(inside):
        raise TreadNotFoundError("too few flank points for the flange angle")
    angles = np.where(inside, angles, -np.inf)
    k = int(np.argmax(angles))
    if angles[k] >= 90.0:
        # x rising with z: a flank cannot overhang, so these points are not the wheel's.
        raise TreadNotFoundError(
            f"the flank overhangs at z = {grid[k + count]:.1f} mm ({angles[k]:.1f}°): "
            "points off the wheel"
        )
    return float(angles[k])


def rim_width(x_mm: np.ndarray, z_mm: np.ndarray) -> tuple[float | None, str | None]:
    """x of the field-side face [mm] and None, or None and why it is not measured."""
    low, high = FIELD_FACE_MM
    face = (z_mm >= low) & (z_mm <= high) & (x_mm > 100.0)
    if np.count_nonzero(face) < MIN_FACE_POINTS:
        return None, (
            f"the outer sensor shows no field-side face ({np.count_nonzero(face)} points "
            f"between z = {low:.0f} and {high:.0f} mm)"
        )
    x = x_mm[face]
    middle = float(np.median(x))
    line = np.abs(x - middle) <= FACE_BAND_MM
    span = np.ptp(z_mm[face][line]) if np.any(line) else 0.0
    if np.count_nonzero(line) < MIN_FACE_POINTS or span < 5.0:
        return None, "the field-side points do not form a vertical face"
    return float(np.median(x[line])), None


def tread_parameters(
    x_mm: np.ndarray,
    z_mm: np.ndarray,
    curve: WheelCurve,
    flange_height_mm: float,
    smooth_hollow: bool = False,
) -> TreadParameters:
    """Tread hollow, flange angle and rim width of one wheel's profile.

    Parameters
    ----------
    x_mm, z_mm : ndarray of shape (K,), float64
        The profile's points (measured, or a true outline) [mm].
    curve : WheelCurve
        Its running surface (`running_surface` or `outline_running_surface`).
    flange_height_mm : float
        Sh of the profile [mm].
    smooth_hollow : bool
        Read the tread hollow on `hollow_surface` of the points (measured profiles) instead
        of on `curve` (a true outline: the definition).

    Returns
    -------
    TreadParameters

    A parameter whose points are missing is None, and `reason` says why.
    """
    reasons = []
    hollow = angle = None
    try:
        hollow = tread_hollow(hollow_surface(x_mm, z_mm) if smooth_hollow else curve)
    except PipelineError as exc:
        reasons.append(f"tread hollow: {exc}")
    try:
        angle = flange_angle(x_mm, z_mm, flange_height_mm)
    except PipelineError as exc:
        reasons.append(f"flange angle: {exc}")
    width, why = rim_width(x_mm, z_mm)
    if why is not None:
        reasons.append(f"rim width: {why}")
    return TreadParameters(hollow, angle, width, "; ".join(reasons) or None)


def outline_tread_values(
    x_mm: np.ndarray, z_mm: np.ndarray, flange_height_mm: float
) -> dict[str, float | None]:
    """Tread hollow, flange angle and rim width of a clean outline (back face → field face),
    as the simulator's truth rows carry them: the same definitions as the measurement."""
    values = tread_parameters(x_mm, z_mm, outline_running_surface(x_mm, z_mm), flange_height_mm)
    return {
        "tread_hollow_mm": values.tread_hollow_mm,
        "flange_angle_deg": values.flange_angle_deg,
        "rim_width_mm": float(np.max(x_mm)),
    }
