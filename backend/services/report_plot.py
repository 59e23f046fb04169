"""The profile-against-reference plot of a report, drawn as vector graphics (reportlab).

The profile frame is drawn to scale (equal mm in x and z). The construction labels sit in
a column right of the plot at fixed heights, each joined to its point by a thin leader, so
no label can overlap another or a curve's tick labels. Adaptive is the thick solid red
line, Steger the thin dashed blue one drawn over it (both stay visible), the reference the
grey dotted one beneath.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from reportlab.graphics.shapes import Drawing, Line, PolyLine, Rect, String
from reportlab.lib import colors
from reportlab.lib.units import mm

X_RANGE_MM = (0.0, 140.0)
Z_RANGE_MM = (-10.0, 32.0)
PLOT_LEFT_PT = 9 * mm
PLOT_BOTTOM_PT = 7 * mm
PLOT_WIDTH_PT = 116 * mm
LABEL_COLUMN_PT = 4 * mm
"""Gap between the plot and the label column."""
FONT = "Helvetica"
FONT_PT = 6.5
MAX_POLYLINE_POINTS = 400
"""Profiles are thinned to this many vertices for drawing: one per 0.35 mm of a 135 mm rim,
0.8 pt on the page at this scale, finer than the 1.6 pt line, so the plot looks the same
and draws in half the time of 700 vertices."""
GAP_MM = 3.0
"""Consecutive profile points further apart than this are not joined (shadowed parts)."""
STYLE = {
    "adaptive": {"colour": colors.HexColor("#c62828"), "width": 1.6, "dash": None},
    "steger": {"colour": colors.HexColor("#1565c0"), "width": 0.7, "dash": [2.5, 1.5]},
    "reference": {"colour": colors.Color(0.55, 0.55, 0.55), "width": 0.8, "dash": [0.6, 1.2]},
}
METHOD_NAMES = {"adaptive": "Adaptive", "steger": "Steger"}


@dataclass(frozen=True, slots=True)
class Curve:
    """One curve of the plot: the reference, or a method's profile outline (NaN between
    pieces) [mm]."""

    kind: str
    x_mm: np.ndarray
    z_mm: np.ndarray


def _scale() -> float:
    return PLOT_WIDTH_PT / (X_RANGE_MM[1] - X_RANGE_MM[0])


def _to_page(x_mm: float, z_mm: float) -> tuple[float, float]:
    s = _scale()
    return PLOT_LEFT_PT + (x_mm - X_RANGE_MM[0]) * s, PLOT_BOTTOM_PT + (z_mm - Z_RANGE_MM[0]) * s


def _runs(x: np.ndarray, z: np.ndarray) -> list[np.ndarray]:
    """Index runs of the visible points without a gap; thinned to MAX_POLYLINE_POINTS."""
    inside = (
        (x >= X_RANGE_MM[0]) & (x <= X_RANGE_MM[1]) & (z >= Z_RANGE_MM[0]) & (z <= Z_RANGE_MM[1])
    )
    step = max(1, int(np.ceil(np.count_nonzero(inside) / MAX_POLYLINE_POINTS)))
    keep = np.flatnonzero(inside)[::step]
    if keep.size < 2:
        return []
    jumps = np.hypot(np.diff(x[keep]), np.diff(z[keep])) > GAP_MM * step
    return [run for run in np.split(keep, np.flatnonzero(jumps) + 1) if run.size >= 2]


def _polylines(curve: Curve) -> list[PolyLine]:
    style = STYLE[curve.kind]
    lines = []
    for run in _runs(curve.x_mm, curve.z_mm):
        points = [c for i in run for c in _to_page(float(curve.x_mm[i]), float(curve.z_mm[i]))]
        lines.append(
            PolyLine(
                points,
                strokeColor=style["colour"],
                strokeWidth=style["width"],
                strokeDashArray=style["dash"],
                strokeLineJoin=1,
            )
        )
    return lines


def _axes(drawing: Drawing) -> None:
    s = _scale()
    height = (Z_RANGE_MM[1] - Z_RANGE_MM[0]) * s
    grey = colors.Color(0.88, 0.88, 0.88)
    for x in range(0, 141, 10):
        px, _ = _to_page(x, 0)
        drawing.add(Line(px, PLOT_BOTTOM_PT, px, PLOT_BOTTOM_PT + height, strokeColor=grey))
        if x % 20 == 0:
            label = String(px, PLOT_BOTTOM_PT - 2.6 * mm, f"{x}", fontName=FONT, fontSize=FONT_PT)
            label.textAnchor = "middle"
            drawing.add(label)
    for z in range(-10, 31, 10):
        _, pz = _to_page(0, z)
        drawing.add(Line(PLOT_LEFT_PT, pz, PLOT_LEFT_PT + PLOT_WIDTH_PT, pz, strokeColor=grey))
        label = String(PLOT_LEFT_PT - 1 * mm, pz - 2, f"{z}", fontName=FONT, fontSize=FONT_PT)
        label.textAnchor = "end"
        drawing.add(label)
    drawing.add(
        Rect(PLOT_LEFT_PT, PLOT_BOTTOM_PT, PLOT_WIDTH_PT, height, fillColor=None, strokeWidth=0.5)
    )
    axis = String(
        PLOT_LEFT_PT + PLOT_WIDTH_PT / 2,
        0.6 * mm,
        "x from the back face [mm]; z [mm], 0 at the tread reference point (x = 70 mm)",
        fontName=FONT,
        fontSize=FONT_PT,
    )
    axis.textAnchor = "middle"
    drawing.add(axis)


def construction_labels(
    construction: dict[str, Any], parameters: dict[str, float | None], method: str
) -> list[tuple[str, tuple[float, float]]]:
    """(label in words, point [mm]) of each construction the stored profile carries."""
    name = METHOD_NAMES.get(method, method)

    def value(key: str) -> str:
        number = parameters.get(key)
        return "–" if number is None else f"{number:.2f} mm"

    wanted = [
        ("sh", "flange_top", f"Flange top: Sh {value('flange_height_mm')}"),
        ("sd", "flank_point", f"Flank at z = 12 mm: Sd {value('flange_thickness_mm')}"),
        ("sd_en", "flank_point", f"Flank at z = 10 mm: Sd EN {value('flange_thickness_10_mm')}"),
        ("qr", "upper_point", f"Flank at Sh − 2 mm: qR {value('qr_mm')} (to z = 10)"),
        ("sh", "tread_point", "Tread reference point (x = 70 mm, z = 0)"),
    ]
    labels = [(f"Constructions ({name}):", (float("nan"), float("nan")))]
    for group, key, text in wanted:
        point = construction.get(group, {}).get(key)
        if isinstance(point, list | tuple) and len(point) == 2 and None not in point:
            labels.append((text, (float(point[0]), float(point[1]))))
    return labels


def profile_drawing(
    curves: list[Curve], labels: list[tuple[str, tuple[float, float]]], reference_name: str | None
) -> Drawing:
    """The plot: axes, curves (reference, Steger over adaptive), labelled constructions
    and a legend, as one reportlab Drawing [pt]."""
    height = PLOT_BOTTOM_PT + (Z_RANGE_MM[1] - Z_RANGE_MM[0]) * _scale() + 1 * mm
    column = PLOT_LEFT_PT + PLOT_WIDTH_PT + LABEL_COLUMN_PT
    drawing = Drawing(182 * mm, height)
    _axes(drawing)
    order = {"reference": 0, "adaptive": 1, "steger": 2}
    for curve in sorted(curves, key=lambda c: order[c.kind]):
        for line in _polylines(curve):
            drawing.add(line)
    row_pt = 3.1 * mm
    top = height - 3 * mm
    for i, (text, (x, z)) in enumerate(labels):
        y = top - i * row_pt
        drawing.add(String(column, y, text, fontName=FONT, fontSize=FONT_PT))
        if np.isfinite(x):
            px, pz = _to_page(x, z)
            drawing.add(Line(px - 1.5, pz - 1.5, px + 1.5, pz + 1.5, strokeWidth=0.6))
            drawing.add(Line(px - 1.5, pz + 1.5, px + 1.5, pz - 1.5, strokeWidth=0.6))
            drawing.add(
                Line(px, pz, column - 1, y + 2, strokeColor=colors.Color(0.55, 0.55, 0.55),
                     strokeWidth=0.25)
            )  # fmt: skip
    legend = [
        ("adaptive", "Adaptive (thick solid)"),
        ("steger", "Steger (thin dashed)"),
        ("reference", f"Reference {reference_name or '–'} (dotted)"),
    ]
    for i, (kind, text) in enumerate(legend):
        y = PLOT_BOTTOM_PT + (len(legend) - 1 - i) * row_pt
        style = STYLE[kind]
        drawing.add(
            Line(column, y + 2, column + 7 * mm, y + 2, strokeColor=style["colour"],
                 strokeWidth=style["width"], strokeDashArray=style["dash"])
        )  # fmt: skip
        drawing.add(String(column + 8.5 * mm, y, text, fontName=FONT, fontSize=FONT_PT))
    return drawing
