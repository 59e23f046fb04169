"""Throw-away databases and servers for tests: a SQLite file, a fresh PostgreSQL database,
and private PostgreSQL and Redis servers.

All are real (docs/style.md §7). PostgreSQL databases are made on the local server
(127.0.0.1:5432, trust auth; `WHEELSCAN_TEST_POSTGRES_PORT` names another port) for one
test session and dropped afterwards. When no server answers there, the tests start one of
their own (a temporary data directory, a free port, stopped when the tests end), after
installing the Debian package when its binaries are missing; a server the machine runs is
never started, stopped or restarted by a test.
"""

from __future__ import annotations

import atexit
import glob
import os
import secrets
import shutil
import socket
import subprocess
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import psycopg

POSTGRES_HOST = "127.0.0.1"
MACHINE_POSTGRES_PORT = int(os.environ.get("WHEELSCAN_TEST_POSTGRES_PORT", "5432"))
BACKENDS = ("sqlite", "postgresql")


def free_port() -> int:
    """A TCP port free on the loopback interface now."""
    with socket.socket() as probe:
        probe.bind((POSTGRES_HOST, 0))
        return probe.getsockname()[1]


def install_debian_packages(*packages: str) -> None:
    """apt-get install `packages` that are not installed (as root, or through sudo)."""
    missing = [
        name
        for name in packages
        if subprocess.run(["dpkg", "-s", name], capture_output=True, check=False).returncode
    ]
    if not missing:
        return
    sudo = [] if os.geteuid() == 0 else ["sudo", "-n"]
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    for command in (["update", "-qq"], ["install", "-y", "-qq", *missing]):
        subprocess.run([*sudo, "apt-get", *command], check=True, env=env, capture_output=True)


def _postgres_bin(name: str) -> str:
    found = sorted(glob.glob(f"/usr/lib/postgresql/*/bin/{name}"))
    if not found:
        install_debian_packages("postgresql")
        found = sorted(glob.glob(f"/usr/lib/postgresql/*/bin/{name}"))
    if not found:
        raise FileNotFoundError(f"no {name} in /usr/lib/postgresql/*/bin after installing")
    return found[-1]


class PostgresServer:
    """A PostgreSQL server of the tests' own: initdb in a temporary folder, a free port,
    trust authentication for `postgres`. As root, it runs as the `postgres` user."""

    def __init__(self) -> None:
        self.port = free_port()
        self.folder = Path(tempfile.mkdtemp(prefix="wheelscan-pg-"))
        self.data = self.folder / "data"
        self._as_user = ["runuser", "-u", "postgres", "--"] if os.geteuid() == 0 else []
        if self._as_user:
            shutil.chown(self.folder, "postgres", "postgres")
        self._run(_postgres_bin("initdb"), "-D", str(self.data), "-U", "postgres",
                  "--auth=trust", "--no-sync", "-E", "UTF8")  # fmt: skip

    def _run(self, *command: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [*self._as_user, *command], capture_output=True, text=True, check=True, timeout=120
        )

    def _ctl(self, action: str) -> None:
        options = f"-p {self.port} -k {self.folder} -c listen_addresses={POSTGRES_HOST}"
        options += " -c fsync=off"  # a throw-away server: durability is not tested here
        self._run(_postgres_bin("pg_ctl"), "-D", str(self.data), "-l",
                  str(self.folder / "server.log"), "-o", options, "-w", action)  # fmt: skip

    def start(self) -> None:
        self._ctl("start")

    def restart(self) -> None:
        self._ctl("restart")

    def stop(self) -> None:
        if (self.data / "postmaster.pid").exists():
            self._run(_postgres_bin("pg_ctl"), "-D", str(self.data), "-m", "fast", "-w", "stop")

    def remove(self) -> None:
        self.stop()
        shutil.rmtree(self.folder, ignore_errors=True)

    @property
    def running(self) -> bool:
        return _answers(self.port)


def _answers(port: int) -> bool:
    try:
        with psycopg.connect(_admin_dsn(port), connect_timeout=3):
            return True
    except psycopg.OperationalError:
        return False


def _admin_dsn(port: int) -> str:
    return f"host={POSTGRES_HOST} port={port} user=postgres dbname=postgres"


_own_server: PostgresServer | None = None


def postgres_port() -> int:
    """The port of a PostgreSQL server for test databases: the machine's when it answers,
    else one of the tests' own (started once, removed at exit)."""
    global _own_server
    if _answers(MACHINE_POSTGRES_PORT):
        return MACHINE_POSTGRES_PORT
    if _own_server is None:
        _own_server = PostgresServer()
        _own_server.start()
        atexit.register(_own_server.remove)
    return _own_server.port


@contextmanager
def throwaway_database(backend: str, tmp_dir: Path, port: int | None = None) -> Iterator[str]:
    """Yield the URL of an empty database of `backend`, removed on exit (PostgreSQL: on
    the server at `port`, by default the one `postgres_port` finds)."""
    if backend == "sqlite":
        yield f"sqlite:///{tmp_dir / 'wheelscan-test.db'}"
        return
    port = port or postgres_port()
    name = f"wheelscan_test_{secrets.token_hex(6)}"
    with psycopg.connect(_admin_dsn(port), autocommit=True, connect_timeout=5) as admin:
        admin.execute(f'CREATE DATABASE "{name}"')
    try:
        yield f"postgresql+psycopg://postgres@{POSTGRES_HOST}:{port}/{name}"
    finally:
        with psycopg.connect(_admin_dsn(port), autocommit=True, connect_timeout=5) as admin:
            admin.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')


def redis_server_binary() -> str:
    """redis-server, installed from Debian when missing."""
    found = shutil.which("redis-server")
    if found is None:
        install_debian_packages("redis-server")
        found = shutil.which("redis-server")
    if found is None:
        raise FileNotFoundError("redis-server is not on PATH after installing redis-server")
    return found
