"""Wheel profiles in and out as text: handheld-gauge files and the exports of a profile.

Read: MiniProf-style ASCII (`.whl`, `.prr`: `key=value` header lines, a blank line, then
one point per row, columns as `ColumnDef` names them) and CSV of x, z (optional header,
`#` comments). The points are brought into the profile frame (docs/coordinate-frames.md):
ordered from the back face to the field side, the flange pointing up (+z), x from the back
face and z = 0 at x = 70 mm. Write: the same two text formats from a profile in that frame.

Handheld gauges sample the flank sparsely (a point every 0.5–1 mm along the contour), so
`handheld_parameters` falls back from the least-squares fits of the wayside profile to
interpolation between the samples where a fit lacks points, and says so in `quality`.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from pipeline.errors import PipelineError
from pipeline.imaging import GEOMETRY_FLOAT, freeze_geometry
from pipeline.profile.flange import (
    FlangeNotFoundError,
    FlangeParameters,
    curve_flange_parameters,
    fit_flange_parameters,
)

REFERENCE_X_MM = 70.0
"""Tread reference point (tape circle) from the back face [mm]: z = 0 there."""
DATUM_TOLERANCE_MM = 5.0
"""A file whose innermost point lies within 5 mm of x = 0 measures x from the back face; one
within 5 mm of x = −70 mm from the tape circle (as the reference tables' sources and many
gauges write them). Any other file has its innermost point, the back face's, moved to 0."""
END_MARGIN_MM = 3.0
"""The flange tip lies 10–20 mm inside the profile's ends; an extreme within 3 mm of an end
is a chamfer or the end of the tread, which tells a file written z-down from one z-up."""
INSTRUMENT_KEYS = {"Sh": "flange_height", "Sd": "flange_thickness", "qR": "qr"}
"""Header keys (case-insensitive) of the instrument's own parameters [mm]."""
MIN_POINTS = 10
LEGACY_MARKER = re.compile(r"\(\s*Sd\s*/\s*Sh\s*/\s*qR\s*\)", re.IGNORECASE)
"""The line of an old MiniProf file's header that names its three numbers Sd, Sh and qR."""


class ProfileFileError(PipelineError):
    """A profile file that cannot be read as a wheel profile (format or geometry)."""


@dataclass(frozen=True, slots=True, eq=False)
class HandheldProfile:
    """A wheel profile read from a gauge's file, in the profile frame.

    Attributes
    ----------
    x_mm, z_mm : ndarray of shape (K,), float64
        Points from the back face to the field side; z = 0 at x = 70 mm [mm].
    instrument : str or None
        The writing program or instrument (header ProgramName / Instrument).
    measured_on : str or None
        Date and time as the header gives them (Date, Time).
    instrument_flange_height_mm, instrument_flange_thickness_mm, instrument_qr_mm : float or None
        Sh, Sd and qR as the instrument computed them (header Sh, Sd, qR).
    reversed : bool
        True if the file ran from the field side to the back face (or mirrored in x).
    x_offset_mm : float
        What was added to x (after any mirroring) to count it from the back face: 0, 70 mm
        for a tape-circle origin, or minus the innermost point's x for any other origin.
    z_offset_mm : float
        What was subtracted from z so that z(70 mm) = 0 (after any flip of z).
    """

    x_mm: np.ndarray
    z_mm: np.ndarray
    instrument: str | None
    measured_on: str | None
    instrument_flange_height_mm: float | None
    instrument_flange_thickness_mm: float | None
    instrument_qr_mm: float | None
    reversed: bool
    x_offset_mm: float
    z_offset_mm: float

    def __post_init__(self) -> None:
        freeze_geometry(self, "x_mm", "z_mm")


@dataclass(frozen=True, slots=True, eq=False)
class ProfileFile:
    """The content of a profile file as written: header and points in the file's frame.

    Attributes
    ----------
    header : tuple of (str, str)
        `key=value` lines in file order, keys as written (CSV comments `# key: value`).
    x_mm, z_mm : ndarray of shape (K,), float64
        The X and Y (or x, z) columns in file order [mm].
    """

    header: tuple[tuple[str, str], ...]
    x_mm: np.ndarray
    z_mm: np.ndarray

    def __post_init__(self) -> None:
        freeze_geometry(self, "x_mm", "z_mm")

    def value(self, key: str) -> str | None:
        """The header value of `key` (case-insensitive), or None."""
        return next((v for k, v in self.header if k.lower() == key.lower()), None)


