"""The floor the field mode's reflectance texture puts under Sh and Sd, per frame.

A study (docs/simulator.md, "The texture's floor under Sh and Sd"), not part of `make bench`:

    PYTHONPATH=. python -m benchmarks.texture_bound [--quick] [--passes N] [--harsh]

(about 12 minutes on 2 loaded cores; --quick --passes 0 under a minute). It prints
markdown tables of

1. the stripe as each sensor sees it in the fit windows of the field benchmark's 8 wheels
   (seed 2027, `benchmarks.field_repeatability`'s train, each wheel centred in the laser
   planes): stripe length [px], 1/e² width [px], peak [DN], and the profile shift [mm] that
   one pixel of centre offset along the image normal makes;
2. the Cramér–Rao bound [mm] of one frame's Sh and Sd (one inner and one outer frame) under
   the multiplicative texture `field.stripe_texture` and the sensor's noise, over the
   texture's correlation [px] and contrast (std/mean), and averaged over the simulator's
   draws (uniform 3–15 px, 0.2–0.6): the root of the mean variance;
3. an empirical check: a long straight stripe under the texture alone, centres from
   `pipeline.extract_centres` (adaptive and Steger), the RMS offset [px] of a quadratic
   fitted along windows as long as the flange top's, beside the bound for the same stripe;
4. one frame's Sh and Sd spread within a pass [mm] as `measure_wheel` (adaptive) reads the
   field benchmark's 9 passes rendered with the texture alone and clean (`--harsh`: also
   every effect; `--passes 0`: none), each wheel's 3 frames measured one by one;
5. the frames a burst needs for the issue's bar (largest per-wheel Std of 8 wheels over 9
   passes ≤ 0.03 mm), the Monte Carlo factor between that statistic and a wheel's true
   spread, and the frames a 60 frames/s camera takes within ±21 mm of travel.

The bound. A frame's grey level near the stripe is A·g(n − δ(s))·t(n, s) + sensor noise,
g the Gaussian cross-section (σ = w/4) across the stripe (n) and t the log-normal texture
of mean 1. Counted as Gaussian noise of the texture's covariance as rendered (estimated
from `scene.grain` fields) plus shot, read and 8-bit quantisation noise, the Fisher
information of the coefficients of an offset δ(s) = Σ θ_k b_k(s) from the pixels of a window
is Dᵀ C⁻¹ D, D = ∂(A·g)/∂θ, C = diag(A·g) C_t diag(A·g) + diag(noise variance); the
stripe's peak (a quadratic along s) and width are nuisance parameters. The basis b_k(s) is
the fit's polynomial in the profile coordinate (x on the top and the tread, z on the flank)
times the image offset per mm of profile shift there, from the station's calibration
(`pixels_to_track_points`, a central difference along the image normal). Each sensor's
window is straightened (a row of pixels along s, 1 px steps of arc length); the inner and
the outer sensor's information add.
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from benchmarks.field_repeatability import AXLES, SEED, VEHICLES
from pipeline import extract_centres
from pipeline.calibration.geometry import pixels_to_track_points
from pipeline.profile.flange import SD_FIT_HALF_WINDOW_MM, SD_HEIGHT_MM, TOP_HALF_WINDOW_MM
from pipeline.profile.fusion import REFERENCE_HALF_WINDOW_MM, REFERENCE_X_MM
from pipeline.profile.measurement import MEASURED, measure_wheel
from pipeline.simulation.field import (
    FIELD_MODES,
    TEXTURE_CONTRAST,
    TEXTURE_CORRELATION_PX,
    FieldEffects,
)
from pipeline.simulation.frame_render import (
    DARK_LEVEL_DN,
    ELECTRONS_PER_DN,
    REACH_SIGMAS,
    READ_NOISE_DN,
    expose,
    stripe_peaks,
)
from pipeline.simulation.passes import (
    SimWheel,
    _pose,
    pass_start_time,
    simulate_pass,
    synthetic_train,
)
from pipeline.simulation.render import wheel_section
from pipeline.simulation.scene import grain
from pipeline.simulation.station import Station, build_station
from pipeline.simulation.wheel import outward_normals

CORRELATIONS_PX = (3.0, 5.0, 7.0, 9.0, 11.0, 13.0, 15.0)
CONTRASTS = (0.2, 0.3, 0.4, 0.5, 0.6)
"""The grid over the simulator's draws (`TEXTURE_CORRELATION_PX`, `TEXTURE_CONTRAST`,
both uniform): the draw average is the trapezoid mean of the variance over it."""
AUTOCOV_SIZE_PX = 768
AUTOCOV_DRAWS = 4
MAX_LAG_PX = 64
"""Texture covariance from `AUTOCOV_DRAWS` fields of 768² px, lags up to 64 px: windows
longer than that are taken in 64 px blocks whose information adds (the back face)."""
QUANTISATION_VAR_DN2 = 1.0 / 12.0
FACE_Z_MM = (-35.0, 2.0)
"""The back face's points `fusion._refine_back_face` averages (z between them) [mm]."""
MEASURED_FRAME_SPREAD_MM = {"Sh": (0.081, 0.094), "Sd": (0.097, 0.056)}
"""One frame's error spread within a pass, seeds 2027 / 2028 (docs/simulator.md, "Per frame
or per pass")."""
BAR_STD_MM = 0.03
PASSES, WHEELS = 9, 8
FRAME_RATE_HZ = 60.0
BURST_HALF_TRAVEL_MM = 21.0
SPEEDS_KMH = (5.0, 10.0, 20.0, 40.0)


