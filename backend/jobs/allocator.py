"""Allocator settings of the measuring processes: keep freed memory for the next frame.

A frame's analysis allocates and frees some hundred MB of arrays. With glibc's defaults,
after the first large free the process maps every large block afresh and trims the heap
top, so each frame faults in (and the kernel zeroes) its memory anew: measured, the band
path took 28 ms a frame in a worker that had run the full-frame path, 15 ms with freed
memory kept. Process-wide, so the service and its workers set it, never the pipeline.
"""

from __future__ import annotations

import ctypes
import ctypes.util

M_TRIM_THRESHOLD = -1
M_MMAP_THRESHOLD = -3
"""glibc mallopt parameters (malloc.h)."""

MMAP_THRESHOLD_BYTES = 32 * 2**20
"""Blocks below this come from the heap and are reused: a frame's arrays (7.7 MB for
1600×1200 float32) all are. 32 MiB is glibc's largest allowed value on 64-bit."""

TRIM_THRESHOLD_BYTES = 1 * 2**30
"""Freed heap kept before any is returned to the system: above a worker's working set."""


def keep_freed_memory() -> bool:
    """Set the thresholds in this process (and the children it forks); False where the C
    library has no mallopt (not glibc), which leaves its defaults."""
    name = ctypes.util.find_library("c")
    if name is None:
        return False
    mallopt = getattr(ctypes.CDLL(name), "mallopt", None)
    if mallopt is None:
        return False
    return bool(
        mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)
        and mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES)
    )
