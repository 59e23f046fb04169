"""Repeatability and reproducibility of wheel parameters over repeated passes.

The statistics of the paper's Tables 2–4: per wheel, parameter and method, over the passes,
the mean, the mean absolute error (MAE) against the reference, the standard deviation (Std,
n − 1) and the maximum error (ME); and pooled over all wheels: MAE over every measurement,
the largest per-wheel Std and the largest error.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

RR_PARAMETERS = (
    "flange_height_mm",
    "flange_thickness_mm",
    "flange_thickness_10_mm",
    "qr_mm",
    "back_to_back_mm",
    "tread_hollow_mm",
    "flange_angle_deg",
    "rim_width_mm",
    "conicity_3mm",
)
AXLE_PARAMETERS = ("back_to_back_mm", "conicity_3mm")
"""Parameters of an axle, not a wheel: observed once per axle (on its left wheel).
Values and statistics keep the `_mm` field names for every parameter; flange_angle_deg is
in degrees and conicity_3mm has no unit."""


def _value(result, parameter: str) -> float | None:
    """One parameter of one PassWheelResult (None when not measured)."""
    if parameter == "back_to_back_mm":
        return result.back_to_back_mm
    if parameter == "conicity_3mm":
        return None if result.conicity is None else result.conicity.conicity_3mm
    if parameter in ("tread_hollow_mm", "flange_angle_deg", "rim_width_mm"):
        tread = result.measurement.tread
        return None if tread is None else getattr(tread, parameter)
    params = result.measurement.parameters
    return None if params is None else getattr(params, parameter)


@dataclass(frozen=True, slots=True)
class Observation:
    """One measured value of one wheel's parameter in one pass, with its reference."""

    wheel: str
    method: str
    parameter: str
    value_mm: float | None
    truth_mm: float


@dataclass(frozen=True, slots=True)
class ParameterStats:
    """Statistics of one wheel's (or all wheels') parameter over the passes [mm].

    Attributes
    ----------
    wheel : str
        Wheel label, or "all" for the pooled row.
    method, parameter : str
    passes : int
        Measured values used.
    missing : int
        Passes in which the wheel was not measured.
    truth_mm, mean_mm, mae_mm, std_mm, max_error_mm : float
        Reference (mean of the references for "all"), mean, MAE, Std (per-wheel Std for one
        wheel; the largest per-wheel Std for "all"), largest |error|.
    """

    wheel: str
    method: str
    parameter: str
    passes: int
    missing: int
    truth_mm: float
    mean_mm: float
    mae_mm: float
    std_mm: float
    max_error_mm: float


def _stats(wheel: str, method: str, parameter: str, values, truths, missing: int) -> ParameterStats:
    values, truths = np.asarray(values, float), np.asarray(truths, float)
    errors = values - truths
    nan = float("nan")
    return ParameterStats(
        wheel=wheel,
        method=method,
        parameter=parameter,
        passes=int(values.size),
        missing=missing,
        truth_mm=float(truths.mean()) if truths.size else nan,
        mean_mm=float(values.mean()) if values.size else nan,
        mae_mm=float(np.abs(errors).mean()) if values.size else nan,
        std_mm=float(values.std(ddof=1)) if values.size > 1 else nan,
        max_error_mm=float(np.abs(errors).max()) if values.size else nan,
    )


def summarise_repeatability(
    observations: Sequence[Observation],
) -> tuple[tuple[ParameterStats, ...], tuple[ParameterStats, ...]]:
    """Per-wheel and pooled statistics of repeated measurements.

    Parameters
    ----------
    observations : sequence of Observation
        Every wheel × method × parameter × pass value (None when not measured).

    Returns
    -------
    per_wheel : tuple of ParameterStats
        One row per (method, parameter, wheel), in first-seen order.
    pooled : tuple of ParameterStats
        One row per (method, parameter) over all wheels (wheel = "all").
    """
    groups: dict[tuple[str, str, str], list[Observation]] = {}
    for obs in observations:
        groups.setdefault((obs.method, obs.parameter, obs.wheel), []).append(obs)
    per_wheel = []
    for (method, parameter, wheel), rows in groups.items():
        measured = [r for r in rows if r.value_mm is not None]
        per_wheel.append(
            _stats(
                wheel,
                method,
                parameter,
                [r.value_mm for r in measured],
                [r.truth_mm for r in measured],
                len(rows) - len(measured),
            )
        )
    pooled = []
    keys = dict.fromkeys((s.method, s.parameter) for s in per_wheel)
    for method, parameter in keys:
        rows = [
            o
            for o in observations
            if o.method == method and o.parameter == parameter and o.value_mm is not None
        ]
        base = _stats(
            "all",
            method,
            parameter,
            [r.value_mm for r in rows],
            [r.truth_mm for r in rows],
            sum(
                1
                for o in observations
                if o.method == method and o.parameter == parameter and o.value_mm is None
            ),
        )
        stds = [s.std_mm for s in per_wheel if (s.method, s.parameter) == (method, parameter)]
        finite = [s for s in stds if np.isfinite(s)]
        pooled.append(
            ParameterStats(
                **{
                    **{f: getattr(base, f) for f in ParameterStats.__slots__},
                    "std_mm": float(max(finite)) if finite else float("nan"),
                }
            )
        )
    return tuple(per_wheel), tuple(pooled)


