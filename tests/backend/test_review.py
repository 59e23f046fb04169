"""The depot's review on SQLite and PostgreSQL: worst wheels by margin, amber band per
fleet, dispositions with their audit, method disagreement, wear forecasts, vehicles."""

from __future__ import annotations

import csv
import io
from datetime import datetime, timedelta

import pytest

from backend.services.pass_wheels import get_or_create_wheel
from backend.services.results import apply_alarms
from db.models import AuditEvent, Measurement, Pass, PassWheel
from tests.backend.pdf_checks import overlapping_words, pdf_pages, pdf_text
from tests.backend.test_pass_list import open_pass

EN_SH_BAND_MM = 36.0 - 27.5
S1002_QR_NEW_MM = 10.7941


def add_wheel(client, pass_id: int, vehicle: str, axle: int, side: str, **values) -> int:
    """A measured wheel in a pass, through the service's own margin and alarm code."""
    steger_sh = values.pop("steger_sh", None)
    params = {"flange_height_mm": 31.0, "flange_thickness_10_mm": 27.5, "qr_mm": 7.5} | values
    with client.app.state.session_factory() as session:
        wheel = get_or_create_wheel(session, vehicle, axle, side)
        pass_wheel = PassWheel(pass_id=pass_id, wheel_id=wheel.id, state="measured")
        session.add(pass_wheel)
        session.flush()
        fleet = session.get(Pass, pass_id).fleet
        for method, sh in (("adaptive", None), ("steger", steger_sh)):
            row = Measurement(
                pass_wheel_id=pass_wheel.id,
                method=method,
                status="measured",
                reference_profile="S1002",
                pipeline_version="test",
                **(params | ({"flange_height_mm": sh} if sh is not None else {})),
            )
            apply_alarms(row, fleet, session)
            session.add(row)
        session.commit()
        return wheel.id


@pytest.fixture
def depot(client, auth) -> dict[str, int]:
    """Two passes at two sites; the newer one has a wheel in alarm, one amber, one fine."""
    old = open_pass(client, auth, "Hamburg-Nord", "2026-05-01T08:00:00Z", "X0")
    new = open_pass(client, auth, "Basel SBB", "2026-05-03T08:00:00Z", "X0")
    return {
        "old": old,
        "new": new,
        "alarm": add_wheel(client, new, "V003", 1, "left", flange_height_mm=36.4, steger_sh=34.4),
        "near": add_wheel(client, new, "V003", 1, "right", flange_height_mm=35.8),
        "fine": add_wheel(
            client,
            new,
            "V017",
            2,
            "left",
            tread_hollow_mm=0.62,
            flange_angle_deg=71.4,
            rim_width_mm=135.02,
            equivalent_conicity=0.181,
        ),  # fmt: skip
        "healed_old": add_wheel(client, old, "V017", 3, "left", flange_height_mm=36.9),
        "healed_new": add_wheel(client, new, "V017", 3, "left"),
    }


def worst(client, auth, **params) -> dict:
    response = client.get("/api/review/worst-wheels", headers=auth("viewer"), params=params)
    assert response.status_code == 200, response.text
    return response.json()


def test_worst_wheels_rank_alarm_then_amber_by_margin_to_the_nearest_limit(
    client, auth, depot
) -> None:
    page = worst(client, auth)
    first, second = page["items"][:2]
    assert (first["wheel_id"], second["wheel_id"]) == (depot["alarm"], depot["near"])
    assert first["margin"]["level"] == "alarm" and second["margin"]["level"] == "near"
    assert first["margin"]["margin_mm"] == pytest.approx(36.0 - 36.4)
    assert second["margin"]["margin_fraction"] == pytest.approx(0.2 / EN_SH_BAND_MM)
    assert second["margin"]["parameter"] == "flange_height_mm"
    assert second["margin"]["bound"] == "max" and second["margin"]["limit_mm"] == 36.0
    fractions = [item["margin"]["margin_fraction"] for item in page["items"]]
    assert fractions == sorted(fractions)
    # the fine wheel's nearest limit is qR ≥ 6.5 mm: 1.0 mm of the 4.29 mm to a new S1002
    fine = next(i for i in page["items"] if i["wheel_id"] == depot["fine"])
    assert fine["margin"]["parameter"] == "qr_mm" and fine["margin"]["level"] == "ok"
    assert fine["margin"]["band_mm"] == pytest.approx(S1002_QR_NEW_MM - 6.5, abs=1e-3)


