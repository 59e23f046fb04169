"""Lines, not edges (line_test), and the stripe's pieces, not the longest outline (segmentation)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import erfc

from pipeline import extract_centres
from pipeline.extraction.centres import _bright_chains
from pipeline.extraction.components import ComponentShapes
from pipeline.extraction.line_test import (
    BODY_SHARE,
    body_shares,
    is_line,
    line_profiles,
    on_bodies,
)
from pipeline.extraction.segmentation import (
    LINE_JOIN_PX,
    LINE_SIDE_PX,
    continuity_labels,
    joined_lines,
    longest_lines,
    stripe_components,
)
from pipeline.imaging import PixelRegion

SHAPE = (80, 120)
ROW = 40.3
"""The profile's centre row [px]; the profiles run across the rows (normal (0, 1))."""


def _frame(profile) -> np.ndarray:
    """A frame whose rows follow `profile(d)`, d = row − ROW [px], on a background of 12."""
    rows = np.arange(SHAPE[0], dtype=np.float64)[:, None] - ROW
    return np.broadcast_to(12 + profile(rows), SHAPE).astype(np.float64)


def _line(width_px: float, peak: float = 150.0):
    return lambda d: peak * np.exp(-8 * d**2 / width_px**2)


def _step(at_px: float, height: float):
    """Brighter by `height` above d = at_px (rows before it), blurred by σ 0.8 px."""
    return lambda d: height * 0.5 * erfc((d - at_px) / (np.sqrt(2) * 0.8))


def _test(
    image: np.ndarray, sigma_px: float, width_min_px: float = 5.0, c_grey: float = 2.55
) -> bool:
    x = np.array([60.0])
    y = np.array([ROW])
    normal = (np.zeros(1), np.ones(1))
    sigma = np.array([sigma_px])
    profiles = line_profiles(image, x, y, *normal, sigma, width_min_px=width_min_px, c_grey=c_grey)
    assert profiles.shape == (5, 1)
    return bool(is_line(profiles)[0])


@pytest.mark.parametrize(("width_px", "sigma_px"), [(5, 2.887), (13, 7.51), (21, 12.12)])
def test_a_bright_line_is_a_line(width_px, sigma_px) -> None:
    assert _test(_frame(_line(width_px)), sigma_px)


def test_a_line_on_a_lit_ramp_and_beside_a_dim_step_is_a_line() -> None:
    ramp = _frame(lambda d: _line(7)(d) + 1.5 * d + _step(-9, 25)(d))
    assert _test(ramp, 2.887)


def _glow(offset_px: float, peak: float, sigma_px: float = 4.0):
    """A specular glow of `peak` grey levels, Gaussian of std sigma_px, offset_px off d = 0."""
    return lambda d: peak * np.exp(-0.5 * ((d - offset_px) / sigma_px) ** 2)


def test_a_dim_line_on_the_flank_of_a_glow_is_a_line() -> None:
    # A dim flange tip (peak 40, w 8 px, on a background of 6) with a specular glow (50 grey
    # levels) 6 px to one side: the side read at d lies on the glow, no darker than the line;
    # the background beyond it, at 2d, is dark.
    tip = _frame(lambda d: _line(8, 40)(d) + _glow(6, 50)(d) - 6)
    assert _test(tip, 2.887)


def test_a_texture_ridge_on_the_flank_of_a_brighter_grain_is_not() -> None:
    # The same shapes on a lit surface (level 60) at a reflectance texture's contrast (a ridge
    # of 20, a grain of 25): the background beyond is not far below the ridge.
    grain = _frame(lambda d: 48 + _line(8, 20)(d) + _glow(6, 25)(d))
    assert not _test(grain, 2.887)


def test_the_bright_side_of_a_step_edge_is_not() -> None:
    # The shoulder 1 px inside a 100-grey-level step: λ1 < 0 there, the grey falls one way only.
    assert not _test(_frame(_step(1.0, 100)), 2.887)


