"""docker-compose.yml and the Dockerfile: valid for Compose, scalable, and every command
they run is a real `wheelscan` verb. (No Docker engine runs here; the same topology is
exercised with local processes in test_celery_workers.py.)"""

from __future__ import annotations

import shlex
import shutil
import subprocess
from pathlib import Path

import pytest
import yaml

from backend.cli import build_parser

ROOT = Path(__file__).resolve().parents[2]
COMPOSE_FILE = ROOT / "docker-compose.yml"
LONG_RUNNING = ("postgres", "redis", "api", "worker", "remote-worker")


def compose_command() -> list[str]:
    """`docker compose` (plugin) or `docker-compose` (standalone), whichever is installed."""
    docker = shutil.which("docker")
    if docker is not None:
        probe = subprocess.run([docker, "compose", "version"], capture_output=True, check=False)
        if probe.returncode == 0:
            return [docker, "compose"]
    standalone = shutil.which("docker-compose")
    if standalone is not None:
        return [standalone]
    pytest.skip(
        "NO DOCKER COMPOSE CLIENT: neither `docker compose` nor `docker-compose` is installed "
        "(the Makefile's DEBIAN_PACKAGES installs docker-compose); docker-compose.yml unchecked"
    )


@pytest.fixture(scope="module")
def compose() -> dict:
    return yaml.safe_load(COMPOSE_FILE.read_text())


def test_compose_accepts_the_file_with_and_without_the_remote_profile() -> None:
    command = [*compose_command(), "-f", str(COMPOSE_FILE)]
    for profile in ([], ["--profile", "remote"]):
        result = subprocess.run(
            [*command, *profile, "config", "--services"],
            capture_output=True,
            text=True,
            check=False,
            cwd=ROOT,
        )
        assert result.returncode == 0, result.stderr
        services = set(result.stdout.split())
        # docker-compose 1.x lists profiled services either way; the plugin only with it.
        assert {"postgres", "redis", "migrate", "api", "worker"} <= services
        assert "remote-worker" in services or not profile


def test_workers_can_be_scaled(compose: dict) -> None:
    worker = compose["services"]["worker"]
    assert "container_name" not in worker and "ports" not in worker


def test_every_long_running_service_has_a_health_check(compose: dict) -> None:
    for name in LONG_RUNNING:
        assert "healthcheck" in compose["services"][name], name


def test_api_and_workers_share_the_frame_store_and_wait_for_the_migration(compose: dict) -> None:
    services = compose["services"]
    for name in ("api", "worker"):
        assert "frames:/data" in services[name]["volumes"], name
        depends = services[name]["depends_on"]
        assert depends["migrate"]["condition"] == "service_completed_successfully", name
        assert depends["redis"]["condition"] == "service_healthy", name
        assert services[name]["environment"]["WHEELSCAN_BROKER_URL"].startswith("redis://")
    assert services["migrate"]["depends_on"]["postgres"]["condition"] == "service_healthy"


def test_the_broker_keeps_queued_wheels_across_a_restart(compose: dict) -> None:
    command = compose["services"]["redis"]["command"]
    assert command[command.index("--appendonly") + 1] == "yes"


def test_every_command_the_deployment_runs_is_a_wheelscan_verb(compose: dict) -> None:
    dockerfile = (ROOT / "Dockerfile").read_text()
    cmd_line = next(line for line in dockerfile.splitlines() if line.startswith("CMD "))
    commands = [yaml.safe_load(cmd_line.removeprefix("CMD "))]
    for service in compose["services"].values():
        commands += [service.get("command", [])]
        test = service.get("healthcheck", {}).get("test", [])
        if test[:2] == ["CMD", "wheelscan"]:
            commands.append(test[1:])
    wheelscan_commands = [c for c in commands if c and c[0] == "wheelscan"]
    assert len(wheelscan_commands) >= 6
    parser = build_parser()
    for command in wheelscan_commands:
        try:
            parser.parse_args(command[1:])
        except SystemExit:
            pytest.fail(f"not a valid wheelscan command: {shlex.join(command)}")