def test_worst_wheels_carry_the_values_without_a_limit(client, auth, depot) -> None:
    """Tread hollow, flange angle and rim width have no limit to rank by: each row carries
    them (and the axle's λe) from the same adaptive measurement; None where not measured."""
    items = {i["wheel_id"]: i for i in worst(client, auth)["items"]}
    fine, alarm = items[depot["fine"]], items[depot["alarm"]]
    assert (fine["tread_hollow_mm"], fine["flange_angle_deg"]) == (0.62, 71.4)
    assert (fine["rim_width_mm"], fine["equivalent_conicity"]) == (135.02, 0.181)
    assert alarm["tread_hollow_mm"] is None and alarm["equivalent_conicity"] is None


def test_worst_wheels_show_each_wheels_newest_pass_unless_asked_for_all(
    client, auth, depot
) -> None:
    newest = [i["wheel_id"] for i in worst(client, auth)["items"]]
    assert newest.count(depot["healed_new"]) == 1 and page_total(client, auth) == 4
    every = worst(client, auth, latest_only="false")
    assert every["total"] == 5 and every["items"][0]["pass_id"] == depot["old"]


def page_total(client, auth, **params) -> int:
    return worst(client, auth, **params)["total"]


def test_worst_wheels_filter_by_site_fleet_vehicle_parameter_and_pass(client, auth, depot) -> None:
    assert page_total(client, auth, site="basel") == 4
    assert page_total(client, auth, site="hamburg", latest_only="false") == 1
    assert page_total(client, auth, fleet="defa") == 4
    assert page_total(client, auth, fleet="freight") == 0
    assert {i["wheel_id"] for i in worst(client, auth, vehicle="v00")["items"]} == {
        depot["alarm"],
        depot["near"],
    }
    by_qr = worst(client, auth, parameter="qr_mm")["items"]
    assert {i["margin"]["parameter"] for i in by_qr} == {"qr_mm"}
    assert page_total(client, auth, pass_id=depot["old"]) == 1
    response = client.get(
        "/api/review/worst-wheels", headers=auth("viewer"), params={"parameter": "sh"}
    )
    assert response.status_code == 422
    assert "parameter must be one of flange_height_mm" in response.json()["detail"]


def test_amber_band_is_set_per_fleet_and_applies_to_wheels_measured_next(
    client, auth, depot
) -> None:
    limits = {
        row["wheel_profile"]: row
        for row in client.get("/api/limits", headers=auth("viewer")).json()
    }
    assert limits["EN"]["near_limit_fraction"] == 0.1
    body = {
        k: v for k, v in limits["EN"].items() if k.endswith("_mm") or k == "near_limit_fraction"
    }
    body["near_limit_fraction"] = 0.02
    response = client.put("/api/limits/default/EN", headers=auth("admin"), json=body)
    assert response.status_code == 200, response.text
    del body["near_limit_fraction"]  # an edit of the limits alone keeps the amber band
    response = client.put("/api/limits/default/EN", headers=auth("admin"), json=body)
    assert response.json()["near_limit_fraction"] == 0.02
    again = add_wheel(client, depot["new"], "V099", 1, "left", flange_height_mm=35.8)
    item = next(i for i in worst(client, auth)["items"] if i["wheel_id"] == again)
    assert item["margin"]["level"] == "ok"  # 2.4 % of the band from the limit, amber is 2 %
    near = next(i for i in worst(client, auth)["items"] if i["wheel_id"] == depot["near"])
    assert near["margin"]["level"] == "near"