def test_a_highlight_thinner_than_the_stripes_along_an_edge_is_not() -> None:
    highlight = _frame(lambda d: _line(2.5, 140)(d) + _step(1.5, 40)(d))
    assert not _test(highlight, 2.887)
    # The same highlight alone on a dark background: a line, but too thin for w_min 5 px.
    assert not _test(_frame(_line(2.5, 140)), 2.887)
    assert _test(_frame(_line(2.5, 140)), 2.887, width_min_px=2.5)


def test_a_stripe_beside_a_wide_piece_closer_than_d_is_a_line() -> None:
    # A 5 px stripe (peak 120) with the wide end of the next piece of a broken stripe
    # (w 15 px, peak 150) 12 px beside it: at σ1 the side read at d = 6.3 px lies on that
    # piece's flank, as bright as the line, and 2d inside it; a valley lies between them.
    beside = _frame(lambda d: _line(5, 120)(d) + _line(15, 150)(d - 12))
    assert _test(beside, 2.887)
    # The same shapes at a lit plate's texture contrast (ridge and grain 40 on 60): no valley
    # is looked for beside so weak a line; with the floor 5× lower it would be found.
    weak = _frame(lambda d: 48 + _line(5, 40)(d) + _line(15, 40)(d - 12))
    assert not _test(weak, 2.887)
    assert _test(weak, 2.887, c_grey=0.5)


def test_extraction_rejects_the_edge_and_keeps_the_stripe() -> None:
    # A stripe across the frame below a lit plate whose edge runs parallel to it.
    rows = np.arange(240, dtype=np.float64)[:, None]
    image = 12 + 150 * np.exp(-8 * (rows - 150.4) ** 2 / 9**2)
    image = image + 60 * 0.5 * erfc((rows - 60) / (np.sqrt(2) * 0.8))  # plate above row 60
    image = image + 120 * np.exp(-8 * (rows - 58.5) ** 2 / 2.5**2)  # its edge's highlight
    frame = np.broadcast_to(image, (240, 320)).astype(np.uint8)
    centres = extract_centres(frame, width_min=5, width_max=21)
    inside = (centres.x > 30) & (centres.x < 290)
    assert inside.sum() > 200
    assert np.abs(centres.y[inside] - 150.4).max() < 0.05
    assert (np.abs(centres.rejected_y - 58.5) < 3).sum() > 200


def _segment(rows, cols, row_px, first_px, stop_px, peak, width_px=7.0):
    along = (cols >= first_px) & (cols < stop_px)
    return peak * np.exp(-8 * (rows - row_px) ** 2 / width_px**2) * along


def test_every_piece_of_a_broken_stripe_is_kept_and_a_longer_dimmer_outline_is_not() -> None:
    rows, cols = np.mgrid[0:300, 0:640].astype(np.float64)
    image = 12 + _segment(rows, cols, 100.3, 20, 420, 170)  # the stripe's long piece
    image += _segment(rows, cols, 108.6, 432, 492, 150)  # its short piece past a 12 px cut
    image += _segment(rows, cols, 40.4, 300, 360, 170)  # another part's short stripe
    image += _segment(rows, cols, 230.2, 20, 620, 45, width_px=9)  # a dim outline, 600 px
    centres = extract_centres(np.rint(image).astype(np.uint8), width_min=5, width_max=21)
    assert ((np.abs(centres.y - 108.6) < 0.1) & (centres.x > 440) & (centres.x < 485)).sum() > 40
    assert ((np.abs(centres.y - 100.3) < 0.1) & (centres.x > 30) & (centres.x < 410)).sum() > 370
    assert not (np.abs(centres.y - 40.4) < 3).any()
    assert not (np.abs(centres.y - 230.2) < 3).any()