def pass_observations(results, truth_rows: Sequence[dict]) -> list[Observation]:
    """Observations of one measured pass against its truth rows (`truth.json` "wheels").

    Parameters
    ----------
    results : sequence of PassWheelResult
        From `measure_pass`.
    truth_rows : sequence of dict
        Rows with vehicle_id, axle, side and the parameters in mm.

    Raises
    ------
    ValueError
        If a measured wheel has no truth row.
    """
    truth = {(r["vehicle_id"], r["axle"], r["side"]): r for r in truth_rows}
    observations = []
    for result in results:
        wheel = result.wheel
        key = (wheel.vehicle_id, wheel.axle, wheel.side)
        if key not in truth:
            raise ValueError(f"truth has no wheel {key[0]} axle {key[1]} {key[2]}")
        for parameter in RR_PARAMETERS:
            if truth[key].get(parameter) is None:
                continue  # a truth file from before the parameter existed, or no truth
            label = f"{key[0]}/{key[1]}"
            if parameter in AXLE_PARAMETERS:
                if wheel.side != "left":
                    continue
            else:
                label += f"/{key[2]}"
            observations.append(
                Observation(
                    label,
                    result.measurement.method,
                    parameter,
                    _value(result, parameter),
                    truth[key][parameter],
                )
            )
    return observations


def _row(s: ParameterStats) -> str:
    return (
        f"| {s.parameter} | {s.wheel} | {s.method} | {s.truth_mm:.3f} | {s.mean_mm:.3f} | "
        f"{s.mae_mm:.3f} | {s.std_mm:.3f} | {s.max_error_mm:.3f} | {s.passes} | {s.missing} |"
    )


def repeatability_markdown(
    per_wheel: Sequence[ParameterStats], pooled: Sequence[ParameterStats]
) -> str:
    """Markdown tables: pooled (Table 2 form) and per wheel (Tables 3–4 form) per parameter."""
    header = (
        "| parameter | wheel | method | truth | mean | MAE | Std | max error | passes "
        "| not measured |\n|---|---|---|---|---|---|---|---|---|---|"
    )
    parts = ["### All wheels pooled (paper Table 2 form; Std = largest per-wheel Std)", "", header]
    parts += [_row(s) for s in pooled]
    for parameter in dict.fromkeys(s.parameter for s in per_wheel):
        parts += ["", f"### Per wheel: {parameter} (paper Tables 3–4 form)", "", header]
        rows = [s for s in per_wheel if s.parameter == parameter]
        parts += [_row(s) for s in sorted(rows, key=lambda s: (s.wheel, s.method))]
    return "\n".join(parts) + "\n"


@dataclass(frozen=True, slots=True)
class AgreementStats:
    """Agreement of one method's parameter with a reference instrument over wheels [mm].

    Attributes
    ----------
    method, parameter : str
    n : int
        Wheels with both values.
    mean_difference_mm : float
        Mean of (value − reference): the bias.
    mae_mm : float
        Mean |value − reference|.
    std_mm : float
        Standard deviation of the differences (n − 1); NaN for n < 2.
    max_error_mm : float
        Largest |value − reference|.
    """

    method: str
    parameter: str
    n: int
    mean_difference_mm: float
    mae_mm: float
    std_mm: float
    max_error_mm: float


def summarise_agreement(observations: Sequence[Observation]) -> tuple[AgreementStats, ...]:
    """Per method and parameter, the differences of measured values from their references
    (`truth_mm`, e.g. a handheld gauge's), in the form of the paper's Table 2.

    Observations without a value are left out; groups keep their first-seen order.
    """
    groups: dict[tuple[str, str], list[float]] = {}
    for obs in observations:
        differences = groups.setdefault((obs.method, obs.parameter), [])
        if obs.value_mm is not None:
            differences.append(obs.value_mm - obs.truth_mm)
    rows = []
    for (method, parameter), values in groups.items():
        d = np.asarray(values, float)
        nan = float("nan")
        rows.append(
            AgreementStats(
                method=method,
                parameter=parameter,
                n=int(d.size),
                mean_difference_mm=float(d.mean()) if d.size else nan,
                mae_mm=float(np.abs(d).mean()) if d.size else nan,
                std_mm=float(d.std(ddof=1)) if d.size > 1 else nan,
                max_error_mm=float(np.abs(d).max()) if d.size else nan,
            )
        )
    return tuple(rows)
