"""Handheld-gauge references of wheels: import, and the comparison with the wayside results.

A reference is a gauge's file (MiniProf `.whl`/`.prr`, CSV x, z) for one wheel, read into
the profile frame and measured with the wayside code (`pipeline.profile.exchange`). A pass's
result for a wheel is compared with that wheel's reference measured nearest in time to the
pass; over a set of passes the differences are summarised per parameter and method as in
the paper's Table 2 (mean difference, MAE, Std, max error, n).
"""

from __future__ import annotations

import hashlib
import math
from datetime import datetime
from pathlib import PurePath

from sqlalchemy import select
from sqlalchemy.orm import Session

from backend.api.schemas import (
    AgreementRead,
    AgreementRow,
    ParameterDifference,
    ReferenceComparison,
    ReferenceRead,
)
from backend.errors import InvalidInputError
from backend.services.auth import record_audit
from db.models import ApiToken, HandheldReference, Pass, PassWheel, Wheel
from db.types import utc_now
from pipeline.profile.exchange import handheld_parameters, read_profile_text
from pipeline.profile.repeatability import Observation, summarise_agreement

COMPARED = ("flange_height_mm", "flange_thickness_mm", "flange_thickness_10_mm", "qr_mm")
"""The parameters a handheld gauge measures (it does not see the axle's back-to-back)."""
SUFFIXES = (".whl", ".prr", ".csv")
STORED_DECIMALS = 4


def decode_profile_file(data: bytes, filename: str) -> str:
    """The text of an uploaded profile file (UTF-8, else Latin-1 as older gauges write)."""
    suffix = PurePath(filename).suffix.lower()
    if suffix not in SUFFIXES:
        raise InvalidInputError(
            f"a profile file must end in {', '.join(SUFFIXES)}, got {filename!r}"
        )
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def import_reference(
    session: Session,
    wheel: Wheel,
    filename: str,
    data: bytes,
    measured_at: datetime | None = None,
) -> HandheldReference:
    """Read, measure and store a handheld profile of `wheel` (flushed, not committed).

    The same file for the same wheel is stored once: importing it again returns the row.

    Raises
    ------
    InvalidInputError
        If the file's name has no supported extension.
    ProfileFileError, FlangeNotFoundError
        If the file is no profile, or its flange cannot be measured (both 422).
    """
    text = decode_profile_file(data, filename)
    sha256 = hashlib.sha256(data).hexdigest()
    existing = session.scalar(
        select(HandheldReference).where(
            HandheldReference.wheel_id == wheel.id, HandheldReference.sha256 == sha256
        )
    )
    if existing is not None:
        return existing
    profile = read_profile_text(text, suffix=PurePath(filename).suffix)
    result = handheld_parameters(profile)
    p = result.parameters
    row = HandheldReference(
        wheel_id=wheel.id,
        filename=PurePath(filename).name[:255],
        sha256=sha256,
        instrument=(profile.instrument or None) and profile.instrument[:100],
        measured_on=(profile.measured_on or None) and profile.measured_on[:60],
        measured_at=measured_at or utc_now(),
        x_mm=[round(float(v), STORED_DECIMALS) for v in profile.x_mm],
        z_mm=[round(float(v), STORED_DECIMALS) for v in profile.z_mm],
        z_offset_mm=profile.z_offset_mm,
        flange_height_mm=p.flange_height_mm,
        flange_thickness_mm=p.flange_thickness_mm,
        flange_thickness_10_mm=p.flange_thickness_10_mm,
        qr_mm=p.qr_mm,
        parameter_quality=result.quality,
        instrument_flange_height_mm=profile.instrument_flange_height_mm,
        instrument_flange_thickness_mm=profile.instrument_flange_thickness_mm,
        instrument_qr_mm=profile.instrument_qr_mm,
    )
    session.add(row)
    session.flush()
    return row


def wheel_references(session: Session, wheel_id: int) -> list[ReferenceRead]:
    """A wheel's handheld references, newest measurement first."""
    rows = session.scalars(
        select(HandheldReference)
        .where(HandheldReference.wheel_id == wheel_id)
        .order_by(HandheldReference.measured_at.desc(), HandheldReference.id.desc())
    )
    return [ReferenceRead.model_validate(row) for row in rows]


def nearest_reference(session: Session, wheel_id: int, at: datetime) -> HandheldReference | None:
    """The wheel's reference measured nearest in time to `at` (None if it has none)."""
    rows = list(
        session.scalars(select(HandheldReference).where(HandheldReference.wheel_id == wheel_id))
    )
    return min(rows, key=lambda r: (abs((r.measured_at - at).total_seconds()), -r.id), default=None)


