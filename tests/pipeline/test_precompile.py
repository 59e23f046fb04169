"""The precompiled kernels load from numba's cache: no process compiles them again."""

from __future__ import annotations

import os
import subprocess
import sys


def _precompile(debug: bool) -> str:
    env = dict(os.environ, NUMBA_DEBUG_CACHE="1" if debug else "0")
    done = subprocess.run(
        [sys.executable, "-m", "pipeline.precompile"],
        capture_output=True,
        text=True,
        check=True,
        env=env,
    )
    return done.stdout + done.stderr


def test_a_second_process_compiles_no_kernel_again() -> None:
    # A kernel whose cache key changes from process to process (a closure calling another
    # closure, say) would compile on every worker's first frame and grow the cache.
    _precompile(debug=False)
    saved = [line for line in _precompile(debug=True).splitlines() if "data saved" in line]
    assert saved == []
