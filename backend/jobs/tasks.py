"""Per-wheel task functions: the unit of measurement work, runnable anywhere.

`measure_pass_wheel(pass_wheel_id, database_url, data_dir)` takes plain arguments, so the
in-process pool and Celery workers call it alike. It claims its wheel with an atomic
UPDATE (queued → running), measures it with every method, and writes all results in one
transaction, so a wheel is never measured twice and a crash leaves nothing half-written.
An exception in one wheel is recorded on that wheel ("failed", with the reason); the pass
goes on.

Process pool, Celery and leases: docs/service.md, "Jobs".
"""

from __future__ import annotations

import logging
from functools import lru_cache
from pathlib import Path

import numpy as np
from sqlalchemy import delete, select, update
from sqlalchemy.orm import Session, sessionmaker

from backend.services.images import prerender_layers
from backend.services.pass_wheels import refresh_job, rows_changed, wheel_frames
from backend.services.results import (
    apply_alarms,
    apply_axle_conicity,
    measurement_row,
    site_rails,
)
from backend.storage.artefacts import save_artefacts
from backend.storage.remote import make_worker_store
from backend.storage.store import BlobStore
from backend.transient import is_transient
from db.engine import make_engine, make_session_factory
from db.models import Frame, Measurement, MeasurementFrame, PassWheel, Wheel
from db.types import utc_now
from pipeline import measure_wheel
from pipeline.archive.manifest import POSITIONS
from pipeline.archive.pass_archive import decode_frame
from pipeline.calibration.model import parse_calibration
from pipeline.profile.measurement import MEASURE_METHODS, MEASURED

logger = logging.getLogger(__name__)


@lru_cache(maxsize=4)
def _worker_context(database_url: str, data_dir: str) -> tuple[sessionmaker[Session], BlobStore]:
    """One engine and store per worker process (cached across tasks)."""
    from backend.config import Settings

    settings = Settings(data_dir=Path(data_dir), database_url=database_url)
    return make_session_factory(make_engine(database_url)), make_worker_store(settings)


def claim_pass_wheel(session: Session, pass_wheel_id: int) -> bool:
    """queued → running, atomically; False when another worker has it or it is finished."""
    changed = rows_changed(
        session,
        update(PassWheel)
        .where(PassWheel.id == pass_wheel_id, PassWheel.state == "queued")
        .values(state="running", attempts=PassWheel.attempts + 1, started_at=utc_now()),
    )
    session.commit()
    return changed == 1


def record_wheel_crash(session: Session, pass_wheel_id: int, reason: str) -> None:
    """Mark a wheel failed with `reason` (unless it finished meanwhile) and recount its job."""
    pass_id = session.scalar(select(PassWheel.pass_id).where(PassWheel.id == pass_wheel_id))
    if pass_id is None:
        return
    session.execute(
        update(PassWheel)
        .where(PassWheel.id == pass_wheel_id, PassWheel.state.in_(("queued", "running")))
        .values(state="failed", reason=reason[:2000], finished_at=utc_now())
    )
    session.commit()
    refresh_job(session, pass_id)


def measure_pass_wheel(pass_wheel_id: int, database_url: str, data_dir: str) -> str:
    """Measure one wheel of one pass with every method and store the results.

    Parameters
    ----------
    pass_wheel_id : int
        Row id in `pass_wheel`; the wheel must be "queued" (else nothing happens).
    database_url, data_dir : str
        Where the database and the frame store are (the worker opens its own connection).

    Returns
    -------
    str
        The wheel's final state ("measured", "not_measured", "failed"), or "skipped" when
        another worker had claimed it or it was finished already.
    """
    factory, store = _worker_context(database_url, data_dir)
    with factory() as session:
        if not claim_pass_wheel(session, pass_wheel_id):
            return "skipped"
        pass_id = session.scalars(
            select(PassWheel.pass_id).where(PassWheel.id == pass_wheel_id)
        ).one()
        refresh_job(session, pass_id)
        try:
            state = store_wheel_results(session, store, pass_wheel_id)
        except Exception as exc:
            if is_transient(exc):
                raise  # database, frame store or disk unavailable: the runner retries
            session.rollback()
            logger.exception("pass wheel %d: measurement crashed", pass_wheel_id)
            record_wheel_crash(session, pass_wheel_id, f"{type(exc).__name__}: {exc}")
            return "failed"
        refresh_job(session, pass_id)
        return state


def _decode(store: BlobStore, frame: Frame) -> np.ndarray:
    data = store.get(frame.sha256, ".png")
    return decode_frame(data, f"{frame.sensor} frame {frame.seq}")