def test_pass_shows_amber_count_and_the_values_in_alarm(client, auth, depot) -> None:
    summary = client.get(f"/api/passes/{depot['new']}", headers=auth("viewer")).json()
    assert summary["alarm_count"] == 1 and summary["near_limit_count"] == 1
    assert summary["alarm_values"] == ["V003 axle 1 left: Sh 36.40 mm"]
    wheels = client.get(f"/api/passes/{depot['new']}/wheels", headers=auth("viewer")).json()
    levels = {w["wheel_id"]: w["level"] for w in wheels}
    assert levels[depot["alarm"]] == "alarm" and levels[depot["near"]] == "near"
    assert levels[depot["fine"]] == "ok"


def test_method_disagreement_is_flagged_beyond_the_fleets_threshold(client, auth, depot) -> None:
    wheels = client.get(f"/api/passes/{depot['new']}/wheels", headers=auth("viewer")).json()
    flagged = {w["wheel_id"]: w["method_disagreement"] for w in wheels}
    assert flagged[depot["alarm"]] == [
        {"parameter": "flange_height_mm", "difference_mm": pytest.approx(2.0), "threshold_mm": 0.5}
    ]
    assert flagged[depot["near"]] == []


def dispose(client, auth, depot, role: str, **body):
    return client.post(
        f"/api/passes/{depot['new']}/wheels/{depot['alarm']}/dispositions",
        headers=auth(role),
        json=body,
    )


def test_dispositions_are_recorded_audited_and_shown_everywhere(client, auth, depot) -> None:
    assert dispose(client, auth, depot, "viewer", kind="monitor").status_code == 403
    unknown = client.post(
        f"/api/passes/{depot['new']}/wheels/999999/dispositions",
        headers=auth("viewer"),
        json={"kind": "monitor"},
    )
    assert unknown.status_code == 403, "the role is checked before the wheel is looked up"
    refused = dispose(client, auth, depot, "operator", kind="false_alarm")
    assert refused.status_code == 422 and "false alarm needs its reason" in refused.json()["detail"]
    assert dispose(client, auth, depot, "operator", kind="monitor").status_code == 201
    made = dispose(client, auth, depot, "operator", kind="false_alarm", comment=" wet rail ")
    assert made.status_code == 201, made.text
    assert made.json()["comment"] == "wet rail" and "test operator" in made.json()["actor"]
    listed = client.get(
        f"/api/passes/{depot['new']}/wheels/{depot['alarm']}/dispositions", headers=auth("viewer")
    ).json()
    assert [d["kind"] for d in listed] == ["false_alarm", "monitor"]
    wheel = client.get(
        f"/api/passes/{depot['new']}/wheels/{depot['alarm']}", headers=auth("viewer")
    ).json()
    assert wheel["disposition"]["kind"] == "false_alarm"
    top = worst(client, auth)["items"][0]
    assert top["wheel_id"] == depot["alarm"] and top["disposition"]["comment"] == "wet rail"
    assert depot["alarm"] not in [
        i["wheel_id"] for i in worst(client, auth, open_only="true")["items"]
    ]
    with client.app.state.session_factory() as session:
        events = session.query(AuditEvent).filter_by(action="disposition.create").all()
        assert [e.detail["kind"] for e in events] == ["monitor", "false_alarm"]
        assert events[1].target_id == f"{depot['new']}/{depot['alarm']}"


