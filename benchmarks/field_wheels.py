"""Per-wheel errors on the field benchmark's passes, and where along the profile they come from.

`python -m benchmarks.field_wheels FOLDER [METHOD]` measures every wheel of the pass folders
under FOLDER (rendering the field benchmark's passes there first when it holds none:
`field_repeatability`'s train, seed and repeats, every field effect on; `--seed=N` draws
another train and passes, held out from the benchmark's; `--frames=N` renders N frames per
sensor and wheel, `passes.FRAME_SPACING_MM` apart) and prints one row
per wheel: measured or why not, the Sh, Sd and Sd 10 errors ("–" and the values' names in
brackets where a value is not measured), the mean offset of each sensor's
points from the true flank at z = 11–13 mm (x less the true flank's x at the point's
height) and the median signed distance of each sensor's points from the true outline
within ±2.5 mm of the top (+: outside the wheel) [mm]. With `--view` it ends with a table
of each sensor's flange points (z > 5 mm) by how grazing its camera sees them
(`view_cosines`): count, median and MAD of their signed distance from the true outline.
Not part of BENCHMARKS.md: a diagnosis tool (docs/simulator.md, "Per-wheel errors on the
field passes").
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from benchmarks.field_repeatability import AXLES, REPEATS, SEED, VEHICLES
from pipeline.archive.pass_archive import read_pass_archive
from pipeline.calibration.geometry import camera_centre_track
from pipeline.profile.flange import missing_value_names
from pipeline.profile.fusion import FusedProfile
from pipeline.profile.measurement import MEASURED, WheelMeasurement, measure_wheel
from pipeline.simulation.field import FIELD_MODES
from pipeline.simulation.passes import read_truth, synthetic_train, write_synthetic_passes
from pipeline.simulation.wheel import WheelProfile

SD_BAND_MM = (11.0, 13.0)
TOP_HALF_WINDOW_MM = 2.5
VIEW_NEIGHBOURS = 24
"""The profile normal at a point: minor axis of its 24 nearest profile points (both
sensors; on the flange the 24th lies a median 1.4 mm away, 10–90 %: 0.9–1.8 mm, so the
neighbourhood is about ±1.4 mm: symmetric about the point its axis is the tangent; at a
piece's end it tilts by up to 1.4 / 12 = 0.12 rad on the R12 top)."""
VIEW_BINS = (0.0, 0.1, 0.2, 0.3, 0.45, 1.0)
VIEW_MIN_Z_MM = 5.0


def outline_offsets(x: np.ndarray, z: np.ndarray, outline: WheelProfile) -> np.ndarray:
    """Signed distance of each point (x, z) from the outline polyline [mm], + outside."""
    ax, az = outline.x_mm[:-1], outline.z_mm[:-1]
    dx, dz = np.diff(outline.x_mm), np.diff(outline.z_mm)
    length2 = np.maximum(dx * dx + dz * dz, 1e-12)
    result = np.empty(x.size)
    for i in range(x.size):
        t = np.clip(((x[i] - ax) * dx + (z[i] - az) * dz) / length2, 0.0, 1.0)
        distance = np.hypot(x[i] - ax - t * dx, z[i] - az - t * dz)
        k = int(np.argmin(distance))
        # the outline runs back face → field face with the material on its right
        result[i] = distance[k] * np.sign(dx[k] * (z[i] - az[k]) - dz[k] * (x[i] - ax[k]))
    return result


def flank_x(outline: WheelProfile, heights_mm: np.ndarray) -> np.ndarray:
    """x of the outline's flank (tread side of its top) at each height, linear [mm]."""
    top = int(np.argmax(outline.z_mm))
    x, z = outline.x_mm[top:], outline.z_mm[top:]
    result = np.full(heights_mm.shape, np.nan)
    for j, height in enumerate(heights_mm):
        down = np.flatnonzero((z[:-1] >= height) & (z[1:] < height))
        if down.size:
            i = int(down[0])
            result[j] = x[i] + (z[i] - height) / (z[i] - z[i + 1]) * (x[i + 1] - x[i])
    return result


def view_cosines(profile: FusedProfile, side: str, cameras_mm: np.ndarray) -> np.ndarray:
    """|cos| of the angle between each profile point's normal and the ray from its camera.

    Parameters
    ----------
    profile : FusedProfile
    side : str
        "left" or "right".
    cameras_mm : ndarray of shape (2, 3)
        Track-frame projection centres of the inner and outer camera [mm].

    Returns
    -------
    ndarray of shape (K,)
        In [0, 1]: 1 seen head-on, 0 grazing.

    Notes
    -----
    The wheel is a surface of revolution whose axis lies in the laser plane near the lowest
    section, so its surface normal lies in the profile plane: the profile normal (nx, nz)
    is the track direction (±nx, 0, −nz). The points are put back into the track frame at
    Y = 0, where the simulated station's laser planes lie (docs/coordinate-frames.md).
    """
    sign = 1.0 if side == "right" else -1.0
    xz = np.column_stack([profile.x_mm, profile.z_mm])
    _, index = cKDTree(xz).query(xz, k=min(VIEW_NEIGHBOURS, len(xz)))
    local = xz[index] - xz[index].mean(axis=1, keepdims=True)
    cxx = np.einsum("ij,ij->i", local[..., 0], local[..., 0])
    cxz = np.einsum("ij,ij->i", local[..., 0], local[..., 1])
    czz = np.einsum("ij,ij->i", local[..., 1], local[..., 1])
    along = 0.5 * np.arctan2(2.0 * cxz, cxx - czz)  # the major axis' angle to x
    normal = np.column_stack([-sign * np.sin(along), np.zeros(len(xz)), -np.cos(along)])
    track = np.column_stack(
        [
            sign * profile.x_mm + profile.back_face_track_x_mm,
            np.zeros(len(xz)),
            profile.reference_track_z_mm - profile.z_mm,
        ]
    )
    ray = track - cameras_mm[profile.sensor]
    return np.abs(np.einsum("ij,ij->i", normal, ray)) / np.linalg.norm(ray, axis=1)


def view_table(sensor: np.ndarray, cosine: np.ndarray, offset: np.ndarray) -> str:
    """Rows per sensor and `VIEW_BINS` bin of cos: count, median and MAD of the offsets."""
    lines = []
    for code, name in ((0, "inner"), (1, "outer")):
        for lo, hi in zip(VIEW_BINS[:-1], VIEW_BINS[1:], strict=True):
            at = (sensor == code) & (cosine >= lo) & (cosine < hi)
            if not np.any(at):
                continue
            median = float(np.median(offset[at]))
            mad = float(np.median(np.abs(offset[at] - median)))
            lines.append(
                f"{name} cos {lo:.2f}-{hi:.2f}: n {int(at.sum()):6d}, offset median "
                f"{median:+.3f} MAD {mad:.3f} mm"
            )
    return "\n".join(lines) + "\n"


def _error(name: str, value: float | None, true: float) -> str:
    """ "name ±error" [mm], or "name –" for a value not measured."""
    return f"{name} –     " if value is None else f"{name} {value - true:+.3f}"


def wheel_row(measurement: WheelMeasurement, truth: dict, outline: WheelProfile) -> str:
    """One wheel's row (see the module docstring)."""
    if measurement.status != MEASURED or measurement.profile is None:
        return f"not measured: {measurement.reason}"
    parameters, profile = measurement.parameters, measurement.profile
    assert parameters is not None
    cells = [
        f"dSh {parameters.flange_height_mm - truth['flange_height_mm']:+.3f}",
        _error("dSd", parameters.flange_thickness_mm, truth["flange_thickness_mm"]),
        _error("dSd10", parameters.flange_thickness_10_mm, truth["flange_thickness_10_mm"]),
        f"gap {parameters.flank_gap_mm:.1f}",
    ]
    if parameters.reason is not None:
        cells.append(f"[{', '.join(missing_value_names(parameters.reason))} not measured]")
    x, z, sensor = profile.x_mm, profile.z_mm, profile.sensor
    x_top = float(x[np.argmax(z)])
    band = (x > x_top) & (z >= SD_BAND_MM[0]) & (z <= SD_BAND_MM[1])
    top = np.abs(x - x_top) <= TOP_HALF_WINDOW_MM
    offsets = outline_offsets(x[top], z[top], outline)
    for code, name in ((0, "inner"), (1, "outer")):
        at = band & (sensor == code)
        flank = np.mean(x[at] - flank_x(outline, z[at])) if at.any() else np.nan
        on_top = np.median(offsets[sensor[top] == code]) if np.any(sensor[top] == code) else np.nan
        cells.append(f"{name}: Sd band n {int(at.sum()):2d} {flank:+.3f}, top {on_top:+.3f}")
    return "  ".join(cells)


def main(argv: list[str]) -> int:
    """Print the per-wheel table of the passes under argv[0] with method argv[1]
    (and the viewing-angle table with `--view`)."""
    view = "--view" in argv
    seeds = [int(a.split("=", 1)[1]) for a in argv if a.startswith("--seed=")]
    seed = seeds[-1] if seeds else SEED
    frames = [int(a.split("=", 1)[1]) for a in argv if a.startswith("--frames=")]
    argv = [a for a in argv if a != "--view" and not a.startswith(("--seed=", "--frames="))]
    if not argv:
        sys.stderr.write(__doc__.split("\n\n")[1] + "\n")
        return 2
    folder, method = Path(argv[0]), argv[1] if len(argv) > 1 else "adaptive"
    seen: list[np.ndarray] = []
    passes = sorted(folder.glob("pass-*"))
    if not passes:
        passes = write_synthetic_passes(
            folder,
            vehicles=VEHICLES,
            axles_per_vehicle=AXLES,
            seed=seed,
            repeat=REPEATS,
            frames_per_sensor=frames[-1] if frames else 1,
            field=FIELD_MODES["harsh"],
        )
    train = synthetic_train(VEHICLES, seed, axles_per_vehicle=AXLES)
    outlines = {(w.vehicle_id, w.axle, w.side): w.profile for w in train.wheels}
    for path in passes:
        archive = read_pass_archive(path)
        assert archive.calibration is not None
        truth = {(r["vehicle_id"], r["axle"], r["side"]): r for r in read_truth(path)}
        for wheel in archive.manifest.wheels:
            key = (wheel.vehicle_id, wheel.axle, wheel.side)
            measurement = measure_wheel(
                [archive.load_frame(p) for p in wheel.frames_inner],
                [archive.load_frame(p) for p in wheel.frames_outer],
                archive.calibration,
                side=wheel.side,
                method=method,
            )
            label = "/".join(map(str, key))
            row = wheel_row(measurement, truth[key], outlines[key])
            sys.stdout.write(f"{path.name} {label:14s} {row}\n")
            profile = measurement.profile
            if view and profile is not None:
                cameras = np.array(
                    [
                        camera_centre_track(archive.calibration.sensor(f"{wheel.side}_{p}"))
                        for p in ("inner", "outer")
                    ]
                )
                flange = profile.z_mm > VIEW_MIN_Z_MM
                offset = outline_offsets(profile.x_mm[flange], profile.z_mm[flange], outlines[key])
                cosine = view_cosines(profile, wheel.side, cameras)[flange]
                seen.append(np.column_stack([profile.sensor[flange], cosine, offset]))
    if seen:
        table = np.concatenate(seen)
        sys.stdout.write(view_table(table[:, 0].astype(int), table[:, 1], table[:, 2]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