def store_wheel_results(session: Session, store: BlobStore, pass_wheel_id: int) -> str:
    """Measure a claimed wheel with every method and write the results (one transaction).

    The measuring and the frame artefacts come first, outside any transaction; the write
    is short. It locks the axle's wheels first (`lock_axle`), so of the two wheels of an
    axle finishing at once the second always sees the first's results and stores the
    axle's values (back-to-back, conicity) in the same commit that makes it "measured":
    no one ever sees both wheels finished and the axle's values missing.

    Returns the wheel's final state: "measured" when at least one method measured it,
    otherwise "not_measured" with the first method's reason.
    """
    pass_wheel = session.get_one(PassWheel, pass_wheel_id)
    train_pass = pass_wheel.train_pass
    calibration = parse_calibration(train_pass.calibration.document)
    frames = {p: wheel_frames(session, pass_wheel, (p,)) for p in POSITIONS}
    images = {p: [_decode(store, f) for f in rows] for p, rows in frames.items()}
    by_index = {(f.sensor, i): f for p in POSITIONS for i, f in enumerate(frames[p])}
    side = pass_wheel.wheel.side
    rows, reasons = [], []
    for method in MEASURE_METHODS:
        result = measure_wheel(
            images["inner"], images["outer"], calibration, side=side, method=method
        )
        row = measurement_row(result, train_pass.fleet, session)
        row.pass_wheel_id = pass_wheel_id
        frame_rows = []
        for frame_centres in result.frames:
            frame = by_index[(frame_centres.sensor, frame_centres.frame_index)]
            frame_rows.append(
                MeasurementFrame(
                    sensor=frame.sensor,
                    seq=frame.seq,
                    artefact_sha256=save_artefacts(store, frame_centres.centres),
                    centre_count=len(frame_centres.centres),
                    **prerender_layers(store, frame_centres.centres),
                )
            )
        rows.append((row, frame_rows))
        if result.status != MEASURED:
            reasons.append(f"{method}: {result.reason}")
    lock_axle(session, pass_wheel)
    session.execute(delete(Measurement).where(Measurement.pass_wheel_id == pass_wheel_id))
    for row, frame_rows in rows:
        session.add(row)
        session.flush()
        for frame_row in frame_rows:
            frame_row.measurement_id = row.id
            session.add(frame_row)
    measured = len(reasons) < len(MEASURE_METHODS)
    pass_wheel.state = "measured" if measured else "not_measured"
    pass_wheel.reason = "; ".join(reasons) or None
    pass_wheel.finished_at = utc_now()
    session.flush()
    update_axle(session, pass_wheel)
    session.commit()
    return pass_wheel.state


def _axle_of(pass_wheel: PassWheel) -> tuple:
    """WHERE terms for the pass wheels of `pass_wheel`'s axle in its pass (joined to Wheel)."""
    wheel = pass_wheel.wheel
    return (
        PassWheel.pass_id == pass_wheel.pass_id,
        Wheel.vehicle_id == wheel.vehicle_id,
        Wheel.axle == wheel.axle,
    )


def lock_axle(session: Session, pass_wheel: PassWheel) -> None:
    """Begin the write that finishes a wheel by locking its axle's wheels in this pass.

    PostgreSQL: both wheels' rows FOR UPDATE, in id order (no deadlock); the other wheel's
    write waits, then reads what this one committed. SQLite: the UPDATE takes the
    database's one write lock, and what is read after it is what the last writer committed.
    """
    if session.get_bind().dialect.name == "postgresql":
        session.execute(
            select(PassWheel.id)
            .join(Wheel, PassWheel.wheel_id == Wheel.id)
            .where(*_axle_of(pass_wheel))
            .order_by(PassWheel.id)
            .with_for_update(of=PassWheel)
        ).all()
    else:
        session.execute(
            update(PassWheel)
            .where(PassWheel.id == pass_wheel.id)
            .values(finished_at=PassWheel.finished_at)
        )


def update_axle(session: Session, pass_wheel: PassWheel) -> None:
    """When both wheels of `pass_wheel`'s axle are measured, store the axle's back-to-back
    distance and equivalent conicity on both wheels' measurements (per method) and
    re-evaluate their alarms. Idempotent; flushes, the caller commits (under `lock_axle`)."""
    pair = session.execute(
        select(PassWheel, Wheel)
        .join(Wheel, PassWheel.wheel_id == Wheel.id)
        .where(*_axle_of(pass_wheel), PassWheel.state == "measured")
        .execution_options(populate_existing=True)
    ).all()
    sides = {w.side: pw for pw, w in pair}
    if set(sides) != {"left", "right"}:
        return
    measurements = {
        side: {
            m.method: m
            for m in session.scalars(
                select(Measurement)
                .where(Measurement.pass_wheel_id == pw.id)
                .execution_options(populate_existing=True)
            )
        }
        for side, pw in sides.items()
    }
    left, right = measurements["left"], measurements["right"]
    fleet = pass_wheel.train_pass.fleet
    rails = site_rails(pass_wheel.train_pass.site)
    for method in set(left) & set(right):
        x_left, x_right = left[method].back_face_track_x_mm, right[method].back_face_track_x_mm
        b2b = None if x_left is None or x_right is None else x_right - x_left
        apply_axle_conicity(left[method], right[method], b2b, rails)
        for row in (left[method], right[method]):
            row.back_to_back_mm = b2b
            apply_alarms(row, fleet, session)
    session.flush()