@dataclass(frozen=True, slots=True)
class Window:
    """One sensor's stripe over one fit window, resampled at 1 px of arc along the stripe.

    Attributes
    ----------
    sensor : str
    coord_mm : ndarray of shape (L,)
        The fit's abscissa at each pixel: profile x (top, tread) or z (flank, face) [mm].
    gain_px_per_mm : ndarray of shape (L,)
        Image offset along the stripe's normal per mm of the fitted curve's shift (z on the
        top and tread, x on the flank and face) [px/mm].
    width_px, peak_dn : ndarray of shape (L,)
        1/e² width [px] and peak grey [DN] of the stripe.
    """

    sensor: str
    coord_mm: np.ndarray
    gain_px_per_mm: np.ndarray
    width_px: np.ndarray
    peak_dn: np.ndarray


def texture_autocovariance(correlation_px: float, contrast: float, seed: int = 0) -> np.ndarray:
    """Autocovariance of t − 1 for `scene.grain` fields, lags ±`MAX_LAG_PX` (rows, columns).

    Parameters
    ----------
    correlation_px : float
        The texture's correlation parameter [px].
    contrast : float
        Its std/mean.
    seed : int

    Returns
    -------
    ndarray of shape (2·MAX_LAG_PX + 1, 2·MAX_LAG_PX + 1)
        Averaged over positions (the grid's phase) and `AUTOCOV_DRAWS` fields [1].
    """
    rng = np.random.default_rng(seed)
    size, lag = AUTOCOV_SIZE_PX, MAX_LAG_PX
    lags = np.arange(-lag, lag + 1)
    overlap = np.outer(size - np.abs(lags), size - np.abs(lags))
    total = np.zeros((2 * lag + 1, 2 * lag + 1))
    for _ in range(AUTOCOV_DRAWS):
        t = grain((size, size), correlation_px, contrast, rng).astype(np.float64) - 1.0
        spectrum = np.fft.rfft2(t, s=(2 * size, 2 * size))
        product = np.fft.irfft2(spectrum * np.conj(spectrum), s=(2 * size, 2 * size))
        product = np.fft.fftshift(product)[size - lag : size + lag + 1, size - lag : size + lag + 1]
        total += product / overlap
    return total / AUTOCOV_DRAWS


def _regions(wheel: SimWheel) -> dict[str, tuple[np.ndarray, int, int]]:
    """Outline points of each fit window, the fit's coordinate (0: x, 1: z) and the shifted
    one: top (z(x), ±2.5 mm), flank (x(z), z = 12 ± 2 mm), tread (z(x), x = 70 ± 5 mm),
    face (x, z in `FACE_Z_MM`)."""
    x, z = wheel.profile.x_mm, wheel.profile.z_mm
    x_top = x[np.argmax(z)]
    return {
        "top": (np.abs(x - x_top) <= TOP_HALF_WINDOW_MM, 0, 1),
        "flank": (
            (x > x_top) & (x < x_top + 40.0) & (np.abs(z - SD_HEIGHT_MM) <= SD_FIT_HALF_WINDOW_MM),
            1,
            0,
        ),
        "tread": (np.abs(x - REFERENCE_X_MM) <= REFERENCE_HALF_WINDOW_MM, 0, 1),
        "face": ((x <= x.min() + 1e-9) & (z > FACE_Z_MM[0]) & (z < FACE_Z_MM[1]), 1, 0),
    }


