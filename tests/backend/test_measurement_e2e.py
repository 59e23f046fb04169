"""End to end: a simulated pass uploaded or streamed is measured like `wheelscan measure`.

One simulated vehicle with one axle (two wheels) keeps the CPU cost small; the pass is
simulated once per test session and measured by the CLI once for the comparison.
"""

from __future__ import annotations

import csv
import io
import json
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from sqlalchemy import delete, select

from backend.ops.demo import zip_folder
from backend.services.ingest import store_archive, validate_archive
from db.models import Frame, Job, Measurement, PassWheel
from tests.backend.conftest import empty_service, make_tokens

PARAMETERS = ("flange_height_mm", "flange_thickness_mm", "qr_mm", "back_to_back_mm")
TREAD = ("tread_hollow_mm", "flange_angle_deg", "rim_width_mm")


@pytest.fixture(scope="session")
def simulated(tmp_path_factory: pytest.TempPathFactory, simulated_pass: Callable) -> dict:
    """A simulated 1-vehicle, 1-axle pass: its folder, zip, truth and CLI measurement."""
    root = tmp_path_factory.mktemp("simulated")
    folder = simulated_pass(root / "pass", 1)
    truth = json.loads((folder / "truth.json").read_text())
    (folder / "truth.json").unlink()
    out = root / "measure.json"
    subprocess.run(
        [sys.executable, "-m", "backend.cli", "measure", str(folder), "--method", "both",
         "--json", str(out)],
        check=True, capture_output=True,
    )  # fmt: skip
    return {
        "folder": folder,
        "zip": zip_folder(folder, root / "pass.zip").read_bytes(),
        "truth": truth,
        "cli": json.loads(out.read_text())["wheels"],
    }


def wait_for_job(client, token: str, job_id: int) -> dict:
    """Follow the job's progress socket until it reports done (no polling sleeps)."""
    last = None
    with client.websocket_connect(f"/api/ws/jobs/{job_id}?token={token}") as socket:
        while last is None or last["state"] != "done":
            last = socket.receive_json()
    return last


@pytest.fixture(scope="module")
def measured(service, simulated) -> dict:
    """The simulated pass uploaded and measured once per database for this module's tests."""
    empty_service(service)
    tokens = make_tokens(service)
    response = service.post(
        "/api/passes",
        headers={"Authorization": f"Bearer {tokens['operator']}"},
        files={"file": ("p.zip", simulated["zip"], "application/zip")},
    )
    assert response.status_code == 202, response.text
    wait_for_job(service, tokens["viewer"], response.json()["job_id"])
    yield {**response.json(), "tokens": tokens}
    empty_service(service)


@pytest.fixture
def client(service, measured):
    """This module shares one measured pass: no emptying between its tests."""
    return service


@pytest.fixture
def tokens(measured) -> dict[str, str]:
    return measured["tokens"]


def results_by_wheel(client, auth, pass_id: int) -> dict:
    wheels = client.get(f"/api/passes/{pass_id}/wheels", headers=auth("viewer")).json()
    return {
        (w["vehicle_id"], w["axle"], w["side"], r["method"]): r
        for w in wheels
        for r in w["results"]
    }


