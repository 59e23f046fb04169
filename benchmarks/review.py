"""The worst-wheels view on a depot's history: 1,000 passes × 64 wheels, SQLite and
PostgreSQL (the bar: ≤ 300 ms per answer).

20 trains of 8 vehicles (4 axles) take turns at 3 sites, so each wheel has 50 passes; every
wheel has an adaptive and a Steger result with margins computed by the service's own
`limit_margins` from random but plausible wear. Each query runs the same code the
route runs (`worst_wheels`), first once to warm the caches, then REPEATS times.

Run alone with `python -m benchmarks.review` (prints the Markdown section).
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np
from sqlalchemy import insert
from sqlalchemy.orm import Session

from backend.services.limits import DEFAULT_LIMITS_MM
from backend.services.margins import limit_margins
from backend.services.review import WorstWheelFilter, worst_wheels
from db.engine import make_engine, upgrade_database
from db.models import Calibration, Measurement, MeasurementMargin, Pass, PassWheel, Site, Wheel
from tests.databases import BACKENDS, throwaway_database

PASSES = 1000
TRAINS, VEHICLES, AXLES = 20, 8, 4
REPEATS = 15
BAR_MS = 300.0
QUERIES = {
    "all passes, newest per wheel": WorstWheelFilter(),
    "one site": WorstWheelFilter(site="north"),
    "one vehicle (part of its id)": WorstWheelFilter(vehicle="T07-V3"),
    "qR only": WorstWheelFilter(parameter="qr_mm"),
    "open only": WorstWheelFilter(open_only=True),
    "every pass (history)": WorstWheelFilter(latest_only=False),
    "one pass": WorstWheelFilter(pass_id=PASSES // 2),
}


def _fill(session: Session, rng: np.random.Generator) -> int:
    sites = [Site(name=n) for n in ("depot north", "depot south", "main line")]
    session.add_all(sites)
    session.flush()
    calibrations = [
        Calibration(site_id=s.id, version=1, sha256="0" * 64, document={}) for s in sites
    ]
    session.add_all(calibrations)
    session.flush()
    wheel_rows = [
        {"vehicle_id": f"T{t:02d}-V{v}", "axle": a, "side": side}
        for t in range(TRAINS)
        for v in range(VEHICLES)
        for a in range(1, AXLES + 1)
        for side in ("left", "right")
    ]
    session.execute(insert(Wheel), wheel_rows)
    wheel_ids = np.array(
        session.scalars(Wheel.__table__.select().with_only_columns(Wheel.id)).all()
    )
    per_train = VEHICLES * AXLES * 2
    start = datetime(2026, 1, 1, tzinfo=UTC)
    session.execute(
        insert(Pass),
        [
            {
                "id": i + 1,
                "site_id": sites[i % 3].id,
                "calibration_id": calibrations[i % 3].id,
                "started_at": start + timedelta(hours=6 * i),
                "source": "upload",
                "state": "closed",
                "fleet": "default",
            }
            for i in range(PASSES)
        ],
    )
    pass_wheels = [
        {"id": i * per_train + k + 1, "pass_id": i + 1, "wheel_id": int(w), "state": "measured"}
        for i in range(PASSES)
        for k, w in enumerate(wheel_ids[(i % TRAINS) * per_train : (i % TRAINS + 1) * per_train])
    ]
    session.execute(insert(PassWheel), pass_wheels)
    limits = DEFAULT_LIMITS_MM["EN"]
    measurements: list[dict] = []
    margins: list[dict] = []
    for pw in pass_wheels:
        values: dict[str, float | None] = {
            "flange_height_mm": float(rng.uniform(28.0, 36.6)),
            "flange_thickness_10_mm": float(rng.uniform(21.5, 33.0)),
            "qr_mm": float(rng.uniform(6.2, 10.8)),
        }
        for method in ("adaptive", "steger"):
            measurement_id = len(measurements) + 1
            found = limit_margins(values, limits, "EN")
            nearest = min(found, key=lambda m: m.margin_fraction)
            measurements.append(
                {"id": measurement_id, "pass_wheel_id": pw["id"], "method": method,
                 "status": "measured", "reference_profile": "S1002", "pipeline_version": "bench",
                 "alarm_count": sum(m.status == "alarm" for m in found), **values}
            )  # fmt: skip
            margins.extend(
                {"measurement_id": measurement_id, "parameter": m.parameter,
                 "value_mm": m.value_mm, "bound": m.bound, "limit_mm": m.limit_mm,
                 "margin_mm": m.margin_mm, "band_mm": m.band_mm,
                 "margin_fraction": m.margin_fraction, "level": m.status, "nearest": m is nearest}
                for m in found
            )  # fmt: skip
    session.execute(insert(Measurement), measurements)
    session.execute(insert(MeasurementMargin), margins)
    session.commit()
    return len(margins)


def _time(session: Session, where: WorstWheelFilter) -> tuple[float, float, int]:
    worst_wheels(session, where, 0, 50)
    times = []
    for _ in range(REPEATS):
        started = time.perf_counter()
        page = worst_wheels(session, where, 0, 50)
        times.append(time.perf_counter() - started)
    return 1e3 * float(np.median(times)), 1e3 * float(np.max(times)), page.total


def _load_1min() -> float:
    with open("/proc/loadavg") as loadavg:
        return float(loadavg.read().split()[0])


def _measure(backend: str, folder: Path) -> tuple[list[str], float, int, tuple[float, float]]:
    with throwaway_database(backend, folder) as url:
        engine = make_engine(url)
        upgrade_database(engine)
        with Session(engine) as session:
            started = time.perf_counter()
            margin_rows = _fill(session, np.random.default_rng(17))
            fill_s = time.perf_counter() - started
            if backend == "postgresql":
                session.connection().exec_driver_sql("ANALYZE")
                session.commit()
            rows = []
            load_before = _load_1min()
            for name, where in QUERIES.items():
                median_ms, max_ms, total = _time(session, where)
                verdict = "ok" if median_ms <= BAR_MS else "**over**"
                rows.append(
                    f"| {backend} | {name} | {total} | {median_ms:.0f} | {max_ms:.0f} | {verdict} |"
                )
            loads = (load_before, _load_1min())
        engine.dispose()
    return rows, fill_s, margin_rows, loads


def run() -> str:
    """The Markdown section: answer times of the worst-wheels query per database and filter."""
    lines = [
        "## Worst-wheels view (1,000 passes × 64 wheels)",
        "",
        f"{PASSES} passes of 64 wheels (20 trains × 8 vehicles × 4 axles in turn, 50 passes "
        f"per wheel), adaptive and Steger results with margins; first 50 rows and the total, "
        f"median and max of {REPEATS} runs after one warm-up. Bar: ≤ {BAR_MS:.0f} ms.",
        "",
        "| database | filter | rows matched | median ms | max ms | bar |",
        "|---|---|---|---|---|---|",
    ]
    notes = []
    with tempfile.TemporaryDirectory() as folder:
        for backend in BACKENDS:
            rows, fill_s, margin_rows, loads = _measure(backend, Path(folder))
            lines.extend(rows)
            notes.append(
                f"{backend}: {margin_rows:,} margin rows written in {fill_s:.0f} s, 1-min load "
                f"average {loads[0]:.1f} before its queries and {loads[1]:.1f} after"
            )
    cores = f"{os.cpu_count()} cores, shared with other work"
    return "\n".join([*lines, "", "; ".join(notes) + f" ({cores}).", ""])


if __name__ == "__main__":
    sys.stdout.write(run())
