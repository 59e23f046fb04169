"""How far each checked parameter of a result lies inside (or outside) the limits that apply.

The report lists wheels in alarm and wheels near a limit first. A parameter is near its
limit when it is inside by less than `NEAR_LIMIT_MM`: 1 mm is about two months of flange
wear on a busy fleet and ten times the adaptive method's MAE, so a wheel flagged near
today is one to plan a turning for, not measurement noise. The checked parameters and the
thickness height per limit set are those of `evaluate_alarms` (EN: Sd at 10 mm, LM: Sd at
12 mm).
"""

from __future__ import annotations

from dataclasses import dataclass

from backend.services.limits import thickness_key

NEAR_LIMIT_MM = 1.0
CHECKED = (
    ("flange_height_mm", "flange_height"),
    ("flange_thickness_mm", "flange_thickness"),
    ("qr_mm", "qr"),
    ("back_to_back_mm", "back_to_back"),
)
"""(parameter, limit stem) pairs; the thickness reads its family's key (thickness_key)."""


@dataclass(frozen=True, slots=True)
class Margin:
    """One parameter against its nearest bound [mm].

    Attributes
    ----------
    parameter : str
        The result field compared (for the thickness, the one the set measures).
    value_mm : float
    bound : str
        "min" or "max", whichever is nearer.
    limit_mm : float
    margin_mm : float
        Distance inside the limits; negative outside (an alarm).
    status : str
        "alarm", "near" (inside by less than NEAR_LIMIT_MM) or "ok".
    """

    parameter: str
    value_mm: float
    bound: str
    limit_mm: float
    margin_mm: float
    status: str


def limit_margins(
    parameters_mm: dict[str, float | None], limits_mm: dict[str, float], family: str
) -> list[Margin]:
    """Margins of the checked parameters of one result; missing parameters are skipped."""
    margins = []
    for name, stem in CHECKED:
        key = thickness_key(family) if stem == "flange_thickness" else name
        value = parameters_mm.get(key)
        if value is None:
            continue
        bounds = [
            (bound, limits_mm[f"{stem}_{bound}_mm"], sign)
            for bound, sign in (("min", 1.0), ("max", -1.0))
            if f"{stem}_{bound}_mm" in limits_mm
        ]
        bound, limit, sign = min(bounds, key=lambda b: b[2] * (value - b[1]))
        margin = sign * (value - limit)
        # near on the margin as shown (0.01 mm), so "+1.00" never reads "near limit"
        status = "alarm" if margin < 0 else "near" if round(margin, 2) < NEAR_LIMIT_MM else "ok"
        margins.append(Margin(key, float(value), bound, limit, margin, status))
    return margins
