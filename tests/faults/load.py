"""Load on loopback: concurrent uploads of simulated passes and concurrent readers of wheel
pages and reports against a real `wheelscan serve`, bounded in count and time.

`run_load` drives it (asyncio, one HTTP connection per simulated user) and `verify_passes`
checks afterwards that no wheel was lost or duplicated. Used by tests/faults/test_load.py
(small) and benchmarks/load.py (20 uploads, 50 readers).
"""

from __future__ import annotations

import asyncio
import os
import random
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import httpx
import numpy as np

from tests.faults.live import LiveServer, manifest_wheels, wait_for_job, wheels_of

READ_TIMEOUT_S = 120.0
UPLOAD_TIMEOUT_S = 300.0
JOB_TIMEOUT_S = 600.0
REPORTS = ("report.csv", "report.json", "report.pdf")


@dataclass(frozen=True, slots=True)
class Seed:
    """A measured pass the readers read: its id and its wheel ids."""

    pass_id: int
    wheel_ids: tuple[int, ...]


@dataclass
class LoadResult:
    """Every request's kind, status and latency, and what was accepted."""

    reads: list[tuple[str, int, float]] = field(default_factory=list)
    uploads: list[tuple[int, float]] = field(default_factory=list)
    accepted: dict[int, dict[str, int]] = field(default_factory=dict)
    errors: list[str] = field(default_factory=list)
    wall_s: float = 0.0
    upload_wall_s: float = 0.0
    busy_fraction: float = 0.0
    load_before: float = 0.0
    load_after: float = 0.0

    def latencies(self, kinds: tuple[str, ...] | None = None) -> np.ndarray:
        return np.array([s for k, _, s in self.reads if kinds is None or k in kinds])


def seed_passes(server: LiveServer, archives: list[bytes]) -> list[Seed]:
    """Upload and measure the passes the readers will read (before the clock starts)."""
    seeds = []
    with server.client() as client:
        for archive in archives:
            accepted = client.post(
                "/api/passes", files={"file": ("seed.zip", archive, "application/zip")}
            ).raise_for_status()
            wait_for_job(client, accepted.json()["job_id"], JOB_TIMEOUT_S)
            pass_id = accepted.json()["pass_id"]
            wheel_ids = tuple(w["wheel_id"] for w in wheels_of(client, pass_id))
            seeds.append(Seed(pass_id, wheel_ids))
    return seeds


def wheel_page(seed: Seed, wheel_id: int) -> list[tuple[str, str]]:
    """The requests the browser makes to show one wheel (frontend/js/actions.js)."""
    wheel = f"/api/passes/{seed.pass_id}/wheels/{wheel_id}"
    return [
        ("json", f"/api/passes/{seed.pass_id}"),
        ("json", f"/api/passes/{seed.pass_id}/wheels"),
        ("json", f"{wheel}/profile?method=adaptive"),
        ("json", f"{wheel}/profile?method=steger"),
        ("json", f"/api/wheels/{wheel_id}/trend"),
        ("png", f"{wheel}/frames/inner.png?index=0"),
        ("json", f"{wheel}/centres/inner?index=0&method=adaptive"),
        ("json", f"{wheel}/centres/inner?index=0&method=steger"),
    ]


def _report(seed: Seed, wheel_id: int, round_index: int) -> tuple[str, str]:
    name = REPORTS[round_index % len(REPORTS)]
    kind = f"report-{name.split('.')[1]}"
    if name == "report.pdf":  # a wheel's PDF: what a depot files
        return kind, f"/api/passes/{seed.pass_id}/wheels/{wheel_id}/{name}"
    return kind, f"/api/passes/{seed.pass_id}/{name}"


async def _reader(
    server: LiveServer, token: str, seeds: list[Seed], rounds: int, index: int, out: LoadResult
) -> None:
    chooser = random.Random(index)
    headers = {"Authorization": f"Bearer {token}"}
    async with httpx.AsyncClient(
        base_url=server.url, headers=headers, timeout=READ_TIMEOUT_S
    ) as client:
        for round_index in range(rounds):
            seed = chooser.choice(seeds)
            wheel_id = chooser.choice(seed.wheel_ids)
            requests = [("json", "/api/passes"), *wheel_page(seed, wheel_id)]
            requests.append(_report(seed, wheel_id, round_index + index))
            for kind, path in requests:
                await _timed_read(client, kind, path, out)


