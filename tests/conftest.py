"""Fixtures more than one test package uses: the simulated passes the service, fault and
scale-out tests upload, each simulated once a session (about a second of CPU a wheel)."""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path

import pytest

from pipeline.simulation.passes import write_synthetic_passes

SIMULATED_SEED = 8


@pytest.fixture(scope="session")
def simulated_pass(tmp_path_factory: pytest.TempPathFactory) -> Callable[[Path, int], Path]:
    """simulated_pass(out, axles) → `out`, a copy of the simulated clean pass (seed 7) of
    one vehicle with `axles` axles: one 1600×1200 frame per sensor, with its truth.json.
    Each shape is simulated on first use and copied for every caller, who may change its
    copy."""
    made: dict[int, Path] = {}

    def copy(out: Path, axles: int) -> Path:
        if axles not in made:
            folder = tmp_path_factory.mktemp(f"simulated-{axles}-axle") / "pass"
            (made[axles],) = write_synthetic_passes(
                folder, vehicles=1, seed=SIMULATED_SEED, axles_per_vehicle=axles
            )
        shutil.copytree(made[axles], out)
        return out

    return copy
