"""Compile and cache the pipeline's numba kernels ahead of the first frame.

Each kernel compiles on its first call (about 15 s in all on a fresh installation) and
is cached beside its module; `make` runs this once after installing, so the first wheel a
worker measures, the first test and the first CLI call start at full speed.
`python -m pipeline.precompile`.
"""

from __future__ import annotations

import numpy as np

from pipeline.extraction.centres import METHODS, extract_centres
from pipeline.profile.fusion import clean_profile_points


def synthetic_stripe(shape: tuple[int, int] = (240, 320)) -> np.ndarray:
    """A bent Gaussian stripe widening from 5 to 21 px across the frame (uint8)."""
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]].astype(np.float64)
    centre = shape[0] / 2 + 0.002 * (cols - shape[1] / 2) ** 2
    width = 5 + 16 * cols / shape[1]
    return (12 + 170 * np.exp(-8 * (rows - centre) ** 2 / width**2)).astype(np.uint8)


def precompile_kernels() -> None:
    """Run every compiled kernel once, on 8- and 16-bit frames, at the default widths (5–21 px)."""
    for image in (synthetic_stripe(), synthetic_stripe().astype(np.uint16) * 257):
        for method in METHODS:
            for full_frame in (False, True):
                extract_centres(image, method, full_frame=full_frame)
    x = np.linspace(0.0, 40.0, 200)
    inner = np.stack([x, 0.01 * x**2], axis=1)
    outer = inner + np.array([0.0, 0.02])
    clean_profile_points(np.concatenate([inner, outer]), np.repeat(np.array([0, 1], np.int8), 200))


if __name__ == "__main__":
    precompile_kernels()
