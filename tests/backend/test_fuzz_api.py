"""API fuzzing: schemathesis against the served OpenAPI document, for every kind of caller.

Every operation of `/openapi.json` gets generated requests (valid and invalid) as a viewer,
an operator, an admin, without a token and with an unknown one, on the real service of
conftest.py (SQLite and PostgreSQL) holding one uploaded pass through its measurement (its
40×30 px frames end "not measured", with centres and layers stored), which the generated
paths also name. Each response must not be a server error and must conform to the
document: a documented status code, content type, headers and a body matching the
documented schema; invalid data must be refused (4xx).

Bounded and reproducible: few examples per operation, derandomized Hypothesis without an
example database or deadline, and a fresh service state before each caller's run. The suite
sends 4 examples per operation and generation mode for a caller with a valid token;
`python -m benchmarks.fuzz` sets `WHEELSCAN_FUZZ_EXAMPLES=12` (three times the cases, about
25 minutes on 2 cores) for the figures in BENCHMARKS.md.
"""

from __future__ import annotations

import logging
import os
import re
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import schemathesis
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from hypothesis.errors import Unsatisfiable
from schemathesis import GenerationMode
from schemathesis.checks import (
    content_type_conformance,
    negative_data_rejection,
    not_a_server_error,
    response_headers_conformance,
    response_schema_conformance,
    status_code_conformance,
)
from schemathesis.core.failures import FailureGroup, ServerError
from starlette.types import ASGIApp, Receive, Scope, Send

from tests.backend.archives import small_archive_bytes
from tests.backend.test_measurement_e2e import wait_for_job

logger = logging.getLogger(__name__)

CALLERS = ("viewer", "operator", "admin", "no token", "unknown token")
VALID_EXAMPLES_PER_OPERATION = int(os.environ.get("WHEELSCAN_FUZZ_EXAMPLES", "4"))
EXAMPLES_PER_OPERATION = dict.fromkeys(
    ("viewer", "operator", "admin"), VALID_EXAMPLES_PER_OPERATION
)
"""Examples per operation for a caller with a valid token; the others are refused before
any input is read, so a few examples show that for every operation."""
REFUSED_EXAMPLES_PER_OPERATION = 3
CHECKS = [
    not_a_server_error,
    status_code_conformance,
    content_type_conformance,
    response_headers_conformance,
    response_schema_conformance,
    negative_data_rejection,
]
"""Left out, because they do not apply here: `ignored_auth` sends the generated (invalid)
credentials, which `_authorize` replaces with the caller's, so it would call a valid token
ignored auth (the "no token" and "unknown token" callers check every operation refuses
them); `positive_data_acceptance` expects 2xx for every schema-valid request, but the API
refuses schema-valid requests by documented rules no JSON Schema states (an expiry in the
past, a site without a calibration, limits with min > max, an archive that does not
validate: 422; random ids: 404)."""


class _AlreadyStarted:
    """The session's app for schemathesis' own ASGI client.

    The app's lifespan (task runner, viewer) already runs in conftest's TestClient; an ASGI
    app that raises on the lifespan scope before its first message has no lifespan, so
    schemathesis does not start a second one. Each caller comes from its own client
    address, so the failed-authentication limit one caller reaches never touches another.
    """

    def __init__(self, app: ASGIApp, address: str) -> None:
        self.app = app
        self.address = address

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] == "lifespan":
            raise RuntimeError("the lifespan runs in the test session's TestClient")
        await self.app({**scope, "client": (self.address, 50000)}, receive, send)


def _authorize(case: Any, caller: str, tokens: dict[str, str]) -> None:
    """Replace the Authorization header schemathesis generated from the bearer scheme
    (a random token, mostly `Bearer `) with the caller's, or drop it."""
    headers = dict(case.headers or {})
    headers.pop("Authorization", None)
    if caller != "no token":
        token = tokens.get(caller, "wst_unknown0000000000000000000000")
        headers["Authorization"] = f"Bearer {token}"
    case.headers = headers


@pytest.fixture
def measured_pass(client, tokens, tmp_path: Path) -> dict[str, Any]:
    """One small uploaded pass, measured, so the wheel and report routes have data; returns
    the path parameters that name its stored objects."""
    response = client.post(
        "/api/passes",
        headers={"Authorization": f"Bearer {tokens['operator']}"},
        files={"file": ("pass.zip", small_archive_bytes(tmp_path), "application/zip")},
    )
    assert response.status_code == 202, response.text
    accepted = response.json()
    wait_for_job(client, tokens["viewer"], accepted["job_id"])
    viewer = {"Authorization": f"Bearer {tokens['viewer']}"}
    wheels = client.get(f"/api/passes/{accepted['pass_id']}/wheels", headers=viewer).json()
    calibrations = client.get("/api/sites/test-site/calibrations", headers=viewer).json()
    return {
        "pass_id": accepted["pass_id"],
        "job_id": accepted["job_id"],
        "wheel_id": wheels[0]["wheel_id"],
        "site_name": "test-site",
        "calibration_id": calibrations[-1]["id"],
    }


