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


def test_a_change_to_any_pipeline_source_clears_every_cached_kernel(tmp_path, monkeypatch) -> None:
    # numba checks a cache against its own module only; a helper inlined from another module
    # would keep its old compiled copy. Precompile clears all caches when any source changed.
    from pipeline import precompile

    (tmp_path / "extraction" / "__pycache__").mkdir(parents=True)
    (tmp_path / "__pycache__").mkdir()
    helper = tmp_path / "extraction" / "helpers.py"
    helper.write_text("WEIGHT = 1.0\n")
    (tmp_path / "extraction" / "kernels.py").write_text("from .helpers import WEIGHT\n")
    cached = tmp_path / "extraction" / "__pycache__" / "kernels.run-1.py311.nbi"
    monkeypatch.setattr(precompile, "PIPELINE_DIR", tmp_path)
    monkeypatch.setattr(precompile, "DIGEST_FILE", tmp_path / "__pycache__" / "digest")

    cached.write_bytes(b"index")
    assert precompile.clear_stale_caches() == 1  # no digest yet: everything is stale
    cached.write_bytes(b"index")
    precompile.save_digest()
    assert precompile.clear_stale_caches() == 0 and cached.exists()
    helper.write_text("WEIGHT = 2.0\n")  # only the other module changes
    assert precompile.clear_stale_caches() == 1 and not cached.exists()