def wheel_windows(station: Station, wheel: SimWheel) -> dict[tuple[str, str], Window]:
    """Each sensor's `Window` of each fit region ("top", "flank", "tread", "face") on `wheel`
    centred in the laser planes (no offset, yaw or trigger jitter); regions a sensor does
    not see are left out."""
    pose = _pose(wheel, 0.0, 0.0, 0.0)
    sign = 1.0 if wheel.side == "right" else -1.0
    normals = outward_normals(wheel.profile.x_mm, wheel.profile.z_mm)
    outline = np.column_stack([wheel.profile.x_mm, wheel.profile.z_mm])
    result = {}
    for position in ("inner", "outer"):
        name = f"{wheel.side}_{position}"
        sensor = station.calibration.sensor(name)
        samples = wheel_section(
            wheel.profile,
            pose,
            sensor,
            station.laser_origin(name),
            scatter_mm=wheel.appearance.scatter_mm,
        )
        peaks = stripe_peaks(samples, wheel.appearance.reflectivity[samples.outline_index])
        for region, (on_outline, along, shifted) in _regions(wheel).items():
            at = np.flatnonzero(on_outline[samples.outline_index])
            if at.size < 10:
                continue
            pixels = samples.pixels[at]
            tangent = np.gradient(pixels, axis=0)
            tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
            across = np.column_stack([-tangent[:, 1], tangent[:, 0]])
            ahead = pixels_to_track_points(*(pixels + 0.5 * across).T, sensor)
            behind = pixels_to_track_points(*(pixels - 0.5 * across).T, sensor)
            moved = np.column_stack(
                [sign * (ahead[:, 0] - behind[:, 0]), -(ahead[:, 2] - behind[:, 2])]
            )  # profile (x, z) per px along the image normal
            normal = normals[samples.outline_index[at]]
            gain = normal[:, shifted] / np.einsum("ij,ij->i", moved, normal)
            arc = np.concatenate(
                [[0.0], np.cumsum(np.linalg.norm(np.diff(pixels, axis=0), axis=1))]
            )
            steps = np.arange(0.0, arc[-1] + 1e-9, 1.0)
            coord = outline[samples.outline_index[at], along]
            result[(region, position)] = Window(
                sensor=name,
                coord_mm=np.interp(steps, arc, coord),
                gain_px_per_mm=np.abs(np.interp(steps, arc, gain)),
                width_px=np.interp(steps, arc, samples.width_px[at]),
                peak_dn=np.interp(steps, arc, peaks[at]),
            )
    return result


def offset_information(
    window: Window,
    centre_mm: float,
    degree: int,
    autocov: np.ndarray | None,
    scene_dn: float = 0.0,
) -> np.ndarray:
    """Fisher information of the fit's coefficients from one sensor's window.

    Parameters
    ----------
    window : Window
    centre_mm : float
        Where the fitted polynomial's coefficients are taken (its value there is θ0) [mm].
    degree : int
        0 (a constant: the back face) or 2 (the quadratic fits).
    autocov : ndarray or None
        `texture_autocovariance` of the texture; None: the sensor's noise alone.
    scene_dn : float
        A uniform background under the stripe adding its shot noise [DN].

    Returns
    -------
    ndarray of shape (degree + 1, degree + 1)
        [mm⁻²] for θ in mm of profile shift (and mm⁻¹, mm⁻² for the higher coefficients);
        the stripe's peak (quadratic along it) and width are nuisance parameters. Windows
        longer than `MAX_LAG_PX` add the information of their blocks.
    """
    length = window.coord_mm.size
    if length > MAX_LAG_PX:
        blocks = np.array_split(np.arange(length), math.ceil(length / MAX_LAG_PX))
        return sum(
            offset_information(
                Window(
                    window.sensor,
                    window.coord_mm[b],
                    window.gain_px_per_mm[b],
                    window.width_px[b],
                    window.peak_dn[b],
                ),
                centre_mm,
                degree,
                autocov,
                scene_dn,
            )
            for b in blocks
        )
    sigma = window.width_px / 4.0
    reach = int(math.ceil(REACH_SIGMAS * sigma.max()))
    n = np.arange(-reach, reach + 1, dtype=np.float64)[:, None]
    g = np.exp(-0.5 * (n / sigma) ** 2) * (np.abs(n) <= REACH_SIGMAS * sigma)
    mean = window.peak_dn * g
    u = window.coord_mm - centre_mm
    t = (np.arange(length) - 0.5 * (length - 1)) / max(length, 1)
    columns = [mean * n / sigma**2 * window.gain_px_per_mm * u**k for k in range(degree + 1)]
    columns += [g * t**k for k in range(3)] + [mean * n**2 / sigma**3]
    lit = g.ravel() > 0
    design = np.column_stack([c.ravel()[lit] for c in columns])
    noise = (mean + DARK_LEVEL_DN + scene_dn) / ELECTRONS_PER_DN + READ_NOISE_DN**2
    covariance = np.diag((noise + QUANTISATION_VAR_DN2).ravel()[lit])
    if autocov is not None:
        rows, cols = (
            np.broadcast_to(n, g.shape).ravel()[lit],
            np.broadcast_to(np.arange(length), g.shape).ravel()[lit],
        )
        lag = MAX_LAG_PX
        texture = autocov[
            (rows[:, None] - rows[None, :]).astype(int) + lag,
            cols[:, None] - cols[None, :] + lag,
        ]
        level = mean.ravel()[lit]
        covariance += level[:, None] * texture * level[None, :]
    information = design.T @ cho_solve(cho_factor(covariance), design)
    k = degree + 1
    own, cross, nuisance = information[:k, :k], information[:k, k:], information[k:, k:]
    return own - cross @ np.linalg.solve(nuisance, cross.T)


