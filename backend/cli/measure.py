"""Measurement verbs: `synth-pass` (simulated passes with truth), `measure`, `calibrate`,
`synth-calibration` and `rr` (repeatability report, against truth or handheld references)."""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict
from pathlib import Path

from tqdm import tqdm

from backend.cli.profiles import add_agreement_arguments, run_agreement
from backend.config import add_settings_arguments
from pipeline.archive.pass_archive import read_pass_archive
from pipeline.calibration.image_sets import calibrate_station, read_calibration_set
from pipeline.calibration.model import SENSOR_NAMES, read_calibration, write_calibration
from pipeline.profile.measurement import PassWheelResult, measure_pass, method_options
from pipeline.profile.repeatability import (
    pass_observations,
    repeatability_markdown,
    summarise_repeatability,
)
from pipeline.simulation.calibration_images import write_synthetic_calibration_set
from pipeline.simulation.field import FIELD_MODES
from pipeline.simulation.passes import AXLES_PER_VEHICLE, read_truth, write_synthetic_passes
from pipeline.version import PIPELINE_VERSION

PARAMETER_KEYS = ("flange_height_mm", "flange_thickness_mm", "flange_thickness_10_mm", "qr_mm")
TREAD_KEYS = ("tread_hollow_mm", "flange_angle_deg", "rim_width_mm")


def _positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be ≥ 1, got {value}")
    return value


def _synth_pass(args: argparse.Namespace) -> int:
    with tqdm(total=args.repeat, desc="synth-pass", unit="pass", file=sys.stderr) as bar:
        folders = write_synthetic_passes(
            args.out,
            vehicles=args.vehicles,
            seed=args.seed,
            repeat=args.repeat,
            bit_depth=args.bit_depth,
            axles_per_vehicle=args.axles,
            frames_per_sensor=args.frames_per_sensor,
            field=FIELD_MODES[args.field],
            flange_wear_per_pass_mm=args.flange_wear_per_pass,
            progress=lambda done, _total: bar.update(done - bar.n),
        )
    for folder in folders:
        sys.stdout.write(f"{folder}\n")
    return 0


def wheel_row(result: PassWheelResult) -> dict[str, object]:
    """One wheel × method of a measured pass as the JSON row of `wheelscan measure`."""
    m, wheel = result.measurement, result.wheel
    parameters = m.parameters
    row: dict[str, object] = {
        "vehicle_id": wheel.vehicle_id,
        "axle": wheel.axle,
        "side": wheel.side,
        "method": m.method,
        "status": m.status,
        "reason": m.reason if parameters is None else parameters.reason,
    }
    for key in PARAMETER_KEYS:
        value = None if parameters is None else getattr(parameters, key)
        row[key] = None if value is None else round(value, 4)
    b2b = result.back_to_back_mm
    row["back_to_back_mm"] = None if b2b is None else round(b2b, 4)
    tread = m.tread
    for key in TREAD_KEYS:
        value = None if tread is None else getattr(tread, key)
        row[key] = None if value is None else round(value, 4)
    row["tread_reason"] = m.tread_reason if tread is None else tread.reason
    conicity = None if result.conicity is None else result.conicity.conicity_3mm
    row["equivalent_conicity"] = None if conicity is None else round(conicity, 6)
    row["conicity_reason"] = result.conicity_reason
    quality = m.quality_figures()
    residual = quality["overlap_residual_mm"]
    row["quality"] = {
        **quality,
        "overlap_residual_mm": None if residual is None else round(residual, 4),
        "searched_fraction": round(float(quality["searched_fraction"] or 0.0), 4),
    }
    return row


def _methods(text: str) -> tuple[str, ...]:
    """ "both", or method labels separated by commas ("adaptive,steger+curvature")."""
    labels = ("adaptive", "steger") if text == "both" else tuple(text.split(","))
    for label in labels:
        try:
            method_options(label)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
    return labels


