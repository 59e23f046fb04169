"""`wheelscan synth-pass` and `wheelscan measure` as a user runs them."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from backend.cli import main


@pytest.fixture(scope="module")
def sim_pass(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("cli") / "pass"
    assert main(["synth-pass", str(out), "--axles", "1", "--seed", "2", "--field", "clean"]) == 0
    return out


def test_measure_writes_one_row_per_wheel_and_method(sim_pass: Path, tmp_path: Path) -> None:
    out = tmp_path / "m.json"
    assert main(["measure", str(sim_pass), "--method", "both", "--json", str(out)]) == 0
    document = json.loads(out.read_text())
    rows = document["wheels"]
    assert [(r["side"], r["method"]) for r in rows] == [
        ("left", "adaptive"),
        ("left", "steger"),
        ("right", "adaptive"),
        ("right", "steger"),
    ]
    truth = json.loads((sim_pass / "truth.json").read_text())["wheels"]
    for row in rows:
        assert row["status"] == "measured"
        expected = next(t for t in truth if t["side"] == row["side"])
        assert row["flange_thickness_mm"] == pytest.approx(expected["flange_thickness_mm"], abs=0.1)
        assert set(row["quality"]) >= {"points_inner", "points_outer", "overlap_residual_mm"}


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["measure", "/nonexistent/pass", "--json", "-"], "neither a folder nor a file"),
        (
            ["measure", "{pass}", "--json", "-", "--calibration", "/none.json"],
            "cannot read calibration",
        ),
    ],
)
def test_bad_input_is_one_line_and_exit_2(sim_pass: Path, capsys, args, message: str) -> None:
    args = [a.replace("{pass}", str(sim_pass)) for a in args]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0] and "Traceback" not in err[0]


def test_broken_manifest_is_one_line(tmp_path: Path, capsys) -> None:
    (tmp_path / "manifest.json").write_text("[]")
    assert main(["measure", str(tmp_path), "--json", "-"]) == 2
    assert "manifest must be a JSON object" in capsys.readouterr().err


def test_rr_reports_both_methods_against_truth(tmp_path: Path) -> None:
    out = tmp_path / "rr"
    synth = ["synth-pass", str(out), "--axles", "1", "--repeat", "2", "--seed", "9"]
    assert main([*synth, "--field", "clean"]) == 0
    report = tmp_path / "rr.json"
    passes = [str(out / "pass-001"), str(out / "pass-002")]
    methods = "adaptive,steger,steger+curvature+asymmetry"
    assert main(["rr", *passes, "--method", methods, "--json", str(report)]) == 0
    document = json.loads(report.read_text())
    pooled = {(r["method"], r["parameter"]): r for r in document["pooled"]}
    assert set(pooled) >= {
        ("adaptive", "flange_height_mm"),
        ("steger", "flange_thickness_mm"),
        ("steger+curvature+asymmetry", "flange_height_mm"),
    }
    sh = pooled[("adaptive", "flange_height_mm")]
    # All 4 wheel-passes, pass 2's left wheel with its dim flange tip beside specular spots.
    assert sh["passes"] == 4 and sh["mae_mm"] < 0.1
    assert pooled[("adaptive", "back_to_back_mm")]["max_error_mm"] < 0.2


def test_rr_without_truth_is_one_line(sim_pass: Path, tmp_path: Path, capsys) -> None:
    bare = tmp_path / "bare"
    bare.mkdir()
    for path in sim_pass.rglob("*"):
        if path.is_file() and path.name != "truth.json":
            target = bare / path.relative_to(sim_pass)
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(path.read_bytes())
    assert main(["rr", str(bare), "--json", "-"]) == 2
    assert "truth.json" in capsys.readouterr().err
