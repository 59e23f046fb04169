"""Per-wheel errors on the field benchmark's passes, and where along the profile they come from.

`python -m benchmarks.field_wheels FOLDER [METHOD]` measures every wheel of the pass folders
under FOLDER (rendering the field benchmark's passes there first when it holds none:
`field_repeatability`'s train, seed and repeats, every field effect on) and prints one row
per wheel: measured or why not, the Sh and Sd errors, the mean offset of each sensor's
points from the true flank at z = 11–13 mm (x less the true flank's x at the point's
height) and the median signed distance of each sensor's points from the true outline
within ±2.5 mm of the top (+: outside the wheel) [mm]. Not part of BENCHMARKS.md: a
diagnosis tool (docs/simulator.md, "Per-wheel errors on the field passes").
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from benchmarks.field_repeatability import AXLES, REPEATS, SEED, VEHICLES
from pipeline.archive.pass_archive import read_pass_archive
from pipeline.profile.measurement import MEASURED, WheelMeasurement, measure_wheel
from pipeline.simulation.field import FIELD_MODES
from pipeline.simulation.passes import read_truth, synthetic_train, write_synthetic_passes
from pipeline.simulation.wheel import WheelProfile

SD_BAND_MM = (11.0, 13.0)
TOP_HALF_WINDOW_MM = 2.5


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


def wheel_row(measurement: WheelMeasurement, truth: dict, outline: WheelProfile) -> str:
    """One wheel's row (see the module docstring)."""
    if measurement.status != MEASURED or measurement.profile is None:
        return f"not measured: {measurement.reason}"
    parameters, profile = measurement.parameters, measurement.profile
    assert parameters is not None
    cells = [
        f"dSh {parameters.flange_height_mm - truth['flange_height_mm']:+.3f}",
        f"dSd {parameters.flange_thickness_mm - truth['flange_thickness_mm']:+.3f}",
        f"gap {parameters.flank_gap_mm:.1f}",
    ]
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
    """Print the per-wheel table of the passes under argv[0] with method argv[1]."""
    if not argv:
        sys.stderr.write(__doc__.split("\n\n")[1] + "\n")
        return 2
    folder, method = Path(argv[0]), argv[1] if len(argv) > 1 else "adaptive"
    passes = sorted(folder.glob("pass-*"))
    if not passes:
        passes = write_synthetic_passes(
            folder,
            vehicles=VEHICLES,
            axles_per_vehicle=AXLES,
            seed=SEED,
            repeat=REPEATS,
            field=FIELD_MODES["harsh"],
        )
    train = synthetic_train(VEHICLES, SEED, axles_per_vehicle=AXLES)
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
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
