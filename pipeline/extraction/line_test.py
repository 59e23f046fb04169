"""Lines, not edges: a candidate centre is a bright line's only when the grey falls off on
both sides of it.

A bright step edge has λ1 < 0 on its bright side and a ridge response near 1, and so has a
thin highlight along an edge; the Hessian alone does not ask whether the grey falls off on
*both* sides. The test reads the frame's profile along the normal, smoothed at the scale the
centre was found at, at the centre and at ±SIDE_REACH_SIGMAS·σ, where the line the scale
matches (w = √3·σ) has fallen to e⁻² of its smoothed peak; a side that does not fall off
enough there is read again twice as far, beyond a bright spot or glow beside the line, where
the line stands well above it. It asks the unsmoothed profile whether the line is as wide as
the narrowest stripe expected.

A round spot (a specular glint beside the stripe) passes both: across any line through its
centre the grey falls off on both sides. What it is not is long: along the would-be line
the grey falls off as fast as across it, so the Hessian's second eigenvalue λ2 is about as
negative as λ1, where a line has λ2 ≈ 0. `is_spot` asks that of each linked chain.
"""

from __future__ import annotations

import math

import numpy as np

from pipeline.extraction.scalespace import bilinear_at
from pipeline.extraction.segmentation import chain_maxima
from pipeline.jit import kernel

SIDE_REACH_SIGMAS = 2.0 * math.sqrt(1.0 + 3.0 / 16.0)
"""Where the sides are read, in units of the centre's σ: a Gaussian line of 1/e² width
w = √3·σ (s = w/4) smoothed at σ has the standard deviation √(σ² + s²) = 1.09·σ, and twice
that (2.18·σ) is where its smoothed profile is down to e⁻² ≈ 0.14 of its peak."""


BACKGROUND_REACH_FACTOR = 2.0
"""A side's level is also read at this multiple of d: beyond a bright spot or glow beside
the line (specular spots 8–12 px off a dim flange tip lift the read at d to the line's
level or above it), the background the line stands on."""

BACKGROUND_CONTRAST = 1.0
"""The farther read is the side's level only where the line stands above it by at least
this share of it: light added by the laser, not the reflectance texture of a lit surface,
which multiplies the ambient level (15 % standard deviation: a texture ridge 3σ high is
0.45 of its surroundings). The bright side of a step edge is as bright at 2d as at d."""

VALLEY_START_SIGMAS = 1.0
"""A strong line's side (VALLEY_FALL_C) that fails at d and at the background read is read a
third time, for a valley between the line and a bright neighbour closer than d (the wide
end of the next piece of a stripe broken at a depth step, a second laser line where the two
cross): the lowest grey of the profile smoothed at σ/2 (VALLEY_SMOOTHING) from this
multiple of σ out to d, every VALLEY_STEP_PX. A line of the width σ matches is down to 0.32
of its peak at σ in that profile; the bright side of a step edge does not dip below the
candidate's level."""

VALLEY_FALL_C = 6.0
"""The valley is looked for only beside a line whose stronger side falls off by at least
this many times the ridge response's structure constant c (`ridges.RIDGE_C_FULL_SCALE`,
15.3 grey levels in 8 bit: a Gaussian line of peak ≈ 45 at its matching scale). Laser
lines fall off by 57–75 on the lit synthetic scenes and 15–95 on the real frames; a texture
ridge of a lit plate by 10–18 (lit-edge-crossing), and beside one a texture bump opens a
valley as well: at 3·c a 33-point texture chain passes there (3.4 % false points), at
10·c the crossing lines of weld-2 lose 0.7 point of coverage (95.1 → 94.4 %)."""

VALLEY_SMOOTHING = 0.5
"""The valley's profile is smoothed by a Gaussian of this share of the centre's σ."""

VALLEY_STEP_PX = 1.0
"""Spacing of the valley reads [px]."""

SIDE_FLOOR = 0.5
"""A line's weaker side falls off by at least this share of its stronger side's fall-off.
A line on a flat background has 1, on a lit ramp or across a plate edge a little less; the
bright side of a step edge has about 0, and a highlight thinner than the narrowest stripe
along a plate edge (w 2.5 px, 30–60 grey levels of step) has 0.15–0.4 at σ1."""

