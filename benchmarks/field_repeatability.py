"""Repeatability on field-mode passes (paper Tables 2–4 form) and the per-effect breakdown.

Two vehicles of two axles (8 wheels: LMA on the first, S1002 on the second, random wear)
pass the simulated station 9 times with every field effect on (the daylit scene, texture,
polished bands, asymmetric cross-sections, the flange ghost, glints, the long part stripe,
the flange-root cut, blooming). Each pass is measured with the adaptive method and with
fixed-σ Steger, each with and without its corrections, in the same run. The breakdown then
renders the first passes again with one effect alone, and with every effect but one, and
reports what each costs each method (renderings are paired: docs/simulator.md).
"""

from __future__ import annotations

import math
import os
import tempfile
import time
from dataclasses import replace

from benchmarks.repeatability import BARS, counts, verdicts
from pipeline.archive.pass_archive import read_pass_archive
from pipeline.profile.measurement import measure_pass
from pipeline.profile.repeatability import (
    ParameterStats,
    pass_observations,
    repeatability_markdown,
    summarise_repeatability,
)
from pipeline.simulation.field import FIELD_MODES, FieldEffects
from pipeline.simulation.passes import FRAME_SPACING_MM, read_truth, write_synthetic_passes

REPEATS = int(os.environ.get("FIELD_REPEATS", "9"))
BREAKDOWN_REPEATS = int(os.environ.get("FIELD_BREAKDOWN_REPEATS", "2"))
"""Passes of the main run and of each breakdown case; FIELD_REPEATS and
FIELD_BREAKDOWN_REPEATS reduce them on a loaded machine (the section says so)."""
FULL_RUN = (9, 2)
SEED = 2027
VEHICLES, AXLES = 2, 2
METHODS = (
    "adaptive",
    "adaptive+asymmetry",
    "adaptive+gaps",
    "adaptive+glints",
    "adaptive-normal",
    "adaptive-normal+scatter",
    "adaptive-normal-curvature",
    "steger",
    "steger+curvature",
    "steger+curvature+asymmetry",
)
"""Adaptive (the matched fit along the normal on by default), adaptive with the guided
search across gaps between chains (off by default, docs/extraction.md §6a), with the glints
beside the stripe subtracted (off by default, docs/extraction.md "Glints fitted and
subtracted"), its Hessian
centres without the matched fit (curvature correction on, with the scatter-chosen support,
and with neither), and Steger (corrections off by default), each with and without the
corrections, side by side."""
WHEEL_BAR_MM = 0.10
"""Every wheel's Sh and Sd within 0.10 mm of the truth."""
KEY_PARAMETERS = ("flange_height_mm", "flange_thickness_mm")


BURST_FRAMES = 3
"""Frames per sensor and wheel of the burst section (`passes.FRAME_SPACING_MM` apart)."""
SIDE_BY_SIDE = ("adaptive", "steger")
"""The methods compared wheel by wheel, and measured on the bursts."""


def _measure(field: FieldEffects | None, repeats: int, methods=METHODS, frames_per_sensor=1):
    """Observations of `repeats` passes rendered with `field` (`frames_per_sensor` frames
    per sensor and wheel), and the seconds spent."""
    with tempfile.TemporaryDirectory() as folder:
        start = time.perf_counter()
        passes = write_synthetic_passes(
            folder,
            vehicles=VEHICLES,
            axles_per_vehicle=AXLES,
            seed=SEED,
            repeat=repeats,
            frames_per_sensor=frames_per_sensor,
            field=field,
        )
        simulated_s = time.perf_counter() - start
        observations = []
        start = time.perf_counter()
        for path in passes:
            results = measure_pass(read_pass_archive(path), methods=methods)
            observations += pass_observations(results, read_truth(path))
    return observations, simulated_s, time.perf_counter() - start


def _pooled(observations) -> dict[tuple[str, str], ParameterStats]:
    _, pooled = summarise_repeatability(observations)
    return {(s.method, s.parameter): s for s in pooled}


def _wheel_checks(per_wheel: tuple[ParameterStats, ...]) -> list[str]:
    lines = []
    for method in SIDE_BY_SIDE:
        rows = [s for s in per_wheel if s.method == method and s.parameter in KEY_PARAMETERS]
        worst = max((s.max_error_mm for s in rows), default=math.nan)
        missing = sum(s.missing for s in rows)
        ok = worst <= WHEEL_BAR_MM and missing == 0
        lines.append(
            f"- {method}: every wheel's Sh and Sd within {WHEEL_BAR_MM} mm: largest error "
            f"{worst:.3f} mm, values not measured {missing} {'✓' if ok else '✗'}"
        )
    return lines


def _ratio_lines(pooled: dict[tuple[str, str], ParameterStats]) -> list[str]:
    lines = []
    for parameter in KEY_PARAMETERS:
        a, s = pooled.get(("adaptive", parameter)), pooled.get(("steger", parameter))
        if a is None or s is None:
            continue
        lines.append(
            f"- {parameter}: MAE Steger / adaptive = {s.mae_mm:.3f} / {a.mae_mm:.3f} = "
            f"{s.mae_mm / a.mae_mm:.2f}×; Std {s.std_mm:.3f} / {a.std_mm:.3f}"
        )
    return lines


