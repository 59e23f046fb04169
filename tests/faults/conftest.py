"""Fixtures of the fault tests: simulated pass archives and real servers to kill."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from tests.faults.live import LiveServer
from tests.scale.topology import zip_pass_folder


@pytest.fixture(scope="session")
def axle_archive(
    tmp_path_factory: pytest.TempPathFactory, simulated_pass: Callable[[Path, int], Path]
) -> bytes:
    """One simulated axle: 2 wheels, one 1600×1200 frame per sensor (about 3.4 MB)."""
    folder = tmp_path_factory.mktemp("axle")
    return zip_pass_folder(simulated_pass(folder / "pass", 1), folder / "pass.zip")


@pytest.fixture(scope="session")
def vehicle_archive(
    tmp_path_factory: pytest.TempPathFactory, simulated_pass: Callable[[Path, int], Path]
) -> bytes:
    """One simulated two-axle vehicle: 4 wheels (measured for a few seconds each)."""
    folder = tmp_path_factory.mktemp("vehicle")
    return zip_pass_folder(simulated_pass(folder / "pass", 2), folder / "pass.zip")


@pytest.fixture
def make_server(tmp_path: Path) -> Iterator[Callable[..., LiveServer]]:
    """make_server(**options) → a started LiveServer, ended (with its workers) afterwards."""
    made: list[LiveServer] = []

    def make(data_dir: Path | None = None, **options: object) -> LiveServer:
        server = LiveServer(data_dir or tmp_path / f"data-{len(made)}", **options)  # type: ignore[arg-type]
        made.append(server)
        server.start()
        return server

    yield make
    for server in made:
        server.close()
