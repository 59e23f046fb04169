"""Load on loopback: 20 concurrent uploads of simulated passes and 50 concurrent readers of
wheel pages and reports against a real `wheelscan serve` (SQLite, 2 measurement workers:
the default single-machine configuration).

Each pass is one simulated axle (2 wheels, one 1600×1200 frame per sensor, about 3.4 MB)
with frames of its own. Two passes are measured before the clock starts so the readers
have wheels to read; each reader does ROUNDS rounds of: the pass list, one wheel page as
the browser loads it (pass, wheels, both profiles, trend, the inner frame PNG, both
methods' centres) and one report (pass CSV, pass JSON or a wheel's PDF in turn). The run is
bounded in count and time and checks afterwards that every upload made one pass whose
wheels are exactly its manifest's, each measured once per method.

Run alone with `python -m benchmarks.load` (prints the Markdown section).
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import numpy as np

from tests.faults.live import LiveServer, check_database, check_store, vary_archive
from tests.faults.load import LoadResult, run_load, seed_passes, verify_passes
from tests.scale.topology import synthetic_pass_zip

UPLOADS = 20
READERS = 50
ROUNDS = 4
SEEDS = 2
WORKERS = 2
DEADLINE_S = 900.0
READ_KINDS = {
    "JSON pages": ("json",),
    "frame PNG": ("png",),
    "pass reports (CSV, JSON)": ("report-csv", "report-json"),
    "wheel reports (PDF)": ("report-pdf",),
}


def _row(name: str, seconds: np.ndarray) -> str:
    if seconds.size == 0:
        return f"| {name} | 0 | – | – | – |"
    p50_ms, p95_ms, max_ms = 1e3 * np.percentile(seconds, [50, 95, 100])
    return f"| {name} | {seconds.size} | {p50_ms:.0f} | {p95_ms:.0f} | {max_ms:.0f} |"


def _measure(root: Path) -> tuple[LoadResult, list[str], int]:
    axle = synthetic_pass_zip(root / "axle", 1, axles_per_vehicle=1)
    archives = [vary_archive(axle, i, distinct_frames=True) for i in range(UPLOADS)]
    server = LiveServer(root / "data", workers=WORKERS)
    server.start()
    try:
        seeds = seed_passes(server, [vary_archive(axle, 100 + i) for i in range(SEEDS)])
        result = run_load(
            server, archives, seeds, readers=READERS, rounds=ROUNDS, deadline_s=DEADLINE_S
        )
        problems = result.errors + verify_passes(server, archives, result)
        problems += check_store(server.data_dir, server.tmp_dir).problems
        problems += check_database(server.settings.resolved_database_url, server.data_dir).problems
    finally:
        server.close()
    return result, problems, len(axle)


def run() -> str:
    """Measure and return the Markdown section (AssertionError if anything was lost)."""
    with tempfile.TemporaryDirectory() as tmp:
        result, problems, archive_bytes = _measure(Path(tmp))
    if problems:
        raise AssertionError("load benchmark found problems:\n" + "\n".join(problems[:20]))
    reads = result.latencies()
    uploads = np.array([s for _, s in result.uploads])
    read_rate = reads.size / result.wall_s
    upload_mb_s = UPLOADS * archive_bytes / 1e6 / result.upload_wall_s
    lines = [
        "## Load on loopback: concurrent uploads and readers",
        "",
        f"{UPLOADS} simulated one-axle passes ({archive_bytes / 1e6:.1f} MB each, 2 wheels) "
        f"uploaded at once while {READERS} readers each do {ROUNDS} rounds (pass list, one "
        "wheel page as the browser loads it, one report: pass CSV/JSON or a wheel PDF) against "
        f"`wheelscan serve` (SQLite, {WORKERS} measurement workers measuring the uploads "
        "meanwhile); client and server share the machine. Result: "
        f"**{len(result.errors)} errors, {UPLOADS} passes with every manifest wheel once, "
        "each measured once per method; nothing half-written.**",
        "",
        "| reads | count | p50 ms | p95 ms | max ms |",
        "|---|---:|---:|---:|---:|",
        _row("all reads", reads),
        *(_row(name, result.latencies(kinds)) for name, kinds in READ_KINDS.items()),
        _row("uploads (202, whole archive)", uploads),
        "",
        f"Read throughput {read_rate:.1f} requests/s over the {result.wall_s:.1f} s run; "
        f"uploads: {UPLOADS} in {result.upload_wall_s:.1f} s ({UPLOADS / result.upload_wall_s:.2f} "
        f"passes/s, {upload_mb_s:.1f} MB/s). Machine during the run: CPU "
        f"{100 * result.busy_fraction:.0f} % busy over {os.cpu_count()} cores, 1-min load "
        f"average {result.load_before:.1f} before (other work on the machine) and "
        f"{result.load_after:.1f} at the end. A wheel PDF is drawn by reportlab in a "
        "request thread (then served from its content cache): under this load the first "
        "renders queue for the CPU (and the GIL), which is where the long tail of the reads "
        "comes from.",
    ]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.stdout.write(run())
