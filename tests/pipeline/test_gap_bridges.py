"""The guided search across a gap between two chains (`pipeline.extraction.gaps`)."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.extraction.gaps import bridge_gaps

C_GREY = 2.55
SIGMA_PX = 2.89


def _frame(dim_peak: float, *, seed: int = 0) -> np.ndarray:
    """A 200×160 frame with a Gaussian stripe (w = 6 px) along y = 80 + 0.2·(x − 100):
    peak 150 outside 60 ≤ x ≤ 140, `dim_peak` inside, on grey 30 with noise σ 2."""
    rng = np.random.default_rng(seed)
    rows, cols = np.mgrid[0:160, 0:200].astype(float)
    line = 80 + 0.2 * (cols - 100)
    distance = (rows - line) / np.hypot(1, 0.2)
    peak = np.where((cols >= 60) & (cols <= 140), dim_peak, 150.0)
    image = 30 + peak * np.exp(-2 * (distance / 3) ** 2) + rng.normal(0, 2, rows.shape)
    return np.clip(image, 0, 255).astype(np.float32)


def _chains() -> tuple[np.ndarray, np.ndarray, np.ndarray, list[np.ndarray]]:
    """Centres 1 px apart on the true line outside the dim stretch, as two chains."""
    x = np.concatenate([np.arange(20.0, 60.0), np.arange(141.0, 180.0)])
    y = 80 + 0.2 * (x - 100)
    return x, y, np.full(x.size, SIGMA_PX), [np.arange(40), np.arange(40, x.size)]


def _true_distance(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    return np.abs(y - (80 + 0.2 * (x - 100))) / np.hypot(1, 0.2)


def test_a_dim_stretch_between_two_chains_is_bridged_on_the_line() -> None:
    x, y, sigma, chains = _chains()
    found = bridge_gaps(_frame(12.0), x, y, sigma, chains, width_min_px=5, c_grey=C_GREY)
    assert found.gaps == 1 and len(found.chains) == 1
    assert found.x.size >= 60  # of the 80 px gap's inner points
    assert found.x.min() > 59 and found.x.max() < 142
    error = _true_distance(found.x, found.y)  # before the matched fit's smoothing along
    assert np.sqrt(np.mean(error**2)) < 0.25 and error.max() < 1.0


def test_a_dark_gap_is_not_bridged() -> None:
    x, y, sigma, chains = _chains()
    found = bridge_gaps(_frame(0.0), x, y, sigma, chains, width_min_px=5, c_grey=C_GREY)
    assert found.gaps == 1 and found.chains == () and found.x.size == 0


def test_ends_that_do_not_face_each_other_are_not_searched() -> None:
    x, y, sigma, chains = _chains()
    x, y = x.copy(), y.copy()
    x[40:] -= 100  # the second chain beside the first, 30 px off its line: no gap between
    y[40:] = 80 + 0.2 * (x[40:] - 100) + 30
    found = bridge_gaps(_frame(12.0), x, y, sigma, chains, width_min_px=5, c_grey=C_GREY)
    assert found.gaps == 0 and found.x.size == 0


def test_a_gap_holding_another_chain_is_not_searched() -> None:
    x, y, sigma, chains = _chains()
    across = np.arange(75.0, 86.0)  # a chain across the predicted path, facing neither end
    x = np.concatenate([x, np.full(across.size, 100.0)])
    y = np.concatenate([y, across])
    sigma = np.full(x.size, SIGMA_PX)
    chains = [*chains, np.arange(79, x.size)]
    found = bridge_gaps(_frame(12.0), x, y, sigma, chains, width_min_px=5, c_grey=C_GREY)
    assert found.x.size == 0


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_noise_alone_in_a_gap_is_not_bridged(seed: int) -> None:
    x, y, sigma, chains = _chains()
    image = _frame(0.0, seed=seed)
    image += np.random.default_rng(seed + 10).normal(0, 4, image.shape).astype(np.float32)
    found = bridge_gaps(image, x, y, sigma, chains, width_min_px=5, c_grey=C_GREY)
    assert found.x.size == 0