def test_a_glint_as_bright_as_the_stripe_and_apart_from_its_pieces_is_not_kept() -> None:
    # A stripe broken at a depth step (its second piece 12 px lower past a 16 px cut) and a
    # polished rod's glint as bright and as narrow, 160 px long, apart from it: the mask
    # keeps the glint (longer than 0.3 of the longest piece), the line rule does not (under
    # half of the stripe's pieces joined).
    rows, cols = np.mgrid[0:300, 0:640].astype(np.float64)
    image = 12 + _segment(rows, cols, 100.3, 20, 220, 170)  # the stripe's first piece
    image += _segment(rows, cols, 112.6, 236, 420, 170)  # its second piece
    image += _segment(rows, cols, 220.4, 300, 460, 170)  # the glint
    centres = extract_centres(np.rint(image).astype(np.uint8), width_min=5, width_max=21)
    assert ((np.abs(centres.y - 100.3) < 0.1) & (centres.x > 30) & (centres.x < 210)).sum() > 170
    assert ((np.abs(centres.y - 112.6) < 0.1) & (centres.x > 246) & (centres.x < 410)).sum() > 150
    assert not (np.abs(centres.y - 220.4) < 3).any()
    assert (np.abs(centres.rejected_y - 220.4) < 0.5).sum() > 140


def test_a_stripe_dimmed_to_a_third_of_the_frames_strongest_is_kept_and_a_ghost_is_not() -> None:
    # A wheel's back face where the laser grazes it: a wide stripe, C ≈ 28 grey levels
    # (≥ 10·c = 25.5) beside the tread's saturated one (C ≈ 81), 0.35 of it, far from it.
    rows, cols = np.mgrid[0:300, 0:640].astype(np.float64)
    image = 12 + _segment(rows, cols, 60.3, 20, 340, 243, width_px=5)  # the tread, saturated
    image += _segment(rows, cols, 200.6, 40, 600, 80, width_px=11)  # the back face, dim
    image += _segment(rows, cols, 110.2, 20, 340, 48, width_px=5)  # a 20 % ghost of the tread
    centres = extract_centres(np.rint(image).astype(np.uint8), width_min=5, width_max=21)
    assert ((np.abs(centres.y - 200.6) < 0.1) & (centres.x > 50) & (centres.x < 590)).sum() > 500
    assert ((np.abs(centres.y - 60.3) < 0.1) & (centres.x > 30) & (centres.x < 330)).sum() > 290
    assert not (np.abs(centres.y - 110.2) < 3).any()


def test_inside_a_search_region_a_short_bright_piece_is_kept() -> None:
    # The flange's glare piece (60 px, saturated) far from the tread's stripe and another
    # part's long stripe: shorter than 0.3 of the longest, so the whole frame drops it; inside
    # the region the calibration bounds every strong piece is kept (measurement's window
    # rejects what lies off the wheel).
    rows, cols = np.mgrid[0:300, 0:640].astype(np.float64)
    image = 12 + _segment(rows, cols, 60.3, 20, 620, 170)  # another part's stripe, 600 px
    image += _segment(rows, cols, 150.4, 200, 420, 170)  # the tread, 220 px
    image += _segment(rows, cols, 240.7, 300, 360, 243, width_px=5)  # the glare piece
    frame = np.rint(image).astype(np.uint8)
    glare = lambda c: ((np.abs(c.y - 240.7) < 0.1) & (c.x > 310) & (c.x < 350)).sum()  # noqa: E731
    assert glare(extract_centres(frame, width_min=5, width_max=21)) == 0
    inside = extract_centres(frame, width_min=5, width_max=21, region=PixelRegion(0, 300, 0, 640))
    assert glare(inside) > 35


