"""The conicity limit of a fleet: default 0.4, editable, and the alarm it raises."""

from __future__ import annotations

from backend.services.limits import evaluate_alarms, limits_for


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
