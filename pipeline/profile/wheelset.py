"""Rolling-radius difference of a wheelset on reference rails by a rigid contact search.

The two wheel profiles of an axle are placed at the axle's back-to-back distance, the
wheelset is shifted laterally by y and, at each y, lowered and rolled until both wheels
touch their rails (rigid bodies, no penetration, vertical approach). The rolling radius of
each wheel is its radius at its contact point, so Δr(y) = r_right − r_left; both wheels are
taken to have the same radius at the tread reference point (one laser plane per sensor
cannot measure a wheel's radius).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.errors import PipelineError
from pipeline.imaging import freeze_geometry
from pipeline.profile.conicity import (
    CURVE_AMPLITUDES_MM,
    NOMINAL_AMPLITUDE_MM,
    ConicityError,
    RollingRadiusDifference,
    equivalent_conicity,
)
from pipeline.profile.flange import (
    MIN_FIT_POINTS,
    OUTLIER_FLOOR_MM,
    OUTLIER_MADS,
    OUTLIER_PASSES,
)
from pipeline.profile.rails import TrackRails, track_rails

NOMINAL_WHEEL_RADIUS_MM = 420.0
"""Radius at the tread reference point assumed for measured wheels (840 mm LM wheels); it
only sets the lever of the wheelset's roll: λₑ changes by about λₑ·γ·Δr₀/e, 1e-4 per 10 mm
of radius at λₑ = 0.15 (the coned-wheel case of `tests/pipeline/test_rails.py`)."""
SHIFT_RANGE_MM = 10.0
SHIFT_STEP_MM = 0.05
"""Lateral shifts searched: −10…10 mm in 0.05 mm steps (past flange contact of new wheels
on gauge 1435); 0.02 mm steps move λₑ(3 mm) by ≤ 0.001 on worn simulated wheels (contact
jumps fall between the steps) and take 2.5× as long."""
CURVE_STEP_MM = 0.1
CURVE_HALF_WINDOW_MM = 0.5
TREAD_HALF_WINDOW_MM = 1.5
FLANGE_ZONE_MM = 15.0
"""The measured running surface: local quadratics z(x) every 0.1 mm, over ±0.5 mm within
15 mm of the flange top (flank and root) and ±1.5 mm beyond. λₑ(3 mm) error against the
truth (RMS, max) on the benchmark's 36 axle-passes (seed 2026), where the width was chosen:
±0.5 mm 0.0098, 0.021; ±1 mm 0.0063, 0.016; ±1.5 mm 0.0065, 0.019; ±2 mm 0.0066, 0.021;
±3 mm 0.0071, 0.023; on 16 other axle-passes (seed 99): ±1 mm 0.0084, 0.017; ±1.5 mm
0.0061, 0.014; ±2 mm 0.0064, 0.017. A quadratic over ±1.5 mm departs from an R13 root arc
by 1.5⁴/(8·13³) < 0.001 mm."""
MAX_SURFACE_GAP_MM = 8.0
"""The longest stretch of running surface without points that the conicity bridges. A
straight bridge across a concave flange root lies above the wheel, so a rail touches the
bridge: the demo pass's field frames (seed 2026, harsh) left 14–19 mm of root unseen on
three wheels and λₑ(3 mm) read 0.227 for a true 0.127 and 0.328 (Steger) for 0.156. On the
benchmark's clean passes the longest gap is 6.0 mm, its axle 0.007 from the truth."""
BRIDGE_SAG_MM = 0.02
"""A contact on a shorter bridge is refused when the bridge's estimated sag, L·|Δs|/8 for a
stretch of length L whose edge slopes differ by Δs (a parabola's chord; 0.037 for the true
0.035 mm across 36–42 mm beyond an S1002's flange top), exceeds 0.02 mm: the Δr(y) nodes
whose contact falls on it are dropped, and with them the amplitudes whose swing reaches
them. Near the root the contact slides along a slope of ~0.1, so small heights move it by
millimetres: that 6 mm bridge on both wheels of a new S1002 pair reads λₑ(3 mm) 0.205 for
0.177, one 8.0 mm long on a root (the flange cut alone, seed 2027, pass 3 V002/1) 0.313 for
0.220. 0.02 mm is twice the clean passes' largest tread height error (RMS 0.011 mm at
38–80 mm beyond the top, seed 2026); on the clean benchmark's 9 passes it drops three
accurate curve values (pass 7 V001/4 at 6–7 mm, errors ≤ 0.008, a bridge of 0.03–0.05 mm
sag) and no λₑ(3 mm)."""
BUMP_HALF_WINDOW_MM = 4.0
BUMP_MM = 0.08
BUMP_ZONE_MM = 25.0
"""A node of the tread (from 25 mm beyond the flange top, its ±4 mm inside the running
surface and short of the field-side chamfer, `CURVE_REACH_MM`) more than 0.08 mm above the
robust quadratic through the nodes within ±4 mm of it is a bump, not the wheel: a glint's
or a glare stretch's hook (0.15–0.6 mm over 1–2 mm of profile) that the ±1.5 mm fits keep.
A rail touches a bump before the surface around it, so the contact sticks there: on the
field benchmark's pass 9 V002/2 (seed 2027) the rails touched hooks 35–37 mm beyond the
flange tops from y = −1 to +2 mm and λₑ(3 mm) read 0.480 for a true 0.227 (above the 0.4
alarm). Shifts whose contact falls on a bump are dropped as those on a sagging bridge are.
On the true outlines of 96 simulated worn wheels (seeds 2026–2028, 7, 8, 99) no tread node
lies more than 0.041 mm above that quadratic and none is a bump; nearer the flange the
flank turns into the root within the window (up to 1.6 mm above it), and the chamfer
beyond the rails' reach is as sharp."""
EDGE_SLOPE_NODES = 3
"""Each edge slope of a bridge: over the 3 nodes (0.3 mm) of running surface beside it."""
CURVE_REACH_MM = 110.0
"""The running surface from the flange top to 110 mm beyond it (x ≈ 126 mm): the rails can
touch up to x ≈ 123 mm at a 10 mm shift."""
FIELD_FACE_MM = (-35.0, -12.0)
"""z range of the field-side face below the chamfer (z > −10 mm on LMA and S1002): points
there are the face, not the running surface."""
ROLL_ITERATIONS = 60
ROLL_TOLERANCE_MM = 1e-5
"""Both gaps equal to 10 nm (a roll error of 1e-8 rad, nothing in Δr), or the roll's step
below 1e-10 rad: at flange contact the minima's parabolic refinement wanders by ~1e-6 mm."""
ROLL_BRACKET_RAD = 0.05
"""The roll stays within ±0.05 rad (a 75 mm height difference across the wheelset)."""


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
        freeze_geometry(self, "x_mm", "z_mm")
        x, z = self.x_mm, self.z_mm
        if x.ndim != 1 or x.shape != z.shape or x.size < 2 or np.any(np.diff(x) <= 0):
            raise ValueError("a wheel curve needs ≥ 2 points with x strictly increasing")


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
    reason : str or None
        Why `delta_r` covers fewer shifts than searched (a rail touching a sagging bridge
        beyond them), None when it covers them all.
    """

    delta_r: RollingRadiusDifference
    conicity_3mm: float | None
    curve_amplitudes_mm: tuple[float, ...]
    curve_conicity: tuple[float | None, ...]
    rail: str
    inclination: str
    gauge_mm: float
    reason: str | None = None


def local_quadratics(
    x_mm: np.ndarray, z_mm: np.ndarray, grid_mm: np.ndarray, half_mm: np.ndarray
) -> np.ndarray:
    """Robust local quadratic z(x) at each grid node, all nodes at once (NaN where none).

    The fit of `robust_polyfit` (flange.py) batched over nodes: least squares on the points
    within ±half of the node, points beyond 3 robust standard deviations (at least 0.03 mm)
    dropped and the fit repeated, up to 4 passes; a node with fewer than 5 points, or points
    spread over less than half its window, gets NaN. `tests/pipeline/test_tread.py` checks
    it against `robust_polyfit` node by node.

    Parameters
    ----------
    x_mm, z_mm : ndarray of shape (K,)
        Points sorted by x [mm].
    grid_mm, half_mm : ndarray of shape (N,)
        Nodes and their window half-widths [mm].

    Returns
    -------
    ndarray of shape (N,), float64
        The fitted z at each node [mm].
    """
    lo, hi = np.searchsorted(x_mm, grid_mm - half_mm), np.searchsorted(x_mm, grid_mm + half_mm)
    counts = hi - lo
    width = max(int(counts.max(initial=0)), 1)
    slots = np.arange(width)
    valid = slots[None, :] < counts[:, None]
    index = np.minimum(lo[:, None] + slots[None, :], x_mm.size - 1)
    t = np.where(valid, x_mm[index] - grid_mm[:, None], 0.0)
    z = np.where(valid, z_mm[index], 0.0)
    spread = np.where(valid, t, np.inf).min(axis=1), np.where(valid, t, -np.inf).max(axis=1)
    usable = (counts >= MIN_FIT_POINTS) & (spread[1] - spread[0] >= half_mm)
    powers = [np.ones_like(t), t, t * t, t**3, t**4]

    def fit(inlier: np.ndarray) -> np.ndarray:
        """Least-squares quadratics on each node's inliers (NaN with fewer than 5): the
        normal equations from the moments Σtᵏ (k ≤ 4) and Σz·tᵏ (k ≤ 2)."""
        weight = inlier.astype(float)
        moments = [np.einsum("nw,nw->n", weight, p) for p in powers]
        right = np.stack([np.einsum("nw,nw->n", weight * z, p) for p in powers[:3]], axis=1)
        normal = np.stack(
            [np.stack([moments[i + j] for j in range(3)], axis=1) for i in range(3)], axis=1
        )
        coefficients = np.full((grid_mm.size, 3), np.nan)
        rows = usable & (inlier.sum(axis=1) >= MIN_FIT_POINTS)
        scale = np.abs(normal[rows]).max(axis=(1, 2)) ** 3
        rows[rows] = np.abs(np.linalg.det(normal[rows])) > 1e-12 * scale  # not all at one x
        coefficients[rows] = np.linalg.solve(normal[rows], right[rows][..., None])[..., 0]
        return coefficients

    inlier = valid.copy()
    for _ in range(OUTLIER_PASSES):
        coefficients = fit(inlier)
        residual = np.abs(
            z - (coefficients[:, :1] + coefficients[:, 1:2] * t + coefficients[:, 2:] * t * t)
        )
        ranked = np.sort(np.where(inlier, residual, np.inf), axis=1)
        count = np.maximum(inlier.sum(axis=1), 1)
        rows = np.arange(grid_mm.size)
        median = 0.5 * (ranked[rows, (count - 1) // 2] + ranked[rows, count // 2])
        spread_mm = 1.4826 * median
        limit = np.maximum(OUTLIER_MADS * spread_mm, OUTLIER_FLOOR_MM)[:, None]
        kept = valid & (residual <= limit)
        if np.array_equal(kept, inlier):
            return coefficients[:, 0]
        inlier = kept
    return fit(inlier)[:, 0]


def surface_quadratics(
    x_mm: np.ndarray, z_mm: np.ndarray, grid_mm: np.ndarray, half_mm: np.ndarray
) -> np.ndarray:
    """`local_quadratics` of a profile's points at the grid nodes [mm], the field face's
    points (below `FIELD_FACE_MM`'s upper end) left out: the surface a rail or a straight
    edge meets."""
    upper = z_mm > FIELD_FACE_MM[1]
    order = np.argsort(x_mm[upper], kind="stable")
    return local_quadratics(x_mm[upper][order], z_mm[upper][order], grid_mm, half_mm)


def running_surface(x_mm: np.ndarray, z_mm: np.ndarray) -> WheelCurve:
    """The running surface z(x) from the flange top to 110 mm beyond, from measured points.

    Robust local quadratics every 0.1 mm smooth the points' noise: over ±0.5 mm on the
    flange (its flank and root bend sharply) and ±1.5 mm on the tread, whose slope decides
    where a rail touches it (±0.5 mm there lets the slope's noise move the contact by
    millimetres; the tread hollow reads a smoother surface, `tread.hollow_surface`). A node
    whose window holds fewer than 5 points, or points spread over less than half the window,
    is left out (linear interpolation bridges it; `axle_conicity` refuses a gap of more than
    `MAX_SURFACE_GAP_MM`).

    Raises
    ------
    ContactError
        If fewer than half the nodes have points.
    """
    start = float(x_mm[int(np.argmax(z_mm))])
    upper = z_mm > FIELD_FACE_MM[1]
    end = min(start + CURVE_REACH_MM, float(x_mm[upper].max()) - CURVE_HALF_WINDOW_MM)
    grid = np.arange(start, end, CURVE_STEP_MM)
    half = np.where(grid < start + FLANGE_ZONE_MM, CURVE_HALF_WINDOW_MM, TREAD_HALF_WINDOW_MM)
    values = surface_quadratics(x_mm, z_mm, grid, half)
    good = np.isfinite(values)
    if np.count_nonzero(good) < grid.size / 2:
        raise ContactError("too few tread points for the running surface")
    return WheelCurve(grid[good], values[good])


def outline_running_surface(x_mm: np.ndarray, z_mm: np.ndarray) -> WheelCurve:
    """The running surface of a clean outline (back face → field face): from the flange top
    until x stops rising (the field-side face), cut at 110 mm beyond the top."""
    top = int(np.argmax(z_mm))
    x, z = x_mm[top:], z_mm[top:]
    stop = np.flatnonzero(np.diff(x) <= 0)
    end = int(stop[0]) + 1 if stop.size else x.size
    keep = x[:end] <= x[0] + CURVE_REACH_MM
    return WheelCurve(x[:end][keep], z[:end][keep])


def _gaps(wheel_x, wheel_z, rail_x, rail_z, shifts, phi, axis_z):
    """Smallest wheel − rail distance along the wheel's vertical, at every shift (S,), the
    wheelset-frame X where it occurs and the distance's derivative by the roll [mm/rad].

    The rails are carried into the wheelset frame (shift y, roll φ about the axle, whose
    height `axis_z` above the rails is the wheel radius: its few-mm error moves X by φ·mm),
    the wheel interpolated at the rails' nodes (finer than its own) and each minimum refined
    by the parabola through it and its neighbours. Measuring along the wheel's vertical
    instead of the track's changes the touching point only at second order in φ.
    """
    c, s = np.cos(phi)[:, None], np.sin(phi)[:, None]
    dx, dz = rail_x[None, :] - shifts[:, None], rail_z[None, :] - axis_z
    x, z = c * dx + s * dz, c * dz - s * dx
    gap = np.interp(x, wheel_x, wheel_z, left=np.inf, right=np.inf) - z
    if not np.all(np.isfinite(gap).sum(axis=1) >= 3):
        raise ContactError("the wheel profile does not reach over its rail")
    k = np.clip(np.argmin(gap, axis=1), 1, gap.shape[1] - 2)
    rows = np.arange(gap.shape[0])
    a, b, e = gap[rows, k - 1], gap[rows, k], gap[rows, k + 1]
    # A minimum next to the wheel curve's end (a neighbour off the curve, gap ∞) is taken
    # at its node: (a − e)·t would be ∞·0 there.
    spread = np.subtract(a, e, out=np.zeros_like(b), where=np.isfinite(a + e))
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where(np.isfinite(a + e) & (a - 2 * b + e > 0), 0.5 * spread / (a - 2 * b + e), 0.0)
    t = np.clip(t, -1.0, 1.0)
    neighbour = np.where(t > 0, x[rows, k + 1], x[rows, k - 1])
    at = x[rows, k] + np.abs(t) * (neighbour - x[rows, k])
    smallest = b - 0.25 * spread * t
    # d(gap)/dφ at the contact: the rail point turns by (z, −x) per radian, so the gap
    # w(x) − z changes by w'(x)·z + x (the lever X and, on a steep flank, the axis height).
    piece = np.clip(np.searchsorted(wheel_x, at) - 1, 0, wheel_x.size - 2)
    slope = np.diff(wheel_z)[piece] / np.diff(wheel_x)[piece]
    height = np.interp(at, wheel_x, wheel_z) - smallest
    return smallest, at, slope * height + at


@dataclass(frozen=True, slots=True, eq=False)
class WheelsetContacts:
    """Δr(y) of an axle and where each wheel touches its rail at every shift.

    Attributes
    ----------
    delta_r : RollingRadiusDifference
    left_x_mm, right_x_mm : ndarray of shape (S,), float64
        The contact point on each wheel at each shift of `delta_r`, in that wheel's profile
        frame (x from its back face) [mm].
    """

    delta_r: RollingRadiusDifference
    left_x_mm: np.ndarray
    right_x_mm: np.ndarray

    def __post_init__(self) -> None:
        freeze_geometry(self, "left_x_mm", "right_x_mm")


def rolling_radius_difference(
    left: WheelCurve, right: WheelCurve, back_to_back_mm: float, rails: TrackRails, **options
) -> RollingRadiusDifference:
    """Δr(y) = r_right − r_left of an axle at lateral shifts y: `wheelset_contacts`'s Δr,
    with its keyword options (radius_mm, shift_range_mm, shift_step_mm)."""
    return wheelset_contacts(left, right, back_to_back_mm, rails, **options).delta_r


def wheelset_contacts(
    left: WheelCurve,
    right: WheelCurve,
    back_to_back_mm: float,
    rails: TrackRails,
    *,
    radius_mm: float = NOMINAL_WHEEL_RADIUS_MM,
    shift_range_mm: float = SHIFT_RANGE_MM,
    shift_step_mm: float = SHIFT_STEP_MM,
) -> WheelsetContacts:
    """Δr(y) = r_right − r_left of an axle at lateral shifts y by rigid contact search,
    with each wheel's contact point.

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
    WheelsetContacts

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
    count = int(round(shift_range_mm / shift_step_mm))
    shifts = shift_step_mm * np.arange(-count, count + 1)
    # Wheel surfaces in the wheelset frame (X from the axle centre, Z up from the axis),
    # each sorted by X; the rails' heads only (flank contact stays above 20 mm down).
    wheels = (
        (-(half + left.x_mm[::-1]), -(radius_mm + left.z_mm[::-1])),
        (half + right.x_mm, -(radius_mm + right.z_mm)),
    )
    rails_xz = []
    for x, z in ((rails.left_x_mm, rails.left_z_mm), (rails.right_x_mm, rails.right_z_mm)):
        rails_xz.append((x[z > -20.0], z[z > -20.0]))
    # The roll φ per shift: both wheels touch when their gaps are equal. The right gap minus
    # the left rises with φ (by the difference of the gaps' derivatives): Newton steps
    # inside a shrinking bracket.
    phi = np.zeros(shifts.size)
    low, high = np.full(shifts.size, -ROLL_BRACKET_RAD), np.full(shifts.size, ROLL_BRACKET_RAD)
    x_l, x_r = np.zeros(shifts.size), np.zeros(shifts.size)
    active = np.arange(shifts.size)
    for iteration in range(ROLL_ITERATIONS):
        (gap_l, x_l[active], rate_l), (gap_r, x_r[active], rate_r) = (
            _gaps(*wheel, *rail, shifts[active], phi[active], radius_mm)
            for wheel, rail in zip(wheels, rails_xz, strict=True)
        )
        difference = gap_r - gap_l
        high[active] = np.where(difference > 0, phi[active], high[active])
        low[active] = np.where(difference < 0, phi[active], low[active])
        step = phi[active] - difference / (rate_r - rate_l)
        done = (np.abs(difference) < ROLL_TOLERANCE_MM) | (np.abs(step - phi[active]) < 1e-10)
        done |= high[active] - low[active] < 1e-10
        # After six steps every third one bisects, so a steep kink (a contact jumping
        # between two points) cannot stall the Newton steps on one side of the root.
        inside = (step > low[active]) & (step < high[active]) & (iteration < 6 or iteration % 3)
        step = np.where(inside, step, 0.5 * (low[active] + high[active]))
        phi[active] = np.where(done, phi[active], step)
        active = active[~done]
        if active.size == 0:
            break
    else:
        raise ContactError("the wheelset's roll did not settle (no two-point support)")
    left_x, right_x = -x_l - half, x_r - half
    z_left = np.interp(left_x, left.x_mm, left.z_mm)
    z_right = np.interp(right_x, right.x_mm, right.z_mm)
    delta = z_right - z_left  # r = radius + z at the contact; the radius cancels
    return WheelsetContacts(RollingRadiusDifference(shifts, delta), left_x, right_x)


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

    Raises
    ------
    ContactError
        If a wheel's running surface has a gap of more than `MAX_SURFACE_GAP_MM` (the
        message names every such gap of both wheels: x from the back face and distance
        beyond the flange top), or a wheel does not reach over its rail, or the rails
        touch a sagging bridge (`BRIDGE_SAG_MM`) at y = 0 or leave no oscillation.

    Notes
    -----
    A bridge whose estimated sag exceeds `BRIDGE_SAG_MM` decides nothing: the shifts at
    which a rail touches the running surface on it are dropped, Δr(y) is kept over the run
    of shifts about y = 0 clear of them, and an amplitude whose swing leaves that run gets
    None (`AxleConicity.reason` says which bridge, where and at which shifts).
    """
    unseen = []
    for side, curve in (("left", left), ("right", right)):
        gaps = np.flatnonzero(np.diff(curve.x_mm) > MAX_SURFACE_GAP_MM)
        if gaps.size:
            stretches = ", ".join(_stretch(curve, k) for k in gaps.tolist())
            unseen.append(f"the {side} wheel's running surface shows no points from {stretches}")
    if unseen:
        raise ContactError(
            f"{'; '.join(unseen)}: a straight bridge over more than "
            f"{MAX_SURFACE_GAP_MM:.0f} mm can carry a false contact"
        )
    contacts = wheelset_contacts(left, right, back_to_back_mm, rails, radius_mm=radius_mm)
    delta_r, reason = contacts.delta_r, None
    y = delta_r.y_mm
    touched = []  # (what the rails touch, shifts where they do)
    for side, curve, at in (
        ("left", left, contacts.left_x_mm),
        ("right", right, contacts.right_x_mm),
    ):
        for k in _sagging_bridges(curve):
            hit = (at > curve.x_mm[k]) & (at < curve.x_mm[k + 1])
            if hit.any():
                what = (
                    f"a straight bridge sagging more than {BRIDGE_SAG_MM} mm, "
                    f"the {side} wheel's over {_stretch(curve, k)}"
                )
                touched.append((what, hit))
        bumps = _bumps(curve)
        node = np.clip(np.searchsorted(curve.x_mm, at), 1, curve.x_mm.size - 1)
        near = np.where(at - curve.x_mm[node - 1] < curve.x_mm[node] - at, node - 1, node)
        on_bump = bumps[near] & (np.abs(curve.x_mm[near] - at) <= CURVE_STEP_MM)
        for start, stop in _runs(on_bump):
            xs = at[start:stop]
            what = (
                f"a bump more than {BUMP_MM} mm above the running surface around it, the "
                f"{side} wheel's at x = {xs.min():.1f} to {xs.max():.1f} mm"
            )
            hit = np.zeros(y.size, bool)
            hit[start:stop] = True
            touched.append((what, hit))
    if touched:
        bad = np.logical_or.reduce([hit for _, hit in touched])
        where = "; ".join(
            f"{what} at y = {y[hit].min():+.2f} to {y[hit].max():+.2f} mm" for what, hit in touched
        )
        centre = int(np.argmin(np.abs(y)))
        if bad[centre]:
            raise ContactError(f"at y = 0 the rails touch {where}")
        low, high = centre, centre
        while low > 0 and not bad[low - 1]:
            low -= 1
        while high < y.size - 1 and not bad[high + 1]:
            high += 1
        if high == low:
            raise ContactError(f"no shift about y = 0 where the rails touch the wheels: {where}")
        delta_r = RollingRadiusDifference(y[low : high + 1], delta_r.delta_r_mm[low : high + 1])
        reason = (
            f"Δr(y) kept over y = {y[low]:+.2f} to {y[high]:+.2f} mm, amplitudes swinging "
            f"beyond it not evaluated: the rails touch {where}"
        )
    amplitudes = np.array((NOMINAL_AMPLITUDE_MM, *CURVE_AMPLITUDES_MM))
    try:
        lambdas = equivalent_conicity(delta_r, amplitudes)
    except ConicityError as exc:
        if reason is None:
            raise
        raise ContactError(f"{reason}; {exc}") from exc
    values = [None if np.isnan(v) else float(v) for v in lambdas]
    return AxleConicity(
        delta_r=delta_r,
        conicity_3mm=values[0],
        curve_amplitudes_mm=CURVE_AMPLITUDES_MM,
        curve_conicity=tuple(values[1:]),
        rail=rails.rail,
        inclination=rails.inclination,
        gauge_mm=rails.gauge_mm,
        reason=reason,
    )


def _stretch(curve: WheelCurve, k: int) -> str:
    """The stretch between nodes k and k + 1 of a running surface, as the reasons name it:
    x from the back face and distance beyond the flange top (the curve's first node) [mm]."""
    x0, x1 = curve.x_mm[k], curve.x_mm[k + 1]
    top = curve.x_mm[0]
    return f"x = {x0:.1f} to {x1:.1f} mm ({x0 - top:.1f}–{x1 - top:.1f} mm beyond the flange top)"


def _bumps(curve: WheelCurve) -> np.ndarray:
    """Which tread nodes of a running surface lie more than `BUMP_MM` above the robust
    quadratic through its nodes within ±`BUMP_HALF_WINDOW_MM` (bool (K,)): from
    `BUMP_ZONE_MM` beyond its first node, with the whole window inside it and within
    `CURVE_REACH_MM` of that node; False where the fit has too few nodes."""
    x = curve.x_mm
    wide = local_quadratics(x, curve.z_mm, x, np.full(x.size, BUMP_HALF_WINDOW_MM))
    stop = min(x[-1], x[0] + CURVE_REACH_MM) - BUMP_HALF_WINDOW_MM
    tread = (x >= x[0] + BUMP_ZONE_MM) & (x <= stop)
    return tread & (np.nan_to_num(curve.z_mm - wide, nan=0.0) > BUMP_MM)


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) of each run of True in a 1-D bool array."""
    edges = np.diff(np.concatenate([[0], flags.astype(np.int8), [0]]))
    starts, stops = np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()
    return list(zip(starts, stops, strict=True))


def _sagging_bridges(curve: WheelCurve) -> np.ndarray:
    """Indices k of the stretches x_k…x_k+1 without nodes (over 1.5 node steps) whose
    straight bridge is estimated to sag more than `BRIDGE_SAG_MM`: L·|s₁ − s₀|/8 with s₀, s₁
    the running surface's slopes over `EDGE_SLOPE_NODES` nodes beside each end."""
    x, z = curve.x_mm, curve.z_mm
    found = []
    for k in np.flatnonzero(np.diff(x) > 1.5 * CURVE_STEP_MM).tolist():
        a, b = max(k - EDGE_SLOPE_NODES, 0), min(k + 1 + EDGE_SLOPE_NODES, x.size - 1)
        before = (z[k] - z[a]) / (x[k] - x[a]) if k > a else 0.0
        after = (z[b] - z[k + 1]) / (x[b] - x[k + 1]) if b > k + 1 else 0.0
        if (x[k + 1] - x[k]) * abs(after - before) / 8.0 > BRIDGE_SAG_MM:
            found.append(k)
    return np.array(found, dtype=int)


