"""Where per-wheel tasks run: a process pool inside the server (the default).

A runner only decides *where* `backend.jobs.tasks.measure_pass_wheel` runs; the task itself
claims its wheel in the database, so any runner (this pool, or Celery workers started by
the scale-out configuration) can call the same function without measuring a wheel twice.

Process pool vs Celery: docs/service.md, "Jobs".
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import threading
import time
from collections.abc import Sequence
from concurrent.futures import Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from threading import Lock
from typing import Protocol

from sqlalchemy import select, update
from sqlalchemy.orm import Session, sessionmaker

from backend.config import Settings
from backend.jobs.allocator import keep_freed_memory
from backend.jobs.tasks import measure_pass_wheel, record_wheel_crash
from backend.services.pass_wheels import refresh_job
from backend.transient import is_transient
from db.models import Job, PassWheel

logger = logging.getLogger(__name__)


PARENT_CHECK_INTERVAL_S = 2.0
"""How often a pool worker checks that the server that started it is still alive."""
RETRY_BACKOFF_MAX_S = 30.0
"""Longest wait between two tries of a wheel that met a passing fault (1, 2, 4, … s)."""


def exit_with_parent(parent_pid: int) -> None:
    """Pool-worker initializer: end the worker when its server is gone; keep freed memory.

    A killed server leaves its spawned workers behind otherwise (they wait on a queue whose
    other end nobody closes); their unfinished wheels are resumed by the next start.
    A spawned worker starts with the C library's allocator defaults (see backend.jobs.allocator).
    """
    keep_freed_memory()

    def watch() -> None:
        while os.getppid() == parent_pid:
            time.sleep(PARENT_CHECK_INTERVAL_S)
        os._exit(0)

    threading.Thread(target=watch, name="exit-with-parent", daemon=True).start()


class TaskRunner(Protocol):
    """What the service needs from a runner."""

    def submit(self, pass_wheel_ids: Sequence[int]) -> None:
        """Run the measurement of these pass wheels (already in state "queued")."""

    def resume(self) -> int:
        """After a restart: queue again what was interrupted; returns how many wheels."""

    def shutdown(self) -> None:
        """Stop taking work; what did not finish is resumed by the next start."""


class ProcessPoolRunner:
    """Per-wheel tasks in a pool of worker processes of this server.

    Workers are started with "spawn" (no fork of a threaded server) and only when the
    first task arrives. A worker that dies hard (segfault, out of memory) breaks the
    pool: its wheel is recorded as failed and a new pool takes over. A task that meets a
    passing fault (the database restarting, the disk full: `backend.transient`) is tried
    again 1, 2, 4, … s later (at most RETRY_BACKOFF_MAX_S apart) until it goes through.
    """

    def __init__(self, settings: Settings, session_factory: sessionmaker[Session]) -> None:
        self._settings = settings
        self._session_factory = session_factory
        self._lock = Lock()
        self._executor: ProcessPoolExecutor | None = None
        self._pending: set[Future[str]] = set()
        self._retries: set[threading.Timer] = set()
        self._stopped = False

    def _pool(self) -> ProcessPoolExecutor:
        with self._lock:
            if self._executor is None:
                self._executor = ProcessPoolExecutor(
                    max_workers=self._settings.workers,
                    mp_context=multiprocessing.get_context("spawn"),
                    initializer=exit_with_parent,
                    initargs=(os.getpid(),),
                )
            return self._executor

    def submit(self, pass_wheel_ids: Sequence[int]) -> None:
        for pass_wheel_id in pass_wheel_ids:
            self._submit_one(pass_wheel_id)

    def _submit_one(self, pass_wheel_id: int) -> None:
        future = self._pool().submit(
            measure_pass_wheel,
            pass_wheel_id,
            self._settings.resolved_database_url,
            str(self._settings.data_dir),
        )
        with self._lock:
            self._pending.add(future)
        future.add_done_callback(lambda done: self._finished(pass_wheel_id, done))

    def drain(self) -> None:
        """Wait until every task submitted so far has finished (graceful stop, tests)."""
        with self._lock:
            pending = list(self._pending)
        wait(pending)

    def _finished(self, pass_wheel_id: int, future: Future[str]) -> None:
        with self._lock:
            self._pending.discard(future)
        if future.cancelled():
            return
        error = future.exception()
        if error is None:
            return
        if is_transient(error):
            self._retry_later(pass_wheel_id, 0, error)
            return
        if isinstance(error, BrokenProcessPool):
            with self._lock:
                self._executor = None
        logger.error("pass wheel %d: task ended with %r", pass_wheel_id, error)
        try:
            with self._session_factory() as session:
                record_wheel_crash(session, pass_wheel_id, f"worker crashed: {error!r}")
        except Exception:
            logger.exception("pass wheel %d: could not record the crash", pass_wheel_id)

    def _retry_later(self, pass_wheel_id: int, attempt: int, error: BaseException) -> None:
        delay_s = min(2.0**attempt, RETRY_BACKOFF_MAX_S)
        logger.warning(
            "pass wheel %d: %s; measuring it again in %.0f s",
            pass_wheel_id,
            str(error).splitlines()[0] if str(error) else type(error).__name__,
            delay_s,
        )
        timer = threading.Timer(delay_s, self._retry, args=(pass_wheel_id, attempt))
        timer.daemon = True
        with self._lock:
            if self._stopped:
                return  # the wheel stays "running"; the next start resumes it
            self._retries.add(timer)
        timer.start()

    def _retry(self, pass_wheel_id: int, attempt: int) -> None:
        with self._lock:
            self._retries.discard(threading.current_thread())  # type: ignore[arg-type]
        try:
            with self._session_factory() as session:
                again = requeue_wheel(session, pass_wheel_id)
        except Exception as error:
            if not is_transient(error):
                raise
            self._retry_later(pass_wheel_id, attempt + 1, error)
            return
        if again:
            self._submit_one(pass_wheel_id)

    def resume(self) -> int:
        with self._session_factory() as session:
            session.execute(
                update(PassWheel).where(PassWheel.state == "running").values(state="queued")
            )
            session.commit()
            queued = list(
                session.scalars(
                    select(PassWheel.id).where(PassWheel.state == "queued").order_by(PassWheel.id)
                )
            )
            unfinished = list(session.scalars(select(Job.pass_id).where(Job.state != "done")))
        self.submit(queued)
        if unfinished:
            with self._session_factory() as session:
                for pass_id in unfinished:
                    refresh_job(session, pass_id)
        return len(queued)

    def shutdown(self) -> None:
        """Cancel queued tasks (they stay "queued" and resume on the next start) and wait
        for the wheels being measured right now."""
        with self._lock:
            executor, self._executor = self._executor, None
            self._stopped = True
            for timer in self._retries:
                timer.cancel()
            running = sum(1 for future in self._pending if future.running())
        if executor is not None:
            if running:
                logger.warning(
                    "stopping: waiting for the %d wheel(s) being measured now; "
                    "queued wheels resume on the next start",
                    running,
                )
            executor.shutdown(wait=True, cancel_futures=True)


def requeue_wheel(session: Session, pass_wheel_id: int) -> bool:
    """Put back a wheel whose task met a passing fault: running → queued; True when it is
    to be measured again. A wheel that was finished before the fault (its results and its
    axle's values are one commit) gets its job's count brought up to date instead."""
    session.execute(
        update(PassWheel)
        .where(PassWheel.id == pass_wheel_id, PassWheel.state == "running")
        .values(state="queued")
    )
    session.commit()
    state, pass_id = session.execute(
        select(PassWheel.state, PassWheel.pass_id).where(PassWheel.id == pass_wheel_id)
    ).one()
    refresh_job(session, pass_id)
    return state == "queued"