def test_trend_forecasts_when_the_wear_fit_reaches_the_limit(client, auth) -> None:
    start = datetime(2026, 1, 1, 8, tzinfo=datetime.now().astimezone().tzinfo).replace(tzinfo=None)
    wheel_id = None
    for day in (0, 30, 60, 90, 120):
        when = (start + timedelta(days=day)).isoformat() + "Z"
        pass_id = open_pass(client, auth, "S", when, "T1")
        # Sh grows 0.02 mm a day from 33.0: the 36 mm limit is 150 days after the first pass
        wheel_id = add_wheel(client, pass_id, "T7", 1, "left", flange_height_mm=33.0 + 0.02 * day)
    trend = client.get(f"/api/wheels/{wheel_id}/trend", headers=auth("viewer")).json()
    assert trend["limits"]["wheel_profile"] == "EN"
    assert trend["limits"]["limits_mm"]["flange_height_max_mm"] == 36.0
    sh = next(f for f in trend["forecasts"] if f["parameter"] == "flange_height_mm")
    assert sh["per"] == "day" and sh["rate_mm"] == pytest.approx(0.02)
    assert sh["bound"] == "max" and sh["limit_mm"] == 36.0
    assert sh["near_mm"] == pytest.approx(36.0 - 0.1 * EN_SH_BAND_MM)
    assert sh["reached_at"].startswith((start + timedelta(days=150)).date().isoformat())
    flat = next(f for f in trend["forecasts"] if f["parameter"] == "qr_mm")
    assert flat["reached_at"] is None and "does not reach" in flat["note"]


def test_trend_fits_wear_per_1000_km_when_every_pass_carries_the_odometer(client, auth) -> None:
    start = datetime(2026, 1, 1, 8)
    wheel_id = None
    # Sd thins 0.05 mm per 1,000 km from 27.0 at 120,000 km, at uneven km per day: the EN
    # 22 mm limit is 100,000 km on, at 220,000 km
    for day, km in ((0, 120_000), (10, 128_000), (40, 136_000), (45, 144_000), (90, 152_000)):
        when = (start + timedelta(days=day)).isoformat() + "Z"
        pass_id = open_pass(client, auth, "S", when, "T1", odometer_km={"T8": km})
        thickness = 27.0 - 0.05 * (km - 120_000) / 1000
        wheel_id = add_wheel(client, pass_id, "T8", 1, "left", flange_thickness_10_mm=thickness)
    trend = client.get(f"/api/wheels/{wheel_id}/trend", headers=auth("viewer")).json()
    assert [p["odometer_km"] for p in trend["points"][::2]] == [120e3, 128e3, 136e3, 144e3, 152e3]
    sd = next(f for f in trend["forecasts"] if f["parameter"] == "flange_thickness_10_mm")
    assert sd["per"] == "1000 km" and sd["rate_mm"] == pytest.approx(-0.05)
    assert sd["rate_low_mm"] <= sd["rate_mm"] <= sd["rate_high_mm"]
    assert sd["bound"] == "min" and sd["limit_mm"] == 22.0
    assert sd["fit_from_km"] == 120e3 and sd["last_km"] == 152e3
    assert sd["reached_km"] == pytest.approx(220e3)
    assert sd["reached_at"] is None, "a distance, not a date"
    assert "220,000 km" in sd["note"]
    # a pass without the reading: the fit falls back to days
    pass_id = open_pass(client, auth, "S", (start + timedelta(days=100)).isoformat() + "Z", "T1")
    add_wheel(client, pass_id, "T8", 1, "left", flange_thickness_10_mm=26.5)
    trend = client.get(f"/api/wheels/{wheel_id}/trend", headers=auth("viewer")).json()
    sd = next(f for f in trend["forecasts"] if f["parameter"] == "flange_thickness_10_mm")
    assert sd["per"] == "day" and sd["reached_km"] is None and sd["reached_at"] is not None


def test_vehicles_are_found_by_part_of_their_id_with_their_history(client, auth, depot) -> None:
    found = client.get("/api/vehicles", headers=auth("viewer"), params={"q": "v01"}).json()
    assert found == ["V017"]
    history = client.get("/api/vehicles/V017", headers=auth("viewer")).json()
    assert [p["pass_id"] for p in history["passes"]] == [depot["new"], depot["old"]]
    assert {w["wheel_id"] for w in history["passes"][0]["wheels"]} == {
        depot["fine"],
        depot["healed_new"],
    }
    missing = client.get("/api/vehicles/NOPE", headers=auth("viewer"))
    assert missing.status_code == 404 and "NOPE" in missing.json()["detail"]