def test_a_lit_bar_wider_than_the_widest_stripe_is_not_kept() -> None:
    # A 9 px laser line and a lit bar as bright (w 45 px, more than CHAIN_WIDTH_FACTOR ×
    # width_max): both are lines and strong, only the line is as wide as a stripe can be.
    rows, cols = np.mgrid[0:300, 0:640].astype(np.float64)
    image = 12 + _segment(rows, cols, 80.3, 20, 620, 150, width_px=9)
    image += _segment(rows, cols, 200.0, 40, 600, 150, width_px=45)
    frame = np.rint(image).astype(np.uint8)
    centres = extract_centres(frame, width_min=5, width_max=21)
    assert ((np.abs(centres.y - 80.3) < 0.1) & (centres.x > 30) & (centres.x < 610)).sum() > 570
    assert not (np.abs(centres.y - 200.0) < 10).any()
    assert (np.abs(centres.rejected_y - 200.0) < 3).sum() > 400
    # With the widest stripe configured at 45 px the bar is a stripe.
    wide = extract_centres(np.rint(image).astype(np.uint8), width_min=5, width_max=45)
    assert ((np.abs(wide.y - 200.0) < 0.5) & (wide.x > 60) & (wide.x < 580)).sum() > 400


def test_a_long_dim_chain_is_kept_beside_the_stripe_and_dropped_apart_from_it() -> None:
    # Chains of centres 1 px apart along x: the stripe's bright chain (height 100) at y 0, and
    # dim ones (height 20, a fifth of it): a long one 10 px beside it (a dim stretch of the
    # stripe), a long one 40 px off (a flare streak), a long one 80 px off but strong in itself
    # (C 30 ≥ 10·c), and a short one 5 px beside it (texture).
    rows = (0.0, 10.0, 40.0, 80.0, 5.0)
    lengths = (100, 40, 40, 40, 10)
    xy = np.concatenate(
        [np.column_stack([np.arange(n), np.full(n, r)]) for r, n in zip(rows, lengths, strict=True)]
    )
    bounds = np.cumsum((0, *lengths))
    chains = [np.arange(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
    height = np.repeat([100.0, 20, 20, 20, 20], lengths)
    strength = np.repeat([40.0, 8, 8, 30, 8], lengths)
    kept, dropped = _bright_chains(chains, height, strength, xy, c_grey=2.55)
    assert [c[0] for c in kept] == [bounds[0], bounds[1], bounds[3]]
    assert sorted(dropped) == [*range(bounds[2], bounds[3]), *range(bounds[4], bounds[5])]


def test_a_short_strong_dim_piece_in_a_gap_of_the_line_is_kept_one_leaving_it_is_not() -> None:
    # Chains of centres 1 px apart along x: bright pieces at 0–49 and 90–139, dim ones (under
    # CHAIN_FRACTION of the height, shorter than CHAIN_MIN_POINTS, strong: C 30 ≥ 10·c) at
    # 60–79, between them (a laser line dimmed over a dark square), and at 150–169, past
    # the second's end with nothing beyond it (a flare streak leaving the line).
    starts, lengths = (0, 60, 90, 150), (50, 20, 50, 20)
    xy = np.concatenate(
        [
            np.column_stack([s + np.arange(n, dtype=float), np.zeros(n)])
            for s, n in zip(starts, lengths, strict=True)
        ]
    )
    bounds = np.cumsum((0, *lengths))
    chains = [np.arange(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
    height = np.repeat([100.0, 40, 100, 40], lengths)
    strength = np.repeat([40.0, 30, 40, 30], lengths)
    kept, dropped = _bright_chains(chains, height, strength, xy, c_grey=2.55)
    assert [c[0] for c in kept] == [bounds[0], bounds[1], bounds[2]]
    assert sorted(dropped) == list(range(bounds[3], bounds[4]))


def test_pieces_end_to_near_are_one_line_and_a_shorter_line_apart_is_not_kept() -> None:
    # Chains of centres 1 px apart along x: a piece of 100, the next one past a gap just
    # inside LINE_JOIN_PX from its end and 20 px lower, a third just beyond the reach of the
    # second's end, and a line of 80 far from all (under half of the first two's 200).
    def chain(x0, y, n):
        return np.column_stack([x0 + np.arange(n, dtype=float), np.full(n, y)])

    gap = LINE_JOIN_PX - 1
    dy = 20.0
    dx = np.sqrt(gap**2 - dy**2)
    parts = [
        chain(0, 0, 100),
        chain(99 + dx, dy, 100),
        chain(198 + dx + LINE_JOIN_PX + 1, dy, 60),
        chain(0, 300, 80),
    ]
    xy = np.concatenate(parts)
    bounds = np.cumsum([0] + [len(p) for p in parts])
    chains = [np.arange(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
    line = joined_lines(xy, chains)
    assert line[0] == line[1]
    assert len({line[1], line[2], line[3]}) == 3
    assert longest_lines(xy, chains).tolist() == [True, True, False, False]


def test_lines_side_by_side_are_not_one_line() -> None:
    # A torch's rims and the wire below it (real frames weld-2, weld-8): a parallel chain
    # just beyond LINE_SIDE_PX beside a chain, their ends level, and one as far to the other
    # side starting just past its end are separate lines; the last just inside
    # LINE_SIDE_PX continues it.
    def chain(x, y0, n):
        return np.column_stack([np.full(n, float(x)), y0 + np.arange(n, dtype=float)])

    beside = LINE_SIDE_PX + 1
    parts = [chain(0, 0, 100), chain(-beside, 0, 100), chain(beside, 110, 30)]
    xy = np.concatenate(parts)
    bounds = np.cumsum([0] + [len(p) for p in parts])
    chains = [np.arange(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
    assert len(set(joined_lines(xy, chains))) == 3
    parts[2] = chain(LINE_SIDE_PX - 1, 110, 30)
    xy = np.concatenate(parts)
    line = joined_lines(xy, chains)
    assert line[0] == line[2] != line[1]


def _clipped(width_px: float, peak: float, centre_px: float = 0.0):
    """A Gaussian line of `peak` clipped at 243 grey levels above the background of 12."""
    return lambda d: np.minimum(_line(width_px, peak)(d - centre_px), 243.0)


def _body(width_px: float, peak: float):
    """A lit body under the line: a Gaussian bump of 1/e² width `width_px`."""
    return _line(width_px, peak)


@pytest.mark.parametrize(
    ("profile", "width_px", "on_body"),
    [
        (_line(9), 9.0, False),
        (_clipped(21, 2.5 * 243), 23.0, False),  # saturated 2.5×, as measured (≤ 23 px)
        (_clipped(13, 10 * 243), 20.0, False),  # saturated 10×
        (lambda d: _line(9)(d) + _step(-12, 60)(d), 9.0, False),  # beside a plate edge
        (lambda d: _line(9)(d) + _line(9, 150)(d - 14), 9.0, False),  # beside a second line
        (lambda d: _clipped(13, 400)(d) + _body(70, 100)(d), 24.0, True),  # a torch's highlight
    ],
    ids=["line", "clipped-2.5x", "clipped-10x", "plate-edge", "second-line", "torch"],
)
def test_a_highlight_on_a_lit_body_has_raised_shoulders_and_a_laser_line_has_not(
    profile, width_px, on_body
) -> None:
    rows = np.arange(200, dtype=np.float64)[:, None] - 100.3
    image = np.broadcast_to(np.minimum(12 + profile(rows), 255.0), (200, 60)).astype(np.uint8)
    one = np.ones(1)
    share = body_shares(image, 30 * one, 100.3 * one, 0 * one, one, width_px * one)[0]
    assert (share >= BODY_SHARE) == on_body, share


def test_a_chain_is_on_a_body_when_more_than_half_of_its_measured_shares_are_high() -> None:
    # on_bodies stops reading a chain's shares once its count is decided: the verdict is
    # the majority of the shares of every centre with a measured width (none: not on one).
    rng = np.random.default_rng(7)
    image = rng.integers(0, 256, (120, 160)).astype(np.uint8)
    sizes = [0, 1, 2, 3, 4, 5, 8, 9, 16, 33]
    count = sum(sizes)
    x, y = rng.uniform(-5, 165, count), rng.uniform(-5, 125, count)
    angle = rng.uniform(0, 2 * np.pi, count)
    width = rng.uniform(0.0, 30.0, count)
    width[rng.random(count) < 0.3] = np.nan
    chains = np.split(rng.permutation(count), np.cumsum(sizes)[:-1])
    width[chains[-2]] = np.nan  # a chain without a measured width
    shares = body_shares(image, x, y, np.cos(angle), np.sin(angle), width)
    expected = []
    for chain in chains:
        known = shares[chain][np.isfinite(shares[chain])]
        expected.append(bool(known.size) and 2 * (known >= BODY_SHARE).sum() > known.size)
    found = on_bodies(image, x, y, np.cos(angle), np.sin(angle), width, chains)
    assert found.tolist() == expected
    assert 0 < sum(expected) < len(chains)


def test_a_clipped_highlight_on_a_lit_body_is_not_kept_and_the_laser_is() -> None:
    # A polished torch: a saturated highlight, 13 px wide and 1.6× full scale, on its lit body
    # (a bump of 100 grey levels, 70 px wide), the strongest ridge of the frame; the laser
    # 9 px wide at 150.
    rows, cols = np.mgrid[0:300, 0:640].astype(np.float64)
    image = 12 + _segment(rows, cols, 80.3, 20, 620, 150, width_px=9)
    image += _segment(rows, cols, 200.0, 40, 600, 100, width_px=70)
    image += np.minimum(_segment(rows, cols, 200.0, 40, 600, 400, width_px=13), 243 - image)
    frame = np.rint(image).astype(np.uint8)
    centres = extract_centres(frame, width_min=5, width_max=21)
    assert ((np.abs(centres.y - 80.3) < 0.1) & (centres.x > 30) & (centres.x < 610)).sum() > 570
    assert not (np.abs(centres.y - 200.0) < 10).any()
    assert (np.abs(centres.rejected_y - 200.0) < 3).sum() > 400
    # Inside a search region no chain is judged so (the bloom around a glare on the stripe
    # raises its own pieces' shoulders; measurement rejects what lies off the wheel).
    inside = extract_centres(frame, width_min=5, width_max=21, region=PixelRegion(0, 300, 0, 640))
    assert ((np.abs(inside.y - 200.0) < 0.5) & (inside.x > 60) & (inside.x < 580)).sum() > 400


def test_inside_a_search_region_a_compact_glare_blob_continuing_a_piece_is_kept() -> None:
    # Components 1..5: the flank's stripe piece (strong, elongated); a compact blob of glare
    # and bloom within CONTINUITY_GAP_PX of it (area 700 px², elongation 1.4, as strong);
    # a second compact blob reached only through the first; a compact blob as strong but
    # near nothing kept; a compact blob near the piece but too weak for a strong candidate.
    shapes = ComponentShapes(
        area_px=np.array([0, 900, 700, 500, 800, 600], float),
        length_px=np.array([0, 120, 31, 25, 33, 28], float),
        elongation=np.array([0, 16.0, 1.4, 1.3, 1.4, 1.3]),
    )
    strength = np.array([0, 80.0, 85.0, 70.0, 90.0, 5.0])
    near = np.array([[1, 2], [2, 3], [1, 5]])
    c_grey = 2.55
    considered = continuity_labels(shapes, strength, c_grey, every_strong=True)
    assert considered is not None and considered.tolist() == [False, True, True, True, True, False]
    kept = stripe_components(shapes, strength, near, c_grey, every_strong=True)
    assert kept.tolist() == [False, True, True, True, False, False]
    # On the whole frame (no search region) a compact blob is never a stripe piece.
    assert continuity_labels(shapes, strength, c_grey, every_strong=False) is None
    whole = stripe_components(shapes, strength, near, c_grey)
    assert whole.tolist() == [False, True, False, False, False, False]
