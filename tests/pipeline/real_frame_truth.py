"""Real laser frames with hand-checked truth (real_frames/, PROVENANCE.md) and their score.

Each frame comes with the pixels its laser lights (NAME.laser.png) and the laser line's medial
axis (NAME.json, points x, y [px]). The issue-15 figures: coverage, the share of medial points
with a centre within COVER_DISTANCE_PX, and the on-line share, the share of centres within
ON_LINE_DISTANCE_PX of a laser pixel.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from scipy.spatial import cKDTree

from tests.pipeline.stripe_scores import COVER_DISTANCE_PX, FALSE_DISTANCE_PX

REAL_FRAMES_DIR = Path(__file__).resolve().parent / "real_frames"
ON_LINE_DISTANCE_PX = FALSE_DISTANCE_PX
REAL_FRAME_NAMES = (
    "weld-1",
    "weld-2",
    "weld-5",
    "weld-8",
    "weld-9",
    "charuco-red",
    "weld-track",
    "charuco-webcam",
    "charuco-dim",
)
COLOUR_FRAMES = {"charuco-red": "red", "charuco-webcam": "red", "charuco-dim": "red"}
"""Frames also kept in colour (NAME.colour.png) and the colour of their laser."""
COLOUR_WIDTHS_PX = dict.fromkeys(COLOUR_FRAMES, (3.0, 21.0))
"""The stripe width range (width_min, width_max) [px] a station would configure for each
colour frame taken by its laser's colour: its line is 2–5 px wide, thinner than the default
width_min of 5 px, so the scale set is extended downward to 3 px (σ1 = 1.73 px)."""


@dataclass(frozen=True, eq=False)
class RealFrame:
    """A grey 8-bit frame, its laser pixels (bool) and its medial points (K, 2) [px]; `colour`
    the RGB frame where one is kept (COLOUR_FRAMES), else None."""

    name: str
    image: np.ndarray
    laser_mask: np.ndarray
    medial_xy: np.ndarray
    colour: np.ndarray | None = None


@dataclass(frozen=True)
class RealScore:
    """Centres found, the on-line share [%] and the coverage of the medial axis [%]."""

    points: int
    on_line_pct: float
    coverage_pct: float


def load_real_frame(name: str) -> RealFrame:
    """Read NAME.png, NAME.laser.png and NAME.json (and NAME.colour.png) from real_frames/."""
    image = cv2.imread(str(REAL_FRAMES_DIR / f"{name}.png"), cv2.IMREAD_GRAYSCALE)
    laser = cv2.imread(str(REAL_FRAMES_DIR / f"{name}.laser.png"), cv2.IMREAD_GRAYSCALE) > 0
    truth = json.loads((REAL_FRAMES_DIR / f"{name}.json").read_text())
    colour = None
    if name in COLOUR_FRAMES:
        bgr = cv2.imread(str(REAL_FRAMES_DIR / f"{name}.colour.png"), cv2.IMREAD_COLOR)
        colour = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
    return RealFrame(name, image, laser, np.asarray(truth["medial_xy"], float), colour)


def score_real_frame(frame: RealFrame, x: np.ndarray, y: np.ndarray) -> RealScore:
    """On-line share of the centres (x, y) and coverage of the frame's medial axis."""
    outside = (~frame.laser_mask).astype(np.uint8)
    to_laser = cv2.distanceTransform(outside, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    rows, cols = frame.image.shape
    r = np.clip(np.rint(y).astype(int), 0, rows - 1)
    c = np.clip(np.rint(x).astype(int), 0, cols - 1)
    on_line = to_laser[r, c] <= ON_LINE_DISTANCE_PX
    covered = np.zeros(len(frame.medial_xy), bool)
    if len(x):
        nearest = cKDTree(np.stack([x, y], axis=1)).query(frame.medial_xy)[0]
        covered = nearest <= COVER_DISTANCE_PX
    return RealScore(
        points=int(len(x)),
        on_line_pct=float(100 * on_line.mean()) if len(x) else 0.0,
        coverage_pct=float(100 * covered.mean()),
    )