def test_an_uploaded_pass_is_measured_as_the_cli_measures_it(client, auth, measured, simulated):
    accepted = measured
    job = client.get(f"/api/jobs/{accepted['job_id']}", headers=auth("viewer")).json()
    assert (job["state"], job["wheels_done"], job["wheels_total"]) == ("done", 2, 2)
    ours = results_by_wheel(client, auth, accepted["pass_id"])
    assert len(ours) == len(simulated["cli"]) == 4
    for row in simulated["cli"]:
        mine = ours[(row["vehicle_id"], row["axle"], row["side"], row["method"])]
        assert mine["status"] == "measured" == row["status"]
        for name in (*PARAMETERS, "flange_thickness_10_mm"):
            # The CLI rounds to 4 decimals; the service stores the full value.
            assert mine[name] == pytest.approx(row[name], abs=6e-5), name
        for name in TREAD:
            assert mine[name] == pytest.approx(row[name], abs=6e-5), name
        assert mine["flange_thickness_en_mm"] == mine["flange_thickness_10_mm"]  # the old name
        # The service computes the axle's conicity from the stored profiles (0.1 µm).
        assert mine["equivalent_conicity"] == pytest.approx(row["equivalent_conicity"], abs=1e-3)
    for truth in simulated["truth"]["wheels"]:
        mine = ours[(truth["vehicle_id"], truth["axle"], truth["side"], "adaptive")]
        assert mine["reference_profile"] == truth["profile"]
        assert mine["equivalent_conicity"] == pytest.approx(truth["conicity_3mm"], abs=0.02)
        assert mine["rim_width_mm"] == pytest.approx(truth["rim_width_mm"], abs=0.1)


def test_the_wheel_views_serve_frames_masks_sigma_centres_and_profile(client, auth, measured):
    pass_id = measured["pass_id"]
    wheel = client.get(f"/api/passes/{pass_id}/wheels", headers=auth("viewer")).json()[0]
    base = f"/api/passes/{pass_id}/wheels/{wheel['wheel_id']}"
    viewer = auth("viewer")
    frame = client.get(f"{base}/frames/inner.png", params={"max_width": 400}, headers=viewer)
    assert frame.status_code == 200 and frame.content.startswith(b"\x89PNG")
    mask = client.get(f"{base}/mask/outer.png", headers=viewer)
    assert mask.status_code == 200 and mask.headers["content-type"] == "image/png"
    again = client.get(
        f"{base}/mask/outer.png", headers={**viewer, "If-None-Match": mask.headers["ETag"]}
    )
    assert again.status_code == 304
    sigma = client.get(f"{base}/sigma/inner.png", headers=viewer)
    low, high = float(sigma.headers["X-Sigma-Min-Px"]), float(sigma.headers["X-Sigma-Max-Px"])
    # every frame on the configured σ1..σ3 (widths 5–21 px), so a colour is one σ everywhere
    assert (low, high) == pytest.approx((5 / np.sqrt(3), 21 / np.sqrt(3)))
    assert sigma.headers["X-Colormap"] == "viridis"
    scales = [float(v) for v in sigma.headers["X-Sigma-Scales-Px"].split(",")]
    assert scales == pytest.approx([5 / np.sqrt(3), 13 / np.sqrt(3), 21 / np.sqrt(3)], abs=1e-4)
    raw = client.get(f"{base}/sigma/inner.f32", headers=viewer)
    width, height = int(raw.headers["X-Width-Px"]), int(raw.headers["X-Height-Px"])
    values = np.frombuffer(raw.content, "<f4").reshape(height, width)
    chosen = values[values > 0]
    assert low - 1e-4 <= chosen.min() and chosen.max() <= high + 1e-4
    steger_sigma = client.get(
        f"{base}/sigma/inner.png", params={"method": "steger"}, headers=viewer
    )
    assert steger_sigma.status_code == 404 and "fixed σ" in steger_sigma.json()["detail"]
    centres = client.get(
        f"{base}/centres/inner", params={"method": "steger"}, headers=viewer
    ).json()
    lengths = {len(centres[k]) for k in ("x", "y", "sigma", "strength", "nx", "ny")}
    assert lengths == {centres["count"]} and centres["count"] > 100
    assert len(centres["rejected_x"]) == len(centres["rejected_y"]), "rejected candidates, x and y"
    profile = client.get(f"{base}/profile", headers=viewer).json()
    assert len(profile["x_mm"]) == len(profile["z_mm"]) > 100
    assert profile["reference_profile"] in ("LMA", "S1002") and len(profile["reference_x_mm"]) > 100
    assert profile["construction"]["sd"]["flank_point"] == [
        round(profile["parameters"]["flange_thickness_mm"], 3),
        12.0,
    ]
    conicity = profile["conicity"]
    assert conicity["rail"] == "60E1" and conicity["inclination"] == "1:40"
    assert len(conicity["y_mm"]) == len(conicity["delta_r_mm"]) == 401
    assert conicity["conicity_3mm"] == profile["parameters"]["equivalent_conicity"]
    trend = client.get(f"/api/wheels/{wheel['wheel_id']}/trend", headers=viewer).json()
    assert [p["method"] for p in trend["points"]] == ["adaptive", "steger"]
    assert trend["points"][0]["equivalent_conicity"] == conicity["conicity_3mm"]


