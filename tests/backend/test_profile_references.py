"""Profiles out (CSV, DXF, .whl) and handheld references in, with the wayside-against-
handheld comparison per wheel and over wheels (Table 2 form), through the API and the CLI.

The handheld files are the wheel's reference table (LMA or S1002) sampled every 0.5 mm of
contour, field side first and 0.3 mm off in z, as a MiniProf writes them; their parameters
are known from the table itself.
"""

from __future__ import annotations

import csv
import io
import json
import subprocess
import sys

import ezdxf
import numpy as np
import pytest

from backend.cli import main as cli
from pipeline.profile.exchange import parse_profile_file
from pipeline.profile.flange import curve_flange_parameters
from pipeline.profile.outline import outline_points
from pipeline.version import PIPELINE_VERSION
from tests.backend.pdf_checks import overlapping_words, pdf_pages, pdf_text
from tests.backend.test_measurement_e2e import client, measured, simulated, tokens
from tests.pipeline.test_profile_exchange import contour_samples, gauge_file

__all__ = ["client", "measured", "simulated", "tokens"]  # the shared measured pass
HEADER = "ProgramName=MiniProf\nDate=2026-11-22\nTime=14:05:00\nSd=32.95\nSh=28.01\nqR=9.70\n"


def first_wheel(client, auth, pass_id: int) -> dict:
    return client.get(f"/api/passes/{pass_id}/wheels", headers=auth("viewer")).json()[0]


def handheld_file(reference_profile: str) -> bytes:
    x, z = contour_samples(reference_profile, 0.5)
    return gauge_file(x, z, reverse=True, z_offset_mm=0.3, header=HEADER).encode()


def stored_profile(client, auth, pass_id: int, wheel_id: int, method: str) -> dict:
    path = f"/api/passes/{pass_id}/wheels/{wheel_id}/profile"
    return client.get(path, params={"method": method}, headers=auth("viewer")).json()


@pytest.mark.parametrize("method", ["adaptive", "steger"])
def test_exports_read_back_within_a_micrometre(client, auth, measured, method) -> None:
    pass_id = measured["pass_id"]
    wheel = first_wheel(client, auth, pass_id)
    profile = stored_profile(client, auth, pass_id, wheel["wheel_id"], method)
    # the files hold the outline the API serves (one trace; its gaps are joined)
    outline = np.array([profile["outline_x_mm"], profile["outline_z_mm"]], dtype=float)
    x, z = outline[:, np.isfinite(outline[0])]
    assert np.array_equal(outline.T, outline_points(profile["x_mm"], profile["z_mm"]), True)
    assert 0 < x.size < len(profile["x_mm"])
    base = f"/api/passes/{pass_id}/wheels/{wheel['wheel_id']}/profile"
    files = {}
    for fmt in ("csv", "dxf", "whl"):
        response = client.get(f"{base}.{fmt}", params={"method": method}, headers=auth("viewer"))
        assert response.status_code == 200, response.text
        assert f"-{method}.{fmt}" in response.headers["content-disposition"]
        files[fmt] = response.text
    csv_file = parse_profile_file(files["csv"], suffix=".csv")
    whl = parse_profile_file(files["whl"], suffix=".whl")
    polyline = ezdxf.read(io.StringIO(files["dxf"])).modelspace().query("LWPOLYLINE")[0]
    dxf_points = np.array(list(polyline.get_points("xy")))
    for xs, zs in ((csv_file.x_mm, csv_file.z_mm), (whl.x_mm, whl.z_mm), dxf_points.T):
        assert np.max(np.abs(xs - x)) < 1e-3 and np.max(np.abs(zs - z)) < 1e-3
    assert (
        csv_file.value("Method") == method and csv_file.value("PipelineVersion") == PIPELINE_VERSION
    )
    assert csv_file.value("CalibrationVersion") == "1" and csv_file.value("Pass") == str(pass_id)
    for key in ("ProgramName", "Date", "Time", "CarNo", "AxleNo", "Side", "Sd", "Sh", "qR"):
        assert whl.value(key), key
    assert whl.value("ColumnDef") == "X,Y" and whl.value("XYPoints") == str(x.size)
    assert files["whl"].split("\n\n", 1)[1].splitlines()[0].count(" ") == 1


def test_an_unknown_export_format_is_refused(client, auth, measured) -> None:
    wheel = first_wheel(client, auth, measured["pass_id"])
    path = f"/api/passes/{measured['pass_id']}/wheels/{wheel['wheel_id']}/profile.stl"
    response = client.get(path, headers=auth("viewer"))
    assert response.status_code == 422 and response.json()["code"]


