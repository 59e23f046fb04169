"""Make the real frames' files from their sources (PROVENANCE.md): frame, laser mask, medial axis.

    python tests/pipeline/real_frames/derive_truth.py weld FIGURE.png NAME
    python tests/pipeline/real_frames/derive_truth.py colour FRAME.png NAME X0 X1 KINK_ROW [MARGIN]
    python tests/pipeline/real_frames/derive_truth.py dark FRAME.png NAME R0 R1

"weld": a figure of three panels (input, hand-labelled mask, prediction); the input and the
label are cut out at the same place, 2 px inside each panel's border, the label thresholded
at half grey. The medial axis is the label's thinned skeleton, each skeleton pixel moved along
the skeleton's normal to the centroid of the squared smoothed grey above its minimum across
the label (the laser's ridge); skeleton pixels at junctions (no single direction) are left out.

"colour": a colour frame of a red laser crossing two flat faces (a folded board) that meet at
KINK_ROW, cut to columns X0..X1 and converted to grey (ITU-R 601 weights, as cv2.cvtColor).
Per row (the line runs along the columns) the centroid of the red excess over max(green,
blue) above RED_EXCESS, within 6 px of the row's strongest, marks the laser where it is red;
on each face a quadratic x(y) is fitted to those marks (rejecting marks FIT_REJECT_PX off:
other red), so the line is continued where its core saturates to white. The medial axis is
that fit at every row but the MARGIN rows (default MARGIN_ROWS) at the frame's top and bottom;
the laser pixels are those within LASER_HALF_WIDTH_PX of it. The cut
colour frame is written too (NAME.colour.png), for the laser-colour path
(`pipeline.imaging.laser_grey`).

"dark": a grey frame of a thin laser line on a dark background with saturated spots (a weld
seam camera), cut to rows R0..R1. The line's regions are the connected regions of the grey
smoothed by σ 2 px above LINE_LEVEL that are long (major axis over MIN_LINE_LENGTH_PX), thin
(minor axis under MAX_WIDTH_SHARE of the major) and not saturated (under SPOT_SATURATED_SHARE
of their pixels at 250 or more: the spots are saturated ellipses); the laser pixels are the
pixels of those regions at half or more of the local peak (grey smoothed by σ 1 px over a
9 × 9 px window), closed by a 5 × 5 px ellipse to bridge the line's speckle. The medial axis
is made from them as for "weld".

Writes NAME.png (grey), NAME.laser.png (laser pixels, 0/255) and NAME.json (medial points
x, y [px], pixel centres at integers) beside this file.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import cv2
import numpy as np
from scipy.ndimage import map_coordinates, maximum_filter
from scipy.spatial import cKDTree

HERE = Path(__file__).resolve().parent
RED_EXCESS = 50
"""Red above max(green, blue) that marks a red laser pixel (8-bit levels)."""
FIT_REJECT_PX = 3.0
"""Red pixels' row centroids farther than this from the fitted line are not laser [px]."""
MARGIN_ROWS = 30
"""Rows left out at the frame's top and bottom, where the line leaves the board."""
LASER_HALF_WIDTH_PX = 2.5
"""Half the laser line's width in the colour frame [px] (2–5 px wide where it is red)."""
LINE_LEVEL = 35
"""Grey (smoothed by σ 2 px) above which a dark frame's pixel may be the laser's (8-bit)."""
MIN_LINE_LENGTH_PX = 60
"""A bright region shorter than this (4 × the standard deviation along it) is not the line."""
MAX_WIDTH_SHARE = 0.3
"""A bright region wider than this share of its length is a spot, not the line."""
SPOT_SATURATED_SHARE = 0.05
"""A bright region with more than this share of saturated pixels is a spot (a reflection)."""