def value_variance(information: np.ndarray) -> float:
    """Variance of θ0 (the fit's value at its centre) from summed information [mm²]."""
    return float(np.linalg.inv(information)[0, 0])


# --- the per-frame bound of Sh and Sd ---------------------------------------------------


def frame_variances(
    windows: dict[tuple[str, str], Window], wheel: SimWheel, autocov: np.ndarray | None
) -> dict[str, float]:
    """Bound variances [mm²] of one frame (inner + outer) on one wheel.

    Returns
    -------
    dict
        "top inner", "top outer", "top" (both), "reference" (z at x = 70 mm), "flank"
        (x at z = 12 mm), "face" (the back face's x), "Sh" = top + reference and
        "Sd" = flank + face + (dx/dz)²·reference, the flank's slope at 12 mm from the
        outline (the reference's error moves the height Sd is read at).
    """
    x, z = wheel.profile.x_mm, wheel.profile.z_mm
    x_top = float(x[np.argmax(z)])
    info = {}
    for (region, position), window in windows.items():
        centre, degree = {
            "top": (x_top, 2),
            "tread": (REFERENCE_X_MM, 2),
            "flank": (SD_HEIGHT_MM, 2),
            "face": (0.0, 0),
        }[region]
        info[(region, position)] = offset_information(window, centre, degree, autocov)

    def both(region: str) -> float:
        return value_variance(sum(v for (r, _), v in info.items() if r == region))

    flank = (x > x_top) & (x < x_top + 40.0)
    slope = float(np.interp(SD_HEIGHT_MM, z[flank][::-1], np.gradient(x[flank], z[flank])[::-1]))
    result = {
        "top inner": value_variance(info[("top", "inner")]),
        "top outer": value_variance(info[("top", "outer")]),
        "top": both("top"),
        "reference": both("tread"),
        "flank": both("flank"),
        "face": both("face"),
    }
    result["Sh"] = result["top"] + result["reference"]
    result["Sd"] = result["flank"] + result["face"] + slope**2 * result["reference"]
    return result


def _trapezoid_weights(values: tuple[float, ...]) -> np.ndarray:
    """Weights of the trapezoid mean over a grid spanning a uniform distribution."""
    edges = np.diff(np.asarray(values))
    weights = np.zeros(len(values))
    weights[:-1] += edges / 2
    weights[1:] += edges / 2
    return weights / weights.sum()


def bound_grid(
    station: Station,
    wheels: tuple[SimWheel, ...],
    correlations: tuple[float, ...],
    contrasts: tuple[float, ...],
) -> tuple[dict[str, np.ndarray], dict[str, float], dict[tuple[str, str], list[Window]]]:
    """Per-frame bound variances over the texture grid, RMS over the wheels.

    Returns
    -------
    grid : dict of ndarray of shape (len(correlations), len(contrasts))
        Mean variance over the wheels per quantity of `frame_variances` [mm²].
    noise_only : dict of float
        The same with the sensor's noise alone (no texture) [mm²].
    windows : dict
        Every wheel's windows per (region, sensor position).
    """
    all_windows = [wheel_windows(station, wheel) for wheel in wheels]
    keys = ("top inner", "top outer", "top", "reference", "flank", "face", "Sh", "Sd")
    grid = {key: np.zeros((len(correlations), len(contrasts))) for key in keys}
    for i, correlation in enumerate(correlations):
        for j, contrast in enumerate(contrasts):
            autocov = texture_autocovariance(correlation, contrast, seed=1000 * i + j)
            for windows, wheel in zip(all_windows, wheels, strict=True):
                for key, value in frame_variances(windows, wheel, autocov).items():
                    grid[key][i, j] += value / len(wheels)
    noise_only = dict.fromkeys(keys, 0.0)
    for windows, wheel in zip(all_windows, wheels, strict=True):
        for key, value in frame_variances(windows, wheel, None).items():
            noise_only[key] += value / len(wheels)
    by_key: dict[tuple[str, str], list[Window]] = {}
    for windows in all_windows:
        for key, window in windows.items():
            by_key.setdefault(key, []).append(window)
    return grid, noise_only, by_key


def draw_average(variance: np.ndarray, correlations, contrasts) -> float:
    """Root of the variance averaged over the simulator's uniform draws [mm]."""
    weights = np.outer(_trapezoid_weights(correlations), _trapezoid_weights(contrasts))
    return float(np.sqrt(np.sum(weights * variance)))


# --- the empirical check: a straight stripe under the texture ----------------------------

