"""A wheel's lease is held by one live process at a time and freed the moment its holder
dies, on PostgreSQL (advisory lock) and on SQLite (flock)."""

from __future__ import annotations

import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from sqlalchemy import Engine

from backend.jobs.leases import hold_wheel_lease
from db.engine import make_engine
from tests.databases import BACKENDS, throwaway_database
from tests.scale.topology import wait_until

HOLDER = """
import sys
from pathlib import Path
from backend.jobs.leases import hold_wheel_lease
from db.engine import make_engine
with hold_wheel_lease(make_engine(sys.argv[1]), Path(sys.argv[2]), 7) as held:
    sys.stdout.write(f"{held}\\n")
    sys.stdout.flush()
    sys.stdin.read()
"""


@pytest.fixture(params=BACKENDS)
def database(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[tuple[str, Engine]]:
    with throwaway_database(request.param, tmp_path) as url:
        engine = make_engine(url)
        yield url, engine
        engine.dispose()


def test_a_lease_is_held_once_and_free_again_after_release(database, tmp_path: Path) -> None:
    _url, engine = database
    with hold_wheel_lease(engine, tmp_path, 7) as first:
        with hold_wheel_lease(engine, tmp_path, 7) as second:
            assert (first, second) == (True, False)
        with hold_wheel_lease(engine, tmp_path, 8) as other_wheel:
            assert other_wheel
    with hold_wheel_lease(engine, tmp_path, 7) as again:
        assert again


def test_a_lease_is_freed_when_its_holder_is_killed(database, tmp_path: Path) -> None:
    url, engine = database
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLDER, url, str(tmp_path)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        cwd=Path(__file__).resolve().parents[2],
    )
    try:
        assert holder.stdout.readline().strip() == "True"
        with hold_wheel_lease(engine, tmp_path, 7) as while_alive:
            assert not while_alive
        holder.send_signal(signal.SIGKILL)
        holder.wait(timeout=30)
    finally:
        holder.kill()

    def free() -> bool:
        with hold_wheel_lease(engine, tmp_path, 7) as held:
            return held

    wait_until(free, 30, "the dead holder's lease to be released")


def test_a_wheel_id_must_be_positive(database, tmp_path: Path) -> None:
    _url, engine = database
    with pytest.raises(ValueError, match="pass_wheel_id must be ≥ 1, got 0"):
        with hold_wheel_lease(engine, tmp_path, 0):
            pass