def _runs(operation: Any, stored: dict[str, Any]) -> list[tuple[str, dict[str, Any]]]:
    """What to generate for an operation: valid and invalid data for random paths, and
    valid data on the stored pass where the path names one of its objects (random ids
    would almost never hit it)."""
    runs = [(mode.value, {"generation_mode": mode}) for mode in GenerationMode]
    names = set(re.findall(r"{(\w+)}", operation.path)) & stored.keys()
    if names:
        fixed = {name: stored[name] for name in names}
        runs.append(("stored objects", {"path_parameters": fixed}))
    return runs


def _fuzz(
    operation: Any, strategy_options: dict[str, Any], call: Callable[[Any], None], examples: int
) -> None:
    @settings(
        max_examples=examples,
        derandomize=True,
        database=None,
        deadline=None,
        phases=[Phase.explicit, Phase.generate, Phase.shrink],
        suppress_health_check=list(HealthCheck),
    )
    @given(data=st.data())
    def run(data: st.DataObject) -> None:
        call(data.draw(operation.as_strategy(**strategy_options)))

    run()


def _failure_kinds(exc: BaseException) -> Counter[str]:
    """How many of a run's failures are 5xx answers, and how many other breaches of the
    document (status, content type, headers, body schema, invalid data accepted)."""
    found = exc.exceptions if isinstance(exc, FailureGroup) else [exc]
    return Counter("server" if isinstance(f, ServerError) else "conformance" for f in found)


@pytest.mark.parametrize("caller", CALLERS)
def test_every_operation_answers_as_documented(client, tokens, measured_pass, caller) -> None:
    schema = schemathesis.openapi.from_asgi(
        "/openapi.json", _AlreadyStarted(client.app, f"fuzz-{caller.replace(' ', '-')}")
    )
    examples = EXAMPLES_PER_OPERATION.get(caller, REFUSED_EXAMPLES_PER_OPERATION)
    cases_run = 0
    failures = []

    def call(case: Any) -> None:
        nonlocal cases_run
        cases_run += 1
        _authorize(case, caller, tokens)
        case.call_and_validate(checks=CHECKS)

    kinds: Counter[str] = Counter()
    operations = [result.ok() for result in schema.get_all_operations()]
    for operation in operations:
        for name, options in _runs(operation, measured_pass):
            try:
                _fuzz(operation, options, call, examples)
            except Unsatisfiable:
                # No invalid data exists for an operation without parameters or body
                # (GET /healthz, GET /api/me): nothing to send that breaks its schema.
                assert name == GenerationMode.NEGATIVE.value, operation.label
            except (Exception, FailureGroup) as exc:  # every operation's failures are reported
                failures.append(f"{operation.label} ({name}):\n{exc}")
                kinds.update(_failure_kinds(exc))
    database = client.app.state.engine.dialect.name
    logger.info(
        "fuzzed as %s on %s: %d operations, %d cases, %d server errors, %d conformance failures",
        caller, database, len(operations), cases_run, kinds["server"], kinds["conformance"],
    )  # fmt: skip
    assert not failures, "\n\n".join(failures)


@pytest.mark.parametrize(
    "path",
    [
        "/api/passes/99999999999999999999",
        "/api/passes/1/wheels/-99999999999999999999",
        "/api/passes?offset=99999999999999999999",
        "/api/calibrations/2147483648",
        "/api/references/agreement?pass_id=99999999999999999999",
        "/api/references/agreement.csv?pass_id=-99999999999999999999",
    ],
)
def test_ids_beyond_the_integer_columns_are_refused_not_crashed(client, auth, path) -> None:
    # Found by the fuzzer: SQLite raised OverflowError (500) on ids past 64 bits.
    response = client.get(path, headers=auth("viewer"))
    assert response.status_code == 422
    assert response.json()["code"] == "invalid_input"


@pytest.mark.parametrize(
    ("method", "url", "body"),
    [
        ("POST", "/api/sites", {"name": "a\u0000b"}),
        ("POST", "/api/tokens", {"role": "viewer", "name": "a\u0000"}),
        ("GET", "/api/passes?site=a%00b", None),
        ("GET", "/api/sites/a%00b/calibrations", None),
    ],
)
def test_text_with_a_nul_is_invalid_input_on_every_database(client, auth, method, url, body):
    # PostgreSQL refuses NUL bytes in text (a DataError, which was a 500); SQLite stored
    # them: both refuse them now, before any query.
    response = client.request(method, url, json=body, headers=auth("admin"))
    assert response.status_code == 422, response.text
    assert "NUL" in response.json()["detail"]
