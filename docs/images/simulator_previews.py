"""Render the simulator previews of docs/simulator.md: each sensor's frame, clean beside field.

Run from the repository root: `python docs/images/simulator_previews.py`. One wheelset of
the same seeded train, the same pass draws (pose, lighting, noise), rendered in clean mode
and with every field effect; each PNG shows one sensor, clean on the left, harsh on the
right, at half size.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from pipeline.calibration.model import SENSOR_NAMES
from pipeline.simulation.field import FIELD_MODES
from pipeline.simulation.passes import build_train, pass_start_time, simulate_pass
from pipeline.simulation.station import build_station

SEED = 2027
PASS_SEED = 11
OUT = Path(__file__).resolve().parent
HALF_SIZE = (800, 600)


def main() -> None:
    """Write docs/images/preview-<sensor>.png for the four sensors."""
    station = build_station()
    train = build_train(1, np.random.default_rng(SEED), axles_per_vehicle=1)
    frames = {
        mode: simulate_pass(
            train,
            station,
            np.random.default_rng(PASS_SEED),
            started_at=pass_start_time(0),
            field=FIELD_MODES[mode],
        ).frames
        for mode in ("clean", "harsh")
    }
    for name in SENSOR_NAMES:
        path = f"frames/{name}/000001.png"
        halves = [cv2.resize(frames[m][path], HALF_SIZE, cv2.INTER_AREA) for m in frames]
        gap = np.full((HALF_SIZE[1], 8), 255, np.uint8)
        cv2.imwrite(str(OUT / f"preview-{name}.png"), np.hstack([halves[0], gap, halves[1]]))


if __name__ == "__main__":
    main()