def _differences(pass_wheel: PassWheel, reference: HandheldReference) -> list[ParameterDifference]:
    out = []
    for measurement in pass_wheel.measurements:
        for parameter in COMPARED:
            wayside = getattr(measurement, parameter)
            handheld = getattr(reference, parameter)
            out.append(
                ParameterDifference(
                    method=measurement.method,
                    parameter=parameter,
                    wayside_mm=wayside,
                    handheld_mm=handheld,
                    difference_mm=None if wayside is None else wayside - handheld,
                )
            )
    return out


def compare_with_reference(session: Session, pass_wheel: PassWheel) -> ReferenceComparison:
    """A wheel's results in a pass against its reference nearest in time to the pass."""
    reference = nearest_reference(session, pass_wheel.wheel_id, pass_wheel.train_pass.started_at)
    return ReferenceComparison(
        pass_id=pass_wheel.pass_id,
        wheel_id=pass_wheel.wheel_id,
        reference=None if reference is None else ReferenceRead.model_validate(reference),
        differences=[] if reference is None else _differences(pass_wheel, reference),
    )


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None


def _rows(observations: list[Observation], wheel_id: int | None) -> list[AgreementRow]:
    rows = [
        AgreementRow(
            wheel_id=wheel_id,
            method=s.method,
            parameter=s.parameter,
            n=s.n,
            mean_difference_mm=_finite(s.mean_difference_mm),
            mae_mm=_finite(s.mae_mm),
            std_mm=_finite(s.std_mm),
            max_error_mm=_finite(s.max_error_mm),
        )
        for s in summarise_agreement(observations)
    ]
    return sorted(rows, key=lambda r: (COMPARED.index(r.parameter), r.method))


def agreement(session: Session, pass_ids: list[int] | None = None) -> AgreementRead:
    """Wayside − handheld over every wheel of the passes (all passes if None) that has a
    reference: per method and parameter, mean difference, MAE, Std, max error and n, over
    all wheels (Table 2 form) and per wheel over its passes (Tables 3–4 form)."""
    query = select(PassWheel).join(Pass, PassWheel.pass_id == Pass.id)
    if pass_ids is not None:
        query = query.where(PassWheel.pass_id.in_(pass_ids))
    by_wheel: dict[int, list[Observation]] = {}
    pairs = 0
    for pass_wheel in session.scalars(query.order_by(Pass.started_at, PassWheel.id)):
        reference = nearest_reference(
            session, pass_wheel.wheel_id, pass_wheel.train_pass.started_at
        )
        if reference is None or not pass_wheel.measurements:
            continue
        pairs += 1
        label = f"{pass_wheel.pass_id}/{pass_wheel.wheel_id}"
        by_wheel.setdefault(pass_wheel.wheel_id, []).extend(
            Observation(label, d.method, d.parameter, d.wayside_mm, d.handheld_mm)
            for d in _differences(pass_wheel, reference)
        )
    pooled = [o for observations in by_wheel.values() for o in observations]
    per_wheel = [row for w, obs in sorted(by_wheel.items()) for row in _rows(obs, w)]
    return AgreementRead(pairs=pairs, rows=_rows(pooled, None), per_wheel=per_wheel)


MAX_PROFILE_FILE_BYTES = 2 * 1024 * 1024
"""A gauge's profile file is a few hundred rows (10–50 kB); 2 MiB leaves room for dense CSV."""


def add_reference(
    session: Session,
    wheel: Wheel,
    filename: str,
    data: bytes,
    measured_at: datetime | None,
    token: ApiToken | None,
) -> HandheldReference:
    """Import a handheld profile (API or CLI), audit it and commit."""
    if len(data) > MAX_PROFILE_FILE_BYTES:
        raise InvalidInputError(
            f"a profile file must be ≤ {MAX_PROFILE_FILE_BYTES} bytes, got {len(data)}"
        )
    if measured_at is not None and measured_at.tzinfo is None:
        raise InvalidInputError("measured_at needs a time zone (e.g. 2026-11-30T08:00:00Z)")
    row = import_reference(session, wheel, filename, data, measured_at)
    detail = {"filename": row.filename, "sha256": row.sha256, "quality": row.parameter_quality}
    record_audit(session, token, "reference.import", "wheel", wheel.id, detail)
    session.commit()
    return row
