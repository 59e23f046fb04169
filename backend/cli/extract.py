"""`wheelscan extract`: stripe centres of a frame (or a folder of frames) to CSV."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from pipeline import Centres, extract_centres
from pipeline.extraction.centres import METHODS
from pipeline.imaging import LASER_CHANNELS, laser_grey

CSV_HEADER = "x,y,nx,ny,sigma,strength"
"""Column header of the centre CSV (the design's contract)."""

IMAGE_SUFFIXES = (".png", ".tif", ".tiff", ".bmp", ".pgm", ".jpg", ".jpeg")
"""Files of a folder that are read as frames."""


def read_frame(path: Path, *, laser: str | None = None) -> np.ndarray:
    """Read a frame as stored (8 or 16 bit); a colour frame as its laser's grey.

    A grey frame is returned as it is (`laser` is then ignored). A colour frame needs
    `laser` ("red", "green" or "blue"): it becomes `pipeline.imaging.laser_grey` of it, the
    laser channel's excess over the others (what a bandpass filter would have kept). OSError
    when the file cannot be read, ValueError for a colour frame without `laser`.
    """
    if not path.is_file():
        raise OSError(f"no such image file: {path}")
    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if image is None:
        raise OSError(f"cannot read {path} as an image")
    if image.ndim == 3 and image.shape[2] in (3, 4):
        if laser is None:
            raise ValueError(
                f"{path} is a colour frame: give the laser's colour with --laser "
                f"({', '.join(LASER_CHANNELS)}), or convert it to grey"
            )
        rgb = cv2.cvtColor(image, cv2.COLOR_BGRA2RGB if image.shape[2] == 4 else cv2.COLOR_BGR2RGB)
        return laser_grey(rgb, laser)
    return image


def write_centres_csv(centres: Centres, path: Path) -> None:
    """Write one row per centre point: x,y [px], unit normal, σ [px], strength [grey levels]."""
    table = np.column_stack(
        [centres.x, centres.y, centres.nx, centres.ny, centres.sigma, centres.strength]
    )
    np.savetxt(
        path,
        table,
        fmt=("%.4f", "%.4f", "%.6f", "%.6f", "%.4f", "%.6g"),
        delimiter=",",
        header=CSV_HEADER,
        comments="",
    )


def summarise(centres: Centres, image_path: Path, csv_path: Path) -> dict[str, object]:
    """JSON-ready summary of one frame's extraction."""
    sigma = centres.sigma
    return {
        "image": str(image_path),
        "output": str(csv_path),
        "method": centres.method,
        "path": centres.path,
        "sigmas_px": list(centres.sigmas_px),
        "points": len(centres),
        "polylines": len(centres.polylines),
        "mask_px": int(centres.mask.sum()),
        "sigma_px_median": float(np.median(sigma)) if sigma.size else None,
        "width_px_median": float(np.nanmedian(centres.width_px))
        if np.isfinite(centres.width_px).any()
        else None,
    }


def _frames(source: Path, out: Path) -> list[tuple[Path, Path]]:
    """(frame, CSV) pairs: one file to `out`, or every frame of a folder into folder `out`."""
    if source.is_dir():
        frames = sorted(p for p in source.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
        if not frames:
            raise ValueError(
                f"IMAGE folder {source} holds no image files ({', '.join(IMAGE_SUFFIXES)})"
            )
        if out.exists() and not out.is_dir():
            raise ValueError(f"-o must be a folder when IMAGE is a folder, got the file {out}")
        out.mkdir(parents=True, exist_ok=True)
        return [(p, out / f"{p.stem}.csv") for p in frames]
    if out.is_dir():
        raise ValueError(f"-o must be a CSV file path when IMAGE is a file, got the folder {out}")
    return [(source, out)]


def run_extract(args: argparse.Namespace) -> int:
    """Extract centres for each frame, write CSVs, optionally print a JSON summary."""
    pairs = _frames(Path(args.image), Path(args.output))
    summaries = []
    progress = tqdm(pairs, desc="extract", unit="frame", file=sys.stderr, disable=len(pairs) < 2)
    for image_path, csv_path in progress:
        image = read_frame(image_path, laser=args.laser)
        try:
            centres = extract_centres(
                image,
                method=args.method,
                width_min=args.width_min,
                width_max=args.width_max,
                sigma=args.sigma,
                full_frame=args.full_frame,
            )
        except (ValueError, TypeError) as exc:
            raise ValueError(f"{image_path}: {exc}") from exc
        write_centres_csv(centres, csv_path)
        summaries.append(summarise(centres, image_path, csv_path))
    if args.json:
        body = summaries[0] if not Path(args.image).is_dir() else {"frames": summaries}
        sys.stdout.write(json.dumps(body, indent=2) + "\n")
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `extract` verb."""
    parser = subparsers.add_parser(
        "extract",
        help="extract laser stripe centres from a frame or a folder of frames",
        description="Sub-pixel stripe centres to CSV (header x,y,nx,ny,sigma,strength).",
    )
    parser.add_argument(
        "image", metavar="IMAGE", help="8/16-bit grey (or, with --laser, colour) frame, or a folder"
    )
    parser.add_argument("--method", choices=METHODS, default="adaptive")
    parser.add_argument(
        "--laser",
        choices=LASER_CHANNELS,
        default=None,
        help="a colour frame's laser colour: the frame is taken as that channel's excess",
    )
    parser.add_argument("--sigma", type=float, default=None, help="fixed σ [px] (steger, classic)")
    parser.add_argument("--width-min", type=float, default=5.0, help="narrowest stripe [px]")
    parser.add_argument("--width-max", type=float, default=21.0, help="widest stripe [px]")
    parser.add_argument(
        "-o", "--output", required=True, metavar="OUT", help="CSV file (a folder for a folder)"
    )
    parser.add_argument(
        "--full-frame",
        action="store_true",
        help="analyse the whole frame (the reference) instead of the stripe band",
    )
    parser.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    parser.set_defaults(func=run_extract)
