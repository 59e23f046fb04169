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

from sqlalchemy import select, update
from sqlalchemy.orm import Session, sessionmaker

from backend.storage import BlobStore
from backend.wheels import refresh_job
from db.engine import make_engine, make_session_factory
from db.models import PassWheel
from db.types import utc_now

logger = logging.getLogger(__name__)


@lru_cache(maxsize=4)
def _worker_context(database_url: str, data_dir: str) -> tuple[sessionmaker[Session], BlobStore]:
    """One engine and store per worker process (cached across tasks)."""
    from backend.config import Settings

    settings = Settings(data_dir=Path(data_dir), database_url=database_url)
    return make_session_factory(make_engine(database_url)), BlobStore(settings.frames_dir)


def claim_pass_wheel(session: Session, pass_wheel_id: int) -> bool:
    """queued → running, atomically; False when another worker has it or it is finished."""
    result = session.execute(
        update(PassWheel)
        .where(PassWheel.id == pass_wheel_id, PassWheel.state == "queued")
        .values(state="running", attempts=PassWheel.attempts + 1, started_at=utc_now())
    )
    session.commit()
    return result.rowcount == 1


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
            session.rollback()
            logger.exception("pass wheel %d: measurement crashed", pass_wheel_id)
            record_wheel_crash(session, pass_wheel_id, f"{type(exc).__name__}: {exc}")
            return "failed"
        update_back_to_back(session, pass_wheel_id)
        refresh_job(session, pass_id)
        return state


def store_wheel_results(session: Session, store: BlobStore, pass_wheel_id: int) -> str:
    """Measure a claimed wheel with every method and write the results (one transaction)."""
    raise NotImplementedError(
        f"pass wheel {pass_wheel_id}: the per-wheel measurement function of the pipeline "
        f"(issue 4) has not landed yet; store {store.root} is untouched"
    )


def update_back_to_back(session: Session, pass_wheel_id: int) -> None:
    """Back-to-back distance of an axle once both its wheels are measured (see issue 4)."""
    session.get(PassWheel, pass_wheel_id)