CHECK_SHAPE = (160, 1600)
CHECK_SLOPE = 0.03
"""A straight stripe across a 160 × 1600 px frame, 0.03 rad off the rows."""
CHECK_MARGIN_PX = 40.0
CHECK_WINDOW_PX = 30
"""The flange top's ±2.5 mm window holds 29–32 px of each sensor's stripe."""
CHECK_PEAK_DN = 80.0
CHECK_CASES = ((14.3, 3.0, 0.2), (14.3, 9.0, 0.4), (14.3, 15.0, 0.6), (10.9, 9.0, 0.4))
"""(width [px], correlation [px], contrast): the inner and the outer sensor's top widths."""


def straight_stripe(
    width_px: float, correlation_px: float, contrast: float, rng, *, sensor_noise: bool
) -> tuple[np.ndarray, float]:
    """A straight Gaussian stripe (peak `CHECK_PEAK_DN`) times a `scene.grain` texture.

    Returns
    -------
    (ndarray of shape CHECK_SHAPE, uint8, float)
        The frame (quantised, with `expose`'s shot and read noise when `sensor_noise`) and
        the row of the line at column 0 [px].
    """
    rows, cols = np.mgrid[0 : CHECK_SHAPE[0], 0 : CHECK_SHAPE[1]].astype(np.float64)
    row0 = 0.5 * CHECK_SHAPE[0] - 0.5 * CHECK_SLOPE * CHECK_SHAPE[1] + rng.uniform(0, 1)
    distance = (rows - row0 - CHECK_SLOPE * cols) / math.hypot(1.0, CHECK_SLOPE)
    sigma = width_px / 4.0
    image = CHECK_PEAK_DN * np.exp(-0.5 * (distance / sigma) ** 2)
    image *= np.abs(distance) <= REACH_SIGMAS * sigma
    image = (image * grain(CHECK_SHAPE, correlation_px, contrast, rng)).astype(np.float32)
    if sensor_noise:
        return expose(image, 8, rng), row0
    return np.clip(np.round(image), 0, 255).astype(np.uint8), row0


def window_offsets(image: np.ndarray, row0: float, method: str) -> np.ndarray:
    """Each window's fitted offset [px]: a quadratic in the column through the centres'
    signed distances from the true line over `CHECK_WINDOW_PX` px of stripe, at its middle."""
    centres = extract_centres(image, method=method)
    offset = (centres.y - row0 - CHECK_SLOPE * centres.x) / math.hypot(1.0, CHECK_SLOPE)
    keep = (
        (centres.x > CHECK_MARGIN_PX)
        & (centres.x < CHECK_SHAPE[1] - CHECK_MARGIN_PX)
        & (np.abs(offset) < 4.0)
    )
    x, offset = centres.x[keep], offset[keep]
    step = CHECK_WINDOW_PX / math.hypot(1.0, CHECK_SLOPE)
    result = []
    for start in np.arange(CHECK_MARGIN_PX, CHECK_SHAPE[1] - CHECK_MARGIN_PX - step, step):
        inside = (x >= start) & (x < start + step)
        if np.count_nonzero(inside) < 0.6 * CHECK_WINDOW_PX:
            continue  # the stripe broken there: the pipeline would not fit across it either
        middle = start + 0.5 * step
        result.append(np.polyval(np.polyfit(x[inside] - middle, offset[inside], 2), 0.0))
    return np.asarray(result)


def straight_bound(width_px: float, autocov: np.ndarray | None) -> float:
    """Bound [px] of the offset at the middle of a `CHECK_WINDOW_PX` window of the straight
    stripe fitted with a quadratic (its peak and width nuisance), sensor noise as `expose`."""
    length = CHECK_WINDOW_PX
    window = Window(
        "straight",
        np.arange(length, dtype=np.float64),
        np.ones(length),
        np.full(length, width_px),
        np.full(length, CHECK_PEAK_DN),
    )
    return math.sqrt(value_variance(offset_information(window, 0.5 * (length - 1), 2, autocov)))


# --- frames: what the bar needs, what a camera takes -------------------------------------


def largest_std_factor(trials: int, rng) -> tuple[float, float, float]:
    """Largest sample Std (ddof 1) of `WHEELS` wheels over `PASSES` passes of unit spread:
    (mean, median, 90th percentile) over `trials` Monte Carlo draws."""
    draws = rng.standard_normal((trials, WHEELS, PASSES))
    largest = draws.std(axis=2, ddof=1).max(axis=1)
    return float(largest.mean()), float(np.median(largest)), float(np.quantile(largest, 0.9))


def frames_in_burst(speed_kmh: float) -> tuple[float, int, int]:
    """Frames at `FRAME_RATE_HZ` whose laser plane lies within ±`BURST_HALF_TRAVEL_MM` of
    the wheel's lowest point: (mean over the trigger's phase, fewest, most)."""
    spacing = speed_kmh / 3.6 * 1000.0 / FRAME_RATE_HZ
    span = 2 * BURST_HALF_TRAVEL_MM / spacing
    return span, math.floor(span), math.floor(span) + 1


