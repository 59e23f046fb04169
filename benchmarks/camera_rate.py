"""Frames per second of 2 worker processes on a simulated pass, and their memory.

A simulated pass (2 vehicles, 16 wheels, 32 frames of 1600×1200 px) is written to a
folder; two spawned worker processes (the service's pool uses spawn too), each on its own
core with one OpenCV thread, read it and then:

- extract the adaptive centres (band path) of FRAMES_PER_WORKER frames each, cycling
  through the pass: frames per second of the pair, and each worker's resident memory after
  every frame (the largest in the first and in the second half: growth across 1,000
  frames);
- measure every wheel of the pass MEASURE_ROUNDS times (`measure_wheel`, adaptive: both
  sensors' centres, the fusion and the flange parameters), the pass split between the two:
  frames per second of the pair and each worker's peak resident memory;
- measure every wheel of a field-mode pass (1 vehicle, a burst of 3 frames per sensor,
  every effect of `pipeline.simulation.field` on) the same way: what a wayside station
  sends, and where the extraction mostly takes the whole search region.

Run alone with `python -m benchmarks.run camera_rate`.
"""

from __future__ import annotations

import multiprocessing
import resource
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

FRAMES_PER_WORKER = 1000
WORKERS = 2
WARM_UP_FRAMES = 4
MEASURE_ROUNDS = 10
"""Times each worker measures its half of the pass's wheels."""
FIELD_FRAMES_PER_SENSOR = 3
"""Burst of the field-mode pass (the demo's and the station's default)."""


@dataclass(frozen=True)
class WorkerRun:
    """What one worker measured."""

    started: float
    finished: float
    frames: int
    first_half_peak_mib: float
    second_half_peak_mib: float
    peak_rss_mib: float
    paths: dict[str, int]


def _rss_mib() -> float:
    pages = int(Path("/proc/self/statm").read_text().split()[1])
    return pages * resource.getpagesize() / 2**20


def _peak_rss_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _extract_frames(folder: str, offset: int) -> WorkerRun:
    """Worker: adaptive centres of FRAMES_PER_WORKER frames of the pass, cycling."""
    from backend.jobs.allocator import keep_freed_memory
    from pipeline import extract_centres

    keep_freed_memory()  # as the service's workers do
    cv2.setNumThreads(1)
    images = []
    for path in sorted(Path(folder).rglob("*.png")):
        image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        if image is None:
            raise OSError(f"{path}: not a readable image")
        images.append(image)
    for image in images[:WARM_UP_FRAMES]:
        extract_centres(image)
    paths: dict[str, int] = {}
    rss = np.empty(FRAMES_PER_WORKER)
    started = time.time()
    for k in range(FRAMES_PER_WORKER):
        centres = extract_centres(images[(offset + k) % len(images)])
        paths[centres.path] = paths.get(centres.path, 0) + 1
        rss[k] = _rss_mib()
    finished = time.time()
    half = FRAMES_PER_WORKER // 2
    return WorkerRun(
        started,
        finished,
        FRAMES_PER_WORKER,
        float(rss[:half].max()),
        float(rss[half:].max()),
        _peak_rss_mib(),
        paths,
    )


def _measure_wheels(folder: str, share: int) -> WorkerRun:
    """Worker: measure_wheel (adaptive) of every WORKERS-th wheel of the pass."""
    from backend.jobs.allocator import keep_freed_memory
    from pipeline.archive.pass_archive import read_pass_archive
    from pipeline.profile.measurement import measure_wheel

    keep_freed_memory()
    cv2.setNumThreads(1)
    archive = read_pass_archive(folder)
    calibration = archive.calibration
    if calibration is None:
        raise ValueError(f"{folder} has no calibration")
    wheels = archive.manifest.wheels[share::WORKERS]

    def measured(entry) -> int:
        inner = [archive.load_frame(p) for p in entry.frames_inner]
        outer = [archive.load_frame(p) for p in entry.frames_outer]
        measure_wheel(inner, outer, calibration, side=entry.side, method="adaptive")
        return len(inner) + len(outer)

    measured(wheels[0])
    started = time.time()
    frames = sum(measured(entry) for _ in range(MEASURE_ROUNDS) for entry in wheels)
    finished = time.time()
    return WorkerRun(started, finished, frames, 0.0, 0.0, _peak_rss_mib(), {})