def test_reports_come_as_csv_json_and_pdf(client, auth, measured):
    pass_id = measured["pass_id"]
    viewer = auth("viewer")
    csv_text = client.get(f"/api/passes/{pass_id}/report.csv", headers=viewer).text
    assert csv_text.splitlines()[0].startswith("pass_id,site,started_at,vehicle_id")
    assert len(csv_text.splitlines()) == 1 + 4
    report = client.get(f"/api/passes/{pass_id}/report.json", headers=viewer).json()
    assert report["pass"]["id"] == pass_id and set(report["limits"]) == {"EN", "LM"}
    rows = list(csv.DictReader(io.StringIO(csv_text)))
    first = report["wheels"][0]["results"][0]
    for name in (*TREAD, "equivalent_conicity"):
        assert float(rows[0][name]) == pytest.approx(first[name]), name
    assert report["limits"]["EN"]["conicity_max"] == 0.4
    pdf = client.get(f"/api/passes/{pass_id}/report.pdf", headers=viewer)
    assert pdf.content.startswith(b"%PDF") and "attachment" in pdf.headers["content-disposition"]
    wheel_id = report["wheels"][0]["wheel_id"]
    wheel_pdf = client.get(f"/api/passes/{pass_id}/wheels/{wheel_id}/report.pdf", headers=viewer)
    assert wheel_pdf.status_code == 200 and wheel_pdf.content.startswith(b"%PDF")


def stream_pass(client, auth, folder: Path, order: np.ndarray, drop_after: int) -> dict:
    """Stream a pass folder's frames in `order`, every third one twice, with the sender
    'dropping' after `drop_after` frames and resuming from the server's frame list."""
    manifest = json.loads((folder / "manifest.json").read_text())
    calibration = json.loads((folder / "calibration.json").read_text())
    opened = client.post(
        "/api/passes/stream",
        headers=auth("operator"),
        json={"site": manifest["site"], "started_at": manifest["started_at"],
              "direction": manifest["direction"], "speed_kmh": manifest["speed_kmh"],
              "calibration": calibration},
    ).json()  # fmt: skip
    frames, next_seq = [], {}
    for wheel in manifest["wheels"]:
        for position in ("inner", "outer"):
            sensor = f"{wheel['side']}_{position}"
            for path in wheel["frames"][position]:
                seq = next_seq.get(sensor, 0)
                next_seq[sensor] = seq + 1
                frames.append((sensor, seq, wheel["vehicle_id"], wheel["axle"], path))

    def send(item) -> int:
        sensor, seq, vehicle, axle, path = item
        return client.put(
            f"/api/passes/{opened['pass_id']}/frames/{sensor}/{seq}",
            params={"vehicle_id": vehicle, "axle": axle},
            headers={**auth("operator"), "Content-Type": "image/png"},
            content=(folder / path).read_bytes(),
        ).status_code

    for count, index in enumerate(order[:drop_after]):
        assert send(frames[index]) == 201
        if count % 3 == 0:
            assert send(frames[index]) == 200
    stored = client.get(f"/api/passes/{opened['pass_id']}/frames", headers=auth("operator")).json()
    done = {(row["sensor"], row["seq"]) for row in stored}
    assert len(done) == drop_after
    for index in order:
        if (frames[index][0], frames[index][1]) not in done:
            assert send(frames[index]) == 201
    closed = client.post(f"/api/passes/{opened['pass_id']}/close", headers=auth("operator"))
    assert closed.status_code == 202
    return opened