def _breakdown() -> list[str]:
    """One effect alone and every effect but one: pooled MAE of Sh and Sd per method, and
    values not measured. Renderings are paired (docs/simulator.md): a row differs from
    "none" or "all" only in its effect's pixels."""
    off = FieldEffects(**dict.fromkeys(FieldEffects.names(), False))
    harsh = FIELD_MODES["harsh"]
    cases: list[tuple[str, FieldEffects | None]] = [("none (clean)", None)]
    cases += [(n, replace(off, **{n: True})) for n in off.names()]
    cases.append(("all (harsh)", harsh))
    cases += [(f"all but {n}", harsh.without(n)) for n in off.names()]
    methods = ("adaptive", "adaptive+asymmetry", "steger", "steger+curvature+asymmetry")
    header = "| effects | " + " | ".join(f"{m} Sh / Sd MAE" for m in methods)
    lines = [
        header + " | not measured |",
        "|---|" + "---|" * (len(methods) + 1),
    ]
    for name, field in cases:
        observations, _, _ = _measure(field, BREAKDOWN_REPEATS, methods)
        pooled = _pooled(observations)
        cells = []
        for method in methods:
            sh, sd = (pooled.get((method, p)) for p in KEY_PARAMETERS)
            cells.append("–" if sh is None or sd is None else f"{sh.mae_mm:.3f} / {sd.mae_mm:.3f}")
        lines.append(f"| {name} | " + " | ".join(cells) + f" | {counts(observations)[1]} |")
    return lines


def _burst() -> list[str]:
    """The same passes with BURST_FRAMES frames per sensor and wheel: bars, per-wheel checks
    and Steger beside adaptive."""
    observations, simulated_s, measured_s = _measure(
        FIELD_MODES["harsh"], REPEATS, SIDE_BY_SIDE, frames_per_sensor=BURST_FRAMES
    )
    per_wheel, pooled = summarise_repeatability(observations)
    table = {(s.method, s.parameter): s for s in pooled}
    rows = ["| method | parameter | MAE | Std | max | measured |", "|---|---|---|---|---|---|"]
    for method in SIDE_BY_SIDE:
        for parameter in KEY_PARAMETERS:
            stats = table.get((method, parameter))
            if stats is not None:
                rows.append(
                    f"| {method} | {parameter} | {stats.mae_mm:.3f} | {stats.std_mm:.3f} | "
                    f"{stats.max_error_mm:.3f} | {stats.passes} of {stats.passes + stats.missing} |"
                )
    return [
        f"### {BURST_FRAMES} frames per sensor and wheel",
        "",
        f"The same train, seed and passes, each sensor taking a burst of {BURST_FRAMES} frames "
        f'of each wheel, {FRAME_SPACING_MM:g} mm of travel apart (docs/simulator.md, "Frames '
        "per wheel\"): every frame sees its own patch of the wheel's texture, and fusion "
        f"takes the points of all of them. Simulation {simulated_s:.0f} s, measurement "
        f"{measured_s:.0f} s. Values not measured: {counts(observations)[1]}.",
        "",
        *rows,
        "",
        f"Bars (adaptive Sh and Sd: MAE ≤ {BARS['mae_mm']}, Std ≤ {BARS['std_mm']}):",
        *verdicts(pooled),
        *_wheel_checks(per_wheel),
        "",
        "Steger beside adaptive:",
        *_ratio_lines(table),
    ]


def run() -> str:
    """Simulate, measure and tabulate; returns the Markdown section."""
    started, load_before = time.perf_counter(), os.getloadavg()[0]
    observations, simulated_s, measured_s = _measure(FIELD_MODES["harsh"], REPEATS)
    burst = _burst()
    breakdown = _breakdown()
    took = (time.perf_counter() - started, load_before, os.getloadavg()[0])
    wheels, missing = counts(observations)
    per_wheel, pooled = summarise_repeatability(observations)
    reduced = (REPEATS, BREAKDOWN_REPEATS) != FULL_RUN
    lines = [
        "## Repeatability on field-mode passes (harsh) and the per-effect breakdown",
        "",
        *(
            [
                f"**Reduced run**: {REPEATS} passes (full: {FULL_RUN[0]}) and "
                f"{BREAKDOWN_REPEATS} per breakdown case (full: {FULL_RUN[1]}), set by "
                "FIELD_REPEATS / FIELD_BREAKDOWN_REPEATS on a loaded machine.",
                "",
            ]
            if reduced
            else []
        ),
        f"{REPEATS} passes of {VEHICLES} vehicles × {AXLES} axles ({wheels} wheels, LMA and "
        f"S1002, worn), seed {SEED}, every field effect on; {len(METHODS)} method variants "
        f"measured on the same frames. Simulation {simulated_s:.0f} s, measurement "
        f"{measured_s:.0f} s. Values not measured: {missing}. Errors against the true "
        "geometry [mm].",
        "",
        f"Bars (adaptive Sh and Sd: MAE ≤ {BARS['mae_mm']}, Std ≤ {BARS['std_mm']}):",
        *verdicts(pooled),
        *_wheel_checks(per_wheel),
        "",
        "Steger beside adaptive:",
        *_ratio_lines({(s.method, s.parameter): s for s in pooled}),
        "",
        *burst,
        "",
        f"### Per-effect breakdown ({BREAKDOWN_REPEATS} passes each: one effect alone, and every "
        "effect but one; paired renderings, so a row differs from 'none' or 'all' only in "
        "its effect's pixels)",
        "",
        *breakdown,
        "",
        f"The whole section took {took[0] / 60:.0f} min (load average {took[1]:.1f} at the "
        f"start, {took[2]:.1f} at the end, on {os.cpu_count()} cores).",
        "",
        repeatability_markdown(per_wheel, pooled),
    ]
    return "\n".join(lines)
