"""`wheelscan worker` refuses to start without what a worker on another machine needs, with
one line on stderr; `--ping` tells whether a worker answers."""

from __future__ import annotations

import pytest

from backend.cli import main


@pytest.fixture(autouse=True)
def no_scale_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in ("WHEELSCAN_BROKER_URL", "WHEELSCAN_DATABASE_URL"):
        monkeypatch.delenv(name, raising=False)


def test_a_worker_without_a_broker_is_refused(capsys) -> None:
    assert main(["worker", "--database-url", "sqlite:///x.db"]) == 2
    assert "no broker: set WHEELSCAN_BROKER_URL" in capsys.readouterr().err


def test_a_worker_without_an_explicit_database_is_refused(capsys) -> None:
    assert main(["worker", "--broker-url", "redis://127.0.0.1:6379/13"]) == 2
    assert "no database: workers need the service's WHEELSCAN_DATABASE_URL" in (
        capsys.readouterr().err
    )


def test_a_worker_needs_at_least_one_process(capsys) -> None:
    assert main(["worker", "--concurrency", "0"]) == 2
    assert "--concurrency must be ≥ 1, got 0" in capsys.readouterr().err


def test_a_ping_nobody_answers_fails_with_one_line(capsys, tmp_path) -> None:
    argv = ["worker", "--ping", "--hostname", "nobody@scale-test"]
    argv += ["--broker-url", "redis://127.0.0.1:6379/13"]
    argv += ["--database-url", f"sqlite:///{tmp_path / 'db.sqlite'}"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "worker nobody@scale-test did not answer" in err
