"""`wheelscan extract` as a user runs it: CSV out, JSON summary, folders, one-line errors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest


def run_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "backend.cli", "extract", *args],
        capture_output=True,
        text=True,
        check=False,
    )


def stripe_png(path: Path, *, dtype=np.uint8, shape=(60, 90)) -> Path:
    rows = np.arange(float(shape[0]))[:, None] * np.ones((1, shape[1]))
    grey = 12 + 170 * np.exp(-8 * (rows - 30.4) ** 2 / 9**2)
    scale = 257 if dtype == np.uint16 else 1
    cv2.imwrite(str(path), np.rint(grey * scale).astype(dtype))
    return path


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_csv_has_the_contract_header_and_sub_pixel_rows(tmp_path: Path, dtype) -> None:
    image = stripe_png(tmp_path / "frame.png", dtype=dtype)
    out = tmp_path / "centres.csv"
    result = run_cli(str(image), "-o", str(out))
    assert result.returncode == 0, result.stderr
    lines = out.read_text().splitlines()
    assert lines[0] == "x,y,nx,ny,sigma,strength"
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    assert len(table) > 40
    np.testing.assert_allclose(table[:, 1], 30.4, atol=0.05)


def test_json_summary_and_steger_sigma(tmp_path: Path) -> None:
    image = stripe_png(tmp_path / "frame.png")
    out = tmp_path / "centres.csv"
    result = run_cli(str(image), "--method", "steger", "--sigma", "3", "-o", str(out), "--json")
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    assert summary["method"] == "steger"
    assert summary["sigmas_px"] == [3.0]
    assert summary["points"] > 40


def test_the_summary_says_which_path_the_frame_took(tmp_path: Path) -> None:
    image = stripe_png(tmp_path / "frame.png", shape=(240, 320))  # a band smaller than the frame
    band = run_cli(str(image), "-o", str(tmp_path / "band.csv"), "--json")
    full = run_cli(str(image), "-o", str(tmp_path / "full.csv"), "--json", "--full-frame")
    assert band.returncode == full.returncode == 0, band.stderr + full.stderr
    assert json.loads(band.stdout)["path"] == "band"
    assert json.loads(full.stdout)["path"] == "full"
    band_rows, full_rows = (
        np.loadtxt(tmp_path / f"{n}.csv", delimiter=",", skiprows=1) for n in ("band", "full")
    )
    np.testing.assert_allclose(band_rows, full_rows, atol=1e-4)


def test_folder_of_frames_writes_one_csv_each(tmp_path: Path) -> None:
    frames = tmp_path / "frames"
    frames.mkdir()
    for name in ("a.png", "b.png"):
        stripe_png(frames / name)
    out = tmp_path / "out"
    result = run_cli(str(frames), "-o", str(out), "--json")
    assert result.returncode == 0, result.stderr
    assert sorted(p.name for p in out.iterdir()) == ["a.csv", "b.csv"]
    assert len(json.loads(result.stdout)["frames"]) == 2


def test_a_colour_frame_is_taken_by_its_lasers_colour(tmp_path: Path) -> None:
    """A red line on white paper with grey print: only the line is found, at its true row."""
    cols = np.arange(120.0)
    rows = np.arange(80.0)[:, None]
    red = 170 * np.exp(-8 * (rows - 40.3) ** 2 / 7**2) * np.ones_like(cols)
    paper = np.full((80, 120), 150.0)
    paper[20:24, :] = 240.0  # a white printed rule, brighter than the line in grey
    rgb = np.stack([paper + red * 0.6, paper - red * 0.3, paper - red * 0.3], axis=-1)
    bgr = np.rint(np.clip(rgb, 0, 254))[..., ::-1].astype(np.uint8)
    cv2.imwrite(str(tmp_path / "colour.png"), bgr)
    out = tmp_path / "centres.csv"
    result = run_cli(str(tmp_path / "colour.png"), "--laser", "red", "-o", str(out))
    assert result.returncode == 0, result.stderr
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    assert len(table) > 60
    np.testing.assert_allclose(table[:, 1], 40.3, atol=0.1)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["missing.png"], "no such image file"),
        (["notimage.png"], "cannot read"),
        (["frame.png", "--width-min", "30"], "width_min must be ≤ width_max"),
        (["frame.png", "--width-min", "-2"], "width_min must be a positive number"),
        (["colour.png"], "colour frame: give the laser's colour with --laser"),
        (["empty"], "holds no image files"),
    ],
)
def test_errors_are_one_line_without_traceback(tmp_path: Path, args, message) -> None:
    stripe_png(tmp_path / "frame.png")
    (tmp_path / "notimage.png").write_text("not a png")
    cv2.imwrite(str(tmp_path / "colour.png"), np.zeros((20, 20, 3), np.uint8))
    (tmp_path / "empty").mkdir()
    name, *options = args
    result = run_cli(str(tmp_path / name), *options, "-o", str(tmp_path / "o.csv"))
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    assert message in result.stderr
