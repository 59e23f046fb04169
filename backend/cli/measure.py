"""Measurement verbs: `synth-pass` (simulated passes with truth), `measure`, `calibrate`,
`synth-calibration` and `rr` (repeatability report)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tqdm import tqdm

from pipeline.simulator import AXLES_PER_VEHICLE, write_synthetic_passes


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
            progress=lambda done, _total: bar.update(done - bar.n),
        )
    for folder in folders:
        sys.stdout.write(f"{folder}\n")
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
    synth.set_defaults(func=_synth_pass)
