"""Rolling-radius difference of a wheelset on reference rails by a rigid contact search.

The two wheel profiles of an axle are placed at the axle's back-to-back distance, the
wheelset is shifted laterally by y and, at each y, lowered and rolled until both wheels
touch their rails (rigid bodies, no penetration, vertical approach). The rolling radius of
each wheel is its radius at its contact point, so Δr(y) = r_right − r_left; both wheels are
taken to have the same radius at the tread reference point (one laser plane per sensor
cannot measure a wheel's radius).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pipeline.errors import PipelineError
from pipeline.imaging import GEOMETRY_FLOAT
from pipeline.profile.conicity import (
    CURVE_AMPLITUDES_MM,
    NOMINAL_AMPLITUDE_MM,
    RollingRadiusDifference,
    equivalent_conicity,
)
from pipeline.profile.rails import TrackRails

NOMINAL_WHEEL_RADIUS_MM = 420.0
"""Radius at the tread reference point assumed for measured wheels (840 mm LM wheels); it
only sets the lever of the wheelset's roll, which moves Δr by < 0.001 mm per 10 mm."""
SHIFT_RANGE_MM = 10.0
SHIFT_STEP_MM = 0.05
"""Lateral shifts searched: −10…10 mm in 0.05 mm steps (past flange contact of new wheels
on gauge 1435; finer steps move λₑ(3 mm) by < 1e-4 on the simulated wheels)."""
ROLL_ITERATIONS = 30
ROLL_TOLERANCE_MM = 1e-9


class ContactError(PipelineError):
    """The wheel profiles do not cover the part of the rails they can touch."""


@dataclass(frozen=True, slots=True, eq=False)
class WheelCurve:
    """One wheel's running surface as a graph z(x) in the profile frame [mm].

    Attributes
    ----------
    x_mm, z_mm : ndarray of shape (K,), float64
        From the flange top towards the field side, x strictly increasing [mm].
    """

    x_mm: np.ndarray
    z_mm: np.ndarray

    def __post_init__(self) -> None:
        x = np.array(self.x_mm, dtype=GEOMETRY_FLOAT)
        z = np.array(self.z_mm, dtype=GEOMETRY_FLOAT)
        if x.ndim != 1 or x.shape != z.shape or x.size < 2 or np.any(np.diff(x) <= 0):
            raise ValueError("a wheel curve needs ≥ 2 points with x strictly increasing")
        for name, array in (("x_mm", x), ("z_mm", z)):
            array.flags.writeable = False
            object.__setattr__(self, name, array)


@dataclass(frozen=True, slots=True, eq=False)
class AxleConicity:
    """Δr(y) of one axle on its rails and the equivalent conicity from it.

    Attributes
    ----------
    delta_r : RollingRadiusDifference
    conicity_3mm : float or None
        λₑ at ŷ = 3 mm (None where the table does not support it).
    curve_amplitudes_mm, curve_conicity : tuple of float
        λₑ at `CURVE_AMPLITUDES_MM` (None where unsupported).
    rail : str
    inclination : str
    gauge_mm : float
    """

    delta_r: RollingRadiusDifference
    conicity_3mm: float | None
    curve_amplitudes_mm: tuple[float, ...]
    curve_conicity: tuple[float | None, ...]
    rail: str
    inclination: str
    gauge_mm: float


def _side_points(curve: WheelCurve, half_b2b_mm: float, radius_mm: float, sign: int):
    """Wheel surface in the wheelset frame (X from the axle centre, Z from the axis)."""
    return sign * (half_b2b_mm + curve.x_mm), -(radius_mm + curve.z_mm)


def _gap(wheel_x, wheel_z, rail_x, rail_z) -> tuple[float, float]:
    """Smallest vertical distance wheel − rail and the X where it occurs.

    The wheel is interpolated at the rail's nodes (finer than the wheel's), and the minimum
    refined by the parabola through it and its neighbours.
    """
    order = np.argsort(wheel_x)
    wx, wz = wheel_x[order], wheel_z[order]
    inside = (rail_x > wx[0]) & (rail_x < wx[-1])
    if np.count_nonzero(inside) < 3:
        raise ContactError("the wheel profile does not reach over its rail")
    rx, rz = rail_x[inside], rail_z[inside]
    gap = np.interp(rx, wx, wz) - rz
    k = int(np.argmin(gap))
    if 0 < k < gap.size - 1:
        a, b, c = gap[k - 1], gap[k], gap[k + 1]
        curvature = a - 2 * b + c
        if curvature > 0:
            t = 0.5 * (a - c) / curvature
            step = rx[k + 1] - rx[k] if t > 0 else rx[k] - rx[k - 1]
            return float(b - 0.25 * (a - c) * t), float(rx[k] + t * step)
    return float(gap[k]), float(rx[k])


