"""Live ingest (README: live streaming): open a pass, put frames in any order, close it.

Frames are idempotent by sha256 and may come in any order and twice; a wheel whose two
sensors have all their frames is queued for measurement at once (claimed by one atomic
UPDATE, so two concurrent requests never queue it twice).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

from sqlalchemy import func, select, update
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from backend.api.schemas import MissingSensor, StreamOpen
from backend.errors import ConflictError, InvalidInputError
from backend.services.auth import record_audit
from backend.services.pass_wheels import (
    create_job,
    create_pass,
    get_or_create_wheel,
    refresh_job,
    rows_changed,
)
from backend.services.sites import (
    add_calibration_version,
    current_calibration,
    get_or_create_site,
    validate_calibration_document,
)
from backend.storage.store import BlobStore
from db.models import SENSORS, ApiToken, Calibration, Frame, Job, Pass, PassWheel, Site, Wheel
from db.types import utc_now
from pipeline.archive.pass_archive import decode_frame, png_header
from pipeline.calibration.model import parse_calibration
from pipeline.errors import ArchiveError


@dataclass(frozen=True, slots=True)
class FrameStored:
    """Outcome of a frame PUT: its sha256, whether it was new, and the wheel's state."""

    sha256: str
    created: bool
    wheel_complete: bool
    queued_pass_wheel_id: int | None


def open_stream(session: Session, body: StreamOpen, token: ApiToken) -> tuple[Pass, Job]:
    """Create an open pass and its job; the calibration is the given one or the site's.

    Refused requests create nothing: the calibration is checked before the site is made.
    """
    site = session.scalar(select(Site).where(Site.name == body.site))
    calibration: Calibration | None
    if body.calibration is not None:
        station = validate_calibration_document(body.calibration)
        site = site or get_or_create_site(session, body.site)
        calibration = add_calibration_version(
            session, site, station, registered=False, note="sent with a streamed pass"
        )
    elif site is None or (calibration := current_calibration(session, site)) is None:
        raise InvalidInputError(
            f"site {body.site!r} has no registered calibration: send one in 'calibration' "
            f"or register it (POST /api/sites/{body.site}/calibrations)"
        )
    train_pass = create_pass(
        session,
        site.id,
        calibration.id,
        body,
        source="stream",
        odometer_km=body.odometer_km,
        state="open",
        frames_per_sensor=body.frames_per_sensor,
        vehicles=[],
    )
    job = create_job(session, train_pass, wheels_total=0)
    record_audit(session, token, "pass.stream.open", "pass", train_pass.id)
    session.commit()
    return train_pass, job


def _check_frame(data: bytes, calibration: Calibration, sensor: str) -> tuple[int, int, int]:
    """(width_px, height_px, bit_depth) of a frame that fits its sensor, else 422.

    The PNG header is checked against the sensor before anything is decoded.
    """
    expected = parse_calibration(calibration.document).sensor(sensor)
    wanted = (expected.image_width_px, expected.image_height_px, expected.bit_depth)
    try:
        header = png_header(data, f"{sensor} frame")
        if header != wanted:
            raise InvalidInputError(
                f"frame is {header[0]}x{header[1]} px {header[2]} bit, but sensor {sensor} is "
                f"calibrated for {wanted[0]}x{wanted[1]} px {wanted[2]} bit"
            )
        decode_frame(data, f"{sensor} frame")
    except ArchiveError as exc:
        raise InvalidInputError(f"{exc}; send the PNG bytes as the request body") from None
    return wanted


def _frame_count(session: Session, pass_id: int, vehicle_id: str, axle: int, sensor: str) -> int:
    count = session.scalar(
        select(func.count(Frame.id)).where(
            Frame.pass_id == pass_id,
            Frame.vehicle_id == vehicle_id,
            Frame.axle == axle,
            Frame.sensor == sensor,
        )
    )
    return count or 0


def _pass_wheel(session: Session, train_pass: Pass, wheel: Wheel) -> PassWheel:
    query = select(PassWheel).where(
        PassWheel.pass_id == train_pass.id, PassWheel.wheel_id == wheel.id
    )
    pass_wheel = session.scalar(query)
    if pass_wheel is not None:
        return pass_wheel
    try:
        with session.begin_nested():
            pass_wheel = PassWheel(pass_id=train_pass.id, wheel_id=wheel.id, state="receiving")
            session.add(pass_wheel)
    except IntegrityError:
        pass_wheel = session.scalars(query).one()
    return pass_wheel


