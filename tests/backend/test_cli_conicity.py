"""`wheelscan conicity --delta-r FILE --json` as a user runs it."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np


def run_conicity(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "backend.cli", "conicity", *args],
        capture_output=True,
        text=True,
        check=False,
    )


def test_json_curve_of_a_two_slope_table(tmp_path: Path) -> None:
    # Δr = 0.2·y within ±2 mm, slope 0.8 beyond, tabulated over −6…8 mm.
    y = np.array([-6.0, -2.0, 2.0, 8.0])
    d = np.where(np.abs(y) <= 2, 0.2 * y, np.sign(y) * (0.4 + 0.8 * (np.abs(y) - 2)))
    path = tmp_path / "dr.csv"
    path.write_text("y_mm,delta_r_mm\n" + "".join(f"{a},{b}\n" for a, b in zip(y, d, strict=True)))
    result = run_conicity("--delta-r", str(path), "--json")
    assert result.returncode == 0, result.stderr
    document = json.loads(result.stdout)
    amplitudes, conicity = document["amplitudes_mm"], document["conicity"]
    assert amplitudes[0] == 0.01 and len(amplitudes) == len(conicity)
    assert amplitudes[-1] == 6.0  # the swing about y = 0 reaches the table's end at −6
    assert conicity[amplitudes.index(1.5)] == 0.1  # inside the knee: λ = 0.2 / 2
    assert conicity[amplitudes.index(3.0)] > 0.1


def test_bad_file_is_one_line_error(tmp_path: Path) -> None:
    path = tmp_path / "dr.csv"
    path.write_text("y_mm,delta_r_mm\n0,1\nzero,2\n")
    result = run_conicity("--delta-r", str(path), "--json")
    assert result.returncode == 2
    assert "line 3: expected two numbers" in result.stderr
    assert "Traceback" not in result.stderr
