"""Scores of extracted centres against a synthetic stripe's exact truth (stripe_images).

False points are centres farther than FALSE_DISTANCE_PX from the true stripe; the RMS is that
of the others. Coverage comes two ways: `coverage_pct` and `max_gap_px` along the line's arc
(true points' projections within GAP_ARC_PX of arc, the issue-3 definition), and, per
segment, `segment_coverage_pct`, the share of the truth with a centre within
COVER_DISTANCE_PX (issue 15's, the same as on real frames).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from tests.pipeline.stripe_images import TRUTH_STEP_PX, SyntheticStripe, project_on_line

EVAL_MARGIN_PX = 10
"""Truth and points this close to the frame edge are not scored (reflected border)."""

FALSE_DISTANCE_PX = 3.0
GAP_ARC_PX = 1.5
COVER_DISTANCE_PX = 2.5
"""A truth sample is covered when a centre lies within this distance of it [px] (issue 15)."""


@dataclass(frozen=True)
class Score:
    """Accuracy of extracted centres against the truth line (scored area: EVAL_MARGIN_PX in).

    `segment_coverage_pct` is, per segment, the share of the scored truth samples with a
    centre within COVER_DISTANCE_PX (issue 15's coverage); `bound_px` the quadratic mean of
    the truth's noise bound over the scored samples (`noise_bound_px`).
    """

    points: int
    rms_px: float
    max_error_px: float
    false_pct: float
    max_gap_px: float
    coverage_pct: float
    segment_coverage_pct: tuple[float, ...]
    bound_px: float

    @property
    def min_segment_coverage_pct(self) -> float:
        return min(self.segment_coverage_pct)

    @property
    def rms_to_bound(self) -> float:
        return self.rms_px / self.bound_px


def score_centres(stripe: SyntheticStripe, x: np.ndarray, y: np.ndarray) -> Score:
    """RMS distance of true points, false points (> 3 px off), largest gap and coverage.

    Notes
    -----
    Points within 3 px of the truth are "true"; their RMS distance is `rms_px` (those
    projecting into a cut end's zone are true but not in the RMS). Each true point is
    projected on the line (arc length); the largest stretch of a segment's scored line not
    within 1.5 px of arc length of a projection is `max_gap_px` (0 when every point of the
    line is covered), and `coverage_pct` is the covered fraction of the scored line.
    """
    rows, cols = stripe.image.shape
    m = EVAL_MARGIN_PX
    xy = np.stack([x, y], axis=1)
    inside = (x >= m) & (x <= cols - 1 - m) & (y >= m) & (y <= rows - 1 - m)
    xy = xy[inside]
    line = stripe.line_xy
    scored = (
        (line[:, 0] >= m)
        & (line[:, 0] <= cols - 1 - m)
        & (line[:, 1] >= m)
        & (line[:, 1] <= rows - 1 - m)
        & ~stripe.end_zone
    )
    d, s, in_end = np.zeros(0), np.zeros(0), np.zeros(0, bool)
    if len(xy):
        foot = project_on_line(cKDTree(line), line, stripe.arc_px, xy, stripe.segment)
        d, s, in_end = foot.distance_px, foot.arc_px, stripe.end_zone[foot.index]
    true = d <= FALSE_DISTANCE_PX
    measured = true & ~in_end
    arc = stripe.arc_px[scored]
    covered = np.zeros(len(arc), bool)
    if true.any():
        proj = np.sort(s[true])
        k = np.clip(np.searchsorted(proj, arc), 1, len(proj) - 1) if len(proj) > 1 else 0
        nearest = np.minimum(np.abs(arc - proj[np.maximum(k - 1, 0)]), np.abs(arc - proj[k]))
        covered = nearest <= GAP_ARC_PX
    segment = stripe.segment[scored]
    near = cKDTree(xy).query(line[scored])[0] <= COVER_DISTANCE_PX if len(xy) else ~scored[scored]
    numbers = np.unique(segment)
    return Score(
        points=int(len(xy)),
        rms_px=float(np.sqrt(np.mean(d[measured] ** 2))) if measured.any() else float("nan"),
        max_error_px=float(d[measured].max()) if measured.any() else float("nan"),
        false_pct=float(100 * (~true).sum() / max(len(xy), 1)),
        max_gap_px=float(max(_runs(~covered[segment == i]) for i in numbers) * TRUTH_STEP_PX),
        coverage_pct=float(100 * covered.mean()) if len(arc) else 0.0,
        segment_coverage_pct=tuple(float(100 * near[segment == i].mean()) for i in numbers),
        bound_px=float(np.sqrt(np.mean(stripe.bound_px[scored] ** 2))),
    )


def _runs(flags: np.ndarray) -> int:
    """Length of the longest run of True."""
    if not flags.any():
        return 0
    padded = np.concatenate([[0], flags.astype(np.int8), [0]])
    edges = np.flatnonzero(np.diff(padded))
    return int((edges[1::2] - edges[::2]).max())
