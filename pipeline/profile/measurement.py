"""Measure wheels: the one chain the CLI, the service's jobs and the benchmarks all call.

`measure_wheel` takes one wheel's frames (in memory) and the calibration, and runs
centres → undistorted rays → light-plane intersection → track frame → fused profile →
datum → flange and tread parameters. `measure_pass` does that for every wheel of a
validated pass archive and adds each axle's back-to-back distance and equivalent conicity.
A wheel whose frames yield no usable stripe is returned as "not measured" with the reason;
it never fails the pass.

Each step and the module doing it: docs/data-flow.md.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from pipeline.archive.manifest import POSITIONS, WheelEntry
from pipeline.archive.pass_archive import PassArchive
from pipeline.calibration.geometry import camera_centre_track, pixels_to_track_points
from pipeline.calibration.model import SensorCalibration, StationCalibration
from pipeline.calibration.search_region import stripe_search_region
from pipeline.errors import PipelineError
from pipeline.extraction.centres import Centres, extract_centres
from pipeline.imaging import validate_image
from pipeline.profile.flange import FlangeParameters, fit_flange_parameters
from pipeline.profile.fusion import FusedProfile, fuse_profile
from pipeline.profile.rails import TrackRails, track_rails
from pipeline.profile.tread import TreadParameters, tread_parameters
from pipeline.profile.wheelset import AxleConicity, WheelCurve, axle_conicity, running_surface
from pipeline.profile.window import in_wheel_window, locate_back_face
from pipeline.version import PIPELINE_VERSION

MEASURED = "measured"
NOT_MEASURED = "not measured"
MEASURE_METHODS = ("adaptive", "steger")
CORRECTIONS = ("curvature", "asymmetry", "scatter", "normal", "gaps", "glints")
"""Corrections a method label can switch on (+name) or off (−name): "steger+curvature",
"adaptive+asymmetry", "adaptive-normal-curvature" (the Hessian centres without the
curvature correction), "adaptive-normal+scatter" (Hessian centres with the along-stripe
support chosen by the centre scatter); "normal" is the matched fit along the normal
(`extract_centres(normal_fit=...)`), which replaces the curvature correction and the
scatter support; "gaps" the guided search across gaps between chains
(`extract_centres(gap_search=...)`, adaptive only); "glints" the glints beside the stripe
fitted and subtracted before a second extraction (`extract_centres(glint_subtraction=...)`,
adaptive only). A bare method keeps its defaults (normal fit on for adaptive, off for
Steger; curvature on for adaptive's Hessian centres, off for Steger; asymmetry, scatter,
gaps and glints off)."""
MIN_SENSOR_POINTS = 50
"""A sensor with fewer centre points than this has no usable stripe (a wheel's stripe gives
over a thousand)."""
MIN_CHAIN_POINTS = 25
"""Linked centre chains shorter than this (≈ 3 mm of profile) are stray spots or glints
beside the stripe, not the profile, and are left out of the measurement."""
MIN_WINDOW_CHAIN_POINTS = 8
"""Inside the wheel window at a located back face (within 6 mm of a reference profile at
the wheel's own lateral position), pieces of chains of ≥ 8 points (≈ 1 mm) are measured:
under glare the dim flange top comes in 1–3 mm pieces (8–22 points; at 25 a harsh pass
lost its whole top). Fusion's consensus and linked-piece tests then drop what is off the
profile (`pipeline.profile.fusion.LINK_RADIUS_MM`)."""


@dataclass(frozen=True, slots=True, eq=False)
class FrameCentres:
    """The centres of one frame, with where the frame came from.

    Attributes
    ----------
    sensor : str
        Sensor name (e.g. "left_inner").
    frame_index : int
        Index of the frame in that sensor's list for the wheel.
    centres : Centres
        Centres, stripe mask and σ map of the frame.
    points_track_mm : ndarray of shape (K, 3), float64
        The centres in the track frame [mm] (same order as the centres).
    used : ndarray of shape (K,), bool
        The centres measured: on pieces of chains of at least `MIN_CHAIN_POINTS` points
        (inside the wheel window, when the station's knowledge is used).
    excluded_bright_px : int
        Pixels outside the search region at least as bright as the stripe's median centre
        pixel: light the region left out (0 without a region).
    """

    sensor: str
    frame_index: int
    centres: Centres
    points_track_mm: np.ndarray
    used: np.ndarray
    excluded_bright_px: int = 0

    def __post_init__(self) -> None:
        self.points_track_mm.flags.writeable = False
        self.used.flags.writeable = False


@dataclass(frozen=True, slots=True, eq=False)
class WheelMeasurement:
    """Result of measuring one wheel with one extraction method.

    Attributes
    ----------
    side : str
    method : str
    status : str
        "measured" or "not measured".
    reason : str or None
        Why the wheel was not measured (None when measured).
    parameters : FlangeParameters or None
    profile : FusedProfile or None
        Fused profile points, datum, back-face X and overlap residual.
    frames : tuple of FrameCentres
        Every frame's centres and track points, inner frames first.
    points_inner, points_outer : int
        Centre points per sensor used in the measurement.
    tread : TreadParameters or None
        Tread hollow, flange angle and rim width (None when not measured, or when the
        profile lacks the tread or flank points: `tread_reason` says which).
    tread_reason : str or None
    surface : WheelCurve or None
        The running surface z(x) the tread hollow and the axle's conicity are read from.
    pipeline_version : str
    """

    side: str
    method: str
    status: str
    reason: str | None
    parameters: FlangeParameters | None
    profile: FusedProfile | None
    frames: tuple[FrameCentres, ...]
    points_inner: int
    points_outer: int
    tread: TreadParameters | None = None
    tread_reason: str | None = None
    surface: WheelCurve | None = None
    pipeline_version: str = PIPELINE_VERSION

    @property
    def back_face_track_x_mm(self) -> float | None:
        """Track-frame X of the back face, when the wheel was measured [mm]."""
        return None if self.profile is None else self.profile.back_face_track_x_mm

    def quality_figures(self) -> dict[str, float | int | None]:
        """The measurement's quality figures: points per sensor, the sensors' overlap, points
        rejected by fusion, the flank gap bridged at the Sd and qR heights (None when not
        measured), and what the search regions left out (bright pixels outside them, and
        the searched share of the frames' area)."""
        profile = self.profile
        searched = [
            f.centres.region.area_px / f.centres.mask.size
            for f in self.frames
            if f.centres.region is not None
        ]
        return {
            "points_inner": self.points_inner,
            "points_outer": self.points_outer,
            "overlap_residual_mm": None if profile is None else profile.overlap_residual_mm,
            "overlap_points": 0 if profile is None else profile.overlap_points,
            "rejected_points": 0 if profile is None else profile.rejected_points,
            "flank_gap_mm": None if self.parameters is None else self.parameters.flank_gap_mm,
            "excluded_bright_px": sum(f.excluded_bright_px for f in self.frames),
            "searched_fraction": float(np.mean(searched)) if searched else 1.0,
        }


@dataclass(frozen=True, slots=True)
class MethodOptions:
    """An extraction method with its corrections, parsed from a method label."""

    method: str
    curvature_correction: bool
    asymmetry_correction: bool
    scatter_support: bool
    normal_fit: bool
    gap_search: bool = False
    glint_subtraction: bool = False


def method_options(label: str) -> MethodOptions:
    """Parse a method label: a method of `MEASURE_METHODS`, then ±correction tokens.

    Raises
    ------
    ValueError
        On an unknown method or correction.
    """
    tokens = re.split(r"(?=[+-])", label)
    if tokens[0] not in MEASURE_METHODS:
        raise ValueError(f"method must be one of {', '.join(MEASURE_METHODS)}, got {label!r}")
    adaptive = tokens[0] == "adaptive"
    switches = {
        "curvature": adaptive,
        "asymmetry": False,
        "scatter": False,
        "normal": adaptive,
        "gaps": False,
        "glints": False,
    }
    for token in tokens[1:]:
        if token[1:] not in CORRECTIONS:
            raise ValueError(
                f"method {label!r}: corrections are +/-{' +/-'.join(CORRECTIONS)}, got {token!r}"
            )
        switches[token[1:]] = token[0] == "+"
    return MethodOptions(
        tokens[0],
        switches["curvature"],
        switches["asymmetry"],
        switches["scatter"],
        switches["normal"],
        switches["gaps"],
        switches["glints"],
    )


def _check_frame(image: object, sensor: SensorCalibration, where: str) -> np.ndarray:
    image = validate_image(image, name=where)
    expected = (sensor.image_height_px, sensor.image_width_px)
    if image.shape != expected or image.dtype != sensor.frame_dtype:
        raise ValueError(
            f"{where} must be {sensor.frame_dtype} of shape {expected} for sensor "
            f"{sensor.name}, got {image.dtype} {image.shape}"
        )
    return image


def _excluded_bright_px(image: np.ndarray, centres: Centres) -> int:
    """Pixels outside the centres' search region at least as bright as their median centre."""
    region = centres.region
    if region is None or len(centres) == 0:
        return 0
    rows = np.clip(np.round(centres.y).astype(int), 0, image.shape[0] - 1)
    cols = np.clip(np.round(centres.x).astype(int), 0, image.shape[1] - 1)
    level = np.median(image[rows, cols])
    bright = int(np.count_nonzero(image >= level))
    inside = image[region.row_start : region.row_stop, region.col_start : region.col_stop]
    return bright - int(np.count_nonzero(inside >= level))


def _used(centres: Centres, inside: np.ndarray, min_points: int = MIN_CHAIN_POINTS) -> np.ndarray:
    """Centres on pieces of chains of ≥ `min_points` points with `inside` set."""
    used = np.zeros(len(centres), bool)
    for chain in centres.polylines:
        breaks = np.flatnonzero(np.diff(inside[chain].astype(np.int8))) + 1
        for piece in np.split(chain, breaks):
            used[piece] = piece.size >= min_points and inside[piece[0]]
    return used


def _frame_centres(images, sensor, options: MethodOptions, widths, region) -> list[FrameCentres]:
    result = []
    for index, image in enumerate(images):
        image = _check_frame(image, sensor, f"{sensor.name} frame {index}")
        centres = extract_centres(
            image,
            method=options.method,
            width_min=widths[0],
            width_max=widths[1],
            curvature_correction=options.curvature_correction,
            asymmetry_correction=options.asymmetry_correction,
            scatter_support=options.scatter_support,
            normal_fit=options.normal_fit,
            gap_search=options.gap_search,
            glint_subtraction=options.glint_subtraction,
            region=region,
        )
        points = pixels_to_track_points(centres.x, centres.y, sensor)
        used = _used(centres, np.ones(len(centres), bool))
        excluded = _excluded_bright_px(image, centres)
        result.append(FrameCentres(sensor.name, index, centres, points, used, excluded))
    return result


def _in_window(frames: list[FrameCentres], side: str) -> list[FrameCentres]:
    """The frames measuring only the pieces of chains that can lie on the wheel: inside
    the wheel window, then near the profiles at the back-face position most points agree on."""
    windowed = [in_wheel_window(f.points_track_mm, side) for f in frames]
    candidates = [
        f.points_track_mm[_used(f.centres, w)] for f, w in zip(frames, windowed, strict=True)
    ]
    back_face = locate_back_face(np.concatenate(candidates), side) if candidates else None
    result = []
    for frame, inside in zip(frames, windowed, strict=True):
        if back_face is not None:
            inside = in_wheel_window(frame.points_track_mm, side, back_face_mm=back_face)
            used = _used(frame.centres, inside, MIN_WINDOW_CHAIN_POINTS)
        else:
            used = _used(frame.centres, inside)
        result.append(replace(frame, used=used))
    return result


def _stack(frames: list[FrameCentres]) -> tuple[np.ndarray, np.ndarray]:
    """The frames' used points in the track frame (K, 3) [mm] and their centres' line
    strengths (K,), in the same order."""
    if not frames:
        return np.zeros((0, 3)), np.zeros(0)
    return (
        np.concatenate([f.points_track_mm[f.used] for f in frames]),
        np.concatenate([f.centres.strength[f.used] for f in frames]),
    )


def measure_wheel(
    frames_inner: Sequence[np.ndarray],
    frames_outer: Sequence[np.ndarray],
    calibration: StationCalibration,
    *,
    side: str,
    method: str = "adaptive",
    width_min: float = 5,
    width_max: float = 21,
    search_region: bool = True,
) -> WheelMeasurement:
    """Measure one wheel from its inner and outer frames.

    Parameters
    ----------
    frames_inner, frames_outer : sequence of ndarray of shape (M, N), uint8 or uint16
        The wheel's frames from the inner and outer sensor of its side.
    calibration : StationCalibration
        Must calibrate `<side>_inner` and `<side>_outer`.
    side : str
        "left" or "right".
    method : str
        Centre extraction method, "adaptive" or "steger", optionally with corrections
        switched on or off ("steger+curvature+asymmetry", see `method_options`).
    width_min, width_max : float
        Stripe width range for the extraction [px].
    search_region : bool
        Use what the station knows: search each frame only where the calibration says the
        wheel's stripe can lie (`pipeline.calibration.search_region`), and measure only the
        centres whose laser-plane points can be on a wheel (`pipeline.profile.window`);
        False searches the whole frame and keeps every long enough chain.

    Returns
    -------
    WheelMeasurement
        Status "not measured" with the reason when the stripe is unusable (too few points,
        no back face, no reference point, no flange); never raises for that.

    Raises
    ------
    ValueError
        Bad input: unknown side or method, a frame of the wrong size or dtype for its
        sensor, a sensor missing from the calibration.
    """
    if side not in ("left", "right"):
        raise ValueError(f"side must be 'left' or 'right', got {side!r}")
    options = method_options(method)
    sensors = [calibration.sensor(f"{side}_{position}") for position in POSITIONS]
    widths = (width_min, width_max)
    regions = [stripe_search_region(s, side) if search_region else None for s in sensors]
    inner = _frame_centres(frames_inner, sensors[0], options, widths, regions[0])
    outer = _frame_centres(frames_outer, sensors[1], options, widths, regions[1])
    if search_region:
        windowed = _in_window(inner + outer, side)
        inner, outer = windowed[: len(inner)], windowed[len(inner) :]
    (inner_points, inner_strength), (outer_points, outer_strength) = _stack(inner), _stack(outer)
    counts = (len(inner_points), len(outer_points))

    def not_measured(reason: str) -> WheelMeasurement:
        return WheelMeasurement(
            side, method, NOT_MEASURED, reason, None, None, tuple(inner + outer), *counts
        )

    for position, count in zip(POSITIONS, counts, strict=True):
        if count < MIN_SENSOR_POINTS:
            return not_measured(
                f"no usable stripe from the {position} sensor ({count} centre points)"
            )
    try:
        cameras = np.array([camera_centre_track(s) for s in sensors])
        profile = fuse_profile(
            inner_points,
            outer_points,
            side=side,
            cameras_track_mm=cameras,
            strengths=(inner_strength, outer_strength),
        )
        parameters = fit_flange_parameters(profile.x_mm, profile.z_mm, profile.strength)
    except PipelineError as exc:
        return not_measured(str(exc))
    tread, tread_reason, surface = None, None, None
    try:
        surface = running_surface(profile.x_mm, profile.z_mm)
        tread = tread_parameters(
            profile.x_mm,
            profile.z_mm,
            surface,
            parameters.flange_height_mm,
            smooth_hollow=True,
        )
    except PipelineError as exc:
        tread_reason = str(exc)
    return WheelMeasurement(
        side,
        method,
        MEASURED,
        None,
        parameters,
        profile,
        tuple(inner + outer),
        *counts,
        tread=tread,
        tread_reason=tread_reason,
        surface=surface,
    )


def axle_conicity_of(
    left: WheelMeasurement, right: WheelMeasurement, back_to_back_mm: float | None, rails
) -> tuple[AxleConicity | None, str | None]:
    """The axle's Δr(y) and equivalent conicity from its two measured wheels, or None and
    why not: which wheel is not measured or has no running surface (with its own reason),
    no back-to-back, a long unseen stretch of running surface, no tread where the rails
    touch. With an axle the reason is `AxleConicity.reason` (why its Δr(y) covers fewer
    shifts, so that some amplitudes have no λₑ), usually None."""
    wheels = (left, right)
    missing = [
        f"the {w.side} wheel is not measured ({w.reason})" for w in wheels if w.profile is None
    ]
    if missing:
        return None, "; ".join(missing)
    if back_to_back_mm is None:
        return None, "the axle's back-to-back distance is not measured"
    if left.surface is None or right.surface is None:
        return None, "; ".join(
            f"the {w.side} wheel's profile has no running surface ({w.tread_reason})"
            for w in wheels
            if w.surface is None
        )
    try:
        axle = axle_conicity(left.surface, right.surface, back_to_back_mm, rails)
    except PipelineError as exc:
        return None, str(exc)
    return axle, axle.reason


def axle_back_to_back(left: WheelMeasurement, right: WheelMeasurement) -> float | None:
    """Back-to-back distance of an axle from its two measured wheels [mm]; None if either
    wheel was not measured."""
    if left.side != "left" or right.side != "right":
        raise ValueError("axle_back_to_back needs the left wheel first, then the right one")
    if left.back_face_track_x_mm is None or right.back_face_track_x_mm is None:
        return None
    return right.back_face_track_x_mm - left.back_face_track_x_mm


@dataclass(frozen=True, slots=True, eq=False)
class PassWheelResult:
    """One wheel of a pass measured with one method, with its axle's back-to-back and
    equivalent conicity (the same objects on both wheels of the axle)."""

    wheel: WheelEntry
    measurement: WheelMeasurement
    back_to_back_mm: float | None
    conicity: AxleConicity | None = None
    conicity_reason: str | None = None


def measure_pass(
    archive: PassArchive,
    *,
    methods: Sequence[str] = ("adaptive",),
    calibration: StationCalibration | None = None,
    rails: TrackRails | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> tuple[PassWheelResult, ...]:
    """Measure every wheel of a validated pass with each method.

    Parameters
    ----------
    archive : PassArchive
        From `read_pass_archive`.
    methods : sequence of str
        Extraction method labels (`method_options`).
    calibration : StationCalibration, optional
        Overrides the archive's calibration.
    rails : TrackRails, optional
        The site's rails for the conicity (default 60E1 at 1:40, gauge 1435 mm).
    progress : callable(done, total), optional
        Called after each wheel and method.

    Returns
    -------
    tuple of PassWheelResult
        In manifest order, methods inner-most.
    """
    calibration = calibration or archive.calibration
    if calibration is None:
        raise ValueError("the pass has no calibration.json; give the site's calibration")
    for method in methods:
        method_options(method)
    total = len(archive.manifest.wheels) * len(methods)
    measured: dict[tuple[str, int, str, str], WheelMeasurement] = {}
    for wheel in archive.manifest.wheels:
        inner = [archive.load_frame(p) for p in wheel.frames_inner]
        outer = [archive.load_frame(p) for p in wheel.frames_outer]
        for method in methods:
            measured[(wheel.vehicle_id, wheel.axle, wheel.side, method)] = measure_wheel(
                inner, outer, calibration, side=wheel.side, method=method
            )
            if progress is not None:
                progress(len(measured), total)
    rails = rails or track_rails()
    axles: dict[tuple[str, int, str], tuple] = {}
    results = []
    for wheel in archive.manifest.wheels:
        for method in methods:
            axle = (wheel.vehicle_id, wheel.axle, method)
            if axle not in axles:
                left = measured.get((wheel.vehicle_id, wheel.axle, "left", method))
                right = measured.get((wheel.vehicle_id, wheel.axle, "right", method))
                b2b = axle_back_to_back(left, right) if left and right else None
                pair = axle_conicity_of(left, right, b2b, rails) if left and right else (None, None)
                axles[axle] = (b2b, *pair)
            key = (wheel.vehicle_id, wheel.axle, wheel.side, method)
            results.append(PassWheelResult(wheel, measured[key], *axles[axle]))
    return tuple(results)
