"""Celery workers on Redis and PostgreSQL measure exactly what the in-process pool does,
lose no wheel when a worker is killed or the broker restarts, and measure none twice."""

from __future__ import annotations

import subprocess
from collections import Counter
from pathlib import Path

import pytest
from sqlalchemy import select

from backend.config import Settings
from backend.storage.store import BlobStore
from db.models import Frame, MeasurementFrame
from tests.scale.conftest import PASS_TIMEOUT_S
from tests.scale.topology import (
    WHEELSCAN,
    RedisServer,
    WorkerProcess,
    api,
    http_server,
    measurement_results,
    operator_token,
    upload,
    wait_for_pass,
    wait_until,
    wheel_states,
    worker_env,
    workers,
)

pytestmark = [pytest.mark.postgres, pytest.mark.slow]

TERMINAL = ("measured", "not_measured", "failed")


def finished_tasks(*started: WorkerProcess) -> int:
    """Tasks that ended with a wheel measured (or not measured, or failed), over all logs."""
    total: Counter[str] = Counter()
    for worker in started:
        total += worker.outcomes()
    return sum(total[state] for state in TERMINAL)


def test_two_celery_workers_store_exactly_the_in_process_results(
    pass_archive, in_process_results, postgres_url, shared_redis_url, tmp_path: Path
) -> None:
    settings = Settings(data_dir=tmp_path, database_url=postgres_url, broker_url=shared_redis_url)
    env = worker_env(settings)
    with workers(2, env, tmp_path) as started, api(settings) as client:
        pass_id = upload(client, pass_archive)
        wait_for_pass(client, pass_id, PASS_TIMEOUT_S)
        results = measurement_results(client, pass_id)
        states = wheel_states(client, pass_id)
        ping = subprocess.run(
            [WHEELSCAN, "worker", "--ping", "--hostname", "w2@scale"], env=env, check=False
        )
    assert ping.returncode == 0, "the health check of a live worker"
    assert results == in_process_results
    assert all(attempts == 1 for _state, attempts in states.values()), states
    assert finished_tasks(*started) == len(states)
    assert all(worker.outcomes() for worker in started), "both workers should have measured"


def test_messages_redelivered_to_live_workers_measure_no_wheel_twice(
    pass_archive, in_process_results, postgres_url, shared_redis_url, tmp_path: Path
) -> None:
    settings = Settings(data_dir=tmp_path, database_url=postgres_url, broker_url=shared_redis_url)
    env = worker_env(settings)
    # Far shorter than a wheel takes (≥ 1 s): every message is delivered again mid-wheel.
    env["WHEELSCAN_BROKER_VISIBILITY_TIMEOUT_S"] = "0.2"
    env["WHEELSCAN_BROKER_RESTORE_INTERVAL_S"] = "0.2"
    with workers(2, env, tmp_path) as started, api(settings) as client:
        pass_id = upload(client, pass_archive)
        wait_for_pass(client, pass_id, PASS_TIMEOUT_S)
        results = measurement_results(client, pass_id)
        states = wheel_states(client, pass_id)
    outcomes = started[0].outcomes() + started[1].outcomes()
    assert outcomes["busy"] + outcomes["skipped"] >= 1, "no message was delivered twice"
    assert results == in_process_results
    assert all(attempts == 1 for _state, attempts in states.values()), states
    assert finished_tasks(*started) == len(states)


def test_a_worker_without_the_shared_volume_measures_from_frames_fetched_over_the_api(
    pass_archive, in_process_results, postgres_url, shared_redis_url, tmp_path: Path
) -> None:
    settings = Settings(
        data_dir=tmp_path / "api", database_url=postgres_url, broker_url=shared_redis_url
    )
    elsewhere = Settings(
        data_dir=tmp_path / "elsewhere", database_url=postgres_url, broker_url=shared_redis_url
    )
    with api(settings) as client, http_server(client) as base_url:
        env = worker_env(elsewhere)
        env["WHEELSCAN_STORE_URL"] = base_url
        env["WHEELSCAN_STORE_TOKEN"] = operator_token(client, "remote worker")
        with workers(1, env, tmp_path, prefix="remote"):
            pass_id = upload(client, pass_archive)
            wait_for_pass(client, pass_id, PASS_TIMEOUT_S)
        results = measurement_results(client, pass_id)
        with client.app.state.session_factory() as session:
            frames = set(session.scalars(select(Frame.sha256)))
            written = session.execute(
                select(
                    MeasurementFrame.artefact_sha256,
                    MeasurementFrame.mask_png_sha256,
                    MeasurementFrame.sigma_png_sha256,
                )
            ).all()
    assert results == in_process_results
    api_store, worker_cache = BlobStore(settings.frames_dir), BlobStore(elsewhere.frames_dir)
    assert len(frames) == 8 and all(worker_cache.has(sha256, ".png") for sha256 in frames)
    assert written, "the worker stored per-frame artefacts"
    for artefact, mask, sigma in written:
        assert api_store.has(artefact, ".npz"), "artefacts reach the service's store"
        assert all(api_store.has(png, ".png") for png in (mask, sigma) if png is not None)