# --- one frame alone on the field benchmark's passes -------------------------------------

FRAME_FIELDS = ("texture", "clean")
"""The fields the passes are rendered with here: the texture alone (every other field effect
off, the clean appearance kept: speckle, spots beside the stripe, stray light, the axle-box
stripe, shot and read noise) and clean; "harsh" (every effect) with --harsh."""


def _field(name: str) -> FieldEffects | None:
    if name == "texture":
        return FieldEffects(**{n: n == "texture" for n in FieldEffects.names()})
    return FIELD_MODES[name]


def frame_errors(field_name: str, passes: int, station: Station, wheels: int) -> np.ndarray:
    """Sh and Sd errors [mm] of each wheel measured from each of its 3 frames alone (inner
    k with outer k) and from the 3 fused, on the field benchmark's passes (seed, train and
    pass draws of `write_synthetic_passes`) rendered with `field_name`'s effects.

    Returns
    -------
    ndarray of shape (passes · wheels, 4, 2)
        [frame 0, 1, 2, fused] × [Sh, Sd]; NaN where not measured. The train's first
        `wheels` wheels are measured.
    """
    train = synthetic_train(VEHICLES, SEED, axles_per_vehicle=AXLES)
    _, *rngs = np.random.default_rng(SEED).spawn(passes + 1)
    rows = []
    for index, rng in enumerate(rngs):
        simulated = simulate_pass(
            train,
            station,
            rng,
            started_at=pass_start_time(index),
            frames_per_sensor=3,
            field=_field(field_name),
        )
        for wheel, entry in list(zip(train.wheels, simulated.manifest.wheels, strict=True))[
            :wheels
        ]:
            inner = [simulated.frames[path] for path in entry.frames_inner]
            outer = [simulated.frames[path] for path in entry.frames_outer]
            row = []
            for chosen in ([0], [1], [2], [0, 1, 2]):
                measured = measure_wheel(
                    [inner[k] for k in chosen],
                    [outer[k] for k in chosen],
                    station.calibration,
                    side=wheel.side,
                )
                if measured.status != MEASURED:
                    row.append((np.nan, np.nan))
                    continue
                found, truth = measured.parameters, wheel.profile.truth
                sd = found.flange_thickness_mm
                row.append(
                    (
                        found.flange_height_mm - truth.flange_height_mm,
                        np.nan if sd is None else sd - truth.flange_thickness_mm,
                    )
                )
            rows.append(row)
    return np.asarray(rows)


def within_pass_spread(errors: np.ndarray) -> tuple[float, int]:
    """One frame's spread within a pass [mm]: the root of the mean over wheels and passes
    of the 3 single-frame errors' sample variance (ddof 1), where all 3 are measured; and
    the number of such (pass, wheel) rows."""
    complete = np.all(np.isfinite(errors), axis=1)
    if not np.any(complete):
        return math.nan, 0
    return float(np.sqrt(np.mean(np.var(errors[complete], axis=1, ddof=1)))), int(
        np.count_nonzero(complete)
    )


# --- the report --------------------------------------------------------------------------


def _row(cells) -> str:
    return "| " + " | ".join(str(c) for c in cells) + " |\n"


def _header(cells) -> str:
    return _row(cells) + _row(["---"] * len(cells))


def _window_table(windows: dict[tuple[str, str], list[Window]]) -> str:
    text = _header(
        ["window", "sensor", "stripe [px]", "width [px]", "peak [DN]", "profile shift [mm/px]"]
    )
    for region in ("top", "flank", "tread", "face"):
        for position in ("inner", "outer"):
            found = windows.get((region, position))
            if not found:
                continue
            length = np.median([w.coord_mm.size for w in found])
            width = np.median([np.median(w.width_px) for w in found])
            peak = [np.median(w.peak_dn) for w in found]
            shift = np.median([1.0 / np.median(w.gain_px_per_mm) for w in found])
            text += _row(
                [
                    region,
                    position,
                    f"{length:.0f}",
                    f"{width:.1f}",
                    f"{np.median(peak):.0f} ({min(peak):.0f}–{max(peak):.0f})",
                    f"{shift:.3f}",
                ]
            )
    return text


def _grid_table(variance: np.ndarray, correlations, contrasts, noise_only: float) -> str:
    text = _header(["correlation [px]", *(f"contrast {c:g}" for c in contrasts)])
    for i, correlation in enumerate(correlations):
        text += _row([f"{correlation:g}", *(f"{math.sqrt(v):.4f}" for v in variance[i])])
    text += (
        f"\nDrawn as the simulator draws them (uniform {TEXTURE_CORRELATION_PX[0]:g}–"
        f"{TEXTURE_CORRELATION_PX[1]:g} px, {TEXTURE_CONTRAST[0]:g}–{TEXTURE_CONTRAST[1]:g}): "
        f"**{draw_average(variance, correlations, contrasts):.4f} mm**; sensor noise alone "
        f"{math.sqrt(noise_only):.4f} mm.\n"
    )
    return text