async def _timed_read(client: httpx.AsyncClient, kind: str, path: str, out: LoadResult) -> None:
    started = time.monotonic()
    try:
        response = await client.get(path)
    except httpx.TransportError as exc:
        out.errors.append(f"GET {path}: {type(exc).__name__} {exc}")
        return
    out.reads.append((kind, response.status_code, time.monotonic() - started))
    if response.status_code != 200:
        out.errors.append(f"GET {path}: {response.status_code} {response.text[:200]}")


async def _uploader(
    server: LiveServer, token: str, archive: bytes, index: int, out: LoadResult
) -> None:
    headers = {"Authorization": f"Bearer {token}"}
    async with httpx.AsyncClient(
        base_url=server.url, headers=headers, timeout=UPLOAD_TIMEOUT_S
    ) as client:
        started = time.monotonic()
        try:
            response = await client.post(
                "/api/passes", files={"file": (f"load-{index}.zip", archive, "application/zip")}
            )
        except httpx.TransportError as exc:
            out.errors.append(f"upload {index}: {type(exc).__name__} {exc}")
            return
        out.uploads.append((response.status_code, time.monotonic() - started))
        if response.status_code == 202:
            out.accepted[index] = response.json()
        else:
            out.errors.append(f"upload {index}: {response.status_code} {response.text[:200]}")


def _cpu_ticks() -> tuple[int, int]:
    """(busy, total) jiffies of the whole machine, from /proc/stat."""
    values = [int(v) for v in open("/proc/stat").readline().split()[1:]]
    idle = values[3] + values[4]
    return sum(values) - idle, sum(values)


async def _drive(
    server: LiveServer, archives: list[bytes], seeds: list[Seed], readers: int, rounds: int
) -> LoadResult:
    out = LoadResult()
    operator, viewer = server.token("operator"), server.token("viewer")
    uploads = [_uploader(server, operator, a, i, out) for i, a in enumerate(archives)]
    reads = [_reader(server, viewer, seeds, rounds, i, out) for i in range(readers)]
    started = time.monotonic()

    async def timed_uploads() -> None:
        await asyncio.gather(*uploads)
        out.upload_wall_s = time.monotonic() - started

    await asyncio.gather(timed_uploads(), *reads)
    out.wall_s = time.monotonic() - started
    return out


def run_load(
    server: LiveServer,
    archives: list[bytes],
    seeds: list[Seed],
    *,
    readers: int,
    rounds: int,
    deadline_s: float,
) -> LoadResult:
    """All uploads at once and `readers` readers of `rounds` rounds each (a round: the pass
    list, one wheel page and one report), concurrently; stops after `deadline_s` at most."""
    load_before = os.getloadavg()[0]
    busy_before, total_before = _cpu_ticks()
    # On a thread of its own: the caller's thread may already run an event loop (a
    # session-wide Playwright of the browser tests does), where asyncio.run is refused.
    with ThreadPoolExecutor(1) as thread:
        running = thread.submit(
            asyncio.run,
            asyncio.wait_for(_drive(server, archives, seeds, readers, rounds), deadline_s),
        )
    try:
        result = running.result()
    except TimeoutError:
        raise AssertionError(f"the load did not finish within {deadline_s} s") from None
    busy_after, total_after = _cpu_ticks()
    result.busy_fraction = (busy_after - busy_before) / max(total_after - total_before, 1)
    result.load_before, result.load_after = load_before, os.getloadavg()[0]
    return result


def verify_passes(server: LiveServer, archives: list[bytes], result: LoadResult) -> list[str]:
    """Problems found once every accepted pass is measured: a wheel lost, duplicated, not
    measured, or measured other than once per method."""
    problems = []
    with server.client("viewer") as client:
        for index, archive in enumerate(archives):
            if index not in result.accepted:
                problems.append(f"upload {index} was not accepted")
                continue
            accepted = result.accepted[index]
            wait_for_job(client, accepted["job_id"], JOB_TIMEOUT_S)
            problems += _wheel_problems(wheels_of(client, accepted["pass_id"]), archive, index)
    return problems


def _wheel_problems(wheels: list[dict[str, Any]], archive: bytes, index: int) -> list[str]:
    expected = manifest_wheels(archive)
    found = [(w["vehicle_id"], w["axle"], w["side"]) for w in wheels]
    problems = []
    if len(found) != len(set(found)):
        problems.append(f"pass of upload {index}: duplicated wheels {sorted(found)}")
    if set(found) != expected:
        problems.append(f"pass of upload {index}: wheels {sorted(found)} ≠ {sorted(expected)}")
    for wheel in wheels:
        methods = sorted(m["method"] for m in wheel["results"])
        if wheel["state"] != "measured" or methods != ["adaptive", "steger"]:
            problems.append(f"upload {index} wheel {wheel['wheel_id']}: {wheel['state']} {methods}")
    return problems