SHOULDER_WIDTHS = 0.3
"""Where the line's shoulders are read on the unsmoothed profile, as a share of the narrowest
stripe width w_min: at ±0.3·w_min a Gaussian line of width w keeps exp(−0.72·(w_min/w)²) of
its height, 0.49 at w = w_min, 0.06 at w = w_min/2."""

SHOULDER_FLOOR = 0.25
"""A line's shoulders keep at least this share of its height above the brighter side: the
line is at least 0.72·w_min wide (a thin highlight along a lit edge is not)."""

TANGENT_OFFSETS_PX = (-1.0, 0.0, 1.0)
"""The unsmoothed profile (centre and shoulders) is averaged over three parallel lines this
far along the tangent [px]; the smoothed one is read on the normal itself, its taps
averaging enough already."""


@kernel
def _profile_at(image, x, y, nx, ny, t, inside) -> float:
    """Mean grey at t [px] along the normal from (x, y), over the lines TANGENT_OFFSETS_PX
    along the tangent."""
    grey = 0.0
    for u in TANGENT_OFFSETS_PX:
        grey += bilinear_at(image, x + t * nx - u * ny, y + t * ny + u * nx, inside)
    return grey / len(TANGENT_OFFSETS_PX)


SMOOTHING_TAPS = 4
"""The profile is smoothed by a Gaussian of the centre's σ sampled at 2·SMOOTHING_TAPS + 1
taps σ/2 apart (±2σ, 95 % of its weight): each tap a bilinear read, so the cost does not
grow with σ."""


@kernel
def _side_passes(fall: float, stronger: float) -> bool:
    """A side's fall-off [grey levels] is positive and ≥ SIDE_FLOOR of the stronger side's."""
    return fall > 0 and fall >= SIDE_FLOOR * stronger


@kernel
def _smoothed_at(image, x, y, nx, ny, s, offset, weights, inside) -> float:
    """The frame's grey at `offset` [px] along the normal from (x, y), smoothed along the
    normal by the Gaussian of std s sampled by `weights` (taps s/2 apart)."""
    grey = 0.0
    for j in range(-SMOOTHING_TAPS, SMOOTHING_TAPS + 1):
        t = offset + 0.5 * j * s
        grey += weights[j + SMOOTHING_TAPS] * bilinear_at(image, x + t * nx, y + t * ny, inside)
    return grey


@kernel
def _background_level(image, x, y, nx, ny, s, reach, centre, near, weights, inside) -> float:
    """A side's level when its read `near` at `reach` [px] (signed) along the normal fails
    the side test: the read BACKGROUND_REACH_FACTOR farther where it is lower and the line
    stands above it by at least BACKGROUND_CONTRAST of it, else `near`."""
    far = _smoothed_at(image, x, y, nx, ny, s, BACKGROUND_REACH_FACTOR * reach, weights, inside)
    if far < near and centre - far >= BACKGROUND_CONTRAST * far:
        return far
    return near


@kernel
def _valley_level(image, x, y, nx, ny, s, reach, near, weights, inside) -> float:
    """A side's level when its reads at d and beyond fail the side test: the lowest grey,
    smoothed at VALLEY_SMOOTHING·s, from VALLEY_START_SIGMAS·s out to `reach` [px]
    (signed) along the normal, if lower than `near`."""
    fine = VALLEY_SMOOTHING * s
    direction = 1.0 if reach > 0 else -1.0
    lowest = near
    t = VALLEY_START_SIGMAS * s
    while t <= abs(reach):
        lowest = min(
            lowest, _smoothed_at(image, x, y, nx, ny, fine, direction * t, weights, inside)
        )
        t += VALLEY_STEP_PX
    return lowest


