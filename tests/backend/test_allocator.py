"""The measuring processes keep freed memory for the next frame (glibc's mallopt)."""

from __future__ import annotations

import ctypes.util
import subprocess
import sys

import pytest

from backend.jobs.allocator import keep_freed_memory


@pytest.mark.skipif(
    ctypes.util.find_library("c") is None, reason="no C library found to set mallopt on"
)
def test_the_thresholds_are_accepted_by_the_c_library() -> None:
    # glibc refuses values out of range (mallopt returns 0): both must be taken.
    assert keep_freed_memory() is True


def _faults(script: str, mode: str) -> int:
    """Minor page faults the script prints, run in a fresh process with `mode` ("keep":
    `keep_freed_memory` first; "default": glibc's own thresholds)."""
    done = subprocess.run(
        [sys.executable, "-c", script, mode], capture_output=True, text=True, check=True
    )
    return int(done.stdout.split()[-1])


_PRELUDE = (
    "import resource, sys, numpy as np\n"
    "from backend.jobs.allocator import keep_freed_memory\n"
    "if sys.argv[1] == 'keep': keep_freed_memory()\n"
)


def test_freed_frame_sized_arrays_are_reused_not_faulted_in_afresh() -> None:
    """The mechanism, counted: a frame's worth of 1600×1200 float32 arrays (24 × 7.7 MB)
    allocated and freed four times. With glibc's defaults every round maps or grows the
    heap afresh and trims it again (about 37,000 faults over three rounds); kept, none."""
    script = _PRELUDE + (
        "def frame():\n"
        "    arrays = [np.ones((1200, 1600), np.float32) for _ in range(24)]\n"
        "    return sum(float(a[0, 0]) for a in arrays)\n"
        "frame()\n"
        "before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt\n"
        "for _ in range(3):\n"
        "    frame()\n"
        "print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)\n"
    )
    keep, default = _faults(script, "keep"), _faults(script, "default")
    assert keep * 10 < default, (keep, default)


def test_a_frame_after_the_full_frame_path_is_not_slowed_by_fresh_memory() -> None:
    """The effect where it was measured, counted, not timed: page faults of band-path
    frames after full-frame ones, with freed memory kept (a band-path frame's arrays
    faulted in afresh are thousands of pages). With glibc's defaults this frame faulted
    207–14,035 times before the lit-frame kernels of 2026-12-04 (night) stopped freeing
    blocks large enough to move glibc's threshold; it now faults 1–2 times, so the
    mechanism is tested on its own above."""
    script = _PRELUDE + (
        "from pipeline import extract_centres\n"
        "from pipeline.precompile import synthetic_stripe\n"
        "image = np.tile(synthetic_stripe(), (4, 4))\n"
        "for _ in range(2):\n"
        "    extract_centres(image, full_frame=True); extract_centres(image)\n"
        "before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt\n"
        "for _ in range(3):\n"
        "    extract_centres(image)\n"
        "print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)\n"
    )
    assert _faults(script, "keep") <= 100
