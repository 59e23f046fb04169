"""PostgreSQL restarted while uploads, reads and measurements run against a server on a
database of its own: requests during the outage get a clear 503 (no hang, no 500), the
service recovers by itself and no accepted pass is lost."""

from __future__ import annotations

import threading
from collections import Counter
from collections.abc import Callable, Iterator
from pathlib import Path

import httpx
import pytest

from tests.databases import PostgresServer, throwaway_database
from tests.faults.live import (
    LiveServer,
    check_database,
    check_store,
    manifest_wheels,
    upload,
    vary_archive,
    wait_for_job,
    wheels_of,
)
from tests.scale.topology import wait_until

pytestmark = pytest.mark.postgres

PASSES = 4
REQUEST_TIMEOUT_S = 15.0
"""Longer than any answer may take: a request still open after this counts as a hang."""
JOB_TIMEOUT_S = 180.0


@pytest.fixture
def postgres_server() -> Iterator[PostgresServer]:
    """A PostgreSQL server of this test's own, to restart (never the machine's)."""
    server = PostgresServer()
    server.start()
    yield server
    server.remove()


@pytest.fixture
def postgres_url(postgres_server: PostgresServer, tmp_path: Path) -> Iterator[str]:
    with throwaway_database("postgresql", tmp_path, port=postgres_server.port) as url:
        yield url


class Traffic:
    """Readers in threads until stopped, every answer (or transport error) recorded."""

    def __init__(self, server: LiveServer) -> None:
        self.server = server
        self.answers: Counter[str] = Counter()
        self.bad: list[str] = []
        self.pass_ids: list[int] = []
        self._stop = threading.Event()
        self._threads = [threading.Thread(target=self._read, daemon=True) for _ in range(3)]

    def record(self, what: str, call: Callable[[], httpx.Response]) -> httpx.Response | None:
        try:
            response = call()
        except httpx.TransportError as exc:
            self.bad.append(f"{what}: {type(exc).__name__} {exc}")
            return None
        code = response.json().get("code", "?") if response.status_code >= 400 else "ok"
        self.answers[f"{response.status_code} {code}"] += 1
        if response.status_code >= 400 and (response.status_code, code) != (
            503,
            "database_unavailable",
        ):
            self.bad.append(f"{what}: {response.status_code} {response.text[:300]}")
        return response

    def _read(self) -> None:
        with self.server.client("viewer", REQUEST_TIMEOUT_S) as client:
            while not self._stop.is_set():
                self.record("healthz", lambda: client.get("/healthz"))
                self.record("list", lambda: client.get("/api/passes"))
                for pass_id in list(self.pass_ids):
                    self.record("wheels", lambda p=pass_id: client.get(f"/api/passes/{p}/wheels"))

    def __enter__(self) -> Traffic:
        for thread in self._threads:
            thread.start()
        return self

    def __exit__(self, *_exc: object) -> None:
        self._stop.set()
        for thread in self._threads:
            thread.join(timeout=2 * REQUEST_TIMEOUT_S)


def test_postgresql_restart_under_load_gives_503s_then_recovers_with_nothing_lost(
    make_server: Callable[..., LiveServer],
    postgres_server: PostgresServer,
    postgres_url: str,
    axle_archive: bytes,
) -> None:
    server = make_server(database_url=postgres_url, workers=1)
    archives = [vary_archive(axle_archive, index) for index in range(PASSES)]
    accepted: dict[int, dict[str, int]] = {}
    with server.client("operator", REQUEST_TIMEOUT_S) as client, Traffic(server) as traffic:
        for index, archive in enumerate(archives):
            if index == PASSES // 2:
                first = accepted[0]["pass_id"]
                wait_until(lambda f=first: being_measured(client, f), 60, "a wheel measured")
                restart = threading.Thread(target=postgres_server.restart)
                restart.start()
            response = traffic.record(f"upload {index}", lambda a=archive: upload(client, a))
            if response is not None and response.status_code == 202:
                accepted[index] = response.json()
                traffic.pass_ids.append(response.json()["pass_id"])
        restart.join(timeout=120)
        wait_until(lambda: healthy(client), 60, "the service to answer again")
    assert postgres_server.running, "PostgreSQL was left down"
    assert not traffic.bad, "\n".join(traffic.bad)
    with server.client("operator", REQUEST_TIMEOUT_S) as client:
        for index, archive in enumerate(archives):
            again = upload(client, archive)
            assert again.status_code == 202, again.text
            if index in accepted:
                assert again.json() == accepted[index], "an accepted pass was lost"
            accepted[index] = again.json()
        for index, archive in enumerate(archives):
            wait_for_job(client, accepted[index]["job_id"], JOB_TIMEOUT_S)
            wheels = wheels_of(client, accepted[index]["pass_id"])
            assert {(w["vehicle_id"], w["axle"], w["side"]) for w in wheels} == manifest_wheels(
                archive
            )
            assert [w["state"] for w in wheels] == ["measured"] * len(wheels), wheels
        assert client.get("/api/passes").json()["total"] == PASSES
    problems = check_store(server.data_dir, server.tmp_dir).problems
    problems += check_database(postgres_url, server.data_dir).problems
    assert not problems, "\n".join(problems)
    assert traffic.answers["503 database_unavailable"] > 0, f"no outage seen: {traffic.answers}"


def being_measured(client: httpx.Client, pass_id: int) -> bool:
    return "running" in {w["state"] for w in wheels_of(client, pass_id)}


def healthy(client: httpx.Client) -> bool:
    try:
        return client.get("/healthz").status_code == 200
    except httpx.TransportError:
        return False
