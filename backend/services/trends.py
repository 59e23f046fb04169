"""A wheel across passes: its parameters per method, the limits that apply, and a wear
forecast per parameter (when the robust linear fit reaches the nearest limit).

Wear is fitted per 1,000 km of the vehicle's odometer when every pass of the wheel carries
its vehicle's reading (the pass manifest's `odometer_km`), and the forecast is an odometer
reading; otherwise per day of pass time (UTC), and the forecast is a date. The schema's
`per` says which.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timedelta
from typing import Literal, cast

import numpy as np
from sqlalchemy import select
from sqlalchemy.orm import Session

from backend.api.schemas import Side, TrendForecast, TrendPoint, WheelLimits, WheelTrend
from backend.services.limits import limits_for, profile_family, review_thresholds
from backend.services.margins import PARAMETERS, Parameter
from backend.services.results import PARAMETER_NAMES
from backend.services.review import PRIMARY_METHOD
from db.models import Pass, PassWheel, Wheel
from pipeline.profile.wear import LimitCrossing, TooFewPointsError, fit_wear, limit_crossing

METHODS = ("adaptive", "steger")
Bound = Literal["min", "max"]
DAY_S = 86400.0
KM_PER_UNIT = 1000.0
"""Odometer rates are per 1,000 km."""
FORECAST_HORIZON_DAYS = 3650.0
"""Crossings beyond ten years say "not within 10 years" rather than a date."""
FORECAST_HORIZON_KM = 2_000_000.0
"""Crossings beyond 2 million km (a wheelset's whole life) say so rather than a reading."""


@dataclass(frozen=True, slots=True)
class _Axis:
    """The fit's x: days since the first pass, or thousands of km since its odometer."""

    per: Literal["day", "1000 km"]
    x: np.ndarray
    origin: datetime
    origin_km: float | None


def _axis(usable: list[TrendPoint]) -> _Axis:
    origin = usable[0].started_at
    readings = [p.odometer_km for p in usable]
    if all(km is not None for km in readings) and len(set(readings)) >= 2:
        km = np.array(readings, dtype=np.float64)
        return _Axis("1000 km", (km - km[0]) / KM_PER_UNIT, origin, float(km[0]))
    days = np.array([(p.started_at - origin).total_seconds() / DAY_S for p in usable])
    return _Axis("day", days, origin, None)


def _when(origin: datetime, days: float | None) -> datetime | None:
    if days is None or not np.isfinite(days) or days > FORECAST_HORIZON_DAYS * 2:
        return None
    return origin + timedelta(days=days)


def _where(origin_km: float, units: float | None) -> float | None:
    if units is None or not np.isfinite(units):
        return None
    km = origin_km + units * KM_PER_UNIT
    return km if km - origin_km <= FORECAST_HORIZON_KM * 2 else None


@dataclass(frozen=True, slots=True)
class _Reached:
    """Where the fit and its interval's ends reach the limit: dates (per day) or odometer
    readings [km] (per 1,000 km); None where not within the horizon."""

    at: datetime | None = None
    at_earliest: datetime | None = None
    at_latest: datetime | None = None
    km: float | None = None
    km_earliest: float | None = None
    km_latest: float | None = None


def _reached(axis: _Axis, crossing: LimitCrossing | None) -> _Reached:
    if crossing is None:
        return _Reached()
    # the wheel was within its limit at its last pass: no end of the interval is earlier
    earliest = None if crossing.x_earliest is None else max(crossing.x_earliest, axis.x.max())
    if axis.origin_km is None:
        return _Reached(
            at=_when(axis.origin, crossing.x),
            at_earliest=_when(axis.origin, earliest),
            at_latest=_when(axis.origin, crossing.x_latest),
        )
    return _Reached(
        km=_where(axis.origin_km, crossing.x),
        km_earliest=_where(axis.origin_km, earliest),
        km_latest=_where(axis.origin_km, crossing.x_latest),
    )


def _target(
    parameter: Parameter, rate: float, limits_mm: dict[str, float], near_limit_fraction: float
) -> tuple[Bound | None, float | None, float | None]:
    """The limit the line heads for (a falling or flat line: the lower one, if any), its
    bound and the amber threshold on that side [mm]."""
    low = limits_mm.get(f"{parameter.limit}_min_mm")
    high = limits_mm.get(f"{parameter.limit}_max_mm")
    bound: Bound | None = None
    limit: float | None = None
    if high is not None and (low is None or rate > 0):
        bound, limit = "max", high
    elif low is not None:
        bound, limit = "min", low
    near = None
    if low is not None and high is not None and limit is not None:
        inset = near_limit_fraction * (high - low)
        near = limit - inset if bound == "max" else limit + inset
    return bound, limit, near


def _forecast(
    parameter: Parameter,
    points: list[TrendPoint],
    limits_mm: dict[str, float],
    near_limit_fraction: float,
) -> TrendForecast | None:
    usable = [p for p in points if getattr(p, parameter.key) is not None]
    if not usable:
        return None
    axis = _axis(usable)
    values = np.array([getattr(p, parameter.key) for p in usable], dtype=np.float64)
    try:
        fit = fit_wear(axis.x, values)
    except TooFewPointsError as exc:
        return TrendForecast(
            parameter=parameter.key, per=axis.per, rate_mm=0.0, rate_low_mm=0.0,
            rate_high_mm=0.0, points=len(usable), bound=None, limit_mm=None, near_mm=None,
            reached_at=None, reached_earliest=None, reached_latest=None, note=str(exc),
        )  # fmt: skip
    bound, limit, near = _target(parameter, fit.rate, limits_mm, near_limit_fraction)
    reached = _reached(axis, limit_crossing(fit, limit) if limit is not None else None)
    beyond = limit is not None and (values[-1] > limit if bound == "max" else values[-1] < limit)
    last_km = usable[-1].odometer_km if axis.origin_km is not None else None
    if beyond:
        note = "beyond the limit at the last pass"
    elif reached.at is not None:
        note = f"robust linear fit of {fit.points} passes; limit reached {reached.at:%Y-%m-%d} UTC"
    elif reached.km is not None:
        note = f"robust linear fit of {fit.points} passes; limit reached at {reached.km:,.0f} km"
    elif axis.origin_km is None:
        note = "the fit does not reach a limit within 10 years"
    else:
        note = f"the fit does not reach a limit within {FORECAST_HORIZON_KM:,.0f} km"
    return TrendForecast(
        parameter=parameter.key,
        per=axis.per,
        rate_mm=fit.rate,
        rate_low_mm=fit.rate_low,
        rate_high_mm=fit.rate_high,
        points=fit.points,
        bound=bound,
        limit_mm=limit,
        near_mm=near,
        reached_at=reached.at,
        reached_earliest=reached.at_earliest,
        reached_latest=reached.at_latest,
        note=note,
        intercept_mm=fit.intercept,
        fit_from=axis.origin,
        fit_from_km=axis.origin_km,
        reached_km=reached.km,
        reached_km_earliest=reached.km_earliest,
        reached_km_latest=reached.km_latest,
        last_km=last_km,
    )


def wheel_trend(session: Session, wheel: Wheel) -> WheelTrend:
    """One wheel across passes, oldest first, with its limits and wear forecasts (from
    the adaptive results and the limits of its newest pass's fleet)."""
    rows = session.execute(
        select(PassWheel, Pass)
        .join(Pass, PassWheel.pass_id == Pass.id)
        .where(PassWheel.wheel_id == wheel.id)
        .order_by(Pass.started_at, Pass.id)
    ).all()
    points = [
        TrendPoint(
            pass_id=train_pass.id,
            started_at=train_pass.started_at,
            odometer_km=(train_pass.odometer_km or {}).get(wheel.vehicle_id),
            site=train_pass.site.name,
            method=m.method,
            status=m.status,
            **{name: getattr(m, name) for name in PARAMETER_NAMES},
            alarm_count=m.alarm_count,
        )
        for pass_wheel, train_pass in rows
        for m in pass_wheel.measurements
        if m.method in METHODS
    ]
    primary = [p for p in points if p.method == PRIMARY_METHOD and p.status == "measured"]
    limits = None
    forecasts = []
    newest = next(
        (m for pw, _ in reversed(rows) for m in pw.measurements if m.method == PRIMARY_METHOD),
        None,
    )
    if primary and newest is not None:
        fleet = rows[-1][1].fleet
        family = profile_family(newest.reference_profile)
        limits_mm = limits_for(session, fleet, family)
        near_limit_fraction, _ = review_thresholds(session, fleet, family)
        limits = WheelLimits(
            wheel_profile=family, limits_mm=limits_mm, near_limit_fraction=near_limit_fraction
        )
        for parameter in PARAMETERS:
            if family in parameter.families:
                forecast = _forecast(parameter, primary, limits_mm, near_limit_fraction)
                if forecast is not None:
                    forecasts.append(forecast)
    return WheelTrend(
        wheel_id=wheel.id,
        vehicle_id=wheel.vehicle_id,
        axle=wheel.axle,
        side=cast(Side, wheel.side),
        points=points,
        limits=limits,
        forecasts=forecasts,
    )
