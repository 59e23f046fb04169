"""Conicity settings: a fleet's limit (default 0.4, editable, the alarm it raises) and a
site's rails (60E1 at 1:40 on gauge 1435 by default, settable by an admin)."""

from __future__ import annotations

from sqlalchemy import select

from backend.services.limits import evaluate_alarms, limits_for
from backend.services.results import site_rails
from db.models import Site


def limits_body(client, auth, family: str) -> dict:
    rows = {r["wheel_profile"]: r for r in client.get("/api/limits", headers=auth("viewer")).json()}
    return {k: v for k, v in rows[family].items() if k.endswith("_mm") or k == "conicity_max"}


def test_conicity_limit_defaults_to_0_4_and_an_edit_moves_the_alarm(client, auth) -> None:
    for family in ("EN", "LM"):
        assert limits_body(client, auth, family)["conicity_max"] == 0.4
    body = {**limits_body(client, auth, "EN"), "conicity_max": 0.15}
    response = client.put("/api/limits/default/EN", headers=auth("admin"), json=body)
    assert response.status_code == 200 and response.json()["conicity_max"] == 0.15
    with client.app.state.session_factory() as session:
        limits = limits_for(session, "default", "EN")
    assert evaluate_alarms({"equivalent_conicity": 0.149}, limits, "EN") == []
    (alarm,) = evaluate_alarms({"equivalent_conicity": 0.2}, limits, "EN")
    assert alarm["parameter"] == "equivalent_conicity" and alarm["bound"] == "max"
    assert alarm["message"] == "equivalent_conicity 0.200 is above 0.15"


def test_a_conicity_limit_out_of_range_is_refused(client, auth) -> None:
    body = {**limits_body(client, auth, "LM"), "conicity_max": 0.0}
    response = client.put("/api/limits/default/LM", headers=auth("admin"), json=body)
    assert response.status_code == 422
    assert "conicity_max" in response.json()["detail"]


def test_a_site_runs_on_60e1_at_1_in_40_until_an_admin_sets_its_rails(client, auth) -> None:
    created = client.post("/api/sites", headers=auth("admin"), json={"name": "north"})
    assert created.status_code == 201
    (site,) = [
        s for s in client.get("/api/sites", headers=auth("viewer")).json() if s["name"] == "north"
    ]
    assert (site["rail_profile"], site["rail_inclination"], site["gauge_mm"]) == (
        "60E1",
        "1:40",
        1435.0,
    )
    body = {"rail_profile": "54E1", "rail_inclination": "1:20", "gauge_mm": 1437.0}
    as_operator = client.put("/api/sites/north/rails", headers=auth("operator"), json=body)
    assert as_operator.status_code == 403
    response = client.put("/api/sites/north/rails", headers=auth("admin"), json=body)
    assert response.status_code == 200 and response.json()["rail_profile"] == "54E1"
    with client.app.state.session_factory() as session:
        rails = site_rails(session.scalars(select(Site).where(Site.name == "north")).one())
    assert (rails.rail, rails.inclination, rails.gauge_mm) == ("54E1", "1:20", 1437.0)
    bad = {**body, "rail_profile": "49E1"}
    refused = client.put("/api/sites/north/rails", headers=auth("admin"), json=bad)
    assert refused.status_code == 422 and "rail_profile" in refused.json()["detail"]