def _existing_frame(session: Session, train_pass: Pass, sensor: str, seq: int) -> Frame | None:
    return session.scalar(
        select(Frame).where(
            Frame.pass_id == train_pass.id, Frame.sensor == sensor, Frame.seq == seq
        )
    )


def _same_or_conflict(frame: Frame, sha256: str, vehicle_id: str, axle: int) -> None:
    if frame.sha256 != sha256:
        raise ConflictError(
            f"{frame.sensor} frame {frame.seq} is already stored with a different image "
            f"(sha256 {frame.sha256[:12]}…); frames are immutable"
        )
    if (frame.vehicle_id, frame.axle) != (vehicle_id, axle):
        raise ConflictError(
            f"{frame.sensor} frame {frame.seq} is stored for vehicle {frame.vehicle_id!r} "
            f"axle {frame.axle}, not {vehicle_id!r} axle {axle}"
        )


def _wheel_complete(session: Session, train_pass: Pass, pass_wheel: PassWheel) -> bool:
    wheel = pass_wheel.wheel
    return all(
        _frame_count(session, train_pass.id, wheel.vehicle_id, wheel.axle, f"{wheel.side}_{p}")
        >= train_pass.frames_per_sensor
        for p in ("inner", "outer")
    )


def _claim_for_measurement(session: Session, pass_wheel: PassWheel) -> bool:
    """receiving → queued, atomically; True for the one caller that made the change."""
    changed = rows_changed(
        session,
        update(PassWheel)
        .where(PassWheel.id == pass_wheel.id, PassWheel.state == "receiving")
        .values(state="queued"),
    )
    return changed == 1


def _lock_pass(session: Session, train_pass: Pass) -> None:
    """Serialise the frame writes of one pass, then read its state afresh.

    A write to the pass row is the one lock both databases take the same way (a row lock
    on PostgreSQL, the write lock on SQLite, which has no SELECT … FOR UPDATE): without it,
    concurrent PUTs each counted the frames before any had stored its own (20 PUTs for
    one frame per sensor stored up to 9). The read transaction is ended first, so that
    SQLite's write starts from the newest data.
    """
    session.commit()
    session.execute(
        update(Pass)
        .where(Pass.id == train_pass.id)
        .values(state=Pass.state)
        .execution_options(synchronize_session=False)
    )
    session.refresh(train_pass)


def put_frame(
    session: Session,
    store: BlobStore,
    train_pass: Pass,
    *,
    sensor: str,
    seq: int,
    vehicle_id: str,
    axle: int,
    data: bytes,
    token: ApiToken,
) -> FrameStored:
    """Store one streamed frame (idempotent) and queue its wheel when that is complete."""
    if sensor not in SENSORS:
        raise InvalidInputError(f"sensor must be one of {', '.join(SENSORS)}, got {sensor!r}")
    sha256 = hashlib.sha256(data).hexdigest()
    width_px, height_px, depth = _check_frame(data, train_pass.calibration, sensor)
    _lock_pass(session, train_pass)
    wheel = get_or_create_wheel(session, vehicle_id, axle, sensor.split("_")[0])
    found = _existing_frame(session, train_pass, sensor, seq)
    if found is not None:
        _same_or_conflict(found, sha256, vehicle_id, axle)
        pass_wheel = _pass_wheel(session, train_pass, wheel)
        return FrameStored(sha256, False, pass_wheel.state != "receiving", None)
    if train_pass.state != "open":
        raise ConflictError(f"pass {train_pass.id} is closed; open a new pass to add frames")
    pass_wheel = _pass_wheel(session, train_pass, wheel)
    if pass_wheel.state != "receiving":
        raise ConflictError(
            f"wheel {vehicle_id} axle {axle} {wheel.side} takes no more frames: "
            f"it is {pass_wheel.state.replace('_', ' ')}"
        )
    if (
        _frame_count(session, train_pass.id, vehicle_id, axle, sensor)
        >= train_pass.frames_per_sensor
    ):
        raise ConflictError(
            f"wheel {vehicle_id} axle {axle} {wheel.side} already has "
            f"{train_pass.frames_per_sensor} {sensor} frame(s) (the pass's frames_per_sensor)"
        )
    store.put(data, ".png")
    frame = Frame(
        pass_id=train_pass.id,
        sensor=sensor,
        seq=seq,
        sha256=sha256,
        vehicle_id=vehicle_id,
        axle=axle,
        width_px=width_px,
        height_px=height_px,
        bit_depth=depth,
    )
    session.add(frame)
    session.flush()
    complete = _wheel_complete(session, train_pass, pass_wheel)
    queued = complete and _claim_for_measurement(session, pass_wheel)
    record_audit(
        session, token, "pass.stream.frame", "pass", train_pass.id,
        {"sensor": sensor, "seq": seq, "sha256": sha256},
    )  # fmt: skip
    session.commit()
    refresh_job(session, train_pass.id)
    return FrameStored(sha256, True, complete, pass_wheel.id if queued else None)