def _thin(mask: np.ndarray) -> np.ndarray:
    """Zhang–Suen thinning of a boolean mask to a one-pixel skeleton."""
    b = mask.astype(np.uint8)
    while True:
        changed = False
        for step in (0, 1):
            p = np.pad(b, 1)
            # Neighbours P2..P9, clockwise from north.
            n = [p[:-2, 1:-1], p[:-2, 2:], p[1:-1, 2:], p[2:, 2:]]
            n += [p[2:, 1:-1], p[2:, :-2], p[1:-1, :-2], p[:-2, :-2]]
            count = sum(x.astype(int) for x in n)
            ring = [*n, n[0]]
            crossings = sum(((ring[k] == 0) & (ring[k + 1] == 1)).astype(int) for k in range(8))
            if step == 0:
                side = (n[0] * n[2] * n[4] == 0) & (n[2] * n[4] * n[6] == 0)
            else:
                side = (n[0] * n[2] * n[6] == 0) & (n[0] * n[4] * n[6] == 0)
            remove = (b == 1) & (count >= 2) & (count <= 6) & (crossings == 1) & side
            if remove.any():
                b[remove] = 0
                changed = True
        if not changed:
            return b.astype(bool)


def _medial_on_ridge(frame: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Skeleton pixels of `mask` moved across it to the grey ridge of `frame` (x, y) [px]."""
    rows, cols = np.nonzero(_thin(mask))
    skeleton = np.stack([cols, rows], axis=1).astype(float)
    smooth = cv2.GaussianBlur(frame.astype(np.float32), (0, 0), 1.0)
    half_width = cv2.distanceTransform(mask.astype(np.uint8), cv2.DIST_L2, 5)
    tree = cKDTree(skeleton)
    medial = []
    for point in skeleton:
        near = skeleton[tree.query_ball_point(point, 6)]
        if len(near) < 5:
            continue
        spread, axes = np.linalg.eigh(np.cov(near.T))
        if spread[1] < 4 * spread[0]:
            continue  # a junction: no single direction
        normal = np.array([-axes[1, 1], axes[0, 1]])
        reach = max(float(half_width[int(point[1]), int(point[0])]), 3.0)
        s = np.arange(-reach, reach + 1e-9, 0.25)
        xy = point + s[:, None] * normal
        profile = map_coordinates(smooth, [xy[:, 1], xy[:, 0]], order=1)
        weight = (profile - profile.min()) ** 2
        if weight.sum() > 0:
            medial.append(point + normal * (weight * s).sum() / weight.sum())
    return np.asarray(medial)


def weld_panels(figure_path: Path):
    """Grey input panel and boolean label of a three-panel figure, cut at the same place."""
    figure = cv2.imread(str(figure_path), cv2.IMREAD_GRAYSCALE)
    third = figure.shape[1] // 3
    dark = figure[:, third : 2 * third] < 30
    rows = np.flatnonzero(dark.mean(axis=1) > 0.3)
    cols = np.flatnonzero(dark.mean(axis=0) > 0.3)
    r0, r1, c0, c1 = rows[0], rows[-1] + 1, cols[0] + third, cols[-1] + 1 + third
    left = np.flatnonzero((figure[r0:r1, :third] < 245).mean(axis=0) > 0.5)[0]
    frame = figure[r0:r1, left : left + c1 - c0][2:-2, 2:-2]
    label = figure[r0:r1, c0:c1][2:-2, 2:-2] > 127
    return frame, label


def _robust_quadratic(y: np.ndarray, x: np.ndarray) -> np.ndarray:
    """x(y) quadratic fitted to the points within FIT_REJECT_PX of the previous fit."""
    keep = np.ones(len(x), bool)
    for _ in range(5):
        coefficients = np.polyfit(y[keep], x[keep], 2)
        keep = np.abs(x - np.polyval(coefficients, y)) < FIT_REJECT_PX
    return coefficients


def colour_truth(frame_path: Path, x0: int, x1: int, kink_row: int, margin_rows: int = MARGIN_ROWS):
    """Grey frame, laser pixels and medial points of a red laser crossing two flat faces."""
    colour = cv2.imread(str(frame_path))[:, x0:x1]
    grey = cv2.cvtColor(colour, cv2.COLOR_BGR2GRAY)
    blue, green, red = (colour[..., k].astype(int) for k in range(3))
    excess = red - np.maximum(green, blue)
    found = []
    for row in np.flatnonzero((excess > RED_EXCESS).any(axis=1)):
        peak = int(np.argmax(excess[row]))
        window = np.arange(max(peak - 6, 0), min(peak + 7, grey.shape[1]))
        weight = np.clip(excess[row, window] - RED_EXCESS, 0, None).astype(float)
        found.append([(weight * window).sum() / weight.sum(), float(row)])
    x, y = np.asarray(found).T
    rows = np.arange(grey.shape[0], dtype=float)
    medial_x = np.full(len(rows), np.nan)
    for lower, upper in ((margin_rows, kink_row), (kink_row, grey.shape[0] - margin_rows)):
        piece = (y >= lower) & (y < upper)
        inside = (rows >= lower) & (rows < upper)
        medial_x[inside] = np.polyval(_robust_quadratic(y[piece], x[piece]), rows[inside])
    cols = np.arange(grey.shape[1])[None, :]
    laser = np.abs(cols - medial_x[:, None]) <= LASER_HALF_WIDTH_PX
    keep = ~np.isnan(medial_x)
    return colour, grey, laser, np.stack([medial_x[keep], rows[keep]], axis=1)


def dark_line_truth(frame_path: Path, r0: int, r1: int):
    """Grey frame cut to rows r0..r1 and the pixels of its thin laser line (dark background)."""
    frame = cv2.imread(str(frame_path), cv2.IMREAD_GRAYSCALE)[r0:r1]
    smooth = cv2.GaussianBlur(frame.astype(np.float32), (0, 0), 2.0)
    count, labels = cv2.connectedComponents((smooth > LINE_LEVEL).astype(np.uint8), connectivity=8)
    line = np.zeros(frame.shape, bool)
    for k in range(1, count):
        region = labels == k
        rows, cols = np.nonzero(region)
        if len(rows) < 30:
            continue
        minor, major = 4 * np.sqrt(np.linalg.eigvalsh(np.cov(np.stack([cols, rows]))))
        spot = (frame[region] >= 250).mean() > SPOT_SATURATED_SHARE
        if major > MIN_LINE_LENGTH_PX and minor < MAX_WIDTH_SHARE * major and not spot:
            line |= region
    fine = cv2.GaussianBlur(frame.astype(np.float32), (0, 0), 1.0)
    laser = (line & (fine >= 0.5 * maximum_filter(fine, 9))).astype(np.uint8)
    bridge = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (5, 5))
    laser = cv2.morphologyEx(laser, cv2.MORPH_CLOSE, bridge)
    return frame, laser.astype(bool) & line


def write(name: str, frame: np.ndarray, laser: np.ndarray, medial: np.ndarray) -> None:
    """Write NAME.png, NAME.laser.png and NAME.json beside this file."""
    cv2.imwrite(str(HERE / f"{name}.png"), frame)
    cv2.imwrite(str(HERE / f"{name}.laser.png"), laser.astype(np.uint8) * 255)
    truth = {"shape": list(frame.shape), "medial_xy": np.round(medial, 2).tolist()}
    (HERE / f"{name}.json").write_text(json.dumps(truth, separators=(",", ":")) + "\n")


def main(argv: list[str]) -> None:
    kind, source, name = argv[:3]
    if kind == "weld":
        frame, laser = weld_panels(Path(source))
        write(name, frame, laser, _medial_on_ridge(frame, laser))
    elif kind == "dark":
        frame, laser = dark_line_truth(Path(source), int(argv[3]), int(argv[4]))
        write(name, frame, laser, _medial_on_ridge(frame, laser))
    else:
        x0, x1, kink_row, *margin = (int(a) for a in argv[3:7])
        colour, *truth = colour_truth(Path(source), x0, x1, kink_row, *margin)
        cv2.imwrite(str(HERE / f"{name}.colour.png"), colour)
        write(name, *truth)


if __name__ == "__main__":
    main(sys.argv[1:])
