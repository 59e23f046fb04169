"""Fixtures of the scale-out tests: a simulated pass, its in-process results, a throw-away
PostgreSQL database, the machine's Redis and a private Redis that tests may restart."""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import redis

from backend.config import Settings
from backend.jobs.celery_runner import MEASURE_QUEUE
from tests.databases import throwaway_database
from tests.scale.topology import (
    TEST_SCALE_ENV,
    RedisServer,
    api,
    measurement_results,
    upload,
    wait_for_pass,
    zip_pass_folder,
)

SHARED_REDIS_URL = os.environ.get("WHEELSCAN_TEST_REDIS_URL", "redis://127.0.0.1:6379/13")
"""The machine's Redis; database 13 is reserved for these tests."""
PASS_TIMEOUT_S = 120.0


@pytest.fixture(scope="session")
def pass_archive(
    tmp_path_factory: pytest.TempPathFactory, simulated_pass: Callable[[Path, int], Path]
) -> bytes:
    """One two-axle vehicle: 4 wheels, one 1600×1200 frame per sensor (small: 2 cores)."""
    folder = tmp_path_factory.mktemp("scale-pass")
    return zip_pass_folder(simulated_pass(folder / "pass", 2), folder / "pass.zip")


@pytest.fixture(scope="session")
def in_process_results(
    pass_archive: bytes, tmp_path_factory: pytest.TempPathFactory
) -> dict[tuple, dict[str, Any]]:
    """The pass measured by the default configuration: SQLite, in-process pool."""
    data_dir = tmp_path_factory.mktemp("in-process")
    with api(Settings(data_dir=data_dir, workers=1)) as client:
        pass_id = upload(client, pass_archive)
        wait_for_pass(client, pass_id, PASS_TIMEOUT_S)
        results = measurement_results(client, pass_id)
    assert len(results) == 8, "4 wheels × 2 methods expected in the reference"
    return results


@pytest.fixture
def postgres_url(tmp_path: Path) -> Iterator[str]:
    with throwaway_database("postgresql", tmp_path) as url:
        yield url


def _clear_queue(client: redis.Redis) -> None:
    client.delete(MEASURE_QUEUE, "unacked", "unacked_index", "unacked_mutex")


@pytest.fixture(scope="session")
def _redis_url() -> Iterator[str]:
    """The machine's Redis when it answers (database 13), else one of the tests' own."""
    client = redis.Redis.from_url(SHARED_REDIS_URL, socket_connect_timeout=2)
    try:
        client.ping()
    except redis.exceptions.ConnectionError:
        folder = Path(tempfile.mkdtemp(prefix="wheelscan-redis-"))
        own = RedisServer(folder, persistent=False)
        own.start()
        yield own.url
        own.stop()
        shutil.rmtree(folder, ignore_errors=True)
        return
    yield SHARED_REDIS_URL


@pytest.fixture
def shared_redis_url(_redis_url: str) -> Iterator[str]:
    """A Redis the tests share, emptied of our keys before and after each test."""
    client = redis.Redis.from_url(_redis_url, socket_connect_timeout=2)
    _clear_queue(client)
    yield _redis_url
    _clear_queue(client)


@pytest.fixture(autouse=True)
def fast_redelivery(monkeypatch: pytest.MonkeyPatch) -> None:
    """The service in this process sweeps for lost messages every second, like the
    workers' short delays (TEST_SCALE_ENV)."""
    for name, value in TEST_SCALE_ENV.items():
        monkeypatch.setenv(name, value)


@pytest.fixture
def private_redis(tmp_path: Path) -> Iterator[RedisServer]:
    """A Redis of this test's own that keeps nothing across a restart."""
    server = RedisServer(tmp_path / "redis", persistent=False)
    server.start()
    yield server
    server.stop()
