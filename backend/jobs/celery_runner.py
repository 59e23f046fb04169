"""Scale-out: per-wheel tasks on Celery workers (Redis broker), switched on by configuration.

With `WHEELSCAN_BROKER_URL` set, the service hands each queued pass wheel to the broker as
one message and any number of `wheelscan worker` processes, on any machines that reach the
broker, the database and the frame store, measure them. Without it the service keeps its
in-process pool (`make_task_runner` decides).

Delivery is at least once (`acks_late`, prefetch 1, a message of a lost worker is
requeued); effects happen once: a worker measures a wheel only while holding its lease
(`backend.jobs.leases`), the claim queued → running admits one measurement, and the results'
unique key stores a wheel once. Transient faults (database or broker unreachable) retry
with exponential backoff; the job's progress is recounted from wheel states
(`backend.services.pass_wheels.refresh_job`), so no message carries pass-level state.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from functools import lru_cache

import kombu.exceptions
import redis.exceptions
import sqlalchemy.exc
from celery import Celery, Task
from sqlalchemy import Engine, select
from sqlalchemy.orm import Session, sessionmaker

from backend.config import Settings
from backend.jobs.leases import hold_wheel_lease, requeue_orphaned_wheel
from backend.jobs.lost_wheels import LostWheelSweeper, find_lost_wheels
from backend.jobs.runner import ProcessPoolRunner, TaskRunner
from backend.jobs.tasks import measure_pass_wheel
from backend.services.pass_wheels import refresh_job
from db.engine import make_engine
from db.models import Job, PassWheel

logger = logging.getLogger(__name__)

MEASURE_WHEEL_TASK = "wheelscan.measure_wheel"
MEASURE_QUEUE = "wheelscan.measure"

TRANSIENT_ERRORS: tuple[type[BaseException], ...] = (
    sqlalchemy.exc.OperationalError,
    sqlalchemy.exc.InterfaceError,
    sqlalchemy.exc.DisconnectionError,
    kombu.exceptions.OperationalError,
    redis.exceptions.ConnectionError,
    redis.exceptions.TimeoutError,
    ConnectionError,
    TimeoutError,
)
"""Faults that pass: the task is retried with exponential backoff instead of failing."""


class WheelscanCelery(Celery):
    """The Celery application of one service or worker process, with its settings."""

    def __init__(self, settings: Settings) -> None:
        if not settings.broker_url:
            raise ValueError("broker_url must be set for Celery (WHEELSCAN_BROKER_URL)")
        super().__init__("wheelscan", broker=settings.broker_url, set_as_current=False)
        self.wheelscan_settings = settings


def make_celery_app(settings: Settings) -> WheelscanCelery:
    """A Celery app for `settings.broker_url` with the per-wheel measurement task.

    Parameters
    ----------
    settings : Settings
        `broker_url` (required), `database_url` and `data_dir` (the frame store) of this
        process, and the redelivery, lease and retry timing: a worker measures against its
        own settings, never the sender's.
    """
    app = WheelscanCelery(settings)
    app.conf.update(
        task_serializer="json",
        accept_content=["json"],
        task_ignore_result=True,
        task_acks_late=True,
        task_reject_on_worker_lost=True,
        task_default_queue=MEASURE_QUEUE,
        worker_prefetch_multiplier=1,
        broker_connection_retry_on_startup=True,
        broker_connection_max_retries=None,
        broker_transport_options={
            "visibility_timeout": settings.broker_visibility_timeout_s,
            "unacked_restore_interval": settings.broker_restore_interval_s,
            "unacked_restore_throttle": 1,
        },
    )
    app.task(
        name=MEASURE_WHEEL_TASK,
        bind=True,
        acks_late=True,
        reject_on_worker_lost=True,
        autoretry_for=TRANSIENT_ERRORS,
        retry_backoff=True,
        retry_backoff_max=settings.retry_backoff_max_s,
        retry_jitter=True,
        max_retries=settings.max_retries,
    )(measure_wheel)
    return app


@lru_cache(maxsize=4)
def _lease_engine(database_url: str) -> Engine:
    """One engine per worker process for leases and re-queueing (pool of its own)."""
    return make_engine(database_url)


def measure_wheel(task: Task, pass_wheel_id: int) -> str:
    """The Celery task: measure one pass wheel under its lease.

    Returns the wheel's state as `backend.jobs.tasks.measure_pass_wheel` reports it, or "busy"
    when a live worker holds the lease (this message is then sent again after
    `lease_retry_s`, so a wheel is never lost should that worker die too).
    """
    app: WheelscanCelery = task.app  # type: ignore[assignment]
    settings = app.wheelscan_settings
    database_url = settings.resolved_database_url
    engine = _lease_engine(database_url)
    with hold_wheel_lease(engine, settings.data_dir / "leases", pass_wheel_id) as held:
        if not held:
            task.apply_async(args=(pass_wheel_id,), countdown=settings.lease_retry_s)
            return "busy"
        with Session(engine) as session:
            if requeue_orphaned_wheel(session, pass_wheel_id):
                logger.warning("pass wheel %d: its worker died; measuring it again", pass_wheel_id)
        return measure_pass_wheel(pass_wheel_id, database_url, str(settings.data_dir))


class CeleryRunner:
    """Per-wheel tasks sent to Celery workers through the broker (`TaskRunner`)."""

    def __init__(self, settings: Settings, session_factory: sessionmaker[Session]) -> None:
        self._settings = settings
        self._session_factory = session_factory
        self._app = make_celery_app(settings)
        self._sweeper = LostWheelSweeper(self.send_lost, settings.sweep_interval_s)

    def submit(self, pass_wheel_ids: Sequence[int]) -> None:
        """Send one message per wheel; a wheel the broker refuses stays "queued" and is
        sent again by the lost-wheel sweeper once the broker answers."""
        try:
            with self._app.producer_or_acquire() as producer:
                for pass_wheel_id in pass_wheel_ids:
                    self._app.send_task(
                        MEASURE_WHEEL_TASK,
                        args=(pass_wheel_id,),
                        queue=MEASURE_QUEUE,
                        producer=producer,
                    )
        except kombu.exceptions.OperationalError:
            logger.exception(
                "broker unreachable: %d wheel(s) stay queued until the next sweep",
                len(pass_wheel_ids),
            )

    def resume(self) -> int:
        """Send again every wheel that is queued or running (its worker may have died:
        the lease tells, so a wheel a live worker holds is not measured twice)."""
        with self._session_factory() as session:
            pending = list(
                session.scalars(
                    select(PassWheel.id)
                    .where(PassWheel.state.in_(("queued", "running")))
                    .order_by(PassWheel.id)
                )
            )
            unfinished = list(session.scalars(select(Job.pass_id).where(Job.state != "done")))
            for pass_id in unfinished:
                refresh_job(session, pass_id)
        self.submit(pending)
        self._sweeper.start()
        return len(pending)

    def send_lost(self) -> int:
        """Send again the wheels whose message was lost (`backend.jobs.lost_wheels`)."""
        with self._session_factory() as session:
            lost = find_lost_wheels(
                session,
                _lease_engine(self._settings.resolved_database_url),
                self._settings.data_dir / "leases",
                broker_queue_empty=self._broker_queue_empty(),
            )
        self.submit(lost)
        return len(lost)

    def _broker_queue_empty(self) -> bool:
        """Whether no measurement message waits in the broker (False when unreachable)."""
        try:
            with self._app.connection_for_write() as connection:
                channel = connection.default_channel
                declared = channel.queue_declare(queue=MEASURE_QUEUE, passive=True)
                return declared.message_count == 0
        except kombu.exceptions.ChannelError:
            return True  # Redis drops an empty list: the queue does not exist.
        except TRANSIENT_ERRORS:
            return False

    def shutdown(self) -> None:
        """Stop sweeping and close broker connections; queued messages stay with the
        broker for the workers."""
        self._sweeper.stop()
        self._app.close()


def make_task_runner(settings: Settings, session_factory: sessionmaker[Session]) -> TaskRunner:
    """Celery when a broker is configured (`WHEELSCAN_BROKER_URL`), else the process pool."""
    if settings.broker_url:
        return CeleryRunner(settings, session_factory)
    return ProcessPoolRunner(settings, session_factory)