def _measure(args: argparse.Namespace) -> int:
    calibration = read_calibration(args.calibration) if args.calibration else None
    archive = read_pass_archive(args.pass_path, site_calibration=calibration)
    methods = _methods(args.method)
    total = len(archive.manifest.wheels) * len(methods)
    with tqdm(total=total, desc="measure", unit="wheel", file=sys.stderr) as bar:
        results = measure_pass(
            archive, methods=methods, progress=lambda done, _t: bar.update(done - bar.n)
        )
    manifest = archive.manifest
    document = {
        "pipeline_version": PIPELINE_VERSION,
        "site": manifest.site,
        "started_at": manifest.started_at.isoformat(),
        "methods": list(methods),
        "wheels": [wheel_row(r) for r in results],
    }
    text = json.dumps(document, indent=2) + "\n"
    if str(args.json) == "-":
        sys.stdout.write(text)
    else:
        Path(args.json).write_text(text, encoding="utf-8")
    measured = sum(r.measurement.status == "measured" for r in results)
    sys.stderr.write(f"measured {measured} of {len(results)} wheel results\n")
    return 0


def _calibrate(args: argparse.Namespace) -> int:
    board, frames = read_calibration_set(args.images, args.target)
    with tqdm(total=len(frames), desc="calibrate", unit="sensor", file=sys.stderr) as bar:
        calibration = calibrate_station(
            board, frames, progress=lambda done, _t: bar.update(done - bar.n)
        )
    write_calibration(calibration, args.output)
    for sensor in calibration.sensors:
        sys.stdout.write(
            f"{sensor.name}: reprojection RMS {sensor.reprojection_rms_px:.3f} px, "
            f"laser plane RMS {sensor.plane_rms_mm:.4f} mm\n"
        )
    return 0


def _synth_calibration(args: argparse.Namespace) -> int:
    sensors = args.sensor or list(SENSOR_NAMES)
    with tqdm(total=len(sensors), desc="synth-calibration", unit="sensor", file=sys.stderr) as bar:
        out = write_synthetic_calibration_set(
            args.out,
            seed=args.seed,
            bit_depth=args.bit_depth,
            sensors=sensors,
            progress=lambda done, _t: bar.update(done - bar.n),
        )
    sys.stdout.write(f"{out}\n")
    return 0


def _finite(row: dict[str, object]) -> dict[str, object]:
    """NaN (e.g. the Std of a single pass) becomes JSON null."""
    return {k: None if isinstance(v, float) and v != v else v for k, v in row.items()}