@dataclass(frozen=True, slots=True)
class HandheldParameters:
    """Flange parameters of a handheld profile and how they were obtained.

    Attributes
    ----------
    parameters : FlangeParameters
        Sh, Sd (12 and 10 mm) and qR [mm], by the wayside profile's definitions.
    quality : str
        "fit" (the wayside least-squares fits had enough points) or "interpolated"
        (linear interpolation between the samples, for sparsely sampled flanks).
    reason : str or None
        Why the fits were not used, for "interpolated".
    """

    parameters: FlangeParameters
    quality: str
    reason: str | None


def _number(text: str) -> float | None:
    try:
        value = float(text.strip().replace(",", "."))
    except ValueError:
        return None
    return value if math.isfinite(value) else None


def _split_row(line: str) -> list[str]:
    return [cell for cell in re.split(r"[\s,;]+", line.strip()) if cell]


def _legacy_header(lines: list[str]) -> tuple[list[tuple[str, str]], set[int]]:
    """The header of an old MiniProf ASCII file (no `key=value` lines: a title such as
    `MINIPROF 2020`, `Stock.......:` lines, then `Sd Sh qR` as three numbers on the line of
    the `(Sd/Sh/qR)` marker or the one before it) and the indices of the lines it used, or
    nothing where no such marker precedes the points."""
    marker = next((i for i, line in enumerate(lines) if LEGACY_MARKER.search(line)), None)
    if marker is None:
        return [], set()
    used = {marker}
    values = _split_row(LEGACY_MARKER.sub("", lines[marker]).replace('"', " "))
    if not values and marker > 0:
        used.add(marker - 1)
        values = _split_row(lines[marker - 1].replace('"', " "))
    header = [(key, value) for key, value in zip(("Sd", "Sh", "qR"), values, strict=False)]
    title = next((line.strip() for line in lines[:marker] if line.strip().upper().startswith(
        "MINIPROF")), None)  # fmt: skip
    return ([("ProgramName", title)] if title else []) + header, used


def _parse_whl(lines: list[str]) -> tuple[list[tuple[str, str]], np.ndarray]:
    """Header lines and the (K, 2) points of a MiniProf-style file. Before the first row
    of numbers, lines that are not `key=value` (titles, section names) are passed over;
    after it, every line must be numbers. Old MiniProf files' `(Sd/Sh/qR)` line is read
    as those three header keys (`_legacy_header`)."""
    header, legacy_lines = _legacy_header(lines)
    rows: list[list[str]] = []
    for number, raw in enumerate(lines, start=1):
        line = raw.strip()
        if not line or line.startswith("#") or number - 1 in legacy_lines:
            continue
        if "=" in line and not rows:
            key, _, value = line.partition("=")
            header.append((key.strip(), value.strip()))
            continue
        cells = _split_row(line)
        if all(_number(c) is not None for c in cells):
            rows.append(cells)
        elif rows:
            raise ProfileFileError(f"line {number} is neither key=value nor numbers: {line!r}")
    keys = {k.lower(): v for k, v in header}
    columns = [c.strip().upper() for c in keys.get("columndef", "X,Y").split(",")]
    if "X" not in columns or "Y" not in columns:
        raise ProfileFileError(f"ColumnDef must name X and Y, got {keys['columndef']!r}")
    ix, iy = columns.index("X"), columns.index("Y")
    width = max(ix, iy) + 1
    if any(len(row) < width for row in rows):
        raise ProfileFileError(f"every point row needs {width} columns (ColumnDef)")
    points = np.array([[_number(r[ix]), _number(r[iy])] for r in rows], dtype=GEOMETRY_FLOAT)
    declared = _number(keys.get("xypoints", ""))
    if declared is not None and int(declared) != len(rows):
        raise ProfileFileError(f"XYPoints says {int(declared)} points, the file has {len(rows)}")
    return header, points.reshape(-1, 2)


