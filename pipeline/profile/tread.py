"""Tread and rim parameters of a wheel profile: tread hollow, flange angle, rim width.

Definitions (profile frame of DESIGN.md: x from the back face, z up towards the flange tip):

- Tread hollow: the largest depth of the tread below the straight line (a straight edge)
  through the profile at x = 60 mm and x = 120 mm, over 60–120 mm. A straight edge across
  the tread is how hollow treads are gauged in service (e.g. the AAR Field Manual, Rule 41,
  "tread worn hollow"); the two points are this system's choice: they keep the edge off the
  flange root and the field-side chamfer of LMA and S1002. The new profiles are slightly
  concave there and read 0.045 mm (LMA) and 0.117 mm (S1002).
- Flange angle: the steepest angle to the horizontal of the flange flank, from lines x(z)
  fitted over 6 mm of height (z ± 3 mm) centred from z = 3 mm to Sh − 3 mm. It enters
  Nadal's derailment limit Y/Q = (tan δ − μ)/(1 + μ tan δ) [1]. Where the flank's points
  leave a gap of more than 1 mm in height there, the steepest part may be in the gap, so
  the angle is not measured (with the reason).
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

import math
from dataclasses import dataclass

import numpy as np

from pipeline.errors import PipelineError
from pipeline.profile.flange import robust_polyfit
from pipeline.profile.wheelset import FIELD_FACE_MM, WheelCurve, outline_running_surface

HOLLOW_EDGE_X_MM = (60.0, 120.0)
FLANK_HALF_HEIGHT_MM = 3.0
FLANK_MARGIN_MM = 3.0
FLANK_STEP_MM = 0.25
"""Flank windows: z ± 3 mm, centred every 0.25 mm from 3 mm to Sh − 3 mm (off the root
fillet and the crest arc, whose angle is not the flank's). On 9 simulated passes ±3 mm
gave a largest per-wheel Std of 0.38° and bias ≤ 0.21°; ±1.5 mm 1.6° and 0.9° (the
maximum over windows picks up the noise of the short fits)."""
MIN_WINDOW_POINTS = 15
FLANK_GAP_MM = 1.0
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
    """Steepest flank angle [°] from lines x(z) over z ± 3 mm of the flank.

    Parameters
    ----------
    x_mm, z_mm : ndarray of shape (K,)
        Profile points (any order), flange and tread [mm].
    flange_height_mm : float
        Sh [mm], the top of the flank windows.

    Raises
    ------
    TreadNotFoundError
        If no window holds enough flank points.
    """
    flank = x_mm > x_mm[int(np.argmax(z_mm))]
    fx, fz = x_mm[flank], z_mm[flank]
    low, high = FLANK_MARGIN_MM, flange_height_mm - FLANK_MARGIN_MM
    heights = np.sort(fz[(fz >= low - FLANK_HALF_HEIGHT_MM) & (fz <= high + FLANK_HALF_HEIGHT_MM)])
    if heights.size < MIN_WINDOW_POINTS:
        raise TreadNotFoundError("too few flank points for the flange angle")
    steps = np.diff(np.concatenate([[low], heights, [high]]))
    if steps.max() > FLANK_GAP_MM:
        k = int(np.argmax(steps))
        edges = np.concatenate([[low], heights, [high]])[k : k + 2]
        raise TreadNotFoundError(
            f"the flank shows no points from z = {edges[0]:.1f} to {edges[1]:.1f} mm"
        )
    steepest, at = -math.inf, math.nan
    for centre in np.arange(low, high + 1e-9, FLANK_STEP_MM):
        near = np.abs(fz - centre) <= FLANK_HALF_HEIGHT_MM
        if np.count_nonzero(near) < MIN_WINDOW_POINTS:
            continue
        try:
            slope = robust_polyfit(fz[near] - centre, fx[near], 1, "flank")[0]
        except PipelineError:
            continue
        angle = math.degrees(math.atan2(1.0, -slope))  # dx/dz < 0 down the flank
        if angle > steepest:
            steepest, at = angle, float(centre)
    if not math.isfinite(steepest):
        raise TreadNotFoundError("too few flank points for the flange angle")
    if steepest >= 90.0:
        # x rising with z: a flank cannot overhang, so these points are not the wheel's.
        raise TreadNotFoundError(
            f"the flank overhangs at z = {at:.1f} mm ({steepest:.1f}°): points off the wheel"
        )
    return steepest


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
    x_mm: np.ndarray, z_mm: np.ndarray, curve: WheelCurve, flange_height_mm: float
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

    Returns
    -------
    TreadParameters

    A parameter whose points are missing is None, and `reason` says why.
    """
    reasons = []
    hollow = angle = None
    try:
        hollow = tread_hollow(curve)
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
