"""Inside a search region a dim, short chain of centres that continues a kept chain (a
polished flank dimmed next to its glare) is kept; dim chains beside the stripe, across it
or off its line are not, and without a region the rule does not apply."""

from __future__ import annotations

import numpy as np

from pipeline.extraction.centres import _bright_chains


def _chains(*pieces: np.ndarray) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """Chains as index ranges into the stacked (x, y) of the pieces."""
    points = np.concatenate(pieces)
    bounds = np.cumsum([0] + [len(p) for p in pieces])
    chains = [np.arange(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
    return chains, points[:, 0], points[:, 1]


def _line(x0: float, y0: float, dx: float, dy: float, count: int) -> np.ndarray:
    steps = np.arange(count)[:, None]
    return np.array([x0, y0]) + steps * np.array([dx, dy])


def _select(
    chains: list[np.ndarray], height: np.ndarray, x: np.ndarray, y: np.ndarray, continuing: bool
) -> tuple[list[np.ndarray], np.ndarray]:
    """`_bright_chains` on chains with no strength of their own (C 0 against c = 1)."""
    strength = np.zeros(height.size)
    return _bright_chains(chains, height, strength, np.column_stack([x, y]), 1.0, continuing)


def test_a_dim_chain_ahead_of_a_kept_one_is_kept_inside_a_region() -> None:
    bright = _line(0.0, 50.0, 1.0, 0.1, 200)  # ends at (199, 69.9), heading (1, 0.1)
    ahead = _line(209.0, 70.9, 1.0, 0.1, 15)  # 10 px on, on its line
    beside = _line(60.0, 30.0, 1.0, 0.1, 15)  # parallel, 26 px away from it
    across = _line(207.0, 60.0, 0.0, 1.0, 15)  # near its end, but across the stripe
    offset = _line(208.0, 77.0, 1.0, 0.1, 15)  # ahead, but 6 px off its line
    short = _line(-10.0, 49.0, -1.0, -0.1, 5)  # ahead of the other end, too short
    chains, x, y = _chains(bright, ahead, beside, across, offset, short)
    height = np.concatenate([np.full(200, 200.0), np.full(65, 60.0)])  # dim: 0.3 of it

    kept, weak = _select(chains, height, x, y, continuing=True)
    assert [c[0] for c in kept] == [0, 200]
    assert weak.size == 3 * 15 + 5

    kept_without, _ = _select(chains, height, x, y, continuing=False)
    assert [c[0] for c in kept_without] == [0]


def test_a_run_of_dim_pieces_continues_piece_by_piece() -> None:
    bright = _line(0.0, 0.0, 1.0, 0.0, 100)
    first = _line(110.0, 0.0, 1.0, 0.0, 10)
    second = _line(130.0, 0.5, 1.0, 0.0, 10)  # continues the first, not the bright one
    chains, x, y = _chains(second, bright, first)  # order does not matter
    height = np.concatenate([np.full(10, 40.0), np.full(100, 200.0), np.full(10, 40.0)])
    kept, weak = _select(chains, height, x, y, continuing=True)
    assert len(kept) == 3 and weak.size == 0


def test_a_broken_dim_flank_between_two_bright_stretches_is_kept() -> None:
    # The linker splits a harsh flank where texture bends a centre's normal: each piece
    # starts beside or behind the previous one's end (0.3-2.8 px apart), so the gap between
    # the ends has no direction of its own and may point across the stripe or back.
    glare = _line(0.0, 0.0, 1.0, 0.0, 100)  # ends at (99, 0), heading (1, 0)
    first = _line(99.1, 0.5, 1.0, 0.05, 20)  # starts 0.5 px beside glare's end
    second = first[-1] + np.array([-1.2, 1.0]) + _line(0.0, 0.0, 1.0, 0.0, 15)  # 1.2 px behind
    glare_on = second[-1] + np.array([-1.0, -0.8]) + _line(0.0, 0.0, 1.0, 0.0, 100)
    elsewhere = _line(150.0, 40.0, 1.0, 0.0, 15)  # a dim chain away from the stripe
    chains, x, y = _chains(glare, first, second, glare_on, elsewhere)
    height = np.concatenate([np.full(100, 200.0), np.full(35, 20.0), np.full(100, 200.0)])
    height = np.concatenate([height, np.full(15, 20.0)])

    kept, weak = _select(chains, height, x, y, continuing=True)
    assert [c[0] for c in kept] == [0, 100, 120, 135]
    assert weak.tolist() == list(range(235, 250))


def test_a_dim_chain_touching_a_kept_end_but_not_heading_on_is_not_kept() -> None:
    bright = _line(0.0, 0.0, 1.0, 0.0, 100)  # ends at (99, 0), heading (1, 0)
    back = _line(99.3, 0.6, -1.0, 0.0, 20)  # from beside its end back along it
    across = _line(99.5, 0.5, 0.0, 1.0, 20)  # from its end across the stripe
    chains, x, y = _chains(bright, back, across)
    height = np.concatenate([np.full(100, 200.0), np.full(40, 20.0)])

    kept, weak = _select(chains, height, x, y, continuing=True)
    assert [c[0] for c in kept] == [0]
    assert weak.size == 40


def test_a_short_chain_forking_off_where_the_stripe_splits_is_dropped() -> None:
    """A glint touching the stripe splits its chain, and a chain through the glint's side
    runs off the line from there: a laser line does not fork, so it is dropped, with or
    without a region. A piece continuing the line there, or a long chain, is kept."""
    first = _line(0.0, 0.0, 0.0, 1.0, 41)  # down to (0, 40)
    second = _line(0.0, 43.0, 0.0, 1.0, 60)  # on from (0, 43): continues the first
    fork = _line(-16.1, 55.2, 0.8, -0.6, 18)[::-1]  # ends at (-2.5, 45.0), 53° off the line
    long_fork = _line(-34.5, 69.0, 0.8, -0.6, 41)[::-1]  # the same, 41 centres
    height = np.full(41 + 60 + 18, 200.0)
    for continuing in (True, False):
        chains, x, y = _chains(first, second, fork)
        kept, weak = _select(chains, height, x, y, continuing)
        assert [c[0] for c in kept] == [0, 41] and weak.size == 18
    chains, x, y = _chains(first, second, long_fork)
    kept, _ = _select(chains, np.full(41 + 60 + 41, 200.0), x, y, continuing=True)
    assert len(kept) == 3
    ahead = _line(0.0, 104.0, 0.0, 1.0, 18)  # beyond the second's end, on the line
    chains, x, y = _chains(first, second, ahead)
    kept, _ = _select(chains, height, x, y, continuing=True)
    assert len(kept) == 3
