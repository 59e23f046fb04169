"""A wheel across passes: its parameters per method, the limits that apply, and a wear
forecast per parameter (when the robust linear fit reaches the nearest limit).

Passes carry no odometry yet, so wear rates are per day of pass time (UTC); the schema's
`per` says which unit a rate is in.
"""

from __future__ import annotations

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
from pipeline.profile.wear import TooFewPointsError, fit_wear, limit_crossing

METHODS = ("adaptive", "steger")
Bound = Literal["min", "max"]
DAY_S = 86400.0
FORECAST_HORIZON_DAYS = 3650.0
"""Crossings beyond ten years say "not within 10 years" rather than a date."""


def _when(origin: datetime, days: float | None) -> datetime | None:
    if days is None or not np.isfinite(days) or days > FORECAST_HORIZON_DAYS * 2:
        return None
    return origin + timedelta(days=days)


def _forecast(
    parameter: Parameter,
    points: list[TrendPoint],
    limits_mm: dict[str, float],
    near_limit_fraction: float,
) -> TrendForecast | None:
    usable = [p for p in points if getattr(p, parameter.key) is not None]
    if not usable:
        return None
    origin = usable[0].started_at
    days = np.array([(p.started_at - origin).total_seconds() / DAY_S for p in usable])
    values = np.array([getattr(p, parameter.key) for p in usable], dtype=np.float64)
    try:
        fit = fit_wear(days, values)
    except TooFewPointsError as exc:
        return TrendForecast(
            parameter=parameter.key, per="day", rate_mm=0.0, rate_low_mm=0.0, rate_high_mm=0.0,
            points=len(usable), bound=None, limit_mm=None, near_mm=None, reached_at=None,
            reached_earliest=None, reached_latest=None, note=str(exc),
        )  # fmt: skip
    low = limits_mm.get(f"{parameter.limit}_min_mm")
    high = limits_mm.get(f"{parameter.limit}_max_mm")
    # the limit the line heads for (a falling or flat line: the lower one, if any)
    bound: Bound | None = None
    limit: float | None = None
    if high is not None and (low is None or fit.rate > 0):
        bound, limit = "max", high
    elif low is not None:
        bound, limit = "min", low
    near = None
    if low is not None and high is not None and limit is not None:
        inset = near_limit_fraction * (high - low)
        near = limit - inset if bound == "max" else limit + inset
    crossing = limit_crossing(fit, limit) if limit is not None else None
    # the wheel was within its limit at its last pass: no end of the interval is earlier
    last_day = float(days.max())
    reached = _when(origin, crossing.x) if crossing else None
    earliest = None
    if crossing and crossing.x_earliest is not None:
        earliest = _when(origin, max(crossing.x_earliest, last_day))
    beyond = limit is not None and (values[-1] > limit if bound == "max" else values[-1] < limit)
    if beyond:
        note = "beyond the limit at the last pass"
    elif reached:
        note = f"robust linear fit of {fit.points} passes; limit reached {reached:%Y-%m-%d} UTC"
    else:
        note = "the fit does not reach a limit within 10 years"
    return TrendForecast(
        parameter=parameter.key,
        per="day",
        rate_mm=fit.rate,
        rate_low_mm=fit.rate_low,
        rate_high_mm=fit.rate_high,
        points=fit.points,
        bound=bound,
        limit_mm=limit,
        near_mm=near,
        reached_at=reached,
        reached_earliest=earliest,
        reached_latest=_when(origin, crossing.x_latest) if crossing else None,
        note=note,
        intercept_mm=fit.intercept,
        fit_from=origin,
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