def test_a_worker_killed_mid_wheel_loses_no_wheel_and_measures_none_twice(
    pass_archive, in_process_results, postgres_url, shared_redis_url, tmp_path: Path
) -> None:
    settings = Settings(data_dir=tmp_path, database_url=postgres_url, broker_url=shared_redis_url)
    env = worker_env(settings)
    with api(settings) as client:
        with workers(1, env, tmp_path) as (victim,):
            pass_id = upload(client, pass_archive)
            wait_until(
                lambda: (
                    any(s == "measured" for s, _ in wheel_states(client, pass_id).values())
                    and any(s == "running" for s, _ in wheel_states(client, pass_id).values())
                ),
                PASS_TIMEOUT_S,
                "the first worker to be measuring its second or a later wheel",
            )
            victim.kill()
            orphans = [i for i, (s, _) in wheel_states(client, pass_id).items() if s == "running"]
            with workers(1, env, tmp_path, prefix="rescuer") as (rescuer,):
                wait_for_pass(client, pass_id, PASS_TIMEOUT_S)
        results = measurement_results(client, pass_id)
        states = wheel_states(client, pass_id)
    assert results == in_process_results
    assert len(orphans) == 1
    assert states[orphans[0]][1] == 2, "the orphaned wheel is claimed once more, by the rescuer"
    assert all(attempts == 1 for i, (_s, attempts) in states.items() if i != orphans[0])
    assert finished_tasks(victim, rescuer) == len(states)


def test_a_pool_process_killed_mid_wheel_is_replaced_and_its_wheel_measured_once_more(
    pass_archive, in_process_results, postgres_url, shared_redis_url, tmp_path: Path
) -> None:
    settings = Settings(data_dir=tmp_path, database_url=postgres_url, broker_url=shared_redis_url)
    with workers(1, worker_env(settings), tmp_path) as (worker,), api(settings) as client:
        pass_id = upload(client, pass_archive)
        wait_until(
            lambda: "running" in [s for s, _ in wheel_states(client, pass_id).values()],
            PASS_TIMEOUT_S,
            "the worker to be measuring a wheel",
        )
        assert worker.kill_pool_children() == 1
        orphans = [i for i, (s, _) in wheel_states(client, pass_id).items() if s == "running"]
        wait_for_pass(client, pass_id, PASS_TIMEOUT_S)
        results = measurement_results(client, pass_id)
        states = wheel_states(client, pass_id)
    assert "WorkerLostError" in worker.log(), "the message is rejected back to the queue"
    assert results == in_process_results
    assert len(orphans) == 1
    assert states[orphans[0]][1] == 2
    assert all(attempts == 1 for i, (_s, attempts) in states.items() if i != orphans[0])
    assert finished_tasks(worker) == len(states)


def test_a_broker_restart_that_drops_every_message_during_a_pass_loses_no_wheel(
    pass_archive,
    in_process_results,
    postgres_url,
    private_redis: RedisServer,
    tmp_path: Path,
) -> None:
    settings = Settings(data_dir=tmp_path, database_url=postgres_url, broker_url=private_redis.url)
    # One worker: after its first wheel, the others wait in the broker for a whole wheel's
    # time, so the restart surely drops their messages.
    with workers(1, worker_env(settings), tmp_path) as started, api(settings) as client:
        pass_id = upload(client, pass_archive)

        def some_measured_some_waiting() -> bool:
            states = [state for state, _ in wheel_states(client, pass_id).values()]
            return any(s in TERMINAL for s in states) and "queued" in states

        wait_until(some_measured_some_waiting, PASS_TIMEOUT_S, "a wheel done, one waiting")
        private_redis.stop()
        waiting = [s for s, _ in wheel_states(client, pass_id).values()].count("queued")
        private_redis.start()
        wait_for_pass(client, pass_id, PASS_TIMEOUT_S)
        results = measurement_results(client, pass_id)
        states = wheel_states(client, pass_id)
    assert waiting >= 1, "the restart should have dropped the message of a waiting wheel"
    assert results == in_process_results
    assert finished_tasks(*started) == len(states)
