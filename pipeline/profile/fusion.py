"""From track-frame stripe points to one wheel's fused profile in the profile frame.

Both sensors of a wheel land in the one track frame, so fusion is a union plus a consistency
check. The datum follows docs/coordinate-frames.md: x from the back face (found in the inner
sensor's points as the innermost vertical line), z up towards the flange tip, z = 0 at the
tread reference point x = 70 mm. At the wheel's lowest section a larger radius is a lower
track Z, so z = Z(x = 70) − Z.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from pipeline.errors import PipelineError
from pipeline.extraction.hessian import eigen2
from pipeline.extraction.normal_equations import solve_symmetric3
from pipeline.imaging import GEOMETRY_FLOAT
from pipeline.jit import kernel
from pipeline.profile.x_windows import window_maxima

REFERENCE_X_MM = 70.0
WHEEL_REACH_MM = (-8.0, 145.0)
"""Profile-frame x window of a wheel: back face (x = 0) to beyond the field face (≈ 135)."""
WHEEL_Z_MM = (-45.0, 40.0)
"""Profile-frame z window: rim faces (to −40) up to a worn flange top (< 36)."""
SEARCH_U_MM = (560.0, 820.0)
"""Where a back face can be: |X| of the back face, half back-to-back 1353/2 ± 100 mm."""
BACK_FACE_Z_MM = (-35.0, 2.0)
"""Part of the back face used for its fit: below the flange root, above the rim edge."""
BACK_FACE_BAND_MM = 1.5
REFERENCE_HALF_WINDOW_MM = 5.0
"""Tread points within ±5 mm of x = 70 give the reference height (quadratic fit, so a worn
tread's curvature does not bias it)."""
OVERLAP_NEIGHBOURS = 8
MIN_BACK_FACE_POINTS = 20
CONSENSUS_RADIUS_MM = 2.0
CONSENSUS_MIN_POINTS = 6
CONSENSUS_TOLERANCE_MM = 0.12
"""Where the other sensor has ≥ 6 points within 2 mm of a point, the point must lie near
their local curve: within 0.12 mm, or more where the two sensors agree less overall."""
SELF_RADIUS_MM = 3.0
SELF_TOLERANCE_MM = 0.05
"""A point is also checked against its own sensor's local quadratic over ±3 mm: a short
bump (a glint, a spot touching the stripe) leaves it by more than 0.05 mm."""
LINK_RADIUS_MM = 1.0
MIN_COMPONENT_POINTS = 40
"""Profile pieces linked by < 1 mm gaps and holding fewer than 40 points (≈ 5 mm of
stripe) are glints or stray spots, not the wheel. A flange top whose dim stripe comes in
pieces of 1–3 mm a few tenths of a mm apart stays one piece at 1 mm; at 0.5 mm its pieces
were dropped (with `measurement.MIN_WINDOW_CHAIN_POINTS`, on the 9 harsh passes × 8 wheels
of the field benchmark: 3 more wheels measured, Sh MAE 0.096 → 0.092 mm, Sd 0.055 and both
largest errors unchanged). 1.5 mm measured one more wheel but let offset pieces in (Sd
largest error 0.238 → 0.367 mm); 2 mm linked glints above the top to it (Sh off by 4.8 mm).
A minimum extent of 3 mm for a piece (glint clusters are compact) changed nothing there.
With the dim chains kept by continuation (`pipeline.extraction.centres._continuing`), 16
points measured 2 fewer wheels and no flank gap more, and let glints above the top in
(Sh MAE 0.118 → 0.849 mm, largest error 4.8 mm)."""

CONTINUATION_GAP_MM = 4.0
CONTINUATION_COS = 0.9
DIRECTION_RADIUS_MM = 2.5
"""A piece of fewer than 40 points is kept where the pieces it continues, directly or
through other short pieces, hold ≥ 40 points together (one of ≥ 40 among them, or short
ones alone): a gap of ≤ 4 mm between their nearest points that runs along both pieces there
(|cos| ≥ 0.9 with the major axis of each piece's points within 2.5 mm of its end of the
gap). A polished flank under harsh light comes as its glare stretches alone, pieces of
16–35 points (2–4 mm) 1–3.5 mm apart along the flank, each of them on the line
(docs/simulator.md, "Short flank pieces kept where they continue the profile"); where the
stretches are short, the flank's pieces continue each other from z ≈ 17 to 5 mm but lie
6–8 mm from the top's and the tread's pieces, and asking for a piece of ≥ 40 among them
dropped them all (docs/simulator.md, "Flank pieces anchored by their group"). Glints and
texture blobs have no axis that points at the profile, and a ghost stripe beside the flank
runs beside it, not on from it. The axis spans most of a short piece, so the 0.3–0.5 mm hook
at a glare stretch's end does not turn it."""

DOUBLED_DX_MM = 0.2
DOUBLED_DZ_MM = 0.5
DOUBLED_FRACTION = 0.5
DOUBLED_MIN_POINTS = 5
SINGLE_VALUED_X_MM = 2.0
"""Between the back face and the rim face the laser plane meets the wheel in one curve
z(x): a linked piece lying above a larger piece (≥ 5 and at least half of its points have
points of a larger piece within ±0.2 mm in x, all of them more than 0.5 mm lower) is a
reflection, a texture blob or another part's stripe, not the wheel. Only pieces above are
dropped: the flange height is read from the highest points, so a piece above the top
biases it by millimetres, while a piece below a larger one may be the true flank beside a
wrong spur attached to the larger piece (Steger on a harsh pass: a 2-sided rule dropped
the flank there). Tested from x = 2 mm (the flange back rises steeply from the back face)
to 3 mm before the larger pieces' end (the rim face). On the texture-only field pass (seed
2027) a 2 mm stripe and a blob 2–4 mm above the flange top (42 points, the outer sensor)
read Sh 0.85 mm high; with the rule 0.02 mm.

The same test then runs point by point across the sensors: a point more than 0.5 mm above
all of the other sensor's kept points within ±0.2 mm in x is dropped. A streak one sensor
draws across the other's tread (another part's edge) is linked to the profile where it
crosses it, so the piece rule keeps it whole; on the field benchmark's pass-004 V001/2/left
an inner-sensor streak from x = 56.5 to 60.5 mm rising 2 mm above the outer sensor's tread
lifted the running surface at x = 60 mm by 0.9 mm and read the tread hollow 0.83 mm high
(0.05 mm without it). On the steep flank ±0.2 mm in x spans ±0.8 mm of height, so the
other sensor's own flank points there keep a point from being "above" them; still, the
point test runs on the tread side of the flange top below z = 5 mm only (`POINT_RULE_Z_MM`,
tread and flange root), where the profile is shallow: on the flank a spur of the other
sensor's below the true flank would drop it (Steger, field pass-007 V002/2/right: a loop
1–5 mm outside the flank whose lower end lies under the outer sensor's flank points; with
the test everywhere Sd read 3.78 mm off instead of 1.81). The inner sensor's points are
tested on the whole tread side of the top, against the outer sensor's, which sees that
flank: an inner streak above the outer's flank is not the wheel (pipeline 0.12.2: a field
wheel in 3 frames, 43 inner points 3.5–5.8 mm beyond the flank at z = 14–20 mm, linked to
the profile, read the flange angle 10.3° steep), and the outer flank is never judged by
the inner's points."""
POINT_RULE_Z_MM = 5.0
RIM_FACE_MARGIN_MM = 3.0
"""Both tests stop 3 mm before the accepted points' largest x (the rim face)."""


CREST_BIN_MM = 0.5
CREST_MIN_POINTS = 5
HIDDEN_MARGIN_MM = 2.5
"""A sensor's point beyond the flange crest from its camera, lying more than 2.5 mm below the
line from the camera through the crest, is hidden by the flange: the ray to it passes
through the flange's material, so it is not the wheel (a reflection, another part's
stripe). The inner camera looks at the flange's back from inside the track; on clean
simulated passes (seed 2026, 24 wheels) its points beyond the crest reach 1.7 mm below that
line (the rounded crest's silhouette lies beyond its highest point), on the field benchmark
a piece of its 1.2 mm outside the flank lay 2–7.4 mm below it and read Sd +0.943 mm (seed
2028, pass-005 V002/2/right; with the rule it is not measured). The crest is `_crest`'s,
not the highest point: through a Steger spur 1.5 mm over the top the line dropped true
points and cost two clean wheel-passes (docs/simulator.md, "Points the flange hides from
their camera")."""


class DatumError(PipelineError):
    """The back face or the tread reference point cannot be found in the stripe points."""


@dataclass(frozen=True, slots=True, eq=False)
class FusedProfile:
    """A wheel's profile from both sensors, in the profile frame, ordered along it.

    Attributes
    ----------
    x_mm, z_mm : ndarray of shape (K,), float64
        Points: the back face bottom-up, then the rest by increasing x [mm].
    sensor : ndarray of shape (K,), int8
        0 for the inner sensor, 1 for the outer one.
    back_face_track_x_mm : float
        Track-frame X of the back face (for the back-to-back distance) [mm].
    reference_track_z_mm : float
        Track-frame Z of the reference point x = 70 mm [mm].
    overlap_residual_mm : float or None
        RMS distance of the outer sensor's points from the inner sensor's local profile
        where both see the wheel (None without overlap) [mm].
    overlap_points : int
        Outer points in that overlap.
    rejected_points : int
        Points dropped as inconsistent with the other sensor or as stray pieces.
    strength : ndarray of shape (K,), float64, or None
        Line strength of each point's centre (`Centres.strength`), when the points came with
        it: the flank fits weight by it (`pipeline.profile.flange.FLANK_WEIGHT_STRENGTH`).
    """

    x_mm: np.ndarray
    z_mm: np.ndarray
    sensor: np.ndarray
    back_face_track_x_mm: float
    reference_track_z_mm: float
    overlap_residual_mm: float | None
    overlap_points: int
    rejected_points: int
    strength: np.ndarray | None = None

    def __post_init__(self) -> None:
        for array in (self.x_mm, self.z_mm, self.sensor, self.strength):
            if array is not None:
                array.flags.writeable = False


def _back_face_u(u_inner: np.ndarray) -> float:
    """Rough back-face position: the 1 mm bin holding most inner points (a vertical line)."""
    inside = u_inner[(u_inner > SEARCH_U_MM[0]) & (u_inner < SEARCH_U_MM[1])]
    if inside.size < MIN_BACK_FACE_POINTS:
        raise DatumError("the inner sensor shows no stripe where a back face can be")
    edges = np.arange(SEARCH_U_MM[0], SEARCH_U_MM[1] + 1.0, 1.0)
    counts, _ = np.histogram(inside, edges)
    best = int(np.argmax(counts))
    if counts[best] < MIN_BACK_FACE_POINTS:
        raise DatumError("the inner sensor's stripe shows no vertical back face")
    near = inside[np.abs(inside - (edges[best] + 0.5)) < BACK_FACE_BAND_MM]
    return float(np.median(near))


def _reference_z(u: np.ndarray, big_z: np.ndarray, u_back: float) -> float:
    near = np.abs(u - u_back - REFERENCE_X_MM) <= REFERENCE_HALF_WINDOW_MM
    if np.count_nonzero(near) < MIN_BACK_FACE_POINTS:
        raise DatumError("no tread points around the reference point x = 70 mm")
    dx = u[near] - u_back - REFERENCE_X_MM
    coefficients = np.polyfit(dx, big_z[near], 2)
    residual = big_z[near] - np.polyval(coefficients, dx)
    keep = np.abs(residual) <= max(3.0 * 1.4826 * np.median(np.abs(residual)), 0.05)
    return float(np.polyfit(dx[keep], big_z[near][keep], 2)[2])


def _cleaned_reference_offset(x: np.ndarray, z: np.ndarray) -> float:
    """z at x = 70 mm of the cleaned profile's own tread points, by `_reference_z` (0 when
    fewer than 20) [mm].

    The first datum comes from every point near x = 70 mm, before `clean_profile_points`
    drops what is not the wheel's one curve; on field frames those can hold a streak that
    pulls it (seed 2027, pass 4, V002/1/left: the cleaned tread at z = +0.34 mm, Sh +0.338
    mm too high). The profile is set down by this offset so that its own tread passes
    through the reference point."""
    try:
        return _reference_z(x, z, 0.0)
    except DatumError:
        return 0.0


def _refine_back_face(u: np.ndarray, z: np.ndarray, u_back: float) -> float:
    face = (
        (np.abs(u - u_back) < BACK_FACE_BAND_MM) & (z > BACK_FACE_Z_MM[0]) & (z < BACK_FACE_Z_MM[1])
    )
    if np.count_nonzero(face) < MIN_BACK_FACE_POINTS:
        raise DatumError("too few back-face points below the flange root")
    values = u[face]
    spread = 1.4826 * np.median(np.abs(values - np.median(values)))
    return float(np.mean(values[np.abs(values - np.median(values)) <= max(3 * spread, 0.02)]))


def overlap_residual(inner_xz: np.ndarray, outer_xz: np.ndarray) -> tuple[float | None, int]:
    """RMS distance of outer points from local lines through the nearest inner points [mm].

    Only outer points within 0.5 mm of some inner point count (the overlap); the local line
    is the principal axis of the 8 nearest inner points, so sampling density and the
    direction of the profile do not matter.
    """
    if inner_xz.shape[0] < OVERLAP_NEIGHBOURS or outer_xz.shape[0] == 0:
        return None, 0
    tree = cKDTree(inner_xz)
    distance, index = tree.query(outer_xz, k=OVERLAP_NEIGHBOURS)
    in_overlap = distance[:, 0] <= 0.5
    if np.count_nonzero(in_overlap) < OVERLAP_NEIGHBOURS:
        return None, 0
    neighbours = inner_xz[index[in_overlap]]
    centred = neighbours - neighbours.mean(axis=1, keepdims=True)
    _, _, vt = np.linalg.svd(centred)
    normal = vt[:, 1, :]
    offsets = outer_xz[in_overlap] - neighbours.mean(axis=1)
    residual = np.einsum("ij,ij->i", offsets, normal)
    return float(np.sqrt(np.mean(residual**2))), int(np.count_nonzero(in_overlap))


@kernel
def _residuals_kernel(points, other, order, radius_mm, min_points, out) -> None:
    """Per point: offset from the quadratic v(u) through `other`'s points within the radius.

    `order` sorts `other` by x. (u, v) are the principal axes of the local points, v the
    minor one oriented upwards (z ≥ 0) so that offsets of neighbouring points share a sign.
    Fewer than 2·radius − 1 mm of extent along u (ptp(u) ≤ 0.5 mm) fits a line instead.
    """
    xs = other[order, 0]
    r2 = radius_mm * radius_mm
    for i in range(points.shape[0]):
        px, pz = points[i, 0], points[i, 1]
        lo = np.searchsorted(xs, px - radius_mm)
        hi = np.searchsorted(xs, px + radius_mm, side="right")
        n = 0
        sx = sz = 0.0
        for k in range(lo, hi):
            j = order[k]
            dx, dz = other[j, 0] - px, other[j, 1] - pz
            if dx * dx + dz * dz <= r2:
                n += 1
                sx += other[j, 0]
                sz += other[j, 1]
        if n < min_points:
            out[i] = np.nan
            continue
        cx, cz = sx / n, sz / n
        cxx = cxz = czz = 0.0
        for k in range(lo, hi):
            j = order[k]
            dx, dz = other[j, 0] - px, other[j, 1] - pz
            if dx * dx + dz * dz <= r2:
                ex, ez = other[j, 0] - cx, other[j, 1] - cz
                cxx += ex * ex
                cxz += ex * ez
                czz += ez * ez
        _, _, ax, az = eigen2(cxx, cxz, czz)  # major axis (λ1 of the covariance ≥ 0)
        nx, nz = -az, ax
        if nz < 0 or (nz == 0 and nx < 0):
            nx, nz = -nx, -nz
        ux, uz = nz, -nx
        s0 = s1 = s2 = s3 = s4 = t0 = t1 = t2 = 0.0
        u_min, u_max = np.inf, -np.inf
        for k in range(lo, hi):
            j = order[k]
            dx, dz = other[j, 0] - px, other[j, 1] - pz
            if dx * dx + dz * dz <= r2:
                ex, ez = other[j, 0] - cx, other[j, 1] - cz
                u = ex * ux + ez * uz
                v = ex * nx + ez * nz
                u_min, u_max = min(u_min, u), max(u_max, u)
                s0 += 1.0
                s1 += u
                s2 += u * u
                s3 += u * u * u
                s4 += u * u * u * u
                t0 += v
                t1 += u * v
                t2 += u * u * v
        eu = (px - cx) * ux + (pz - cz) * uz
        ev = (px - cx) * nx + (pz - cz) * nz
        if u_max - u_min > 0.5:  # least squares v = a + b·u + c·u²
            a, b, c = solve_symmetric3(s0, s1, s2, s2, s3, s4, t0, t1, t2)
            out[i] = ev - (a + b * eu + c * eu * eu)
        else:  # a line v = a + b·u
            det = s0 * s2 - s1 * s1
            a = (t0 * s2 - s1 * t1) / det
            b = (s0 * t1 - s1 * t0) / det
            out[i] = ev - (a + b * eu)


def _local_residuals(points: np.ndarray, other: np.ndarray, radius_mm: float) -> np.ndarray:
    """Offset of each point from the local curve of `other` (NaN where it has no say).

    The local curve is a quadratic v(u) in the principal axes of the points of `other`
    within `radius_mm`, so the curvature of the flange top does not count as offset.
    """
    residual = np.full(points.shape[0], np.nan)
    if points.shape[0] == 0 or other.shape[0] < CONSENSUS_MIN_POINTS:
        return residual
    points = np.ascontiguousarray(points, np.float64)
    other = np.ascontiguousarray(other, np.float64)
    order = np.argsort(other[:, 0], kind="stable")
    _residuals_kernel(points, other, order, radius_mm, CONSENSUS_MIN_POINTS, residual)
    return residual


def _outside(residual: np.ndarray, floor_mm: float) -> np.ndarray:
    """True where |residual| exceeds max(floor, |median| + 4·1.4826·MAD) (NaN → False)."""
    known = np.isfinite(residual)
    if not np.any(known):
        return np.zeros(residual.shape, bool)
    centre = float(np.median(residual[known]))
    spread = 1.4826 * float(np.median(np.abs(residual[known] - centre)))
    tolerance = max(floor_mm, abs(centre) + 4.0 * spread)
    return known & (np.abs(np.nan_to_num(residual)) > tolerance)


def _consistent_with(points: np.ndarray, other: np.ndarray) -> np.ndarray:
    """False for points that leave the other sensor's local curve AND bend away from their own.

    A bump seen by one sensor only fails both tests; where the two sensors disagree smoothly
    (a systematic offset, a method's bias) neither sensor's points are dropped, so the flange
    top is never left without points. Tolerances follow the data: max(floor, |median| +
    4·1.4826·MAD) of the offsets.
    """
    cross = _outside(_local_residuals(points, other, CONSENSUS_RADIUS_MM), CONSENSUS_TOLERANCE_MM)
    if not np.any(cross):
        return np.ones(points.shape[0], bool)
    own = _outside(_local_residuals(points, points, SELF_RADIUS_MM), SELF_TOLERANCE_MM)
    return ~(cross & own)


def _pieces(xz: np.ndarray) -> np.ndarray:
    """Label of each point's linked piece: points within LINK_RADIUS_MM chain into one."""
    pairs = cKDTree(xz).query_pairs(LINK_RADIUS_MM, output_type="ndarray")
    graph = coo_matrix(
        (np.ones(len(pairs), bool), (pairs[:, 0], pairs[:, 1])), shape=(len(xz), len(xz))
    )
    return connected_components(graph, directed=False)[1]


def _axis(points: np.ndarray, at: np.ndarray) -> np.ndarray | None:
    """Unit major axis of the points within DIRECTION_RADIUS_MM of `at` (None: < 3 of them)."""
    near = points[np.hypot(*(points - at).T) <= DIRECTION_RADIUS_MM]
    if len(near) < 3:
        return None
    return np.linalg.svd(near - near.mean(axis=0), full_matrices=False)[2][0]


def _continuing(xz: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """True for points of pieces (`labels`, from `_pieces`) whose group holds ≥
    MIN_COMPONENT_POINTS points: pieces linked by gaps that run along both of them
    (`CONTINUATION_GAP_MM`, `CONTINUATION_COS`), piece by piece, a piece of ≥
    MIN_COMPONENT_POINTS a group of its own at least."""
    sizes = np.bincount(labels)
    edges = [(label, label) for label in range(sizes.size)]
    tree = cKDTree(xz)
    for label in np.flatnonzero(sizes < MIN_COMPONENT_POINTS):
        members = np.flatnonzero(labels == label)
        near = cKDTree(xz[members]).sparse_distance_matrix(
            tree, CONTINUATION_GAP_MM, output_type="ndarray"
        )
        apart = labels[near["j"]] != label
        a, b, gap = members[near["i"][apart]], near["j"][apart], near["v"][apart]
        for other in np.unique(labels[b]):
            at = np.flatnonzero(labels[b] == other)
            k = at[np.argmin(gap[at])]
            step = xz[b[k]] - xz[a[k]]
            ends = _axis(xz[members], xz[a[k]]), _axis(xz[labels == other], xz[b[k]])
            if gap[k] > 0 and all(
                axis is not None and abs(step @ axis) >= CONTINUATION_COS * gap[k] for axis in ends
            ):
                edges.append((int(label), int(other)))
    pairs = np.array(edges)
    graph = coo_matrix(
        (np.ones(len(pairs), bool), (pairs[:, 0], pairs[:, 1])), shape=(sizes.size,) * 2
    )
    groups = connected_components(graph, directed=False)[1]
    anchored = np.bincount(groups, weights=sizes) >= MIN_COMPONENT_POINTS
    return anchored[groups[labels]]


def _doubled(xz: np.ndarray, accepted: np.ndarray) -> np.ndarray:
    """True for points with accepted points within ±DOUBLED_DX_MM in x, all of them more
    than DOUBLED_DZ_MM below (inside SINGLE_VALUED_X_MM < x < the accepted points' largest x
    less RIM_FACE_MARGIN_MM; elsewhere False)."""
    x_stop_mm = accepted[:, 0].max() - RIM_FACE_MARGIN_MM
    order = np.argsort(accepted[:, 0], kind="stable")
    ax, az = accepted[order, 0], accepted[order, 1]
    lo = np.searchsorted(ax, xz[:, 0] - DOUBLED_DX_MM, side="left")
    hi = np.searchsorted(ax, xz[:, 0] + DOUBLED_DX_MM, side="right")
    testable = (xz[:, 0] > SINGLE_VALUED_X_MM) & (xz[:, 0] < x_stop_mm) & (hi > lo)
    return testable & (window_maxima(az, lo, hi) < xz[:, 1] - DOUBLED_DZ_MM)


def _single_valued(xz: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """True for points of linked pieces (`labels`, from `_pieces`) that do not lie above a
    larger piece (z(x) is one curve between the faces), largest pieces first."""
    sizes = np.bincount(labels)
    keep = np.zeros(len(xz), bool)
    for label in np.argsort(-sizes, kind="stable")[: np.count_nonzero(sizes)]:
        members = labels == label
        if np.any(keep):
            accepted = xz[keep]
            doubled = _doubled(xz[members], accepted)
            count = int(np.count_nonzero(doubled))
            if count >= DOUBLED_MIN_POINTS and count >= DOUBLED_FRACTION * members.sum():
                continue
        keep |= members
    return keep


def _crest(xz: np.ndarray) -> np.ndarray:
    """(x, z) of the profile's crest [mm]: the highest of the lowest z in CREST_BIN_MM bins
    of x holding ≥ CREST_MIN_POINTS, at that point. A spur stands over the profile, never
    under it (Steger's beside a glint on a clean pass, seed 2026 pass 9 V001/1/left, rises
    1.5 mm above the top where the profile holds points too), so the bins' lowest points
    stay on the profile."""
    bins = np.floor(xz[:, 0] / CREST_BIN_MM).astype(np.int64)
    order = np.argsort(bins, kind="stable")
    starts = np.flatnonzero(np.diff(bins[order])) + 1
    best = None
    for piece in np.split(order, starts):
        if piece.size >= CREST_MIN_POINTS:
            low = piece[int(np.argmin(xz[piece, 1]))]
            if best is None or xz[low, 1] > xz[best, 1]:
                best = low
    return xz[best] if best is not None else xz[int(np.argmax(xz[:, 1]))]


def _hidden(xz: np.ndarray, kept: np.ndarray, camera_xz: np.ndarray) -> np.ndarray:
    """True for points beyond the crest of the `kept` points (`_crest`), seen from
    `camera_xz` (profile frame [mm]), lying more than HIDDEN_MARGIN_MM below the line from
    the camera through the crest."""
    crest = _crest(xz[kept])
    run = crest[0] - camera_xz[0]
    if abs(run) < 1e-9:
        return np.zeros(len(xz), bool)
    slope = (crest[1] - camera_xz[1]) / run
    beyond = np.sign(xz[:, 0] - crest[0]) == np.sign(run)
    line = crest[1] + slope * (xz[:, 0] - crest[0])
    return beyond & (xz[:, 1] < line - HIDDEN_MARGIN_MM)


def clean_profile_points(
    xz: np.ndarray, sensor: np.ndarray, cameras_xz: np.ndarray | None = None
) -> np.ndarray:
    """Mask of the profile points kept: cross-sensor consensus, no small stray pieces (short
    pieces continuing the profile are kept), no piece above a larger one, no point above
    the other sensor's, and (with the cameras) no point the flange hides from its camera.

    Parameters
    ----------
    xz : ndarray of shape (K, 2)
        Profile-frame points [mm].
    sensor : ndarray of shape (K,), int8
        0 inner, 1 outer.
    cameras_xz : ndarray of shape (2, 2), optional
        The inner and the outer camera's centre in the profile frame [mm]
        (`HIDDEN_MARGIN_MM`).
    """
    keep = np.ones(len(xz), bool)
    inner, outer = sensor == 0, sensor == 1
    keep[inner] = _consistent_with(xz[inner], xz[outer])
    keep[outer] = _consistent_with(xz[outer], xz[inner])
    if np.count_nonzero(keep) < 2:
        return keep
    kept = np.flatnonzero(keep)
    labels = _pieces(xz[kept])
    # no small stray pieces (removing whole pieces leaves the others' links as they were),
    # unless they continue the profile
    main = _continuing(xz[kept], labels)
    keep[kept] = main
    if np.count_nonzero(main) >= 2:
        keep[kept[main]] = _single_valued(xz[kept[main]], labels[main])
    if not np.any(keep):
        return keep
    beyond = xz[:, 0] > xz[keep][np.argmax(xz[keep, 1]), 0]  # the tread side of the top
    tread = (xz[:, 1] < POINT_RULE_Z_MM) & beyond
    for own, other, tested in ((inner, outer, beyond), (outer, inner, tread)):
        mine, theirs = np.flatnonzero(keep & own & tested), np.flatnonzero(keep & other)
        if mine.size and theirs.size >= CONSENSUS_MIN_POINTS:
            keep[mine[_doubled(xz[mine], xz[theirs])]] = False
    if cameras_xz is not None and np.any(keep):
        for code in (0, 1):
            keep &= ~((sensor == code) & _hidden(xz, keep, cameras_xz[code]))
    return keep


def fuse_profile(
    inner_track_mm: np.ndarray,
    outer_track_mm: np.ndarray,
    *,
    side: str,
    cameras_track_mm: np.ndarray | None = None,
    strengths: tuple[np.ndarray, np.ndarray] | None = None,
) -> FusedProfile:
    """Fuse a wheel's inner and outer track-frame points into its profile.

    Parameters
    ----------
    inner_track_mm, outer_track_mm : ndarray of shape (K, 3)
        Stripe points of the inner and outer sensor in the track frame [mm].
    side : str
        "left" or "right": the profile's x runs towards −X or +X.
    cameras_track_mm : ndarray of shape (2, 3), optional
        The inner and the outer camera's centre in the track frame [mm]: points the flange
        hides from their camera are dropped (`HIDDEN_MARGIN_MM`).
    strengths : (ndarray of shape (K_inner,), ndarray of shape (K_outer,)), optional
        Line strength of each inner and outer point's centre, kept with the points
        (`FusedProfile.strength`).

    Returns
    -------
    FusedProfile

    Raises
    ------
    DatumError
        If the back face or the reference point cannot be found.
    """
    if side not in ("left", "right"):
        raise ValueError(f"side must be 'left' or 'right', got {side!r}")
    sign = 1.0 if side == "right" else -1.0
    points = np.concatenate([inner_track_mm, outer_track_mm]).astype(GEOMETRY_FLOAT)
    sensor = np.concatenate(
        [np.zeros(len(inner_track_mm), np.int8), np.ones(len(outer_track_mm), np.int8)]
    )
    strength = None
    if strengths is not None:
        strength = np.concatenate([np.asarray(a, GEOMETRY_FLOAT).ravel() for a in strengths])
        if strength.shape != sensor.shape:
            raise ValueError(
                f"strengths must hold one value per point ({sensor.size}), got {strength.size}"
            )
    u, big_z = sign * points[:, 0], points[:, 2]
    u_back = _back_face_u(u[sensor == 0])
    z_ref = _reference_z(u, big_z, u_back)
    u_back = _refine_back_face(u, z_ref - big_z, u_back)
    z_ref = _reference_z(u, big_z, u_back)
    x, z = u - u_back, z_ref - big_z
    keep = (x > WHEEL_REACH_MM[0]) & (x < WHEEL_REACH_MM[1])
    keep &= (z > WHEEL_Z_MM[0]) & (z < WHEEL_Z_MM[1])
    x, z, sensor = x[keep], z[keep], sensor[keep]
    strength = None if strength is None else strength[keep]
    cameras_xz = None
    if cameras_track_mm is not None:
        cameras = np.asarray(cameras_track_mm, dtype=GEOMETRY_FLOAT)
        cameras_xz = np.column_stack([sign * cameras[:, 0] - u_back, z_ref - cameras[:, 2]])
    clean = clean_profile_points(np.column_stack([x, z]), sensor, cameras_xz)
    x, z, sensor = x[clean], z[clean], sensor[clean]
    strength = None if strength is None else strength[clean]
    offset = _cleaned_reference_offset(x, z)
    z, z_ref = z - offset, z_ref - offset
    on_face = (np.abs(x) < BACK_FACE_BAND_MM) & (z < BACK_FACE_Z_MM[1])
    order = np.concatenate(
        [
            np.flatnonzero(on_face)[np.argsort(z[on_face])],
            np.flatnonzero(~on_face)[np.argsort(x[~on_face])],
        ]
    )
    residual, count = overlap_residual(
        np.column_stack([x[sensor == 0], z[sensor == 0]])[~on_face[sensor == 0]],
        np.column_stack([x[sensor == 1], z[sensor == 1]]),
    )
    return FusedProfile(
        x_mm=x[order],
        z_mm=z[order],
        sensor=sensor[order],
        back_face_track_x_mm=sign * u_back,
        reference_track_z_mm=z_ref,
        overlap_residual_mm=residual,
        overlap_points=count,
        rejected_points=int(np.count_nonzero(~clean)),
        strength=None if strength is None else strength[order],
    )
