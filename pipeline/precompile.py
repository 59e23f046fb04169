"""Compile and cache the pipeline's numba kernels ahead of the first frame.

Each kernel compiles on its first call (about 15 s in all on a fresh installation) and
is cached beside its module; `make` runs this once after installing, so the first wheel a
worker measures, the first test and the first CLI call start at full speed.
`python -m pipeline.precompile`.

numba checks a cached kernel against its own module's file only: a kernel that inlines a
helper or a constant from another module keeps its old compiled copy when only that other
module changes. So this first compares a digest of every pipeline source with the one saved
at the last precompile, and on any difference deletes all cached kernels before compiling.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from pipeline.extraction.band_analysis import analyse_band_level, analyse_fixed_scale
from pipeline.extraction.blocks import all_blocks
from pipeline.extraction.centres import METHODS, extract_centres, full_scale
from pipeline.extraction.ridges import RIDGE_C_FULL_SCALE
from pipeline.profile.fusion import clean_profile_points


def synthetic_stripe(shape: tuple[int, int] = (240, 320)) -> np.ndarray:
    """A bent Gaussian stripe widening from 5 to 21 px across the frame (uint8)."""
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]].astype(np.float64)
    centre = shape[0] / 2 + 0.002 * (cols - shape[1] / 2) ** 2
    width = 5 + 16 * cols / shape[1]
    return (12 + 170 * np.exp(-8 * (rows - centre) ** 2 / width**2)).astype(np.uint8)


PIPELINE_DIR = Path(__file__).resolve().parent
DIGEST_FILE = PIPELINE_DIR / "__pycache__" / "kernel-sources.sha256"
"""Digest of the pipeline's sources when its kernels were last compiled (beside the caches)."""


def sources_digest() -> str:
    """sha256 over every pipeline source file's path and bytes, in path order (hex)."""
    digest = hashlib.sha256()
    for path in sorted(PIPELINE_DIR.rglob("*.py")):
        digest.update(path.relative_to(PIPELINE_DIR).as_posix().encode() + b"\0")
        digest.update(path.read_bytes())
    return digest.hexdigest()


def clear_stale_caches() -> int:
    """Delete every cached kernel if the sources changed since the last precompile.

    Returns the number of cache files deleted (0 when the sources are unchanged).
    """
    current = sources_digest()
    if DIGEST_FILE.is_file() and DIGEST_FILE.read_text().strip() == current:
        return 0
    stale = [p for p in PIPELINE_DIR.rglob("__pycache__/*") if p.suffix in (".nbi", ".nbc")]
    for path in stale:
        path.unlink(missing_ok=True)
    return len(stale)


def save_digest() -> None:
    """Record the sources the cached kernels were compiled from."""
    DIGEST_FILE.parent.mkdir(exist_ok=True)
    DIGEST_FILE.write_text(sources_digest() + "\n")


def precompile_kernels() -> None:
    """Run every compiled kernel once, on 8- and 16-bit frames, at the default widths (5–21 px)."""
    for image in (synthetic_stripe(), synthetic_stripe().astype(np.uint16) * 257):
        for method in METHODS:
            for full_frame in (False, True):
                extract_centres(image, method, full_frame=full_frame)
        # The whole frame completing a refused band's fields (`band_analysis._completed`):
        # its V and C go into given arrays, a kernel of their own the frames above miss.
        c_grey = RIDGE_C_FULL_SCALE * full_scale(image.dtype)
        scale = analyse_fixed_scale(image, 3.0, c_grey=c_grey)
        blocks = all_blocks(scale.response.shape)
        analyse_band_level(
            scale.level,
            blocks,
            ~blocks,
            c_grey=c_grey,
            frame_shape=image.shape,
            hint_blocks=all_blocks(image.shape),
            into=scale,
        )
    x = np.linspace(0.0, 40.0, 200)
    inner = np.stack([x, 0.01 * x**2], axis=1)
    outer = inner + np.array([0.0, 0.02])
    clean_profile_points(np.concatenate([inner, outer]), np.repeat(np.array([0, 1], np.int8), 200))


if __name__ == "__main__":
    clear_stale_caches()
    precompile_kernels()
    save_digest()