@kernel
def _line_profiles(image, x, y, nx, ny, sigma, shoulder_px, strong_fall, out) -> None:
    """Per centre: out[0], out[1] the fall-off to +d·n and −d·n of the profile smoothed along
    the normal by a Gaussian of the centre's σ (SMOOTHING_TAPS), a side that fails the side
    test read against its background (`_background_level`), then, beside a line whose
    stronger side falls off by ≥ `strong_fall`, for a valley (`_valley_level`); out[2] the
    unsmoothed profile's height at the centre and out[3] the lower of its heights at
    ±shoulder_px, both above the brighter side; out[4] the stronger side's fall-off at d.
    Once a side fails the side test (`is_line` fails) the reads still to come are not
    made (out[1] after the side +n, out[2] and out[3]: NaN): 18k of the lit speed frame's
    25k candidates fail."""
    height, width = image.shape
    weights = np.empty(2 * SMOOTHING_TAPS + 1)
    for j in range(-SMOOTHING_TAPS, SMOOTHING_TAPS + 1):
        weights[j + SMOOTHING_TAPS] = np.exp(-0.125 * j * j)  # taps σ/2 apart
    weights /= weights.sum()
    for k in range(x.size):
        s = sigma[k]
        reach = SIDE_REACH_SIGMAS * s
        # Every read lies within `extent` of the centre: no folding needed inside the frame.
        extent = BACKGROUND_REACH_FACTOR * reach + 0.5 * SMOOTHING_TAPS * s + 1.0
        extent += max(TANGENT_OFFSETS_PX)
        inside = extent <= x[k] < width - 1 - extent and extent <= y[k] < height - 1 - extent
        xk, yk, nxk, nyk = x[k], y[k], nx[k], ny[k]
        centre = _smoothed_at(image, xk, yk, nxk, nyk, s, 0.0, weights, inside)
        plus = _smoothed_at(image, xk, yk, nxk, nyk, s, reach, weights, inside)
        minus = _smoothed_at(image, xk, yk, nxk, nyk, s, -reach, weights, inside)
        stronger = centre - min(plus, minus)
        if not _side_passes(centre - plus, stronger):
            plus = _background_level(
                image, xk, yk, nxk, nyk, s, reach, centre, plus, weights, inside
            )
        if stronger >= strong_fall and not _side_passes(centre - plus, stronger):
            plus = _valley_level(image, xk, yk, nxk, nyk, s, reach, plus, weights, inside)
        if not _side_passes(centre - plus, stronger):  # not a line: the rest is not read
            out[0, k], out[4, k] = centre - plus, stronger
            out[1, k] = out[2, k] = out[3, k] = np.nan
            continue
        if not _side_passes(centre - minus, stronger):
            minus = _background_level(
                image, xk, yk, nxk, nyk, s, -reach, centre, minus, weights, inside
            )
        if stronger >= strong_fall and not _side_passes(centre - minus, stronger):
            minus = _valley_level(image, xk, yk, nxk, nyk, s, -reach, minus, weights, inside)
        out[0, k] = centre - plus
        out[1, k] = centre - minus
        out[4, k] = stronger
        if not _side_passes(centre - minus, stronger):
            out[2, k] = out[3, k] = np.nan
            continue
        side = max(minus, plus)
        out[2, k] = _profile_at(image, xk, yk, nxk, nyk, 0.0, inside) - side
        shoulder = min(
            _profile_at(image, xk, yk, nxk, nyk, shoulder_px, inside),
            _profile_at(image, xk, yk, nxk, nyk, -shoulder_px, inside),
        )
        out[3, k] = shoulder - side


def line_profiles(
    image: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    nx: np.ndarray,
    ny: np.ndarray,
    sigma: np.ndarray,
    *,
    width_min_px: float,
    c_grey: float,
) -> np.ndarray:
    """The profile across candidate centres: how far the grey falls off on each side, and
    the line's height at its centre and shoulders.

    Parameters
    ----------
    image : ndarray of shape (M, N), uint8, uint16 or float
        The frame [grey levels].
    x, y, nx, ny : ndarray of shape (K,)
        Centres [px] and unit normals.
    sigma : ndarray of shape (K,)
        The scale each centre was found at [px].
    width_min_px : float
        The narrowest stripe width expected [px].
    c_grey : float
        The ridge response's structure constant c [grey levels] (`ridges.RIDGE_C_FULL_SCALE`
        of full scale): the valley read is tried beside lines whose stronger side falls off
        by ≥ VALLEY_FALL_C·c.

    Returns
    -------
    ndarray of shape (5, K), float64
        [grey levels] Rows 0 and 1: fall-off of the profile smoothed at σ (along the normal,
        SMOOTHING_TAPS) from the centre to its level on the side +n and −n: the read at
        d = SIDE_REACH_SIGMAS·σ, or, for a side that falls off by less than SIDE_FLOOR of
        the stronger side (or not at all), its background beyond a spot (the read at
        BACKGROUND_REACH_FACTOR·d where the line stands above it by ≥ BACKGROUND_CONTRAST
        of it) or, beside a strong line, the valley before a bright neighbour (the lowest
        read from VALLEY_START_SIGMAS·σ to d, smoothed at VALLEY_SMOOTHING·σ); negative
        where the side is brighter.
        Rows 2 and 3: the unsmoothed profile at the centre and the lower of it at
        ±SHOULDER_WIDTHS·width_min_px, above the brighter side's level, each the mean over
        lines TANGENT_OFFSETS_PX along the tangent.
        Row 4: the stronger side's fall-off at d. Read bilinearly, reflect border.
        Where a side fails the side test (`is_line` is False), the rows not yet read are
        NaN: row 1 when the side +n fails, rows 2 and 3 when either does.
    """
    out = np.empty((5, np.size(x)))
    fx, fy, fnx, fny, fsigma = (np.ascontiguousarray(a, np.float64) for a in (x, y, nx, ny, sigma))
    _line_profiles(
        np.ascontiguousarray(image),
        fx,
        fy,
        fnx,
        fny,
        fsigma,
        SHOULDER_WIDTHS * width_min_px,
        VALLEY_FALL_C * c_grey,
        out,
    )
    return out


