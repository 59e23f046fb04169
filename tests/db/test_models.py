"""Models: constraints and types behave alike on SQLite and PostgreSQL."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta, timezone

import pytest
from sqlalchemy.exc import IntegrityError

from db.models import Calibration, Frame, Pass, Site, Wheel


def make_site_with_pass(session) -> Pass:
    site = Site(name="Depot A")
    session.add(site)
    session.flush()
    calibration = Calibration(site_id=site.id, version=1, sha256="0" * 64, document={"a": [1]})
    session.add(calibration)
    session.flush()
    train_pass = Pass(
        site_id=site.id,
        calibration_id=calibration.id,
        started_at=datetime(2026, 5, 1, 12, tzinfo=UTC),
        source="upload",
    )
    session.add(train_pass)
    session.flush()
    return train_pass


def test_timestamps_come_back_as_utc_whatever_zone_went_in(session) -> None:
    train_pass = make_site_with_pass(session)
    train_pass.started_at = datetime(2026, 5, 1, 14, tzinfo=timezone(timedelta(hours=2)))
    session.flush()
    session.expire_all()
    assert session.get(Pass, train_pass.id).started_at == datetime(2026, 5, 1, 12, tzinfo=UTC)
    assert session.get(Pass, train_pass.id).started_at.utcoffset() == timedelta(0)


def test_naive_timestamps_are_refused(session) -> None:
    session.add(Site(name="naive", created_at=datetime(2026, 1, 1)))
    with pytest.raises(Exception, match="timezone-aware"):
        session.flush()


def test_one_frame_per_sensor_and_sequence_number(session) -> None:
    train_pass = make_site_with_pass(session)
    fields = {"vehicle_id": "V1", "axle": 1, "width_px": 8, "height_px": 8, "bit_depth": 8}
    session.add(Frame(pass_id=train_pass.id, sensor="left_inner", seq=0, sha256="a" * 64, **fields))
    session.flush()
    session.add(Frame(pass_id=train_pass.id, sensor="left_inner", seq=0, sha256="b" * 64, **fields))
    with pytest.raises(IntegrityError):
        session.flush()


def test_a_wheel_is_one_row_per_vehicle_axle_and_side(session) -> None:
    session.add(Wheel(vehicle_id="V1", axle=1, side="left"))
    session.add(Wheel(vehicle_id="V1", axle=1, side="right"))
    session.flush()
    session.add(Wheel(vehicle_id="V1", axle=1, side="left"))
    with pytest.raises(IntegrityError):
        session.flush()


def test_json_columns_keep_nested_numbers(session) -> None:
    train_pass = make_site_with_pass(session)
    session.expire_all()
    assert session.get(Calibration, train_pass.calibration_id).document == {"a": [1]}
