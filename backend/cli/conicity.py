"""`wheelscan conicity --delta-r FILE [--json]`: equivalent conicity of a Δr(y) table.

FILE is a CSV with the header `y_mm,delta_r_mm` (Δr = r_right − r_left [mm], rising with y,
y strictly increasing). The evaluation is EN 15302's nonlinear one
(`pipeline.profile.conicity`); `--json` prints `{"amplitudes_mm": [...], "conicity": [...]}`
on a 0.01 mm amplitude grid over every amplitude the table supports.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path

import numpy as np

from pipeline.profile.conicity import (
    CURVE_AMPLITUDES_MM,
    RollingRadiusDifference,
    conicity_curve,
    equivalent_conicity,
)

HEADER = ("y_mm", "delta_r_mm")


def read_delta_r(path: Path) -> RollingRadiusDifference:
    """The Δr table of a `y_mm,delta_r_mm` CSV file.

    Raises
    ------
    ValueError
        If the header, a number or the ordering is wrong (naming the line).
    OSError
        If the file cannot be read.
    """
    with path.open(newline="", encoding="utf-8") as handle:
        rows = list(csv.reader(handle))
    if not rows or tuple(cell.strip() for cell in rows[0]) != HEADER:
        raise ValueError(f"{path}: the first line must be 'y_mm,delta_r_mm'")
    values = []
    for number, row in enumerate(rows[1:], start=2):
        if not row:
            continue
        try:
            y, d = (float(cell) for cell in row)
        except ValueError:
            raise ValueError(f"{path} line {number}: expected two numbers, got {row}") from None
        values.append((y, d))
    if len(values) < 2:
        raise ValueError(f"{path}: needs at least 2 rows of y_mm,delta_r_mm")
    table = np.array(values)
    try:
        return RollingRadiusDifference(table[:, 0], table[:, 1])
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def _conicity(args: argparse.Namespace) -> int:
    function = read_delta_r(args.delta_r)
    if args.json:
        curve = conicity_curve(function)
        document = {
            "amplitudes_mm": [round(float(a), 2) for a in curve.amplitudes_mm],
            "conicity": [round(float(c), 6) for c in curve.conicity],
        }
        sys.stdout.write(json.dumps(document) + "\n")
        return 0
    values = equivalent_conicity(function, np.array(CURVE_AMPLITUDES_MM))
    sys.stdout.write("amplitude_mm  conicity\n")
    for amplitude, value in zip(CURVE_AMPLITUDES_MM, values, strict=True):
        shown = "not supported" if np.isnan(value) else f"{value:.4f}"
        sys.stdout.write(f"{amplitude:12.2f}  {shown}\n")
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the conicity verb."""
    conicity = subparsers.add_parser(
        "conicity",
        help="equivalent conicity (EN 15302) of a rolling-radius-difference table",
    )
    conicity.add_argument(
        "--delta-r",
        type=Path,
        required=True,
        metavar="FILE",
        help="CSV with header y_mm,delta_r_mm (Δr = r_right − r_left, rising with y)",
    )
    conicity.add_argument(
        "--json",
        action="store_true",
        help='print {"amplitudes_mm": [...], "conicity": [...]} on a 0.01 mm grid',
    )
    conicity.set_defaults(func=_conicity)