def is_line(profiles: np.ndarray) -> np.ndarray:
    """Whether each candidate is a bright stripe's line (bool (K,)).

    Its weaker side falls off (to its level at d or, beyond a bright spot, to its
    background) by more than 0 and by at least SIDE_FLOOR of its stronger side's fall-off at
    d (a line, not an edge), and its shoulders keep at least SHOULDER_FLOOR
    of its height (not thinner than the stripes expected).
    """
    weaker, stronger = profiles[:2].min(axis=0), profiles[4]
    wide = profiles[3] >= SHOULDER_FLOOR * profiles[2]
    return (weaker > 0) & (weaker >= SIDE_FLOOR * stronger) & wide


BODY_NEAR_WIDTHS = 0.75
"""Where a line's shoulders are read, in units of its measured 1/e² width W (`widths`): a
Gaussian line is down to exp(−2·1.5²) = 1.1 % of its peak at 0.75·W, a line clipped at
2.5× full scale to 2.8 % of the clip level."""

BODY_FAR_WIDTHS = 2.0
"""... against the lowest grey on the same side out to this many W (BODY_READS reads from
the shoulder on): the level of the surface the line lies on."""

BODY_READS = 6
"""Reads from BODY_NEAR_WIDTHS·W to BODY_FAR_WIDTHS·W, a quarter of W apart: the same
cost at every width (a dark gap between a highlight and the next bright line on its body,
6–12 px on the real frames beside a 22–26 px wide highlight, is not missed)."""

BODY_SHARE = 0.11
"""A line whose shoulders, on both sides, stand at least this share of its height above
the surface beside them is a highlight on a lit body, not light added by the laser. A
specular highlight along a polished cylinder (a welding torch, a rod) is clipped and lies
on the body it reflects from: on the real frames its shoulders keep 17–22 % of its height
(chain medians) where the laser's chains keep ≤ 6.5 % (9.9 % for an 18-centre piece where
two laser lines cross); on the synthetic stripes (texture, noise, lit plates, crossings,
broken pieces, saturation) ≤ 5 %."""


@kernel
def _body_extent(image, x, y, w) -> bool:
    """Whether every read of `_side_share` at a centre of width W = w lies inside the frame."""
    height, frame_width = image.shape
    extent = BODY_FAR_WIDTHS * w + max(TANGENT_OFFSETS_PX) + 1.0
    return extent <= x < frame_width - 1 - extent and extent <= y < height - 1 - extent


@kernel
def _side_share(image, x, y, nx, ny, w, direction, centre, inside) -> float:
    """(shoulder − surface)/(centre − surface) on the side `direction` (±1) of one centre of
    width W = w > 0 and unsmoothed grey `centre`, the shoulder read at BODY_NEAR_WIDTHS·W
    and the surface the lowest of BODY_READS reads from there to BODY_FAR_WIDTHS·W
    (`_profile_at`); 0 where the line does not stand above the surface at all."""
    spacing = (BODY_FAR_WIDTHS - BODY_NEAR_WIDTHS) * w / (BODY_READS - 1)
    near = direction * BODY_NEAR_WIDTHS * w
    shoulder = _profile_at(image, x, y, nx, ny, near, inside)
    surface = shoulder
    for i in range(1, BODY_READS):
        t = near + direction * i * spacing
        surface = min(surface, _profile_at(image, x, y, nx, ny, t, inside))
    rise = centre - surface
    return (shoulder - surface) / rise if rise > 0 else 0.0


