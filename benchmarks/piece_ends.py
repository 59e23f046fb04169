"""Across-line error of centres near a piece's end, by stage, on synthetic pieces with truth.

Run: python -m benchmarks.piece_ends [--png DIR]. Cases: tests/pipeline/piece_ends.py. For
the adaptive method the centres are recorded after each stage of `_refine_on_normals`: the
Hessian sub-pixel centres ("hessian"), after the curvature-bias removal ("unbiased"), after
the matched fit along the normal ("matched"; these three along the Hessian normals), and the
result ("final", its end centres read along the interior's normal); then
"adaptive-normal" (normal_fit=False: Hessian centres with the curvature correction) and
"steger" (σ2, no correction). Figures: median |across| [px] at 0, 1, 2, 4, 8 and ≥ 16
centres from the nearer end, the median normal tilt [deg] at 0–2 and ≥ 16 centres, the RMS
of every centre [px], and the centres per frame whose foot lies past the truth's ends
("past": texture or noise continuing the chain beyond the stripe). "adaptive, Hessian n at
ends" is the adaptive method with its end centres read along their own Hessian normals
(`centres.END_POINTS` = 0), as before pipeline 0.11.7.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

import pipeline.extraction.centres as centres_module
from pipeline import extract_centres
from tests.pipeline.piece_ends import END_BINS, PieceCase, make_piece, score_piece

SEEDS = 4
NOISE = {"read_noise": 3.0, "shot_noise": True}

CASES = [
    PieceCase("straight-fade6", **NOISE),
    PieceCase("straight-sharp", fade_px=0, **NOISE),
    PieceCase("curved-R80-fade6", radius_px=80, **NOISE),
    PieceCase("curved-R80-sharp", radius_px=80, fade_px=0, **NOISE),
    PieceCase("straight-fade6-w15", width_px=15, **NOISE),
    PieceCase("straight-sharp-lit", fade_px=0, scene="lit", **NOISE),
    PieceCase("curved-R80-fade6-lit", radius_px=80, scene="lit", **NOISE),
    PieceCase("texture-3px", texture_period_px=3, texture_depth=0.3, **NOISE),
    PieceCase("texture-6px", texture_period_px=6, texture_depth=0.3, **NOISE),
    PieceCase("texture-15px", texture_period_px=15, texture_depth=0.3, **NOISE),
    PieceCase(
        "texture-6px-R80-lit",
        radius_px=80,
        scene="lit",
        texture_period_px=6,
        texture_depth=0.3,
        **NOISE,
    ),
]

_STAGES: dict[str, tuple[np.ndarray, np.ndarray]] = {}
_refine = centres_module._refine_on_normals


def _recording_refine(image, x, y, nx, ny, sigma, widths, polylines, asymmetry):
    """`_refine_on_normals` that records its intermediate centres in _STAGES."""
    from pipeline.extraction.curvature import remove_curvature_bias

    _STAGES["hessian"] = (x.copy(), y.copy())
    ux, uy = remove_curvature_bias(x, y, nx, ny, sigma, polylines)
    _STAGES["unbiased"] = (ux, uy)
    s = centres_module._matched_sigma(sigma, widths)
    offsets = centres_module.matched_offsets(
        image, ux, uy, nx, ny, s, centres_module.KERNEL_FACTORS
    )
    t = np.where(np.isfinite(offsets[0]), offsets[0], 0.0)
    _STAGES["matched"] = (ux + t * nx, uy + t * ny)
    out = _refine(image, x, y, nx, ny, sigma, widths, polylines, asymmetry)
    _STAGES["final"] = out[:2]
    return out


def run_case(case: PieceCase, seed: int, png: Path | None = None) -> dict:
    """Scores of every stage and method on one frame of `case`."""
    piece = make_piece(replace(case, seed=seed))
    centres_module._refine_on_normals = _recording_refine
    try:
        found = extract_centres(piece.image, "adaptive")
    finally:
        centres_module._refine_on_normals = _refine
    scores = {}
    for stage, (x, y) in list(_STAGES.items()):
        scores[stage] = score_piece(piece, x, y, found.nx, found.ny, found.polylines)
    plain = extract_centres(piece.image, "adaptive", normal_fit=False)
    scores["adaptive-normal"] = score_piece(
        piece, plain.x, plain.y, plain.nx, plain.ny, plain.polylines
    )
    end_points = centres_module.END_POINTS
    centres_module.END_POINTS = 0  # the ends read along their own Hessian normals
    try:
        hessian_n = extract_centres(piece.image, "adaptive")
    finally:
        centres_module.END_POINTS = end_points
    scores["adaptive, Hessian n at ends"] = score_piece(
        piece, hessian_n.x, hessian_n.y, hessian_n.nx, hessian_n.ny, hessian_n.polylines
    )
    steger = extract_centres(piece.image, "steger")
    scores["steger"] = score_piece(
        piece, steger.x, steger.y, steger.nx, steger.ny, steger.polylines
    )
    if png is not None and seed == 0:
        save_overlay(piece, found, _STAGES, png / f"{case.name}.png")
    return scores


def save_overlay(piece, found, stages, path: Path) -> None:
    """Zoomed overlay of each end of the piece: truth, Hessian and final centres."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 6))
    for ax, end in zip(axes, (0, -1), strict=True):
        cx, cy = piece.line_xy[end]
        ax.imshow(piece.image, cmap="gray", interpolation="nearest")
        ax.plot(*piece.line_xy.T, "c-", lw=0.8, label="truth")
        hx, hy = stages["hessian"]
        ax.plot(hx, hy, "y.", ms=5, label="hessian")
        ax.plot(found.x, found.y, "r.", ms=5, label="final")
        scale = 12
        for i in range(found.x.size):
            ax.plot(
                [found.x[i], found.x[i] + 0.15 * scale * found.nx[i]],
                [found.y[i], found.y[i] + 0.15 * scale * found.ny[i]],
                "m-",
                lw=0.5,
            )
        ax.set_xlim(cx - 14, cx + 14)
        ax.set_ylim(cy + 14, cy - 14)
        ax.legend(loc="lower right", fontsize=7)
    fig.suptitle(piece.case.name)
    fig.savefig(path, dpi=90)
    plt.close(fig)