def measured_axle_conicity(
    left_x_mm: np.ndarray,
    left_z_mm: np.ndarray,
    right_x_mm: np.ndarray,
    right_z_mm: np.ndarray,
    back_to_back_mm: float,
    rails: TrackRails,
) -> AxleConicity:
    """`axle_conicity` of two measured profiles (points in the profile frame, any order).

    Raises
    ------
    ContactError
        If a profile lacks the tread points the rails can touch.
    """
    left = running_surface(np.asarray(left_x_mm, float), np.asarray(left_z_mm, float))
    right = running_surface(np.asarray(right_x_mm, float), np.asarray(right_z_mm, float))
    return axle_conicity(left, right, back_to_back_mm, rails)


def outline_conicity(
    left_x_mm: np.ndarray,
    left_z_mm: np.ndarray,
    right_x_mm: np.ndarray,
    right_z_mm: np.ndarray,
    back_to_back_mm: float,
    radius_mm: float,
) -> float | None:
    """λₑ at 3 mm of an axle of two clean outlines on the default rails (the simulator's
    truth, by the same contact search and evaluation as the measurement)."""
    left = outline_running_surface(left_x_mm, left_z_mm)
    right = outline_running_surface(right_x_mm, right_z_mm)
    rails = track_rails()
    return axle_conicity(left, right, back_to_back_mm, rails, radius_mm=radius_mm).conicity_3mm