@kernel
def _body_share(image, x, y, nx, ny, w) -> float:
    """The lower over the two sides of `_side_share` at one centre of width W = w > 0."""
    inside = _body_extent(image, x, y, w)
    centre = _profile_at(image, x, y, nx, ny, 0.0, inside)
    lower = np.inf
    for direction in (1.0, -1.0):
        lower = min(lower, _side_share(image, x, y, nx, ny, w, direction, centre, inside))
    return lower


@kernel
def _is_high(image, x, y, nx, ny, w) -> bool:
    """`_body_share` ≥ BODY_SHARE at one centre of width W = w > 0: the side −n is read
    only where the side +n reaches it (the laser's centres fail on both sides, so this
    halves their reads)."""
    inside = _body_extent(image, x, y, w)
    centre = _profile_at(image, x, y, nx, ny, 0.0, inside)
    for direction in (1.0, -1.0):
        if not _side_share(image, x, y, nx, ny, w, direction, centre, inside) >= BODY_SHARE:
            return False
    return True


@kernel
def _measured(w: float) -> bool:
    """Whether a width W [px] was measured (finite and > 0)."""
    return np.isfinite(w) and w > 0


@kernel
def _body_shares(image, x, y, nx, ny, width, out) -> None:
    """Per centre `_body_share`; NaN where W was not measured."""
    for k in range(x.size):
        w = width[k]
        out[k] = _body_share(image, x[k], y[k], nx[k], ny[k], w) if _measured(w) else np.nan


def body_shares(
    image: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    nx: np.ndarray,
    ny: np.ndarray,
    width_px: np.ndarray,
) -> np.ndarray:
    """How far each line's shoulders stand above the surface beside it, as a share of the
    line's height: the lower of its two sides.

    Parameters
    ----------
    image, x, y, nx, ny : ndarray
        The frame and the centres with their normals, as for `line_profiles`.
    width_px : ndarray of shape (K,)
        Measured 1/e² widths W [px] (`widths.stripe_widths`); NaN where none was measured.

    Returns
    -------
    ndarray of shape (K,), float64
        Per side, (shoulder − surface)/(centre − surface) of the unsmoothed profile (mean
        over lines TANGENT_OFFSETS_PX along the tangent): the shoulder read at
        BODY_NEAR_WIDTHS·W, the surface the lowest of BODY_READS reads from there out to
        BODY_FAR_WIDTHS·W; 0 on a side the centre does not stand above. The lower of the
        two sides; NaN where W is NaN. Read bilinearly, reflect border.
    """
    out = np.empty(np.size(x))
    arrays = (x, y, nx, ny, width_px)
    fx, fy, fnx, fny, fwidth = (np.ascontiguousarray(a, np.float64) for a in arrays)
    _body_shares(np.ascontiguousarray(image), fx, fy, fnx, fny, fwidth, out)
    return out


@kernel
def _on_bodies(image, x, y, nx, ny, width, bounds, out) -> None:
    """Per chain points[bounds[c]:bounds[c + 1]]: whether more than half of its centres of
    measured width have `_body_share` ≥ BODY_SHARE (`_is_high`). Its centres are read in
    order until the count decides either way."""
    for c in range(bounds.size - 1):
        lo, hi = bounds[c], bounds[c + 1]
        known = 0
        for k in range(lo, hi):
            known += _measured(width[k])
        high, left = 0, known
        for k in range(lo, hi):
            if 2 * high > known or 2 * (high + left) <= known:
                break
            if _measured(width[k]):
                left -= 1
                high += _is_high(image, x[k], y[k], nx[k], ny[k], width[k])
        out[c] = 2 * high > known


