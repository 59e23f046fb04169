"""Service configuration and verbs: flags beat WHEELSCAN_* variables, which beat defaults."""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

from fastapi.testclient import TestClient

from backend.api.app import create_app
from backend.config import Settings, add_settings_arguments, settings_from_args


def run_cli(*args: str, env: dict | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "backend.cli", *args],
        capture_output=True,
        text=True,
        check=False,
        env=env,
    )


def parse(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    add_settings_arguments(parser)
    return parser.parse_args(argv)


def test_a_flag_beats_the_environment_which_beats_the_default(monkeypatch, tmp_path) -> None:
    assert Settings().data_dir == Path("data")
    monkeypatch.setenv("WHEELSCAN_DATA_DIR", str(tmp_path / "env"))
    monkeypatch.setenv("WHEELSCAN_WORKERS", "3")
    assert settings_from_args(parse()).data_dir == tmp_path / "env"
    chosen = settings_from_args(parse("--data", str(tmp_path / "flag")))
    assert chosen.data_dir == tmp_path / "flag" and chosen.workers == 3
    assert chosen.resolved_database_url.endswith("/flag/wheelscan.db")


def test_serve_help_lists_host_port_and_data() -> None:
    result = run_cli("serve", "--help")
    assert result.returncode == 0
    assert all(flag in result.stdout for flag in ("--host", "--port", "--data"))


def test_token_create_prints_a_token_the_service_accepts(tmp_path) -> None:
    result = run_cli("token", "create", "--role", "admin", "--data", str(tmp_path))
    assert result.returncode == 0, result.stderr
    token = result.stdout.strip()
    with TestClient(create_app(Settings(data_dir=tmp_path, workers=1))) as client:
        me = client.get("/api/me", headers={"Authorization": f"Bearer {token}"})
    assert me.json()["role"] == "admin"


def test_token_create_refuses_a_non_positive_lifetime_in_one_line(tmp_path) -> None:
    result = run_cli("token", "create", "--role", "viewer", "--days", "0", "--data", str(tmp_path))
    assert result.returncode == 2
    assert result.stderr == "wheelscan token: error: --days must be > 0, got 0.0\n"
