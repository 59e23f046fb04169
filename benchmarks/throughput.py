"""Throughput of the measurement service: in-process pool vs 1 and 2 Celery worker processes.

One simulated 16-axle pass (4 vehicles × 4 axles, 32 wheels, one 1600×1200 frame per
sensor, 64 frames) is uploaded to the service on PostgreSQL; the clock runs from the upload
request to the job's "done". Workers are started, and warmed up by a one-axle pass, before
the clock starts. The same train rendered in the simulator's harsh field mode (a lit,
textured scene: what a wayside camera sees) is measured by the in-process pool too: lit
frames take the extraction's whole-frame path, so they cost several times a clean frame.
The end-to-end time is set against the time the same train takes to pass the station at
5 km/h: the station can keep up with traffic when measuring is faster than passing.

Run alone with `python -m benchmarks.throughput` (prints the Markdown section).
"""

from __future__ import annotations

import os
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass
from pathlib import Path

from backend.config import Settings
from pipeline.simulation.field import FIELD_MODES
from tests.databases import throwaway_database
from tests.scale.topology import (
    RedisServer,
    api,
    synthetic_pass_zip,
    upload,
    wait_for_pass,
    worker_env,
    workers,
)

VEHICLES = 4
AXLES_PER_VEHICLE = 4
FRAMES_PER_WHEEL = 2
"""One frame per sensor (inner, outer) per wheel, as `wheelscan synth-pass` writes."""
VEHICLE_LENGTH_M = 19.5
"""Assumed length over couplers of one vehicle (a metro car; 4 of them: a 78 m train)."""
TRAIN_SPEED_KMH = 5.0
PASS_TIMEOUT_S = 1800.0


@dataclass(frozen=True, slots=True)
class ThroughputRun:
    """One configuration measuring the whole pass."""

    mode: str
    frames: str
    processes: int
    upload_s: float
    end_to_end_s: float
    cpu_s: float
    wheels: int

    @property
    def cpu_s_per_wheel(self) -> float:
        return self.cpu_s / self.wheels

    @property
    def frames_per_s(self) -> float:
        return self.wheels * FRAMES_PER_WHEEL / self.end_to_end_s

    @property
    def wheels_per_min(self) -> float:
        return self.wheels * 60.0 / self.end_to_end_s


def process_tree_cpu_s(root_pid: int) -> float:
    """CPU seconds (user + system) used so far by `root_pid` and all its descendants alive
    now: the API, pool processes, Celery workers and their children, the broker."""
    tick_s = 1.0 / os.sysconf("SC_CLK_TCK")
    parents: dict[int, int] = {}
    cpu: dict[int, float] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            text = stat.read_text()
        except OSError:
            continue
        fields = text[text.rindex(")") + 2 :].split()
        pid = int(stat.parent.name)
        parents[pid] = int(fields[1])
        cpu[pid] = (int(fields[11]) + int(fields[12])) * tick_s
    total = 0.0
    for pid, seconds in cpu.items():
        ancestor = pid
        while ancestor not in (0, 1, root_pid) and ancestor in parents:
            ancestor = parents[ancestor]
        if ancestor == root_pid:
            total += seconds
    return total


def train_passing_time_s() -> float:
    """Time the assumed train takes to pass one point at TRAIN_SPEED_KMH."""
    return VEHICLES * VEHICLE_LENGTH_M / (TRAIN_SPEED_KMH / 3.6)


@contextmanager
def _celery_workers(count: int, settings: Settings, folder: Path) -> Iterator[None]:
    with workers(count, worker_env(settings, fast_redelivery=False), folder):
        yield


def measure_once(
    archive: bytes,
    warm_up: bytes,
    folder: Path,
    processes: int,
    redis: RedisServer | None,
    frames: str = "clean",
) -> ThroughputRun:
    """Measure the pass once: in-process pool when `redis` is None, else Celery workers;
    `frames` names the archive's kind for the table.

    A one-axle `warm_up` pass goes first, so pool processes are started and every process
    has its database connections, as in a service that has been running a while.
    """
    folder.mkdir(parents=True)
    with throwaway_database("postgresql", folder) as url:
        settings = Settings(
            data_dir=folder,
            database_url=url,
            broker_url=redis.url if redis else None,
            workers=processes,
        )
        started = _celery_workers(processes, settings, folder) if redis else nullcontext()
        with started, api(settings) as client:
            wait_for_pass(client, upload(client, warm_up), PASS_TIMEOUT_S)
            cpu_begin = process_tree_cpu_s(os.getpid())
            begin = time.perf_counter()
            pass_id = upload(client, archive)
            uploaded = time.perf_counter()
            wait_for_pass(client, pass_id, PASS_TIMEOUT_S)
            end = time.perf_counter()
            cpu_s = process_tree_cpu_s(os.getpid()) - cpu_begin
    return ThroughputRun(
        mode="Celery workers" if redis else "in-process pool",
        frames=frames,
        processes=processes,
        upload_s=uploaded - begin,
        end_to_end_s=end - begin,
        cpu_s=cpu_s,
        wheels=VEHICLES * AXLES_PER_VEHICLE * 2,
    )


