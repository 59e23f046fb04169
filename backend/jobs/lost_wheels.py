"""Finding wheels whose Celery message was lost, so the service can send them again.

A message can vanish: a broker restarted without persistence, a worker that died holding
one (it comes back only after the broker's visibility timeout), a submit while the broker
was down. The database says which wheels still need measuring, and two facts tell which
of them nobody will measure:

- a "running" wheel whose lease is free has a dead worker (a live one holds the lease
  from before its claim until after its final state is written);
- a "queued" wheel while the broker's queue is empty has no message left.

Sending such a wheel again is always safe: a duplicate message finds the lease taken or
the wheel finished and does nothing.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from pathlib import Path

from sqlalchemy import Engine, select
from sqlalchemy.orm import Session

from backend.jobs.leases import hold_wheel_lease
from db.models import PassWheel

logger = logging.getLogger(__name__)


def find_lost_wheels(
    session: Session, engine: Engine, leases_dir: Path, *, broker_queue_empty: bool
) -> list[int]:
    """Pass-wheel ids that need a new message (see the module docstring), ascending."""
    running = session.scalars(select(PassWheel.id).where(PassWheel.state == "running")).all()
    lost = [wheel_id for wheel_id in running if _lease_free(engine, leases_dir, wheel_id)]
    if broker_queue_empty:
        lost += session.scalars(select(PassWheel.id).where(PassWheel.state == "queued")).all()
    return sorted(lost)


def _lease_free(engine: Engine, leases_dir: Path, pass_wheel_id: int) -> bool:
    with hold_wheel_lease(engine, leases_dir, pass_wheel_id) as held:
        return held


class LostWheelSweeper:
    """Calls `sweep` every `interval_s` seconds in a daemon thread until stopped."""

    def __init__(self, sweep: Callable[[], int], interval_s: float) -> None:
        if interval_s <= 0:
            raise ValueError(f"interval_s must be > 0, got {interval_s}")
        self._sweep = sweep
        self._interval_s = interval_s
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="lost-wheel-sweeper", daemon=True)

    def start(self) -> None:
        """Start sweeping (once; later calls do nothing)."""
        if self._thread.ident is None:
            self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join()

    def _run(self) -> None:
        while not self._stop.wait(self._interval_s):
            try:
                sent = self._sweep()
            except Exception:
                logger.exception("lost-wheel sweep failed; trying again in %s s", self._interval_s)
                continue
            if sent:
                logger.warning("sent %d wheel(s) again whose message was lost", sent)