def _contact(left, right, rails: TrackRails, shift_mm: float) -> tuple[float, float]:
    """Contact X of each wheel in the wheelset frame at lateral shift y, both wheels touching.

    Newton on the roll φ: the right wheel's gap minus the left's changes by about
    (X_right − X_left)·dφ, so a few steps level them.
    """
    phi = 0.0
    for _ in range(ROLL_ITERATIONS):
        c, s = math.cos(phi), math.sin(phi)
        placed, gaps, xs = [], [], []
        for (wx, wz), rail_x, rail_z in (
            (left, rails.left_x_mm, rails.left_z_mm),
            (right, rails.right_x_mm, rails.right_z_mm),
        ):
            x_track = c * wx - s * wz + shift_mm
            gap, x_contact = _gap(x_track, s * wx + c * wz, rail_x, rail_z)
            placed.append((x_track, wx))
            gaps.append(gap)
            xs.append(x_contact)
        difference = gaps[1] - gaps[0]
        if abs(difference) < ROLL_TOLERANCE_MM:
            break
        phi -= difference / (xs[1] - xs[0])
    # The contact's X on the placed wheel back to the wheel's own X (the roll moves the
    # running surface sideways by about radius·φ).
    result = []
    for (x_track, wx), x_contact in zip(placed, xs, strict=True):
        order = np.argsort(x_track)
        result.append(float(np.interp(x_contact, x_track[order], wx[order])))
    return result[0], result[1]


def rolling_radius_difference(
    left: WheelCurve,
    right: WheelCurve,
    back_to_back_mm: float,
    rails: TrackRails,
    *,
    radius_mm: float = NOMINAL_WHEEL_RADIUS_MM,
    shift_range_mm: float = SHIFT_RANGE_MM,
    shift_step_mm: float = SHIFT_STEP_MM,
) -> RollingRadiusDifference:
    """Δr(y) = r_right − r_left of an axle at lateral shifts y by rigid contact search.

    Parameters
    ----------
    left, right : WheelCurve
        The running surfaces of the left and right wheel (profile frame, each from its own
        back face) [mm].
    back_to_back_mm : float
        Distance between the wheels' back faces [mm], 1300–1400.
    rails : TrackRails
    radius_mm : float
        Wheel radius at the tread reference point [mm] (the lever of the roll).
    shift_range_mm, shift_step_mm : float
        Shifts y from −range to +range in steps [mm].

    Returns
    -------
    RollingRadiusDifference

    Raises
    ------
    ContactError
        If a wheel curve does not reach over its rail at some shift.
    """
    if not (np.isfinite(back_to_back_mm) and 1300 <= back_to_back_mm <= 1400):
        raise ValueError(f"back_to_back_mm must be in [1300, 1400], got {back_to_back_mm}")
    if not (0 < shift_step_mm <= shift_range_mm):
        raise ValueError(
            f"need 0 < shift_step_mm ≤ shift_range_mm, got {shift_step_mm}, {shift_range_mm}"
        )
    half = back_to_back_mm / 2
    sides = (_side_points(left, half, radius_mm, -1), _side_points(right, half, radius_mm, 1))
    count = int(round(shift_range_mm / shift_step_mm))
    shifts = shift_step_mm * np.arange(-count, count + 1)
    delta = np.empty(shifts.size)
    for i, shift in enumerate(shifts):
        x_left, x_right = _contact(*sides, rails, float(shift))
        z_left = np.interp(-x_left - half, left.x_mm, left.z_mm)
        z_right = np.interp(x_right - half, right.x_mm, right.z_mm)
        delta[i] = z_right - z_left  # r = radius + z at the contact; the radius cancels
    return RollingRadiusDifference(shifts, delta)


def axle_conicity(
    left: WheelCurve,
    right: WheelCurve,
    back_to_back_mm: float,
    rails: TrackRails,
    *,
    radius_mm: float = NOMINAL_WHEEL_RADIUS_MM,
) -> AxleConicity:
    """Δr(y) of an axle and its equivalent conicity at 3 mm and over 1–7 mm (EN 15302).

    Parameters
    ----------
    left, right : WheelCurve
    back_to_back_mm : float
    rails : TrackRails
    radius_mm : float

    Returns
    -------
    AxleConicity
    """
    delta_r = rolling_radius_difference(left, right, back_to_back_mm, rails, radius_mm=radius_mm)
    amplitudes = np.array((NOMINAL_AMPLITUDE_MM, *CURVE_AMPLITUDES_MM))
    values = [None if np.isnan(v) else float(v) for v in equivalent_conicity(delta_r, amplitudes)]
    return AxleConicity(
        delta_r=delta_r,
        conicity_3mm=values[0],
        curve_amplitudes_mm=CURVE_AMPLITUDES_MM,
        curve_conicity=tuple(values[1:]),
        rail=rails.rail,
        inclination=rails.inclination,
        gauge_mm=rails.gauge_mm,
    )