def _parse_csv(lines: list[str]) -> tuple[list[tuple[str, str]], np.ndarray]:
    header: list[tuple[str, str]] = []
    rows: list[list[float | None]] = []
    for number, raw in enumerate(lines, start=1):
        line = raw.strip()
        if line.startswith("#") and ":" in line:
            key, _, value = line.lstrip("#").partition(":")
            header.append((key.strip(), value.strip()))
        if not line or line.startswith("#"):
            continue
        cells = _split_row(line)
        values = [_number(c) for c in cells[:2]]
        if len(cells) < 2 or None in values:
            if not rows and not any(v is not None for v in values):
                continue  # a column-name header
            raise ProfileFileError(f"line {number} is not an x, z pair: {line!r}")
        rows.append(values)
    return header, np.array(rows, dtype=GEOMETRY_FLOAT).reshape(-1, 2)


def _crest_score(x: np.ndarray, z: np.ndarray) -> float:
    """How much the highest point looks like a flange tip: its height above the median
    (the tread), or 0 where it lies at an end of the profile (a chamfer, a tread's end)."""
    top = int(np.argmax(z))
    if min(x[top] - x.min(), x.max() - x[top]) < END_MARGIN_MM:
        return 0.0
    return float(z[top] - np.median(z))


def _orient(x: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """Flange up (+z), back face first, x from the back face."""
    if _crest_score(x, -z) > _crest_score(x, z):
        z = -z
    top = int(np.argmax(z))
    mirrored = bool(abs(x[top] - x.min()) > abs(x[top] - x.max()))
    if mirrored:
        x = -x
    flipped = bool(x[-1] < x[0])
    if flipped:
        x, z = x[::-1], z[::-1]
    return x, z, mirrored != flipped


def _x_datum_shift(x: np.ndarray) -> float:
    """What to add to x so that it counts from the back face (DATUM_TOLERANCE_MM)."""
    innermost = float(x.min())
    if abs(innermost) <= DATUM_TOLERANCE_MM:
        return 0.0
    if abs(innermost + REFERENCE_X_MM) <= DATUM_TOLERANCE_MM:
        return REFERENCE_X_MM
    return -innermost


def _tread_height(x: np.ndarray, z: np.ndarray) -> float:
    """z at x = 70 mm, linear between the samples on the tread side of the flange top."""
    tread = np.arange(int(np.argmax(z)), x.size)
    crossing = np.flatnonzero(
        (x[tread[:-1]] - REFERENCE_X_MM) * (x[tread[1:]] - REFERENCE_X_MM) <= 0
    )
    if crossing.size == 0:
        raise ProfileFileError(
            f"the profile spans x = {x.min():.1f}…{x.max():.1f} mm from the back face and "
            f"does not reach the reference point at {REFERENCE_X_MM:g} mm"
        )
    i = tread[int(crossing[0])]
    if x[i + 1] == x[i]:
        return float(z[i])
    t = (REFERENCE_X_MM - x[i]) / (x[i + 1] - x[i])
    return float(z[i] + t * (z[i + 1] - z[i]))


def parse_profile_file(text: str, *, suffix: str) -> ProfileFile:
    """The header and points of a `.whl`, `.prr` or `.csv` profile file, as written.

    Parameters
    ----------
    text : str
        The file's content.
    suffix : str
        The file name's extension (".whl", ".prr" or ".csv"), choosing the format.

    Raises
    ------
    ValueError
        If `suffix` names no supported format.
    ProfileFileError
        If the text is not a profile file of that format.
    """
    kind = suffix.lower().lstrip(".")
    if kind not in ("whl", "prr", "csv"):
        raise ValueError(f"suffix must be .whl, .prr or .csv, got {suffix!r}")
    lines = text.splitlines()
    header, points = _parse_csv(lines) if kind == "csv" else _parse_whl(lines)
    return ProfileFile(tuple(header), points[:, 0], points[:, 1])


def read_profile_text(text: str, *, suffix: str) -> HandheldProfile:
    """A handheld-gauge profile from the text of a `.whl`, `.prr` or `.csv` file, brought
    into the profile frame (oriented, x from the back face, z(70 mm) = 0). `text` and
    `suffix` as for `parse_profile_file`.

    Returns
    -------
    HandheldProfile

    Raises
    ------
    ValueError
        If `suffix` names no supported format.
    ProfileFileError
        If the text is not a profile of that format, has fewer than 10 points, or does not
        reach x = 70 mm.
    """
    parsed = parse_profile_file(text, suffix=suffix)
    if parsed.x_mm.size < MIN_POINTS:
        raise ProfileFileError(f"a profile needs ≥ {MIN_POINTS} points, got {parsed.x_mm.size}")
    x, z, reversed_ = _orient(parsed.x_mm, parsed.z_mm)
    shift = _x_datum_shift(x)
    x = x + shift
    offset = _tread_height(x, z)
    values = {name: parsed.value(key) for key, name in INSTRUMENT_KEYS.items()}
    when = " ".join(v for k in ("Date", "Time") if (v := parsed.value(k))) or None
    return HandheldProfile(
        x_mm=x,
        z_mm=z - offset,
        instrument=parsed.value("ProgramName") or parsed.value("Instrument") or None,
        measured_on=when,
        instrument_flange_height_mm=_number(values["flange_height"] or ""),
        instrument_flange_thickness_mm=_number(values["flange_thickness"] or ""),
        instrument_qr_mm=_number(values["qr"] or ""),
        reversed=reversed_,
        x_offset_mm=shift,
        z_offset_mm=offset,
    )


def handheld_parameters(profile: HandheldProfile) -> HandheldParameters:
    """Sh, Sd and qR of a handheld profile by the wayside profile's code.

    The least-squares fits of `fit_flange_parameters` are used when every fit window has
    enough samples; a flank sampled more sparsely (a gap the wayside fit would bridge) is
    read by linear interpolation between its samples (`curve_flange_parameters`), which is
    exact on a gauge's polyline, flagged "interpolated".

    Raises
    ------
    FlangeNotFoundError
        If even the samples do not cross a height the parameters need.
    """
    try:
        fitted = fit_flange_parameters(profile.x_mm, profile.z_mm)
    except FlangeNotFoundError as exc:
        reason = str(exc)
    else:
        if fitted.reason is not None:
            reason = fitted.reason
        elif fitted.flank_gap_mm == 0.0:
            return HandheldParameters(fitted, "fit", None)
        else:
            reason = f"the flank's samples are {fitted.flank_gap_mm:.2f} mm apart in z"
    parameters = curve_flange_parameters(profile.x_mm, profile.z_mm)
    return HandheldParameters(parameters, "interpolated", reason)


def _rows(x_mm: np.ndarray, z_mm: np.ndarray, separator: str) -> list[str]:
    return [f"{x:.6f}{separator}{z:.6f}" for x, z in zip(x_mm, z_mm, strict=True)]


def profile_csv_text(x_mm: np.ndarray, z_mm: np.ndarray, header: list[tuple[str, str]]) -> str:
    """CSV of a profile: `# key: value` comment lines, the `x_mm,z_mm` header, then rows
    with 6 decimals (1 nm, so a profile reads back well within 1 µm)."""
    lines = [f"# {key}: {value}" for key, value in header]
    return "\n".join([*lines, "x_mm,z_mm", *_rows(x_mm, z_mm, ",")]) + "\n"


def profile_whl_text(x_mm: np.ndarray, z_mm: np.ndarray, header: list[tuple[str, str]]) -> str:
    """MiniProf-style ASCII: `key=value` lines (then ColumnDef=X,Y and XYPoints), a blank
    line, then `x y` rows in the profile frame [mm]."""
    lines = [f"{key}={value}" for key, value in header]
    lines += ["ColumnDef=X,Y", f"XYPoints={len(x_mm)}", ""]
    return "\n".join([*lines, *_rows(x_mm, z_mm, " ")]) + "\n"
