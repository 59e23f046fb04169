"""Speed probe of the adaptive band path: its time against one full-frame float32 Gaussian
blur at σ 7.5 px, the two alternating in one process, and its time per stage.

Not a BENCHMARKS.md section (`benchmarks.extraction` is): a quick, repeatable check while
changing the band kernels. One thread (OpenCV set to 1, the numba kernels start none), freed
memory kept as in the service's workers. On a shared machine only ratios of one run and
least times mean much: each round times the blur and the band path back to back, and the
ratio is taken of the least (and of the median) thread times.

    python -m benchmarks.band_probe [--rounds N] [--stages] [--case NAME]

The lit scene (every frame falls back today, docs/extraction.md §7): --case "lit scene, glints".
"""

from __future__ import annotations

import argparse
import functools
import importlib
import os
import sys
import time
from collections import defaultdict
from dataclasses import replace

import cv2
import numpy as np

from backend.jobs.allocator import keep_freed_memory
from benchmarks.extraction import BLUR_SIGMA_PX, SPEED_CASES
from pipeline import extract_centres
from tests.pipeline.stripe_images import make_stripe

STAGES = (
    ("pipeline.extraction.band_analysis", "build_pyramid"),
    ("pipeline.extraction.band_analysis", "band_derivatives"),
    ("pipeline.extraction.band_analysis", "analyse_band_level"),
    ("pipeline.extraction.band_analysis", "locate_band"),
    ("pipeline.extraction.band_analysis", "segment_band"),
    ("pipeline.extraction.band_analysis", "_left_out_safely"),
    ("pipeline.extraction.band_analysis", "_with_peaks"),
    ("pipeline.extraction.centres", "choose_in_band"),
    ("pipeline.extraction.centres", "choose_scales"),
    ("pipeline.extraction.centres", "centre_pixels"),
    ("pipeline.extraction.centres", "_lines_only"),
    ("pipeline.extraction.centres", "link_points"),
    ("pipeline.extraction.centres", "_widths"),
    ("pipeline.extraction.centres", "_no_spots"),
    ("pipeline.extraction.centres", "_off_bodies"),
    ("pipeline.extraction.centres", "_bright_chains"),
    ("pipeline.extraction.centres", "_refine_on_normals"),
    ("pipeline.extraction.centres", "remove_curvature_bias"),
    ("pipeline.extraction.centres", "matched_offsets"),
    ("pipeline.extraction.centres", "local_fits"),
    ("pipeline.extraction.centres", "smooth_along"),
)
"""(module, name) of the stages timed with --stages: the name as that module calls it."""


def _say(line: str) -> None:
    sys.stdout.write(line + "\n")
    sys.stdout.flush()


def _least_thread_ms(function, repeats: int) -> float:
    least = float("inf")
    for _ in range(repeats):
        start = time.thread_time()
        function()
        least = min(least, time.thread_time() - start)
    return 1000 * least


def _instrument(spent: dict[str, float]) -> None:
    """Wrap each stage so its thread time adds up in `spent` [s] (nested stages count in
    both, e.g. the fits inside `_refine_on_normals`)."""
    for module_name, name in STAGES:
        module = importlib.import_module(module_name)
        if not hasattr(module, name):
            continue
        original = getattr(module, name)

        @functools.wraps(original)
        def timed(*args, _f=original, _n=name, **kwargs):
            start = time.thread_time()
            try:
                return _f(*args, **kwargs)
            finally:
                spent[_n] += time.thread_time() - start

        setattr(module, name, timed)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=15)
    parser.add_argument("--back-to-back", type=int, default=3)
    parser.add_argument("--case", action="append", help="speed case name (default: the first 4)")
    parser.add_argument("--stages", action="store_true", help="also time each stage")
    args = parser.parse_args()
    keep_freed_memory()
    cv2.setNumThreads(1)
    cases = [c for c in SPEED_CASES if c.name in (args.case or [])] or SPEED_CASES[:4]
    _say(f"load {os.getloadavg()[0]:.1f}")
    for case in cases:
        image = make_stripe(replace(case)).image
        frame32 = image.astype(np.float32)
        found = extract_centres(image)
        full = extract_centres(image, full_frame=True)
        same = np.array_equal(found.x, full.x) and np.array_equal(found.y, full.y)

        def blur(frame32=frame32):
            cv2.GaussianBlur(frame32, (0, 0), BLUR_SIGMA_PX)

        def band(image=image):
            extract_centres(image)

        blur_ms, band_ms = [], []
        for _ in range(args.rounds):
            blur_ms.append(_least_thread_ms(blur, args.back_to_back))
            band_ms.append(_least_thread_ms(band, args.back_to_back))
        least = min(band_ms) / min(blur_ms)
        median = float(np.median(band_ms) / np.median(blur_ms))
        _say(
            f"{case.name:14s} {found.path:9s} {found.x.size:5d} centres, band = full {same}: "
            f"blur {min(blur_ms):.2f} / {np.median(blur_ms):.2f} ms, band "
            f"{min(band_ms):.2f} / {np.median(band_ms):.2f} ms (least / median): "
            f"{least:.3f}× / {median:.3f}×"
        )
    if args.stages:
        spent: dict[str, float] = defaultdict(float)
        _instrument(spent)
        for case in cases:
            image = make_stripe(case).image
            extract_centres(image)
            totals = []
            per_stage = defaultdict(list)
            for _ in range(args.rounds):
                spent.clear()
                start = time.thread_time()
                extract_centres(image)
                totals.append(time.thread_time() - start)
                for name, seconds in spent.items():
                    per_stage[name].append(seconds)
            _say(f"{case.name}: total least {1000 * min(totals):.2f} ms")
            for name, values in per_stage.items():
                _say(f"  {name:24s} {1000 * min(values):6.2f} ms (least)")
    _say(f"load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
