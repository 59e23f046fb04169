"""Shared helpers of the capture-agent tests: small pass archives and emulated cameras."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pytest

from pipeline.archive.manifest import PassManifest, WheelEntry
from pipeline.archive.pass_archive import write_pass_archive


@pytest.fixture
def emulated_cameras(monkeypatch: pytest.MonkeyPatch) -> int:
    """Four pylon emulated cameras (pylon reads PYLON_CAMEMU at each enumeration)."""
    monkeypatch.setenv("PYLON_CAMEMU", "4")
    return 4


def make_archive(
    out: Path,
    *,
    vehicles: tuple[str, ...] = ("80-01", "80-02"),
    axles: int = 2,
    frames_per_wheel: int = 2,
    dtype: type = np.uint8,
    size_px: tuple[int, int] = (48, 64),
    seed: int = 0,
) -> tuple[Path, dict[str, np.ndarray]]:
    """A small pass archive of random frames (the agent never measures them).

    Returns the archive folder and its frames by archive path.
    """
    rng = np.random.default_rng(seed)
    top = 256 if dtype == np.uint8 else 4096
    wheels, frames = [], {}
    for vehicle in vehicles:
        for axle in range(1, axles + 1):
            for side in ("left", "right"):
                paths = {}
                for position in ("inner", "outer"):
                    sensor = f"{side}_{position}"
                    paths[position] = tuple(
                        f"frames/{sensor}/{vehicle}-{axle}-{k}.png" for k in range(frames_per_wheel)
                    )
                    for path in paths[position]:
                        frames[path] = rng.integers(0, top, size_px).astype(dtype)
                wheels.append(WheelEntry(vehicle, axle, side, paths["inner"], paths["outer"]))
    manifest = PassManifest(
        site="test-site",
        started_at=datetime(2026, 11, 23, 22, 0, tzinfo=UTC),
        direction="up",
        speed_kmh=20.0,
        vehicles=vehicles,
        wheels=tuple(wheels),
    )
    return write_pass_archive(out, manifest, frames), frames
