"""Draw docs/figures/coordinate-frames.svg: the pixel, track/camera and profile frames.

Run `python docs/figures/coordinate_frames.py` after changing it; the profile panel draws
the LMA reference table of pipeline/profile/data/. SVG markup lines stay whole (E501).
"""

# ruff: noqa: E501

from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
lma = np.loadtxt(ROOT / "pipeline/profile/data/LMA.csv", delimiter=",", skiprows=1)
W, H = 1240, 560
out = []
add = out.append
add(
    f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" viewBox="0 0 {W} {H}" font-family="DejaVu Sans, Arial, sans-serif" font-size="13">'
)
add(
    '<defs><marker id="a" viewBox="0 0 10 10" refX="9" refY="5" markerWidth="7" markerHeight="7" orient="auto-start-reverse"><path d="M0,0 L10,5 L0,10 z" fill="context-stroke"/></marker></defs>'
)
add(f'<rect width="{W}" height="{H}" fill="#fff"/>')


def arrow(x1, y1, x2, y2, colour="#000", width=1.6, dash=None):
    d = f' stroke-dasharray="{dash}"' if dash else ""
    add(
        f'<line x1="{x1:.1f}" y1="{y1:.1f}" x2="{x2:.1f}" y2="{y2:.1f}" stroke="{colour}" stroke-width="{width}" marker-end="url(#a)"{d}/>'
    )


def text(x, y, s, size=13, anchor="start", colour="#000", weight="normal", italic=False):
    style = ' font-style="italic"' if italic else ""
    add(
        f'<text x="{x:.1f}" y="{y:.1f}" font-size="{size}" text-anchor="{anchor}" fill="{colour}" font-weight="{weight}"{style}>{s}</text>'
    )


# ---- (a) pixel frame -------------------------------------------------------------
text(20, 28, "(a) pixel frame", 15, weight="bold")
ox, oy, iw, ih = 40, 60, 260, 195
add(f'<rect x="{ox}" y="{oy}" width="{iw}" height="{ih}" fill="#1b1b1b"/>')
t = np.linspace(0, 1, 60)
sx = ox + 20 + 220 * t
sy = oy + 150 - 95 * np.sin(np.pi * t * 0.9) + 25 * t
pts = " ".join(f"{a:.1f},{b:.1f}" for a, b in zip(sx, sy, strict=True))
add(
    f'<polyline points="{pts}" fill="none" stroke="#e8e8e8" stroke-width="11" stroke-linecap="round" opacity="0.85"/>'
)
add(f'<polyline points="{pts}" fill="none" stroke="#d62728" stroke-width="1.6"/>')
k = 22
px, py = sx[k], sy[k]
dx, dy = sx[k + 1] - sx[k - 1], sy[k + 1] - sy[k - 1]
n = np.array([dy, -dx]) / np.hypot(dx, dy)
arrow(px, py, px + 34 * n[0], py + 34 * n[1], "#1f77b4", 1.8)
add(f'<circle cx="{px:.1f}" cy="{py:.1f}" r="3" fill="#1f77b4"/>')
text(px + 34 * n[0] + 4, py + 34 * n[1] - 2, "n = (nx, ny)", 12, colour="#1f77b4")
arrow(ox, oy, ox + iw + 25, oy, "#000", 1.8)
arrow(ox, oy, ox, oy + ih + 25, "#000", 1.8)
text(ox + iw + 28, oy + 4, "x", 14, italic=True)
text(ox - 4, oy + ih + 42, "y", 14, italic=True)
text(ox - 6, oy - 8, "(0, 0)", 12, anchor="end")
text(ox + iw / 2, oy + ih + 22, "x = column, y = row [px]", 12, anchor="middle")
# pixel inset
gx, gy, cell = 80, 330, 40
for r in range(3):
    for c in range(3):
        add(
            f'<rect x="{gx + c * cell}" y="{gy + r * cell}" width="{cell}" height="{cell}" fill="none" stroke="#888"/>'
        )
add(f'<circle cx="{gx + 1.5 * cell}" cy="{gy + 1.5 * cell}" r="3.5" fill="#000"/>')
text(gx + 3 * cell + 12, gy + 1.5 * cell - 6, "pixel [r, c] has its", 12)
text(gx + 3 * cell + 12, gy + 1.5 * cell + 10, "centre at (x = c, y = r)", 12)
text(gx + 3 * cell + 12, gy + 1.5 * cell + 26, "and covers c ± 0.5", 12)
text(40, 470, "Centres: (x, y) = (c + t·nx, r + t·ny)", 12)