def _run_pair(function, folder: Path) -> list[WorkerRun]:
    context = multiprocessing.get_context("spawn")
    with context.Pool(WORKERS) as pool:
        return pool.starmap(function, [(str(folder), k) for k in range(WORKERS)])


def _rate(runs: list[WorkerRun]) -> tuple[float, float]:
    wall = max(r.finished for r in runs) - min(r.started for r in runs)
    frames = sum(r.frames for r in runs)
    return frames / wall, wall


def run() -> str:
    """Markdown section: frames per second of 2 workers, and their memory."""
    from benchmarks.extraction import simulate_field_pass
    from pipeline.archive.pass_archive import write_pass_archive
    from pipeline.simulation.passes import (
        build_station,
        build_train,
        pass_start_time,
        simulate_pass,
    )

    station = build_station()
    train_rng, pass_rng = np.random.default_rng(8).spawn(2)
    simulated = simulate_pass(
        build_train(2, train_rng), station, pass_rng, started_at=pass_start_time(0)
    )
    # What a wayside station sends: a field-mode pass, a burst of frames per sensor.
    field = simulate_field_pass(station, FIELD_FRAMES_PER_SENSOR)
    with tempfile.TemporaryDirectory() as tmp:
        folder, field_folder = Path(tmp) / "pass", Path(tmp) / "field"
        for where, made in ((folder, simulated), (field_folder, field)):
            write_pass_archive(where, made.manifest, made.frames, calibration=station.calibration)
        extraction = _run_pair(_extract_frames, folder)
        measuring = _run_pair(_measure_wheels, folder)
        field_measuring = _run_pair(_measure_wheels, field_folder)
    extract_fps, extract_wall = _rate(extraction)
    measure_fps, measure_wall = _rate(measuring)
    field_fps, field_wall = _rate(field_measuring)
    paths: dict[str, int] = {}
    for r in extraction:
        for name, count in r.paths.items():
            paths[name] = paths.get(name, 0) + count
    taken = ", ".join(f"{count} {name}" for name, count in sorted(paths.items()))
    rows = [
        f"| worker {k + 1} | {r.first_half_peak_mib:.0f} | {r.second_half_peak_mib:.0f} | "
        f"{r.second_half_peak_mib - r.first_half_peak_mib:+.1f} | {m.peak_rss_mib:.0f} |"
        for k, (r, m) in enumerate(zip(extraction, measuring, strict=True))
    ]
    return (
        "\n".join(
            [
                "## Camera rate: 2 workers on a simulated pass (benchmarks/camera_rate.py)",
                "",
                f"A simulated pass of {len(simulated.frames)} frames (1600×1200 px, 8-bit, 2 "
                f"vehicles, 16 wheels); {WORKERS} spawned worker processes, one OpenCV thread "
                "each, keeping freed memory as the service's workers do, on this 2-core machine. "
                "The camera delivers 60 frames per second.",
                "",
                "| what | frames | wall s | frames per second |",
                "|---|---|---|---|",
                f"| adaptive centres, band path ({taken}) | {sum(r.frames for r in extraction)} | "
                f"{extract_wall:.1f} | {extract_fps:.1f} |",
                f"| measure every wheel {MEASURE_ROUNDS}× (adaptive: centres of both sensors, "
                f"fusion, parameters) | {sum(r.frames for r in measuring)} | {measure_wall:.1f} | "
                f"{measure_fps:.1f} |",
                f"| measure every wheel {MEASURE_ROUNDS}× of a field-mode pass (1 vehicle, "
                f"{FIELD_FRAMES_PER_SENSOR} frames per sensor, every field effect on) | "
                f"{sum(r.frames for r in field_measuring)} | {field_wall:.1f} | {field_fps:.1f} |",
                "",
                "Resident memory per worker [MiB], read after every frame: the largest in the "
                f"first and in the second half of the {FRAMES_PER_WORKER} frames of extraction "
                "(growth: the difference), and the peak while measuring the pass's wheels.",
                "",
                "| worker | frames 1–500 | frames 501–1000 | growth | peak, measuring |",
                "|---|---|---|---|---|",
                *rows,
            ]
        )
        + "\n"
    )


if __name__ == "__main__":
    import sys

    sys.stdout.write(run())
