"""Per-wheel task functions: the unit of measurement work, runnable anywhere.

`measure_pass_wheel(pass_wheel_id, database_url, data_dir)` takes plain arguments, so the
in-process pool and Celery workers call it alike. It claims its wheel with an atomic
UPDATE (queued → running), measures it with every method, and writes all results in one
transaction, so a wheel is never measured twice and a crash leaves nothing half-written.
An exception in one wheel is recorded on that wheel ("failed", with the reason); the pass
goes on.
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
        update_back_to_back(session, pass_wheel_id)
        refresh_job(session, pass_id)
        return state


def _decode(store: BlobStore, frame: Frame) -> np.ndarray:
    data = store.get(frame.sha256, ".png")
    return decode_frame(data, f"{frame.sensor} frame {frame.seq}")


def store_wheel_results(session: Session, store: BlobStore, pass_wheel_id: int) -> str:
    """Measure a claimed wheel with every method and write the results (one transaction).

    Returns the wheel's final state: "measured" when at least one method measured it,
    otherwise "not_measured" with the first method's reason.
    """
    pass_wheel = session.get_one(PassWheel, pass_wheel_id)
    train_pass = pass_wheel.train_pass
    calibration = parse_calibration(train_pass.calibration.document)
    frames = {p: wheel_frames(session, pass_wheel, (p,)) for p in POSITIONS}
    images = {p: [_decode(store, f) for f in rows] for p, rows in frames.items()}
    session.execute(delete(Measurement).where(Measurement.pass_wheel_id == pass_wheel_id))
    reasons = []
    for method in MEASURE_METHODS:
        result = measure_wheel(
            images["inner"], images["outer"], calibration, side=pass_wheel.wheel.side, method=method
        )
        row = measurement_row(result, train_pass.fleet, session)
        row.pass_wheel_id = pass_wheel_id
        session.add(row)
        session.flush()
        by_index = {(f.sensor, i): f for p in POSITIONS for i, f in enumerate(frames[p])}
        for frame_centres in result.frames:
            frame = by_index[(frame_centres.sensor, frame_centres.frame_index)]
            session.add(
                MeasurementFrame(
                    measurement_id=row.id,
                    sensor=frame.sensor,
                    seq=frame.seq,
                    artefact_sha256=save_artefacts(store, frame_centres.centres),
                    centre_count=len(frame_centres.centres),
                    **prerender_layers(store, frame_centres.centres),
                )
            )
        if result.status != MEASURED:
            reasons.append(f"{method}: {result.reason}")
    measured = len(reasons) < len(MEASURE_METHODS)
    pass_wheel.state = "measured" if measured else "not_measured"
    pass_wheel.reason = "; ".join(reasons) or None
    pass_wheel.finished_at = utc_now()
    session.commit()
    return pass_wheel.state


def update_back_to_back(session: Session, pass_wheel_id: int) -> None:
    """Once both wheels of an axle are finished, store the axle's back-to-back distance and
    equivalent conicity on both wheels' measurements (per method) and re-evaluate their
    alarms. Idempotent."""
    pass_wheel = session.get_one(PassWheel, pass_wheel_id)
    wheel = pass_wheel.wheel
    pair = session.execute(
        select(PassWheel, Wheel)
        .join(Wheel, PassWheel.wheel_id == Wheel.id)
        .where(
            PassWheel.pass_id == pass_wheel.pass_id,
            Wheel.vehicle_id == wheel.vehicle_id,
            Wheel.axle == wheel.axle,
            PassWheel.state == "measured",
        )
    ).all()
    sides = {w.side: pw for pw, w in pair}
    if set(sides) != {"left", "right"}:
        return
    left = {m.method: m for m in sides["left"].measurements}
    right = {m.method: m for m in sides["right"].measurements}
    fleet = pass_wheel.train_pass.fleet
    rails = site_rails(pass_wheel.train_pass.site)
    for method in set(left) & set(right):
        x_left, x_right = left[method].back_face_track_x_mm, right[method].back_face_track_x_mm
        b2b = None if x_left is None or x_right is None else x_right - x_left
        apply_axle_conicity(left[method], right[method], b2b, rails)
        for row in (left[method], right[method]):
            row.back_to_back_mm = b2b
            apply_alarms(row, fleet, session)
    session.commit()