# ---- (b) camera and track frames (end view, looking along +Y) ----------------------
bx0 = 360
text(bx0, 28, "(b) track and camera frames (end view along the rail)", 15, weight="bold")
cx, rail_y = bx0 + 235, 290  # track centre line, rail top (Z = 0)
s = 0.9  # px per mm around each wheel
gap = 62  # px from the centre line to a back face (axis broken)
add(
    f'<line x1="{bx0}" y1="{rail_y + 30}" x2="{bx0 + 470}" y2="{rail_y + 30}" stroke="#999" stroke-width="1"/>'
)
rim = [
    (0, 60),
    (0, -8),
    (6, -22),
    (16, -28),
    (28, -18),
    (36, -3),
    (70, 0),
    (130, 3),
    (135, 8),
    (135, 60),
]
for sign in (-1, 1):
    back = cx + sign * gap
    rx = back + sign * 74 * s  # rail head under the tread reference point
    add(f'<rect x="{rx - 16:.1f}" y="{rail_y}" width="32" height="30" fill="#bbb" stroke="#555"/>')
    poly = " ".join(f"{back + sign * u * s:.1f},{rail_y - h * s:.1f}" for u, h in rim)
    add(f'<polygon points="{poly}" fill="#cfd8e3" stroke="#345" stroke-width="1.2"/>')
    for pos, off, drop in (("inner", -28, 100), ("outer", 165, 90)):
        camx, camy = back + sign * off * s, rail_y + drop
        add(
            f'<rect x="{camx - 12:.1f}" y="{camy - 8:.1f}" width="24" height="16" rx="3" fill="#444"/>'
        )
        text(camx, camy + 24, pos, 11, anchor="middle")
        for u, h in ((0, -8), (30, -16)) if pos == "inner" else ((22, -26), (132, 3)):
            add(
                f'<line x1="{camx:.1f}" y1="{camy:.1f}" x2="{back + sign * u * s:.1f}" y2="{rail_y - h * s:.1f}" stroke="#7b2cbf" stroke-width="1" stroke-dasharray="4 3"/>'
            )
    text(
        back + sign * 67 * s,
        rail_y - 66,
        "left wheel" if sign < 0 else "right wheel",
        12,
        anchor="middle",
    )
    text(
        back,
        rail_y - 92,
        f"X_back ≈ {'−' if sign < 0 else '+'}676 mm",
        10,
        anchor="middle",
        colour="#345",
    )
    add(
        f'<line x1="{back:.1f}" y1="{rail_y - 86}" x2="{back:.1f}" y2="{rail_y - 56}" stroke="#345" stroke-width="0.8"/>'
    )
# axle (cut away)
add(
    f'<line x1="{cx - gap:.1f}" y1="{rail_y - 30}" x2="{cx + gap:.1f}" y2="{rail_y - 30}" stroke="#345" stroke-width="8" opacity="0.35"/>'
)
text(cx, rail_y - 40, "axle", 11, anchor="middle", colour="#345")
add(f'<circle cx="{cx}" cy="{rail_y}" r="3.5" fill="#000"/>')
arrow(cx, rail_y, cx + 46, rail_y, "#000", 2)
arrow(cx, rail_y, cx, rail_y - 120, "#000", 2)
text(cx + 36, rail_y + 16, "X", 14, weight="bold")
text(cx + 6, rail_y - 122, "Z", 14, weight="bold")
add(
    f'<circle cx="{cx - 20}" cy="{rail_y - 12}" r="6" fill="none" stroke="#000"/><circle cx="{cx - 20}" cy="{rail_y - 12}" r="1.8" fill="#000"/>'
)
text(cx - 30, rail_y - 8, "Y", 14, anchor="end", weight="bold")
for sign in (-1, 1):  # axis break marks: the drawing is not to scale between the wheels
    bxk = cx + sign * 30
    add(
        f'<line x1="{bxk - 4}" y1="{rail_y + 36}" x2="{bxk + 2}" y2="{rail_y + 24}" stroke="#555"/><line x1="{bxk + 2}" y1="{rail_y + 36}" x2="{bxk + 8}" y2="{rail_y + 24}" stroke="#555"/>'
    )
y = rail_y + 160
text(
    bx0, y, "Track frame [mm]: origin on the track centre line at the rail top (Z = 0); X along", 11
)
text(
    bx0, y + 14, "the axle, + towards the right rail; Z up; Y along the rail (out of the page).", 11
)
text(
    bx0,
    y + 32,
    "Camera frame [mm]: origin at the camera, z along its optical axis;",
    11,
    colour="#e07000",
)
text(
    bx0,
    y + 46,
    "camera_to_track (T_track_camera, 4×4) maps it into the track frame.",
    11,
    colour="#e07000",
)
text(
    bx0,
    y + 64,
    "Laser planes n·P = d (camera frame) lie near Y = 0, the page; each camera",
    11,
    colour="#7b2cbf",
)
text(
    bx0,
    y + 78,
    "sits about 380 mm along the rail from its plane (not to scale here).",
    11,
    colour="#7b2cbf",
)
text(bx0, y + 98, "pixel → undistort → ray m → P = (d / n·m)·m → T_track_camera·P", 12)
camx, camy = cx + gap + 165 * s, rail_y + 90
arrow(camx, camy, camx - 26, camy - 34, "#e07000", 1.8)
add(
    f'<text x="{camx - 46:.1f}" y="{camy - 30:.1f}" font-size="13" fill="#e07000">z<tspan font-size="9" dy="3">c</tspan></text>'
)
# ---- (c) profile frame ---------------------------------------------------------------
px0 = 860
text(px0, 28, "(c) profile frame (one wheel)", 15, weight="bold")
sx_mm, sz_mm = 2.45, 4.9
x0, z0 = px0 + 15, 240  # screen position of x = 0, z = 0


