"""Fleet alarm limits: defaults, lookup, and the comparison of wheel parameters with them.

EN defaults (docs/numbers.md, "Alarms"): flange height Sh 27.5–36 mm, flange thickness Sd
22–33 mm measured at the EN height of 10 mm, qR ≥ 6.5 mm, back-to-back 1357–1363 mm. LM
defaults follow the operator's rules for LM-profile wheelsets (Sd measured at 12 mm;
wheelset inner distance 1353 ± 3 mm); both are editable per fleet through the API. The equivalent
conicity of an axle (EN 15302, at 3 mm amplitude) alarms above `conicity_max`, 0.4 by
default: a hunting risk on most vehicles; operators set their own value per fleet.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from backend.api.schemas import LimitsRead, LimitsUpdate
from backend.errors import InvalidInputError
from backend.services.auth import record_audit
from backend.services.margins import (
    ALARM,
    METHOD_DISAGREEMENT_MM,
    NEAR_LIMIT_FRACTION,
    PARAMETERS,
    Margin,
    limit_margins,
)
from db.models import ApiToken, FleetLimit
from db.types import utc_now

WHEEL_PROFILES = ("EN", "LM")

DEFAULT_LIMITS_MM: dict[str, dict[str, float]] = {
    "EN": {
        "flange_height_min_mm": 27.5,
        "flange_height_max_mm": 36.0,
        "flange_thickness_min_mm": 22.0,
        "flange_thickness_max_mm": 33.0,
        "qr_min_mm": 6.5,
        "back_to_back_min_mm": 1357.0,
        "back_to_back_max_mm": 1363.0,
        "conicity_max": 0.4,
    },
    "LM": {
        "flange_height_min_mm": 25.0,
        "flange_height_max_mm": 33.0,
        "flange_thickness_min_mm": 23.0,
        "flange_thickness_max_mm": 34.0,
        "qr_min_mm": 6.5,
        "back_to_back_min_mm": 1350.0,
        "back_to_back_max_mm": 1356.0,
        "conicity_max": 0.4,
    },
}

REFERENCE_PROFILE_FAMILY = {"S1002": "EN", "LMA": "LM", "LM": "LM"}

LIMIT_FIELDS = tuple(DEFAULT_LIMITS_MM["EN"])
ALARM_NAMES = {p.key: p.alarm_name for p in PARAMETERS}


@dataclass(frozen=True, slots=True)
class Alarm:
    """One parameter outside its limit."""

    parameter: str
    value_mm: float
    bound: str
    limit_mm: float

    def as_dict(self) -> dict[str, Any]:
        word = "below" if self.bound == "min" else "above"
        unit = " mm" if self.parameter.endswith("_mm") else ""
        digits = 2 if unit else 3
        return {
            "parameter": self.parameter,
            "value_mm": self.value_mm,
            "bound": self.bound,
            "limit_mm": self.limit_mm,
            "message": f"{self.parameter} {self.value_mm:.{digits}f}{unit} is {word} "
            f"{self.limit_mm:g}{unit}",
        }


def profile_family(reference_profile: str | None) -> str:
    """EN or LM: which limit set applies to a wheel measured against `reference_profile`."""
    return REFERENCE_PROFILE_FAMILY.get((reference_profile or "").upper(), "EN")


def ensure_default_limits(session: Session, fleet: str = "default") -> None:
    """Insert the default limits of `fleet` where it has none yet (never overwrites edits)."""
    present = set(
        session.scalars(select(FleetLimit.wheel_profile).where(FleetLimit.fleet == fleet))
    )
    for family in WHEEL_PROFILES:
        if family not in present:
            session.add(FleetLimit(fleet=fleet, wheel_profile=family, **DEFAULT_LIMITS_MM[family]))
    session.flush()


def fleet_limits(session: Session, fleet: str) -> list[FleetLimit]:
    """The limits of `fleet` for both profile families (its defaults stored on first use)."""
    ensure_default_limits(session, fleet)
    session.commit()
    return list(
        session.scalars(
            select(FleetLimit).where(FleetLimit.fleet == fleet).order_by(FleetLimit.wheel_profile)
        )
    )


def replace_limits(
    session: Session, admin: ApiToken, fleet: str, wheel_profile: str, body: LimitsUpdate
) -> FleetLimit:
    """Replace the limits of one fleet and profile family (audited, committed); each
    minimum must be below its maximum."""
    for stem in ("flange_height", "flange_thickness", "back_to_back"):
        low, high = getattr(body, f"{stem}_min_mm"), getattr(body, f"{stem}_max_mm")
        if low >= high:
            raise InvalidInputError(f"{stem}_min_mm ({low}) must be below {stem}_max_mm ({high})")
    ensure_default_limits(session, fleet)
    row = session.scalars(
        select(FleetLimit).where(
            FleetLimit.fleet == fleet, FleetLimit.wheel_profile == wheel_profile
        )
    ).one()
    before = LimitsRead.model_validate(row).model_dump(mode="json")
    # review thresholds left out of the body keep their values
    for name, value in body.model_dump(exclude_none=True).items():
        setattr(row, name, value)
    row.updated_at = utc_now()
    record_audit(
        session,
        admin,
        "limits.update",
        "fleet_limit",
        f"{fleet}/{wheel_profile}",
        {"before": before, "after": body.model_dump(exclude_none=True)},
    )
    session.commit()
    return row


def limits_for(session: Session, fleet: str, family: str) -> dict[str, float]:
    """The limits of `fleet` for a profile family, falling back to the defaults."""
    row = session.scalar(
        select(FleetLimit).where(FleetLimit.fleet == fleet, FleetLimit.wheel_profile == family)
    )
    if row is None:
        return dict(DEFAULT_LIMITS_MM[family])
    return {name: getattr(row, name) for name in LIMIT_FIELDS}


def review_thresholds(session: Session, fleet: str, family: str) -> tuple[float, float]:
    """The fleet's amber band (fraction of each limit band) and its method-disagreement
    threshold [mm] for a profile family, falling back to the defaults."""
    row = session.scalar(
        select(FleetLimit).where(FleetLimit.fleet == fleet, FleetLimit.wheel_profile == family)
    )
    if row is None:
        return NEAR_LIMIT_FRACTION, METHOD_DISAGREEMENT_MM
    return row.near_limit_fraction, row.method_disagreement_mm


def alarms_of(margins: list[Margin]) -> list[dict[str, Any]]:
    """The alarms (parameters outside their band) among a wheel's margins, as plain dicts.

    For EN limits the flange thickness checked is the one at the EN height (10 mm); for LM
    limits the one at 12 mm; either is reported as the `flange_thickness_mm` alarm.
    """
    return [
        Alarm(ALARM_NAMES[m.parameter], m.value_mm, m.bound, m.limit_mm).as_dict()
        for m in margins
        if m.status == ALARM
    ]


def evaluate_alarms(
    parameters_mm: dict[str, float | None], limits_mm: dict[str, float], family: str
) -> list[dict[str, Any]]:
    """Compare a wheel's parameters with limits; returns the alarms as plain dicts.
    Missing parameters (None) raise no alarm."""
    return alarms_of(limit_margins(parameters_mm, limits_mm, family))