def on_bodies(
    image: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    nx: np.ndarray,
    ny: np.ndarray,
    width_px: np.ndarray,
    chains: list[np.ndarray],
) -> np.ndarray:
    """Which linked chains of centres are highlights on a lit body, not the laser.

    Parameters
    ----------
    image, x, y, nx, ny, width_px : ndarray
        The frame, the centres (K,) with their normals and measured widths, as for
        `body_shares`.
    chains : list of ndarray of int
        The chains, index arrays into the centres.

    Returns
    -------
    ndarray of shape (len(chains),), bool
        More than half of the chain's centres with a measured width have `body_shares`
        ≥ BODY_SHARE (False for a chain with none). A chain's shares are read only until
        its count is decided.
    """
    out = np.zeros(len(chains), bool)
    if not chains:
        return out
    points = np.concatenate(chains)
    bounds = np.cumsum([0] + [c.size for c in chains])
    arrays = (x[points], y[points], nx[points], ny[points], width_px[points])
    fx, fy, fnx, fny, fwidth = (np.ascontiguousarray(a, np.float64) for a in arrays)
    _on_bodies(np.ascontiguousarray(image), fx, fy, fnx, fny, fwidth, bounds, out)
    return out


SPOT_RATIO = 0.6
"""A chain is a round spot when λ2/λ1 at the chosen σ, at its highest centre, is at least
this. A round Gaussian spot has 1 at its centre whatever its size and the scale; a straight
line 0, one curved at radius R ≈ (σ/R)² (≤ 0.05 for the flange top, R ≥ 30 px at σ ≤ 7 px);
inside a line's end, smoothed at σ, at most 0.34 (at σ from the end); the middle of a piece
of line of length L has 0.84 at L = 2σ, 0.53 at 3σ and 0.27 at 4σ, so a piece at least 3σ
(1.7 widths the scale matches) long is a line. On simulated wheel frames spots have
0.89–0.99, the stripe's chains −0.06–0.2 (0.38 at most at any centre)."""

SPOT_LENGTH_SIGMAS = 6.0
"""... and the chain is at most this many σ (at its highest centre) long along its centres:
the chains through a spot's centre reach to where λ1 fades, 2.5–4.2 σ on simulated wheel
frames; a chain of the stripe with a glint on it (λ2/λ1 ≈ 1 at the glint, its highest
centre) is longer."""


def is_spot(xy: np.ndarray, height: np.ndarray, ratio: np.ndarray, sigma: np.ndarray) -> bool:
    """Whether a linked chain of centres is a round spot, not a piece of line.

    Parameters
    ----------
    xy : ndarray of shape (K, 2)
        The chain's centres in order [px].
    height : ndarray of shape (K,)
        Their heights above the brighter side [grey levels] (`line_profiles` row 2).
    ratio : ndarray of shape (K,)
        λ2/λ1 of the Hessian at the scale each centre was found at.
    sigma : ndarray of shape (K,)
        That scale [px].

    Returns
    -------
    bool
        λ2/λ1 at the highest centre ≥ SPOT_RATIO and the chain's length along its centres
        ≤ SPOT_LENGTH_SIGMAS·σ there.
    """
    top = int(np.argmax(height))
    length = float(np.hypot(*np.diff(xy, axis=0).T).sum())
    return bool(ratio[top] >= SPOT_RATIO and length <= SPOT_LENGTH_SIGMAS * sigma[top])


def chain_tops(height: np.ndarray, chains: list[np.ndarray]) -> np.ndarray:
    """The centre of each chain (an index into the centres) where `height` is highest, the
    first of equal ones (as `np.argmax`: a chain holding NaN heights gets its first NaN),
    for all chains at once: (len(chains),) int64. Chains must not be empty."""
    points = np.concatenate(chains)
    owner = np.repeat(np.arange(len(chains)), [c.size for c in chains])
    values = height[points]
    at = np.flatnonzero((values == chain_maxima(height, chains)[owner]) | np.isnan(values))
    first = np.unique(owner[at], return_index=True)[1]
    return points[at[first]]


def spot_chains(
    xy: np.ndarray,
    height: np.ndarray,
    ratio: np.ndarray,
    sigma: np.ndarray,
    chains: list[np.ndarray],
) -> np.ndarray:
    """`is_spot` of each linked chain (bool (len(chains),)); the arrays hold all centres
    (as for `is_spot`) and `chains` index them. λ2/λ1 at each chain's highest centre is
    looked up for all chains at once; only the chains where it reaches SPOT_RATIO are
    measured along (a lit frame has hundreds of chains and a dozen such)."""
    out = np.zeros(len(chains), bool)
    if not chains:
        return out
    round_top = ratio[chain_tops(height, chains)] >= SPOT_RATIO
    for i in np.flatnonzero(round_top):
        c = chains[i]
        out[i] = is_spot(xy[c], height[c], ratio[c], sigma[c])
    return out