def test_streaming_out_of_order_with_repeats_and_a_drop_equals_the_upload(
    client, auth, tokens, measured, simulated
):
    uploaded = measured
    order = np.random.default_rng(5).permutation(4)
    streamed = stream_pass(client, auth, simulated["folder"], order, drop_after=2)
    wait_for_job(client, tokens["viewer"], streamed["job_id"])
    by_upload = results_by_wheel(client, auth, uploaded["pass_id"])
    by_stream = results_by_wheel(client, auth, streamed["pass_id"])
    assert by_stream.keys() == by_upload.keys()
    for key, row in by_upload.items():
        for name in (*PARAMETERS, "flange_thickness_10_mm", "alarms", "quality"):
            assert by_stream[key][name] == row[name], (key, name)


def test_a_crash_in_one_wheel_is_recorded_on_it_and_the_pass_goes_on(
    client, auth, tokens, simulated, tmp_path
):
    app = client.app
    path = tmp_path / "pass.zip"
    path.write_bytes(simulated["zip"])
    with app.state.session_factory() as session:
        archive = validate_archive(session, path, app.state.settings)
        train_pass, job, pass_wheel_ids = store_archive(
            session, app.state.store, archive, "0" * 64, None
        )
        victim = session.scalars(
            select(Frame).where(Frame.pass_id == train_pass.id).order_by(Frame.id).limit(1)
        ).one()
        victim_wheel = (victim.vehicle_id, victim.axle, victim.sensor.split("_")[0])
    # The frame store loses one wheel's frame: its task raises, the other wheel is measured.
    blob = app.state.store.path_for(victim.sha256, ".png")
    kept = blob.read_bytes()
    blob.unlink()
    try:
        app.state.runner.submit(pass_wheel_ids)
        assert wait_for_job(client, tokens["viewer"], job.id)["wheels_done"] == 2
    finally:
        app.state.store.put(kept, ".png")
    wheels = client.get(f"/api/passes/{train_pass.id}/wheels", headers=auth("viewer")).json()
    states = {(w["vehicle_id"], w["axle"], w["side"]): w for w in wheels}
    failed = states.pop(victim_wheel)
    assert failed["state"] == "failed" and failed["reason"].startswith("FileNotFoundError")
    assert [w["state"] for w in states.values()] == ["measured"]


def test_a_restart_resumes_interrupted_wheels_and_measures_nothing_twice(client, tokens, measured):
    accepted = measured
    factory = client.app.state.session_factory
    with factory() as session:
        before = {m.id for m in session.scalars(select(Measurement))}
        assert client.app.state.runner.resume() == 0
        interrupted = session.scalars(
            select(PassWheel).where(PassWheel.pass_id == accepted["pass_id"]).limit(1)
        ).one()
        session.execute(delete(Measurement).where(Measurement.pass_wheel_id == interrupted.id))
        interrupted.state = "running"
        session.get(Job, accepted["job_id"]).state = "running"
        session.commit()
        interrupted_id = interrupted.id
    assert client.app.state.runner.resume() == 1
    wait_for_job(client, tokens["viewer"], accepted["job_id"])
    with factory() as session:
        rows = list(
            session.scalars(
                select(Measurement)
                .join(PassWheel, Measurement.pass_wheel_id == PassWheel.id)
                .where(PassWheel.pass_id == accepted["pass_id"])
            )
        )
        attempts = session.get(PassWheel, interrupted_id).attempts
    assert len(rows) == 4 and attempts == 2
    kept = {m.id for m in rows if m.pass_wheel_id != interrupted_id}
    assert kept <= before and len(kept) == 2
    assert client.app.state.runner.resume() == 0