def summarise(all_scores: list[dict]) -> dict[str, list[float]]:
    """Median |across| per END_BINS bin (last: ≥ 16) and median tilt at 0–2 and ≥ 16."""
    out = {}
    for stage in all_scores[0]:
        across = np.concatenate([s[stage].across_px for s in all_scores])
        tilt = np.concatenate([s[stage].tilt_deg for s in all_scores])
        ends = np.concatenate([s[stage].from_end for s in all_scores])
        row = []
        for k, lo in enumerate(END_BINS):
            sel = ends >= lo if k == len(END_BINS) - 1 else ends == lo
            row.append(float(np.median(np.abs(across[sel]))) if sel.any() else np.nan)
        row.append(float(np.median(tilt[ends <= 2])) if (ends <= 2).any() else np.nan)
        row.append(float(np.median(tilt[ends >= 16])) if (ends >= 16).any() else np.nan)
        row.append(float(np.sqrt(np.mean(across**2))))
        past = np.concatenate([s[stage].past_end for s in all_scores])
        row.append(past.sum() / len(all_scores))
        out[stage] = row
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--png", type=Path, default=None)
    parser.add_argument("--cases", nargs="*", default=None)
    args = parser.parse_args()
    if args.png:
        args.png.mkdir(parents=True, exist_ok=True)
    head = " ".join(f"e{b:<5}" for b in END_BINS)
    for case in CASES:
        if args.cases and case.name not in args.cases:
            continue
        scores = [run_case(case, seed, args.png) for seed in range(SEEDS)]
        out = sys.stdout.write
        out(f"\n{case.name}  (median |across| px by centres from the end; tilt deg; RMS)\n")
        out(f"  {'stage':16s} {head}  tilt0-2 tilt16+  rms    past\n")
        for stage, row in summarise(scores).items():
            cells = " ".join(f"{v:6.3f}" for v in row[: len(END_BINS)])
            tilts = f"{row[-4]:6.2f} {row[-3]:6.2f}"
            out(f"  {stage:16s} {cells}  {tilts}  {row[-2]:.3f}  {row[-1]:4.1f}\n")


if __name__ == "__main__":
    main()