def run_all(folder: Path) -> list[ThroughputRun]:
    """The three configurations on the same clean archive, and the pool on its field twin."""
    archive = synthetic_pass_zip(folder / "pass", VEHICLES, axles_per_vehicle=AXLES_PER_VEHICLE)
    warm_up = synthetic_pass_zip(folder / "warm-up", 1, axles_per_vehicle=1, seed=1)
    harsh = FIELD_MODES["harsh"]
    field = synthetic_pass_zip(
        folder / "field", VEHICLES, axles_per_vehicle=AXLES_PER_VEHICLE, field=harsh
    )
    redis = RedisServer(folder / "redis")
    redis.start()
    try:
        return [
            measure_once(archive, warm_up, folder / "pool-2", 2, None),
            measure_once(archive, warm_up, folder / "celery-1", 1, redis),
            measure_once(archive, warm_up, folder / "celery-2", 2, redis),
            measure_once(field, warm_up, folder / "pool-2-field", 2, None, "field (harsh)"),
        ]
    finally:
        redis.stop()


def format_section(runs: list[ThroughputRun]) -> str:
    """The BENCHMARKS.md section of these runs."""
    passing_s = train_passing_time_s()
    lines = [
        "## Service throughput (benchmarks/throughput.py)",
        "",
        f"One simulated pass of {VEHICLES} vehicles × {AXLES_PER_VEHICLE} axles "
        f"({VEHICLES * AXLES_PER_VEHICLE} axles, {runs[0].wheels} wheels, "
        f"{runs[0].wheels * FRAMES_PER_WHEEL} frames of 1600×1200 px), both methods per "
        "wheel, PostgreSQL; time from the upload request to the job's done, after a "
        "one-axle warm-up pass (processes started, connections open). "
        f"Train assumed {VEHICLES} × {VEHICLE_LENGTH_M} m = {VEHICLES * VEHICLE_LENGTH_M:.0f} m "
        f"long: at {TRAIN_SPEED_KMH:g} km/h it passes in {passing_s:.0f} s. "
        f"Machine load average at start: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores. "
        "Frames: clean (the simulator's dark scene) or field (harsh): the same train in the "
        "simulator's harsh field mode, a lit, textured scene as a wayside camera sees it, "
        "whose frames take the extraction's whole-frame path (BENCHMARKS extraction section, "
        "the lit frame).",
        "",
        "CPU s/wheel counts every process of the run (API, pool or workers, broker; not "
        "PostgreSQL), so it "
        "does not depend on what else the machine is doing; the last column derives from it "
        "what the same processes would reach alone on this machine "
        "(60 × min(processes, cores) / CPU s per wheel).",
        "",
        "| runner | frames | processes | upload s | end-to-end s | frames/s | wheels/min "
        "| vs train passing | CPU s/wheel | wheels/min, machine alone (derived) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    cores = os.cpu_count() or 1
    for run in runs:
        alone = 60.0 * min(run.processes, cores) / run.cpu_s_per_wheel
        lines.append(
            f"| {run.mode} | {run.frames} | {run.processes} | {run.upload_s:.1f} "
            f"| {run.end_to_end_s:.1f} "
            f"| {run.frames_per_s:.2f} | {run.wheels_per_min:.1f} "
            f"| {run.end_to_end_s / passing_s:.2f}× | {run.cpu_s_per_wheel:.2f} | {alone:.1f} |"
        )
    return "\n".join(lines) + "\n"


def run() -> str:
    """Run the benchmark and return its Markdown section."""
    with tempfile.TemporaryDirectory(prefix="wheelscan-throughput-") as folder:
        return format_section(run_all(Path(folder)))


if __name__ == "__main__":
    import sys

    sys.stdout.write(run())