def declare_missing(
    session: Session, train_pass: Pass, body: MissingSensor, token: ApiToken
) -> PassWheel:
    """Mark a wheel "not measured" because a sensor delivered no frames for it."""
    if body.sensor.split("_")[0] != body.side:
        raise InvalidInputError(f"sensor {body.sensor} is not on the {body.side} side")
    if train_pass.state != "open":
        raise ConflictError(f"pass {train_pass.id} is closed")
    wheel = get_or_create_wheel(session, body.vehicle_id, body.axle, body.side)
    pass_wheel = _pass_wheel(session, train_pass, wheel)
    reason = f"frames missing: {body.sensor} ({body.reason})"
    changed = rows_changed(
        session,
        update(PassWheel)
        .where(PassWheel.id == pass_wheel.id, PassWheel.state == "receiving")
        .values(
            state="not_measured",
            reason=reason,
            missing_sensors=[body.sensor],
            finished_at=utc_now(),
        ),
    )
    if changed != 1:
        session.rollback()
        raise ConflictError(
            f"wheel {body.vehicle_id} axle {body.axle} {body.side} is already "
            f"{pass_wheel.state.replace('_', ' ')}"
        )
    record_audit(session, token, "pass.wheel.missing", "pass", train_pass.id, body.model_dump())
    session.commit()
    refresh_job(session, train_pass.id)
    session.refresh(pass_wheel)
    return pass_wheel


def close_pass(session: Session, train_pass: Pass, token: ApiToken) -> tuple[Job, bool]:
    """Close an open pass; wheels still incomplete become "not measured". Idempotent.

    Returns the job and whether this call closed the pass (False when it was closed).
    """
    job = session.scalars(select(Job).where(Job.pass_id == train_pass.id).limit(1)).one()
    closed = rows_changed(
        session,
        update(Pass)
        .where(Pass.id == train_pass.id, Pass.state == "open")
        .values(state="closed", closed_at=utc_now()),
    )
    if closed != 1:
        session.rollback()
        return job, False
    for pass_wheel in session.scalars(
        select(PassWheel).where(PassWheel.pass_id == train_pass.id, PassWheel.state == "receiving")
    ):
        missing = _missing_sensors(session, train_pass, pass_wheel)
        pass_wheel.state = "not_measured"
        pass_wheel.missing_sensors = missing
        pass_wheel.reason = f"frames missing: {', '.join(missing)}"
        pass_wheel.finished_at = utc_now()
    record_audit(session, token, "pass.stream.close", "pass", train_pass.id)
    session.commit()
    return refresh_job(session, train_pass.id), True


def _missing_sensors(session: Session, train_pass: Pass, pass_wheel: PassWheel) -> list[str]:
    wheel = pass_wheel.wheel
    sensors = [f"{wheel.side}_{p}" for p in ("inner", "outer")]
    return [
        s
        for s in sensors
        if _frame_count(session, train_pass.id, wheel.vehicle_id, wheel.axle, s)
        < train_pass.frames_per_sensor
    ]


def list_frames(session: Session, train_pass: Pass) -> list[Frame]:
    """Every frame stored for a pass (what a resuming sender may skip)."""
    return list(
        session.scalars(
            select(Frame).where(Frame.pass_id == train_pass.id).order_by(Frame.sensor, Frame.seq)
        )
    )