def _check_table(frames: int, rng) -> tuple[str, dict[str, float]]:
    """The straight stripe's windows: the bound beside adaptive and Steger [px]."""
    text = _header(
        [
            "width [px]",
            "correlation [px]",
            "contrast",
            "sensor noise",
            "bound [px]",
            "adaptive RMS [px] (windows)",
            "Steger RMS [px] (windows)",
            "adaptive / bound",
            "Steger / bound",
        ]
    )
    for width, correlation, contrast in CHECK_CASES:
        autocov = texture_autocovariance(correlation, contrast)
        bound = straight_bound(width, autocov)
        for noise in (False, True):
            found = {"adaptive": [], "steger": []}
            for _ in range(frames):
                image, row0 = straight_stripe(width, correlation, contrast, rng, sensor_noise=noise)
                for method, values in found.items():
                    values.append(window_offsets(image, row0, method))
            rms = {m: float(np.sqrt(np.mean(np.concatenate(v) ** 2))) for m, v in found.items()}
            count = {m: sum(a.size for a in v) for m, v in found.items()}
            text += _row(
                [
                    f"{width:g}",
                    f"{correlation:g}",
                    f"{contrast:g}",
                    "yes" if noise else "quantised only",
                    f"{bound:.3f}",
                    f"{rms['adaptive']:.3f} ({count['adaptive']})",
                    f"{rms['steger']:.3f} ({count['steger']})",
                    f"{rms['adaptive'] / bound:.2f}",
                    f"{rms['steger'] / bound:.2f}",
                ]
            )
    # drawn as the simulator draws them, with the sensor's noise
    text += "\nTextures drawn as the simulator draws them, with the sensor's noise:\n\n"
    text += _header(
        ["width [px]", "frames", "bound (RMS) [px]", "adaptive RMS [px]", "Steger RMS [px]"]
    )
    ratios: dict[str, list[float]] = {"adaptive": [], "steger": []}
    for width in (14.3, 10.9):
        bounds, found = [], {"adaptive": [], "steger": []}
        for _ in range(2 * frames):
            correlation = rng.uniform(*TEXTURE_CORRELATION_PX)
            contrast = rng.uniform(*TEXTURE_CONTRAST)
            bounds.append(straight_bound(width, texture_autocovariance(correlation, contrast)))
            image, row0 = straight_stripe(width, correlation, contrast, rng, sensor_noise=True)
            for method, values in found.items():
                values.append(window_offsets(image, row0, method))
        bound = math.sqrt(np.mean(np.square(bounds)))
        rms = {m: float(np.sqrt(np.mean(np.concatenate(v) ** 2))) for m, v in found.items()}
        for method in ratios:
            ratios[method].append(rms[method] / bound)
        text += _row(
            [
                f"{width:g}",
                2 * frames,
                f"{bound:.3f}",
                f"{rms['adaptive']:.3f} ({rms['adaptive'] / bound:.2f}×)",
                f"{rms['steger']:.3f} ({rms['steger'] / bound:.2f}×)",
            ]
        )
    return text, {m: float(np.mean(v)) for m, v in ratios.items()}


def _frames_table(per_frame: dict[str, float], measured: dict, rng) -> str:
    mean, median, p90 = largest_std_factor(200_000, rng)
    target = BAR_STD_MM / mean
    text = (
        f"The largest sample Std (ddof 1) of {WHEELS} wheels over {PASSES} passes, in units of "
        f"a wheel's true spread (Monte Carlo, 200 000 draws): mean {mean:.3f}, median "
        f"{median:.3f}, 90 % {p90:.3f}. The bar Std ≤ {BAR_STD_MM} mm thus asks for a true "
        f"per-wheel spread ≤ {target:.4f} mm (on the mean).\n\n"
    )
    text += _header(["per-frame spread", "Sh [mm]", "frames for Sh", "Sd [mm]", "frames for Sd"])
    rows = [
        ("bound (texture + sensor noise, drawn)", per_frame["Sh"], per_frame["Sd"]),
        *(
            (f"measured here, {name}", measured[(name, "Sh")], measured[(name, "Sd")])
            for name in ("texture", "harsh")
            if (name, "Sh") in measured
        ),
        *(
            (
                f"measured, seed {seed}",
                MEASURED_FRAME_SPREAD_MM["Sh"][k],
                MEASURED_FRAME_SPREAD_MM["Sd"][k],
            )
            for k, seed in enumerate((2027, 2028))
        ),
    ]
    for label, sh, sd in rows:
        text += _row(
            [
                label,
                f"{sh:.3f}",
                f"{math.ceil((sh / target) ** 2)}",
                f"{sd:.3f}",
                f"{math.ceil((sd / target) ** 2)}",
            ]
        )
    text += (
        f"\nFrames at {FRAME_RATE_HZ:g} frames/s whose laser plane lies within "
        f"±{BURST_HALF_TRAVEL_MM:g} mm of travel of the wheel's lowest point:\n\n"
    )
    text += _header(["speed [km/h]", "travel per frame [mm]", "frames (mean)", "frames"])
    for speed in SPEEDS_KMH:
        span, fewest, most = frames_in_burst(speed)
        text += _row(
            [
                f"{speed:g}",
                f"{speed / 3.6 * 1000 / FRAME_RATE_HZ:.1f}",
                f"{span:.2f}",
                f"{fewest} or {most}",
            ]
        )
    return text


