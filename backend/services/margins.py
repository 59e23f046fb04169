"""Wheel parameters checked against limits, and each one's margin to its nearest limit.

`PARAMETERS` is the one list of checked parameters (name, label, unit, limit): alarms,
margins, the worst-wheels view and the trends all iterate it, so a new parameter is one
entry here (and its limit columns). `REPORTED` adds the values shown without a limit
(tread hollow, flange angle, rim width), in the order the reports show them.

A margin is the signed distance from a value to its nearest limit [mm], negative outside
the band, and as a fraction of the band: the limits' span where there are two, or the
distance from the one limit to the new wheel's value (the reference profile's) where
there is one (qR ≥ 6.5 mm: S1002 new is 10.79 mm, so its band is 4.29 mm wide). A value
within `near_limit_fraction` of the band from a limit is "near" (amber).

Margins, amber and alarms in one hop: docs/numbers.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

from pipeline.profile.flange import curve_flange_parameters
from pipeline.profile.reference import load_reference_profile

OK, NEAR, ALARM = "ok", "near", "alarm"
LEVELS = (OK, NEAR, ALARM)

NEAR_LIMIT_FRACTION = 0.10
"""Default amber band: the inner 10 % of each limit band (editable per fleet)."""
METHOD_DISAGREEMENT_MM = 0.5
"""Default flag when adaptive and Steger differ by more in any parameter [mm]: about four
times the adaptive method's Sh/Sd MAE on simulated passes (0.10–0.12 mm), twice Steger's."""

FAMILY_REFERENCE = {"EN": "S1002", "LM": "LMA"}
"""The new-wheel profile of each limit family (nominal values of one-sided limits)."""


@dataclass(frozen=True, slots=True)
class Parameter:
    """One checked wheel parameter.

    key is the measurement's column, limit the stem of its limit columns
    (`{limit}_min_mm`, `{limit}_max_mm`, or `{limit}_min`/`_max` for a unitless one);
    families are the limit families that check this key (EN checks Sd at 10 mm, LM at
    12 mm); alarm names the alarm it raises (both Sd heights raise `flange_thickness_mm`).
    """

    key: str
    label: str
    title: str
    unit: str
    limit: str
    families: tuple[str, ...] = ("EN", "LM")
    alarm: str = ""
    digits: int = 2
    """Decimals shown."""
    per_axle: bool = False
    """One value per axle (the same on both wheels)."""

    @property
    def alarm_name(self) -> str:
        return self.alarm or self.key

    def bound_field(self, bound: str) -> str:
        """The limits' field of the `bound` ("min" or "max") of this parameter."""
        return f"{self.limit}_{bound}" + ("_mm" if self.unit == "mm" else "")


PARAMETERS = (
    Parameter("flange_height_mm", "Sh", "Flange height", "mm", "flange_height"),
    Parameter(
        "flange_thickness_mm", "Sd", "Flange thickness at 12 mm", "mm", "flange_thickness", ("LM",)
    ),
    Parameter(
        "flange_thickness_en_mm",
        "Sd EN",
        "Flange thickness at 10 mm (EN)",
        "mm",
        "flange_thickness",
        ("EN",),
        alarm="flange_thickness_mm",
    ),
    Parameter("qr_mm", "qR", "Flange slope qR", "mm", "qr"),
    Parameter("back_to_back_mm", "B2B", "Back-to-back distance", "mm", "back_to_back"),
    Parameter(
        "equivalent_conicity", "λe", "Equivalent conicity (axle)", "", "conicity",
        digits=3, per_axle=True,
    ),
)  # fmt: skip
PARAMETER_KEYS = tuple(p.key for p in PARAMETERS)
REPORTED = (
    *(p for p in PARAMETERS if not p.per_axle),
    Parameter("tread_hollow_mm", "Hollow", "Tread hollow", "mm", "", ()),
    Parameter("flange_angle_deg", "δ", "Flange angle", "°", "", (), digits=1),
    Parameter("rim_width_mm", "Rim", "Rim width", "mm", "", ()),
    *(p for p in PARAMETERS if p.per_axle),
)
"""Every value the reports show, checked (`PARAMETERS`) or not (no limit families)."""


@dataclass(frozen=True, slots=True)
class Margin:
    """How far one parameter of a wheel is from its nearest limit."""

    parameter: str
    value_mm: float
    bound: str
    limit_mm: float
    margin_mm: float
    band_mm: float
    status: str
    """"alarm", "near" (within the amber band) or "ok"."""

    @property
    def margin_fraction(self) -> float:
        """The margin as a fraction of the band (negative outside)."""
        return self.margin_mm / self.band_mm


@lru_cache(maxsize=4)
def nominal_mm(family: str, key: str) -> float | None:
    """The new wheel's value of `key` for a limit family (its reference profile) [mm]."""
    reference = load_reference_profile(FAMILY_REFERENCE[family])
    values = curve_flange_parameters(reference.x_mm, reference.z_mm)
    nominal = {
        "flange_height_mm": values.flange_height_mm,
        "flange_thickness_mm": values.flange_thickness_mm,
        "flange_thickness_en_mm": values.flange_thickness_10_mm,
        "qr_mm": values.qr_mm,
    }
    return nominal.get(key)


def _margin(
    parameter: Parameter,
    value: float,
    low: float | None,
    high: float | None,
    family: str,
    near_limit_fraction: float,
) -> Margin | None:
    bounds = [("min", low, value - low)] if low is not None else []
    if high is not None:
        bounds.append(("max", high, high - value))
    if not bounds:
        return None
    nominal = nominal_mm(family, parameter.key)
    if low is not None and high is not None:
        band = high - low
    elif nominal is not None:
        band = abs(nominal - bounds[0][1])
    else:
        # a one-sided limit with no new-wheel value: the limit's own size stands in
        band = abs(bounds[0][1])
    bound, limit, margin = min(bounds, key=lambda b: b[2])
    level = ALARM if margin < 0 else NEAR if margin < near_limit_fraction * band else OK
    return Margin(parameter.key, float(value), bound, float(limit), float(margin), band, level)


def limit_margins(
    values_mm: dict[str, float | None],
    limits_mm: dict[str, float],
    family: str,
    near_limit_fraction: float = NEAR_LIMIT_FRACTION,
) -> list[Margin]:
    """The margin of every checked parameter of one wheel, in `PARAMETERS` order.

    Parameters
    ----------
    values_mm : dict
        Measured values by parameter key [mm, or none for the conicity]; None (not
        measured) gives no margin.
    limits_mm : dict
        The fleet's limits for `family` (`Parameter.bound_field`) [mm].
    family : str
        "EN" or "LM": which parameters are checked (Sd at 10 or at 12 mm).
    near_limit_fraction : float
        Width of the amber band as a fraction of each limit band.

    Returns
    -------
    list of Margin
    """
    margins = []
    for parameter in PARAMETERS:
        value = values_mm.get(parameter.key)
        if value is None or family not in parameter.families:
            continue
        low = limits_mm.get(parameter.bound_field("min"))
        high = limits_mm.get(parameter.bound_field("max"))
        margin = _margin(parameter, value, low, high, family, near_limit_fraction)
        if margin is not None:
            margins.append(margin)
    return margins