def _rr(args: argparse.Namespace) -> int:
    if args.against == "references":
        if args.passes:
            raise ValueError("--against references reads stored passes: give --pass-id, not PASS")
        return run_agreement(args)
    if not args.passes:
        raise ValueError("rr needs PASS folders (with truth.json), or --against references")
    methods = args.method
    archives = [read_pass_archive(p) for p in args.passes]
    truths = [read_truth(p) for p in args.passes]
    observations = []
    total = sum(len(a.manifest.wheels) for a in archives) * len(methods)
    with tqdm(total=total, desc="rr", unit="wheel", file=sys.stderr) as bar:
        for archive, truth in zip(archives, truths, strict=True):
            start = bar.n

            def advance(done: int, _total: int, start: int = start) -> None:
                bar.update(start + done - bar.n)

            results = measure_pass(archive, methods=methods, progress=advance)
            observations += pass_observations(results, truth)
    per_wheel, pooled = summarise_repeatability(observations)
    document = {
        "pipeline_version": PIPELINE_VERSION,
        "passes": [str(p) for p in args.passes],
        "methods": list(methods),
        "pooled": [_finite(asdict(s)) for s in pooled],
        "per_wheel": [_finite(asdict(s)) for s in per_wheel],
    }
    text = json.dumps(document, indent=2, allow_nan=False) + "\n"
    if str(args.json) == "-":
        sys.stdout.write(text)
    else:
        Path(args.json).write_text(text, encoding="utf-8")
        sys.stdout.write(repeatability_markdown(per_wheel, pooled))
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the measurement verbs."""
    synth = subparsers.add_parser(
        "synth-pass",
        help="simulate train passes over the station (wheelscan-pass/1 folders + truth.json)",
    )
    synth.add_argument("out", type=Path, help="output folder")
    synth.add_argument("--vehicles", type=_positive_int, default=1)
    synth.add_argument(
        "--axles",
        type=_positive_int,
        default=AXLES_PER_VEHICLE,
        help="axles per vehicle (default 4)",
    )
    synth.add_argument("--seed", type=int, default=0)
    synth.add_argument(
        "--repeat",
        type=_positive_int,
        default=1,
        help="passes of the same train, written to OUT/pass-001, …",
    )
    synth.add_argument("--bit-depth", type=int, choices=(8, 16), default=8)
    synth.add_argument("--frames-per-sensor", type=_positive_int, default=1)
    synth.add_argument(
        "--field",
        choices=tuple(FIELD_MODES),
        default="harsh",
        help="harsh: the station's daylit scene and every field effect (default); "
        "clean: the stripe on black",
    )
    synth.add_argument(
        "--flange-wear-per-pass",
        type=float,
        default=0.0,
        metavar="MM",
        help="flank wear added between repeated passes [mm] (a wear trend; default 0)",
    )
    synth.set_defaults(func=_synth_pass)

    measure = subparsers.add_parser(
        "measure", help="measure every wheel of a pass archive (folder or .zip)"
    )
    measure.add_argument("pass_path", metavar="PASS", type=Path)
    measure.add_argument("--method", choices=("adaptive", "steger", "both"), default="adaptive")
    measure.add_argument(
        "--json", required=True, metavar="OUT", help="output JSON file, - for stdout"
    )
    measure.add_argument(
        "--calibration", type=Path, help="site calibration, for archives without calibration.json"
    )
    measure.set_defaults(func=_measure)

    calibrate = subparsers.add_parser(
        "calibrate",
        help="calibrate sensors from checkerboard, laser and track-target frames",
    )
    calibrate.add_argument(
        "images",
        nargs="+",
        type=Path,
        help="<sensor>/board-NN.png, <sensor>/laser-NN.png, <sensor>/track.png (or folders)",
    )
    calibrate.add_argument("--target", type=Path, required=True, help="target.json of the set")
    calibrate.add_argument("-o", "--output", type=Path, required=True, help="calibration.json")
    calibrate.set_defaults(func=_calibrate)

    synth_cal = subparsers.add_parser(
        "synth-calibration", help="render a calibration image set of the simulated station"
    )
    synth_cal.add_argument("out", type=Path)
    synth_cal.add_argument("--seed", type=int, default=0)
    synth_cal.add_argument("--bit-depth", type=int, choices=(8, 16), default=8)
    synth_cal.add_argument(
        "--sensor",
        action="append",
        choices=SENSOR_NAMES,
        help="only this sensor (repeatable; default all four)",
    )
    synth_cal.set_defaults(func=_synth_calibration)

    rr = subparsers.add_parser(
        "rr",
        help="repeatability over repeated simulated passes (truth.json), or stored results "
        "against handheld references",
    )
    rr.add_argument("passes", nargs="*", type=Path, metavar="PASS")
    rr.add_argument(
        "--against",
        choices=("truth", "references"),
        default="truth",
        help="truth: PASS folders' truth.json; references: stored handheld references",
    )
    rr.add_argument(
        "--method",
        type=_methods,
        default=("adaptive", "steger"),
        help="both (default), or method labels separated by commas with ±curvature, "
        "±asymmetry, ±scatter, ±normal, ±gaps, ±glints "
        "(e.g. adaptive,adaptive-normal,adaptive+glints,steger+curvature+asymmetry)",
    )
    rr.add_argument("--json", required=True, metavar="OUT", help="output JSON file, - for stdout")
    add_agreement_arguments(rr)
    add_settings_arguments(rr)
    rr.set_defaults(func=_rr)
