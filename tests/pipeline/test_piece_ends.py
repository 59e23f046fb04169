"""Centres at the ends of a stripe piece against exact truth (tests/pipeline/piece_ends.py).

A piece that fades out over 6 px or stops sharply (an occlusion) inside the frame, w 9 px,
read noise σ 3 and shot noise, dark scene. Bars: the centres 0–2 from a polyline's end lie
a median ≤ END_BAR_PX across the true line; those ≥ 16 from an end ≤ INTERIOR_BAR_PX (the
scoring's own check). Where the adaptive method does not yet meet a bar the test is a strict
expected failure with the figure measured when it was added (docs/extraction.md, "Centres
at a piece's end").
"""

from __future__ import annotations

import functools

import pytest

from pipeline import extract_centres
from tests.pipeline.bars import bar_params
from tests.pipeline.piece_ends import EndScore, PieceCase, make_piece, score_piece

NOISE = {"read_noise": 3.0, "shot_noise": True}
CASES = {
    case.name: case
    for case in (
        PieceCase("straight-fade6", **NOISE),
        PieceCase("straight-sharp", fade_px=0, **NOISE),
    )
}
END_BAR_PX = 0.2
"""Median |across| of the centres 0–2 from an end [px]: the normal fit's end points reach
0.12–0.13 px on these frames when read along the interior's normal."""
INTERIOR_BAR_PX = 0.03
"""Median |across| of the centres ≥ 16 from an end [px] (measured 0.015)."""

NOT_YET: dict[tuple[str, str], str] = {}


@functools.cache
def adaptive_ends(name: str) -> EndScore:
    piece = make_piece(CASES[name])
    found = extract_centres(piece.image, "adaptive")
    return score_piece(piece, found.x, found.y, found.nx, found.ny, found.polylines)


@pytest.mark.parametrize(("metric", "name"), bar_params(CASES, ("end", "interior"), NOT_YET))
def test_adaptive_centres_at_piece_ends(metric: str, name: str) -> None:
    score = adaptive_ends(name)
    if metric == "end":
        assert score.median_abs(0, upto=2) <= END_BAR_PX
    else:
        assert score.median_abs(16, upto=10**9) <= INTERIOR_BAR_PX


def test_one_polyline_per_piece() -> None:
    piece = make_piece(CASES["straight-sharp"])
    found = extract_centres(piece.image, "adaptive")
    assert len(found.polylines) == 1