def main(argv: list[str] | None = None) -> None:
    """Print the study's tables (markdown) to stdout."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--quick", action="store_true", help="2 wheels, a 3 × 3 texture grid, 1 check frame"
    )
    parser.add_argument(
        "--passes", type=int, default=9, help="passes measured frame by frame (0: none)"
    )
    parser.add_argument("--harsh", action="store_true", help="also the harsh passes (slow)")
    args = parser.parse_args(argv)
    station = build_station()
    wheels = synthetic_train(VEHICLES, SEED, axles_per_vehicle=AXLES).wheels
    correlations, contrasts, frames = CORRELATIONS_PX, CONTRASTS, 2
    if args.quick:
        wheels, correlations, contrasts, frames = wheels[:2], (3.0, 9.0, 15.0), (0.2, 0.4, 0.6), 1
    out = sys.stdout
    grid, noise_only, windows = bound_grid(station, wheels, correlations, contrasts)
    out.write(f"## Fit windows ({len(wheels)} wheels of seed {SEED}, medians)\n\n")
    out.write(_window_table(windows))
    per_frame = {}
    for name in ("Sh", "Sd"):
        out.write(f"\n## Per-frame bound of {name} [mm] (inner + outer frame, RMS over wheels)\n\n")
        out.write(_grid_table(grid[name], correlations, contrasts, noise_only[name]))
        per_frame[name] = draw_average(grid[name], correlations, contrasts)
    out.write("\n## Its parts, drawn textures [mm]\n\n")
    out.write(_header(["part", "bound", "sensor noise alone"]))
    for key in ("top inner", "top outer", "top", "reference", "flank", "face", "Sh", "Sd"):
        value = draw_average(grid[key], correlations, contrasts)
        out.write(_row([key, f"{value:.4f}", f"{math.sqrt(noise_only[key]):.4f}"]))
    for name in ("Sh", "Sd"):
        measured = MEASURED_FRAME_SPREAD_MM[name]
        out.write(
            f"\n{name}: measured one frame's spread {measured[0]:.3f} / {measured[1]:.3f} mm "
            f"(seeds 2027 / 2028) = {measured[0] / per_frame[name]:.1f}× / "
            f"{measured[1] / per_frame[name]:.1f}× the bound.\n"
        )
    rng = np.random.default_rng(SEED)
    out.write(f"\n## The straight stripe under the texture ({CHECK_WINDOW_PX} px windows)\n\n")
    text, ratios = _check_table(frames, rng)
    out.write(text)
    out.write(
        f"\nOn the drawn textures adaptive reads {ratios['adaptive']:.2f}× the bound and Steger "
        f"{ratios['steger']:.2f}×: Sh from the texture alone, as adaptive extracts it, about "
        f"{ratios['adaptive'] * per_frame['Sh']:.3f} mm per frame "
        f"(Steger {ratios['steger'] * per_frame['Sh']:.3f}).\n"
    )
    measured = {}
    if args.passes:
        fields = FRAME_FIELDS + (("harsh",) if args.harsh else ())
        out.write(
            f"\n## One frame alone, measured ({args.passes} passes × {len(wheels)} wheels, "
            "3 frames, adaptive)\n\n"
        )
        out.write(
            _header(
                [
                    "field",
                    "Sh: one frame's spread [mm] (rows)",
                    "× bound",
                    "Sd: one frame's spread [mm] (rows)",
                    "× bound",
                ]
            )
        )
        for name in fields:
            errors = frame_errors(name, args.passes, station, len(wheels))
            cells = [name]
            for j, parameter in enumerate(("Sh", "Sd")):
                spread, rows = within_pass_spread(errors[:, :3, j])
                measured[(name, parameter)] = spread
                cells += [f"{spread:.3f} ({rows})", f"{spread / per_frame[parameter]:.1f}"]
            out.write(_row(cells))
    out.write("\n## Frames\n\n")
    out.write(_frames_table(per_frame, measured, rng))


if __name__ == "__main__":
    main()
