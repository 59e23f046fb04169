"""The commit that finishes the second wheel of an axle carries the axle's values.

A job is "done" as soon as every wheel is finished, so anything stored after a wheel's
own commit (the axle's back-to-back and conicity) could be missing when a reader follows
the job to its end: CI once saw `back_to_back_mm` None on a streamed pass. Here both
wheels of one axle reach their write at the same instant, on SQLite and PostgreSQL; each
wheel's results must find the axle complete the moment both are measured, with no later
step.
"""

from __future__ import annotations

import hashlib
import threading
from collections.abc import Callable
from pathlib import Path

import pytest
from sqlalchemy import select

import backend.jobs.tasks as tasks
from backend.config import Settings
from backend.ops.demo import zip_folder
from backend.services.ingest import store_archive, validate_archive
from backend.storage.store import BlobStore
from db.engine import make_engine, make_session_factory, upgrade_database
from db.models import Measurement, PassWheel
from tests.databases import BACKENDS, throwaway_database


@pytest.fixture(scope="module")
def one_axle_archive(tmp_path_factory: pytest.TempPathFactory, simulated_pass: Callable) -> Path:
    """A simulated clean pass of one vehicle with one axle, zipped."""
    root = tmp_path_factory.mktemp("axle")
    simulated_pass(root / "pass", 1)
    (root / "pass" / "truth.json").unlink()
    return zip_folder(root / "pass", root / "pass.zip")


def _claimed_wheels(settings: Settings, archive: Path) -> list[int]:
    """Store the archive as an upload does and claim its wheels (queued → running)."""
    engine = make_engine(settings.resolved_database_url)
    try:
        upgrade_database(engine)
        with make_session_factory(engine)() as session:
            valid = validate_archive(session, archive, settings)
            sha256 = hashlib.sha256(archive.read_bytes()).hexdigest()
            ids = store_archive(session, BlobStore(settings.frames_dir), valid, sha256, None)[2]
            assert all(tasks.claim_pass_wheel(session, i) for i in ids)
        return ids
    finally:
        engine.dispose()


@pytest.mark.parametrize("backend", BACKENDS)
def test_two_wheels_finishing_at_once_store_the_axle_in_their_own_commits(
    backend: str, one_axle_archive: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    with throwaway_database(backend, tmp_path) as url:
        settings = Settings(data_dir=tmp_path / "data", database_url=url)
        ids = _claimed_wheels(settings, one_axle_archive)
        assert len(ids) == 2
        engine = make_engine(url)
        factory = make_session_factory(engine)
        store = BlobStore(settings.frames_dir)
        # Both wheels are measured, then meet here before either begins its write.
        both_measured = threading.Barrier(2, timeout=120)
        lock_axle = tasks.lock_axle

        def meet_then_lock(session, pass_wheel) -> None:
            both_measured.wait()
            lock_axle(session, pass_wheel)

        monkeypatch.setattr(tasks, "lock_axle", meet_then_lock)
        states: dict[int, str] = {}
        errors: list[BaseException] = []

        def finish(pass_wheel_id: int) -> None:
            try:
                with factory() as session:
                    states[pass_wheel_id] = tasks.store_wheel_results(session, store, pass_wheel_id)
            except BaseException as error:  # reported below, in the test's thread
                errors.append(error)
                both_measured.abort()

        threads = [threading.Thread(target=finish, args=(i,)) for i in ids]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join(timeout=300)
        assert not errors, errors
        assert set(states.values()) == {"measured"}, states
        with factory() as session:
            rows = session.execute(
                select(PassWheel.id, Measurement.method, Measurement.back_to_back_mm)
                .join(Measurement, Measurement.pass_wheel_id == PassWheel.id)
                .where(PassWheel.id.in_(ids))
            ).all()
        engine.dispose()
    measured = [r for r in rows if r.method == "adaptive"]
    assert len(measured) == 2
    assert all(r.back_to_back_mm is not None for r in measured), rows
    assert measured[0].back_to_back_mm == measured[1].back_to_back_mm
    assert 1350.0 < measured[0].back_to_back_mm < 1365.0
