"""One wheel's data: a frame of a pass wheel, its result per method, the extraction stored
for a frame, and the fused profile with its reference (the trend is in `trends`).

Lookups that the API answers with 404 raise `NotFoundError` with what is missing.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from sqlalchemy import select
from sqlalchemy.orm import Session

from backend.api.schemas import ProfileRead
from backend.errors import GoneError, NotFoundError
from backend.services.images import cached_artefacts
from backend.services.pass_wheels import method_measurement, wheel_frames
from backend.services.queries import method_result
from backend.services.results import PARAMETER_NAMES
from backend.storage.artefacts import FrameArtefacts
from backend.storage.store import BlobStore
from db.models import Frame, Measurement, MeasurementFrame, PassWheel
from pipeline.profile.outline import outline_points
from pipeline.profile.reference import REFERENCE_PROFILES, load_reference_profile


def wheel_frame(session: Session, pass_wheel: PassWheel, position: str, index: int) -> Frame:
    """Frame `index` (0-based, by sequence number) of the wheel's sensor at `position`."""
    frames = wheel_frames(session, pass_wheel, (position,))
    if index >= len(frames):
        sensor = f"{pass_wheel.wheel.side}_{position}"
        raise NotFoundError(f"wheel has {len(frames)} {sensor} frame(s); index {index} is beyond")
    return frames[index]


def retained_frame(session: Session, pass_wheel: PassWheel, position: str, index: int) -> Frame:
    """`wheel_frame`, or GoneError once frame retention removed the pass's frames (the
    results are kept)."""
    frame = wheel_frame(session, pass_wheel, position, index)
    removed_at = pass_wheel.train_pass.frames_removed_at
    if removed_at is not None:
        raise GoneError(
            f"frames of pass {pass_wheel.pass_id} were removed by retention on "
            f"{removed_at:%Y-%m-%d}; the measurement results are kept"
        )
    return frame


def measurement_or_404(pass_wheel: PassWheel, method: str) -> Measurement:
    """The wheel's result of `method`; NotFoundError (with the wheel's state) when none."""
    measurement = method_measurement(pass_wheel, method)
    if measurement is None:
        raise NotFoundError(
            f"wheel {pass_wheel.wheel_id} of pass {pass_wheel.pass_id} has no {method} result "
            f"(state: {pass_wheel.state.replace('_', ' ')})"
        )
    return measurement


def stored_extraction(
    session: Session, pass_wheel: PassWheel, method: str, position: str, index: int
) -> tuple[Frame, MeasurementFrame]:
    """A frame of the wheel and the row of what `method` extracted from it."""
    frame = wheel_frame(session, pass_wheel, position, index)
    measurement = measurement_or_404(pass_wheel, method)
    row = session.scalar(
        select(MeasurementFrame).where(
            MeasurementFrame.measurement_id == measurement.id,
            MeasurementFrame.sensor == frame.sensor,
            MeasurementFrame.seq == frame.seq,
        )
    )
    if row is None:
        raise NotFoundError(
            f"no {method} extraction is stored for {frame.sensor} frame {frame.seq}"
        )
    return frame, row


def stored_artefacts(
    session: Session,
    store: BlobStore,
    pass_wheel: PassWheel,
    method: str,
    position: str,
    index: int,
) -> tuple[Frame, FrameArtefacts]:
    """A frame of the wheel and the artefacts (centres, mask, σ map) `method` stored for it."""
    frame, row = stored_extraction(session, pass_wheel, method, position, index)
    return frame, cached_artefacts(store, row.artefact_sha256)


def stored_outline(profile: dict[str, Any]) -> np.ndarray:
    """The outline (`pipeline.profile.outline.outline_points`: (S, 2) [mm], a NaN row
    between pieces) of a measurement's stored profile document; no rows without points."""
    return outline_points(np.asarray(profile.get("x_mm", [])), np.asarray(profile.get("z_mm", [])))


def wheel_profile(pass_wheel: PassWheel, method: str) -> ProfileRead:
    """The fused profile of `method` and its reference profile [mm], with the Sh/Sd/qR
    construction points, the parameters and the axle's Δr(y) and conicity curve."""
    measurement = measurement_or_404(pass_wheel, method)
    profile = measurement.profile or {}
    reference = measurement.reference_profile
    ref = load_reference_profile(reference) if reference in REFERENCE_PROFILES else None
    result = method_result(measurement)
    outline_columns = [
        [None if np.isnan(v) else float(v) for v in column] for column in stored_outline(profile).T
    ]
    return ProfileRead(
        method=method,
        reference_profile=reference,
        x_mm=profile.get("x_mm", []),
        z_mm=profile.get("z_mm", []),
        outline_x_mm=outline_columns[0],
        outline_z_mm=outline_columns[1],
        reference_x_mm=ref.x_mm.tolist() if ref else [],
        reference_z_mm=ref.z_mm.tolist() if ref else [],
        construction=profile.get("construction", {}),
        parameters={name: getattr(result, name) for name in PARAMETER_NAMES},
        conicity=measurement.conicity,
    )