def X(x):  # noqa: N802 (the profile frame's x → screen)
    return x0 + x * sx_mm


def Z(z):  # noqa: N802
    return z0 - z * sz_mm


pts = " ".join(f"{X(a):.1f},{Z(b):.1f}" for a, b in lma[::3])
add(f'<polyline points="{pts}" fill="none" stroke="#d62728" stroke-width="2"/>')
add(
    f'<line x1="{X(0)}" y1="{Z(6.6)}" x2="{X(0)}" y2="{Z(-14)}" stroke="#d62728" stroke-width="2"/>'
)
arrow(X(0), Z(0), X(145), Z(0), "#000", 1.6)
arrow(X(0), Z(-16), X(0), Z(38), "#000", 1.6)
text(X(145) - 4, Z(0) - 6, "x", 14, italic=True)
text(X(0) + 6, Z(38) + 4, "z", 14, italic=True)
add(f'<circle cx="{X(70)}" cy="{Z(0)}" r="3.5" fill="#000"/>')
text(X(70), Z(0) + 18, "tread reference point (70, 0)", 11, anchor="middle")
text(X(0) + 5, Z(-14) + 4, "back face x = 0", 11)
top = lma[np.argmax(lma[:, 1])]
add(
    f'<line x1="{X(top[0])}" y1="{Z(top[1])}" x2="{X(112)}" y2="{Z(top[1])}" stroke="#888" stroke-dasharray="3 3"/>'
)
add(
    f'<line x1="{X(70)}" y1="{Z(0)}" x2="{X(112)}" y2="{Z(0)}" stroke="#888" stroke-dasharray="3 3"/>'
)
arrow(X(108), Z(0), X(108), Z(top[1]), "#1f77b4", 1.6)
text(X(108) + 5, Z(top[1] / 2), f"Sh {top[1]:.1f}", 12, colour="#1f77b4")


def flank(h):
    i = int(np.argmax(lma[:, 1]))
    x, z = lma[i:, 0], lma[i:, 1]
    j = int(np.flatnonzero((z[:-1] >= h) & (z[1:] < h))[0])
    t = (z[j] - h) / (z[j] - z[j + 1])
    return x[j] + t * (x[j + 1] - x[j])


f12, f10, ftop = flank(12), flank(10), flank(top[1] - 2)
arrow(X(0), Z(12), X(f12), Z(12), "#2ca02c", 1.6)
text(X(f12) + 6, Z(12) - 2, f"Sd {f12:.2f} (z = 12)", 12, colour="#2ca02c")
add(
    f'<line x1="{X(0)}" y1="{Z(10)}" x2="{X(f10)}" y2="{Z(10)}" stroke="#2ca02c" stroke-dasharray="4 3"/>'
)
text(X(f10) + 6, Z(10) + 12, f"Sd10 {f10:.2f} (z = 10)", 11, colour="#2ca02c")
for xx, zz in ((ftop, top[1] - 2), (f10, 10)):
    add(f'<circle cx="{X(xx):.1f}" cy="{Z(zz):.1f}" r="3.2" fill="#9467bd"/>')
    add(
        f'<line x1="{X(xx):.1f}" y1="{Z(zz):.1f}" x2="{X(xx):.1f}" y2="{Z(top[1] + 6):.1f}" stroke="#9467bd" stroke-width="0.8" stroke-dasharray="2 2"/>'
    )
arrow(X(ftop), Z(top[1] + 5), X(f10), Z(top[1] + 5), "#9467bd", 1.4)
text(
    X(f10) + 6,
    Z(top[1] + 5) + 4,
    f"qR {f10 - ftop:.2f}: x(z = 10) − x(z = Sh − 2)",
    11,
    colour="#9467bd",
)
y = 360
text(px0, y, "LMA reference profile [mm], z drawn ×2.", 11)
text(px0, y + 16, "x from the back face towards the field side; z up", 11)
text(px0, y + 30, "towards the flange tip (the flange reaches below the", 11)
text(px0, y + 44, "rail top): z = Z_ref − Z with Z_ref the track Z at x = 70.", 11)
text(px0, y + 62, "Right wheel x = X − X_back; left wheel x = X_back − X.", 11)
add("</svg>")
(ROOT / "docs/figures/coordinate-frames.svg").write_text("\n".join(out) + "\n", encoding="utf-8")
