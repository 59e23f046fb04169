"""A wheel's fused profile out of the system: CSV, DXF and MiniProf-style `.whl`.

All three hold the stored profile's outline (`pipeline.profile.outline`: one ordered trace,
the medians of the fused points in 0.25 mm steps along the profile, as a handheld gauge
samples its contour) in the profile frame (x from the back face, z up, z = 0 at x = 70 mm)
in mm, with what identifies it: pass, wheel, method, pipeline and calibration versions.
The fused points themselves are served by `GET …/wheels/{id}/profile` (x_mm, z_mm). The
text formats are written by `pipeline.profile.exchange` (and read back by it); the DXF is
one 2-D polyline drawn by ezdxf, in mm.
"""

from __future__ import annotations

import io
from dataclasses import dataclass

import ezdxf
import numpy as np

from backend.errors import NotFoundError
from backend.services.wheel_data import measurement_or_404, stored_outline
from db.models import PassWheel
from pipeline.profile.exchange import profile_csv_text, profile_whl_text
from pipeline.profile.outline import OUTLINE_STEP_MM

FORMATS = ("csv", "dxf", "whl")
MEDIA_TYPES = {"csv": "text/csv", "dxf": "image/vnd.dxf", "whl": "text/plain"}
DXF_MILLIMETRES = 4
"""$INSUNITS code of millimetres."""


@dataclass(frozen=True, slots=True)
class ExportedProfile:
    """An exported profile file: its bytes, name and media type."""

    data: bytes
    filename: str
    media_type: str


def _dxf(x_mm: np.ndarray, z_mm: np.ndarray, header: list[tuple[str, str]]) -> bytes:
    document = ezdxf.new("R2010")
    document.header["$INSUNITS"] = DXF_MILLIMETRES
    document.header["$MEASUREMENT"] = 1
    modelspace = document.modelspace()
    modelspace.add_lwpolyline(np.column_stack([x_mm, z_mm]).tolist(), format="xy")
    for i, (key, value) in enumerate(header):
        modelspace.add_text(f"{key}: {value}", height=1.5).set_placement((0.0, -14.0 - 2.5 * i))
    stream = io.StringIO()
    document.write(stream)
    return stream.getvalue().encode("utf-8")


def export_profile(pass_wheel: PassWheel, method: str, fmt: str) -> ExportedProfile:
    """The stored `method` profile of a wheel in a pass as a `fmt` file.

    Raises
    ------
    NotFoundError
        If the wheel has no profile of that method.
    ValueError
        If `fmt` is not csv, dxf or whl.
    """
    if fmt not in FORMATS:
        raise ValueError(f"fmt must be one of {', '.join(FORMATS)}, got {fmt!r}")
    measurement = measurement_or_404(pass_wheel, method)
    profile = measurement.profile or {}
    if not profile.get("x_mm"):
        raise NotFoundError(f"the {method} result of wheel {pass_wheel.wheel_id} has no profile")
    outline = stored_outline(profile)
    x_mm, z_mm = outline[np.isfinite(outline[:, 0])].T  # one trace: its gaps joined
    train_pass, wheel = pass_wheel.train_pass, pass_wheel.wheel
    ident = [
        ("Pass", str(train_pass.id)),
        ("Site", train_pass.site.name),
        ("PassTime", f"{train_pass.started_at:%Y-%m-%dT%H:%M:%SZ}"),
        ("Wheel", f"{wheel.id} (vehicle {wheel.vehicle_id}, axle {wheel.axle}, {wheel.side})"),
        ("Method", method),
        ("PipelineVersion", measurement.pipeline_version),
        ("CalibrationVersion", str(train_pass.calibration.version)),
        ("Frame", "x from the back face, z up, z = 0 at x = 70 mm; mm"),
        (
            "Points",
            f"outline: medians of {len(profile['x_mm'])} fused points in "
            f"{OUTLINE_STEP_MM} mm steps along the profile",
        ),
    ]
    stem = f"wheelscan-pass-{train_pass.id}-wheel-{wheel.id}-{method}"
    if fmt == "csv":
        data = profile_csv_text(x_mm, z_mm, ident).encode("utf-8")
    elif fmt == "dxf":
        data = _dxf(x_mm, z_mm, ident)
    else:
        values = [
            ("Sd", measurement.flange_thickness_10_mm),
            ("Sh", measurement.flange_height_mm),
            ("qR", measurement.qr_mm),
        ]
        header = [
            ("ProgramName", "wheelscan"),
            ("Date", f"{train_pass.started_at:%Y-%m-%d}"),
            ("Time", f"{train_pass.started_at:%H:%M:%S}"),
            ("CarNo", wheel.vehicle_id),
            ("AxleNo", str(wheel.axle)),
            ("Side", wheel.side),
            *((key, f"{value:.4f}") for key, value in values if value is not None),
            *ident,
        ]
        data = profile_whl_text(x_mm, z_mm, header).encode("utf-8")
    return ExportedProfile(data, f"{stem}.{fmt}", MEDIA_TYPES[fmt])
