"""Looking at PDFs in tests: every page rendered to PNG (pdftoppm), word boxes and text
(pdftotext), and the words whose boxes overlap (text drawn over text)."""

from __future__ import annotations

import re
import subprocess
from dataclasses import dataclass
from pathlib import Path

import numpy as np

WORD = re.compile(
    r'<word xMin="([\d.]+)" yMin="([\d.]+)" xMax="([\d.]+)" yMax="([\d.]+)">(.*?)</word>'
)
OVERLAP_PT = 0.6
"""Boxes must intersect by more than this in both directions to count: pdftotext's boxes
of adjacent glyph runs touch or overlap by a few hundredths of a point."""


@dataclass(frozen=True)
class Page:
    boxes: np.ndarray
    """(K, 4) xMin, yMin, xMax, yMax [pt]."""
    words: list[str]


def pdf_pages(pdf: Path) -> list[Page]:
    """The word boxes of every page."""
    xhtml = subprocess.run(
        ["pdftotext", "-bbox", str(pdf), "-"], check=True, capture_output=True, text=True
    ).stdout
    pages = []
    for chunk in xhtml.split("<page ")[1:]:
        found = WORD.findall(chunk)
        boxes = np.array([[float(v) for v in w[:4]] for w in found]).reshape(-1, 4)
        pages.append(Page(boxes, [w[4] for w in found]))
    return pages


def overlapping_words(page: Page) -> list[tuple[str, str]]:
    """Pairs of words on a page whose boxes overlap."""
    b = page.boxes
    dx = np.minimum(b[:, None, 2], b[None, :, 2]) - np.maximum(b[:, None, 0], b[None, :, 0])
    dy = np.minimum(b[:, None, 3], b[None, :, 3]) - np.maximum(b[:, None, 1], b[None, :, 1])
    i, j = np.nonzero(np.triu((dx > OVERLAP_PT) & (dy > OVERLAP_PT), k=1))
    return [(page.words[a], page.words[c]) for a, c in zip(i, j, strict=True)]


def render_pages(pdf: Path, out_dir: Path, dpi: int = 60) -> list[Path]:
    """Every page as a PNG in `out_dir` (page-01.png, …)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    subprocess.run(
        ["pdftoppm", "-r", str(dpi), "-png", str(pdf), str(out_dir / "page")], check=True
    )
    return sorted(out_dir.glob("page-*.png"))


def pdf_text(pdf: Path) -> str:
    """The text of the PDF in reading layout."""
    return subprocess.run(
        ["pdftotext", "-layout", str(pdf), "-"], check=True, capture_output=True, text=True
    ).stdout