def pass_pdf_text(client, auth, pass_id: int, tmp_path, name: str) -> tuple[str, str]:
    """The pass PDF's text (every page checked for text over text) and its ETag."""
    response = client.get(f"/api/passes/{pass_id}/report.pdf", headers=auth("viewer"))
    assert response.status_code == 200, response.text
    pdf = tmp_path / f"{name}.pdf"
    pdf.write_bytes(response.content)
    assert all(overlapping_words(page) == [] for page in pdf_pages(pdf))
    return pdf_text(pdf), response.headers["ETag"]


def test_reports_show_each_wheels_disposition_and_a_new_one_changes_the_etag(
    client, auth, depot, tmp_path
) -> None:
    before, etag = pass_pdf_text(client, auth, depot["new"], tmp_path, "before")
    assert "Disposition: open" in before
    made = dispose(client, auth, depot, "operator", kind="false_alarm", comment="wet rail")
    assert made.status_code == 201, made.text
    actor = made.json()["actor"]
    held = client.get(
        f"/api/passes/{depot['new']}/report.pdf",
        headers={**auth("viewer"), "If-None-Match": etag},
    )
    assert held.status_code == 200 and held.headers["ETag"] != etag
    after, _ = pass_pdf_text(client, auth, depot["new"], tmp_path, "after")
    assert f"Disposition: false alarm: wet rail — by {actor}" in after
    assert after.count("Disposition: open") == before.count("Disposition: open") - 1
    rows = list(csv.DictReader(io.StringIO(
        client.get(f"/api/passes/{depot['new']}/report.csv", headers=auth("viewer")).text
    )))  # fmt: skip
    by_wheel = {int(r["wheel_id"]): r for r in rows}
    alarm = by_wheel[depot["alarm"]]
    assert (alarm["disposition"], alarm["disposition_comment"]) == ("false alarm", "wet rail")
    assert alarm["disposition_by"] == actor and alarm["disposition_at"].endswith("+00:00")
    assert by_wheel[depot["near"]]["disposition"] == "open"
    path = f"/api/passes/{depot['new']}/wheels/{depot['alarm']}/report"
    wheel = client.get(f"{path}.json", headers=auth("viewer")).json()["wheels"][0]
    assert wheel["disposition"]["kind"] == "false_alarm" and wheel["disposition"]["actor"] == actor
    one = tmp_path / "wheel.pdf"
    one.write_bytes(client.get(f"{path}.pdf", headers=auth("viewer")).content)
    assert f"Disposition: false alarm: wet rail — by {actor}" in pdf_text(one)


def test_report_margins_use_the_fleets_amber_band(client, auth, depot, tmp_path) -> None:
    def summary_rows(text: str) -> list[str]:
        table = text.split("All wheels")[0].split("Wheels in alarm and near a limit")[1]
        return [line for line in table.splitlines() if "V003" in line]

    default, _ = pass_pdf_text(client, auth, depot["new"], tmp_path, "default")
    assert any("near limit" in row and "right" in row for row in summary_rows(default))
    assert "the inner 10 %" in default
    limits = next(
        r for r in client.get("/api/limits", headers=auth("viewer")).json()
        if r["fleet"] == "default" and r["wheel_profile"] == "EN"
    )  # fmt: skip
    body = {k: v for k, v in limits.items() if k.endswith("_mm") or k == "near_limit_fraction"}
    body["near_limit_fraction"] = 0.02  # V003 right's Sh is 2.35 % of its band from 36 mm
    assert client.put("/api/limits/default/EN", headers=auth("admin"), json=body).is_success
    narrow, _ = pass_pdf_text(client, auth, depot["new"], tmp_path, "narrow")
    assert [row for row in summary_rows(narrow) if "near limit" in row] == []
    assert any("ALARM" in row for row in summary_rows(narrow)) and "the inner 2 %" in narrow