def test_a_handheld_reference_is_imported_compared_and_summarised(client, auth, measured):
    pass_id = measured["pass_id"]
    wheel = first_wheel(client, auth, pass_id)
    name = wheel["results"][0]["reference_profile"]
    truth = curve_flange_parameters(*contour_samples(name, 0.01))
    data = handheld_file(name)
    url = f"/api/wheels/{wheel['wheel_id']}/references"
    files = {"file": ("gauge.whl", data, "text/plain")}
    assert client.post(url, files=files, headers=auth("viewer")).status_code == 403
    created = client.post(
        url, files=files, data={"measured_at": "2026-11-22T14:05:00Z"}, headers=auth("operator")
    )
    assert created.status_code == 201, created.text
    row = created.json()
    assert row["instrument"] == "MiniProf" and row["measured_on"] == "2026-11-22 14:05:00"
    assert row["parameter_quality"] == "interpolated"
    assert row["z_offset_mm"] == pytest.approx(0.3, abs=0.002)
    assert row["instrument_flange_thickness_mm"] == 32.95
    assert row["flange_thickness_10_mm"] == pytest.approx(truth.flange_thickness_10_mm, abs=0.02)
    assert row["flange_thickness_en_mm"] == row["flange_thickness_10_mm"]  # the old name, kept
    assert row["qr_mm"] == pytest.approx(truth.qr_mm, abs=0.02)
    again = client.post(url, files=files, headers=auth("operator"))
    assert again.json()["id"] == row["id"]
    assert [r["id"] for r in client.get(url, headers=auth("viewer")).json()] == [row["id"]]

    comparison = client.get(
        f"/api/passes/{pass_id}/wheels/{wheel['wheel_id']}/reference-comparison",
        headers=auth("viewer"),
    ).json()
    assert comparison["reference"]["id"] == row["id"]
    results = {r["method"]: r for r in wheel["results"]}
    for d in comparison["differences"]:
        wayside = results[d["method"]][d["parameter"]]
        assert d["difference_mm"] == pytest.approx(wayside - row[d["parameter"]], abs=1e-9)
    assert len(comparison["differences"]) == 2 * 4

    table = client.get(
        "/api/references/agreement", params={"pass_id": pass_id}, headers=auth("viewer")
    ).json()
    assert table["pairs"] == 1 and {r["n"] for r in table["rows"]} == {1}
    by_key = {(r["method"], r["parameter"]): r for r in table["rows"]}
    for d in comparison["differences"]:
        r = by_key[(d["method"], d["parameter"])]
        assert r["mean_difference_mm"] == pytest.approx(d["difference_mm"])
        assert r["std_mm"] is None and r["max_error_mm"] == pytest.approx(abs(d["difference_mm"]))
    text = client.get("/api/references/agreement.csv", headers=auth("viewer")).text
    assert next(csv.reader(io.StringIO(text)))[:4] == ["wheel_id", "parameter", "method", "n"]
    per_wheel = [{**r, "wheel_id": None} for r in table["per_wheel"]]
    assert {r["wheel_id"] for r in table["per_wheel"]} == {wheel["wheel_id"]}
    assert per_wheel == table["rows"]  # one wheel: its rows are the pooled ones
    pdf = client.get("/api/references/agreement.pdf", headers=auth("viewer")).content
    assert pdf.startswith(b"%PDF")


@pytest.mark.parametrize(
    "filename, content, match",
    [
        ("gauge.txt", b"1 2\n", "must end in .whl, .prr, .csv"),
        ("gauge.whl", b"ColumnDef=X,Y\n\n1 2\nx y\n", "line 4 is neither"),
        ("gauge.csv", b"x,z\n" + b"1,2\n" * 5, "needs \u2265 10 points"),
    ],
)
def test_a_bad_reference_file_gets_a_422_saying_why(
    client, auth, measured, filename, content, match
):
    wheel = first_wheel(client, auth, measured["pass_id"])
    response = client.post(
        f"/api/wheels/{wheel['wheel_id']}/references",
        files={"file": (filename, content, "text/plain")},
        headers=auth("operator"),
    )
    assert response.status_code == 422 and match in response.json()["detail"]


def test_the_cli_measures_imports_exports_and_compares(client, auth, measured, tmp_path):
    pass_id = measured["pass_id"]
    wheel = first_wheel(client, auth, pass_id)
    name = wheel["results"][0]["reference_profile"]
    gauge = tmp_path / "gauge.prr"
    gauge.write_bytes(handheld_file(name))
    printed = subprocess.run(
        [sys.executable, "-m", "backend.cli", "profile-params", str(gauge), "--json"],
        check=True, capture_output=True, text=True,
    ).stdout  # fmt: skip
    params = json.loads(printed)
    truth = curve_flange_parameters(*contour_samples(name, 0.01))
    for key in ("flange_height_mm", "flange_thickness_mm", "flange_thickness_10_mm", "qr_mm"):
        assert params[key] == pytest.approx(getattr(truth, key), abs=0.03), key
    assert params["instrument"]["flange_height_mm"] == 28.01
    database = ["--database-url", client.app.state.settings.resolved_database_url]
    assert cli(["import-reference", str(gauge), "--wheel", str(wheel["wheel_id"]), *database]) == 0
    out = tmp_path / "profile.dxf"
    args = ["export-profile", "--pass", str(pass_id), "--wheel", str(wheel["wheel_id"]), "-o"]
    assert cli([*args, str(out), *database]) == 0
    assert len(ezdxf.readfile(out).modelspace().query("LWPOLYLINE")) == 1
    report, table_pdf = tmp_path / "rr.json", tmp_path / "rr.pdf"
    rr = ["rr", "--against", "references", "--json", str(report), "--pdf", str(table_pdf)]
    assert cli([*rr, "--pass-id", str(pass_id), *database]) == 0
    assert json.loads(report.read_text())["pairs"] == 1
    assert "Wayside against handheld gauge" in pdf_text(table_pdf)
    assert all(overlapping_words(page) == [] for page in pdf_pages(table_pdf))
