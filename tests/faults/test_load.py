"""A small load on loopback (the check of benchmarks/load.py, held in CI): concurrent
uploads and readers of wheel pages and reports, no error, no wheel lost or duplicated."""

from __future__ import annotations

from collections.abc import Callable

from tests.faults.live import LiveServer, check_database, check_store, vary_archive
from tests.faults.load import run_load, seed_passes, verify_passes

UPLOADS = 5
READERS = 10
ROUNDS = 2
DEADLINE_S = 120.0


def test_concurrent_uploads_and_readers_give_no_error_and_every_wheel_once(
    make_server: Callable[..., LiveServer], axle_archive: bytes
) -> None:
    server = make_server(workers=2)
    seeds = seed_passes(server, [vary_archive(axle_archive, 100)])
    archives = [vary_archive(axle_archive, i, distinct_frames=True) for i in range(UPLOADS)]
    result = run_load(
        server, archives, seeds, readers=READERS, rounds=ROUNDS, deadline_s=DEADLINE_S
    )
    assert not result.errors, "\n".join(result.errors)
    assert len(result.reads) == READERS * ROUNDS * 10
    assert sorted(result.accepted) == list(range(UPLOADS))
    problems = verify_passes(server, archives, result)
    problems += check_store(server.data_dir, server.tmp_dir).problems
    problems += check_database(server.settings.resolved_database_url, server.data_dir).problems
    assert not problems, "\n".join(problems)
