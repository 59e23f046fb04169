"""Ingest of an uploaded pass archive: validate everything, then store it in one go.

Nothing is stored before the whole archive has been validated (zip safety, manifest,
calibration, every frame decoded and checked against its sensor's calibration). Frames go
into the content-addressed store, rows into one transaction; a repeated upload of the same
archive (same sha256) returns the pass already made from it.
"""

from __future__ import annotations

import hashlib
import tempfile
from pathlib import Path
from typing import BinaryIO

from sqlalchemy import select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from backend.config import Settings
from backend.errors import InvalidInputError, PayloadTooLargeError
from backend.services.auth import record_audit
from backend.services.pass_wheels import create_job, create_pass, get_or_create_wheel
from backend.services.sites import add_calibration_version, current_calibration, get_or_create_site
from backend.storage.store import BlobStore, temporary_prefix
from db.models import ApiToken, Calibration, Frame, Job, Pass, PassWheel, Site
from pipeline.archive.manifest import POSITIONS, WheelEntry
from pipeline.archive.pass_archive import ArchiveLimits, PassArchive, read_pass_archive
from pipeline.calibration.model import StationCalibration, parse_calibration
from pipeline.errors import ArchiveError

COPY_CHUNK_BYTES = 1024 * 1024


def archive_limits(settings: Settings) -> ArchiveLimits:
    """Zip safety limits from the settings."""
    return ArchiveLimits(
        max_members=settings.max_archive_members,
        max_member_bytes=settings.max_frame_bytes,
        max_total_bytes=settings.max_uncompressed_bytes,
        max_compression_ratio=settings.max_compression_ratio,
    )


def incoming_dir(settings: Settings) -> Path:
    """Where uploads are received before they are validated and stored."""
    return settings.data_dir / "incoming"


def receive_upload(stream: BinaryIO, settings: Settings) -> tuple[Path, str]:
    """Copy an upload into a private temporary file, enforcing the size limit.

    Returns the file's path and the sha256 of its bytes; the caller removes the file.
    """
    incoming = incoming_dir(settings)
    incoming.mkdir(parents=True, exist_ok=True)
    digest = hashlib.sha256()
    handle = tempfile.NamedTemporaryFile(
        dir=incoming, prefix=temporary_prefix(), suffix=".zip", delete=False
    )
    size_bytes = 0
    try:
        with handle:
            while chunk := stream.read(COPY_CHUNK_BYTES):
                size_bytes += len(chunk)
                if size_bytes > settings.max_upload_bytes:
                    raise PayloadTooLargeError(
                        f"upload is larger than {settings.max_upload_bytes} bytes; "
                        "split the pass or raise WHEELSCAN_MAX_UPLOAD_BYTES"
                    )
                digest.update(chunk)
                handle.write(chunk)
        if size_bytes == 0:
            raise InvalidInputError("the uploaded file is empty; send a wheelscan-pass/1 zip")
    except BaseException:
        Path(handle.name).unlink(missing_ok=True)  # refused, or the disk is full: keep nothing
        raise
    return Path(handle.name), digest.hexdigest()


def existing_upload(session: Session, archive_sha256: str) -> tuple[Pass, Job] | None:
    """The pass (and its job) already made from the archive with this sha256, if any."""
    train_pass = session.scalar(select(Pass).where(Pass.archive_sha256 == archive_sha256))
    if train_pass is None:
        return None
    job = session.scalars(
        select(Job).where(Job.pass_id == train_pass.id).order_by(Job.id).limit(1)
    ).one()
    return train_pass, job


def validate_archive(session: Session, path: Path, settings: Settings) -> PassArchive:
    """Fully validate an archive (no side effects); InvalidInputError says what to fix.

    The caller closes the returned archive once its frames are stored.
    """
    limits = archive_limits(settings)
    try:
        site_calibration = None
        headers = read_pass_archive(path, decode_frames=False, limits=limits)
        headers.close()
        if not headers.has_own_calibration:
            site_name = headers.manifest.site
            site = session.scalar(select(Site).where(Site.name == site_name))
            registered = current_calibration(session, site) if site is not None else None
            if registered is None:
                raise InvalidInputError(
                    f"site {site_name!r} has no registered calibration: put "
                    "calibration.json in the archive or register one "
                    f"(POST /api/sites/{site_name}/calibrations)"
                )
            site_calibration = parse_calibration(registered.document)
        return read_pass_archive(
            path, site_calibration=site_calibration, decode_frames=True, limits=limits
        )
    except ArchiveError as exc:
        # the reader's own words may already name the pass archive; say it once
        words = str(exc)
        raise InvalidInputError(
            words if words.startswith("pass archive") else f"pass archive: {words}"
        ) from None


def store_archive(
    session: Session,
    store: BlobStore,
    archive: PassArchive,
    archive_sha256: str,
    token: ApiToken | None,
) -> tuple[Pass, Job, list[int]]:
    """Store a validated archive: frames, pass, wheels (queued) and job, then commit.

    Returns the pass, its job and the ids of the pass wheels to measure. Concurrent uploads
    of the same archive all get the pass of the one that committed first (the others'
    rows collide on its archive_sha256, at their flush or at their commit).
    """
    manifest = archive.manifest
    # The frames go to the store before the first row: a SQLite writer holds the database's
    # write lock from its first INSERT to its commit, and concurrent uploads queue behind it.
    frame_sha256 = {
        path: store.put(archive.frame_bytes(path), ".png")
        for entry in manifest.wheels
        for position in POSITIONS
        for path in entry.frames(position)
    }
    try:
        train_pass, job, pass_wheel_ids = _add_pass_rows(
            session, archive, archive_sha256, frame_sha256
        )
        record_audit(
            session, token, "pass.upload", "pass", train_pass.id, {"sha256": archive_sha256}
        )
        session.commit()
    except IntegrityError:
        session.rollback()
        found = existing_upload(session, archive_sha256)
        if found is None:
            raise
        return found[0], found[1], []
    return train_pass, job, pass_wheel_ids


def _add_pass_rows(
    session: Session, archive: PassArchive, archive_sha256: str, frame_sha256: dict[str, str]
) -> tuple[Pass, Job, list[int]]:
    manifest, station = archive.manifest, archive.calibration
    if station is None:
        raise InvalidInputError("pass archive: no calibration (validate_archive first)")
    site = get_or_create_site(session, manifest.site)
    calibration: Calibration | None
    if archive.has_own_calibration:
        calibration = add_calibration_version(
            session, site, station, registered=False, note="from an uploaded archive"
        )
    else:
        calibration = current_calibration(session, site)
    if calibration is None:
        raise InvalidInputError(f"site {site.name!r} has no registered calibration")
    train_pass = create_pass(
        session,
        site.id,
        calibration.id,
        manifest,
        source="upload",
        archive_sha256=archive_sha256,
        state="closed",
        frames_per_sensor=max(
            len(w.frames(p)) for w in manifest.wheels for p in ("inner", "outer")
        ),
        vehicles=list(manifest.vehicles),
        odometer_km=dict(manifest.odometer_km) or None,
    )
    train_pass.closed_at = train_pass.created_at
    next_seq: dict[str, int] = {}
    pass_wheel_ids = []
    for entry in manifest.wheels:
        wheel = get_or_create_wheel(session, entry.vehicle_id, entry.axle, entry.side)
        pass_wheel = PassWheel(pass_id=train_pass.id, wheel_id=wheel.id, state="queued")
        session.add(pass_wheel)
        for position in ("inner", "outer"):
            sensor = entry.sensor_name(position)
            for path in entry.frames(position):
                _add_frame(
                    session, station, train_pass, entry, sensor, frame_sha256[path], next_seq
                )
        session.flush()
        pass_wheel_ids.append(pass_wheel.id)
    job = create_job(session, train_pass, wheels_total=len(pass_wheel_ids))
    return train_pass, job, pass_wheel_ids


def _add_frame(
    session: Session,
    station: StationCalibration,
    train_pass: Pass,
    entry: WheelEntry,
    sensor: str,
    sha256: str,
    next_seq: dict[str, int],
) -> None:
    sensor_calibration = station.sensor(sensor)
    seq = next_seq.get(sensor, 0)
    next_seq[sensor] = seq + 1
    session.add(
        Frame(
            pass_id=train_pass.id,
            sensor=sensor,
            seq=seq,
            sha256=sha256,
            vehicle_id=entry.vehicle_id,
            axle=entry.axle,
            width_px=sensor_calibration.image_width_px,
            height_px=sensor_calibration.image_height_px,
            bit_depth=sensor_calibration.bit_depth,
        )
    )


def ingest_upload(
    session: Session, store: BlobStore, settings: Settings, stream: BinaryIO, token: ApiToken
) -> tuple[Pass, Job, list[int]]:
    """Receive, validate and store an uploaded archive (or find the pass made from it).

    Returns the pass, its job and the ids of the pass wheels to measure (none when the
    archive was uploaded before).
    """
    path, archive_sha256 = receive_upload(stream, settings)
    try:
        found = existing_upload(session, archive_sha256)
        if found is not None:
            return found[0], found[1], []
        archive = validate_archive(session, path, settings)
        try:
            return store_archive(session, store, archive, archive_sha256, token)
        finally:
            archive.close()
    finally:
        path.unlink(missing_ok=True)
