"""Checkerboard calibration targets: the board model.

Board frame: origin at the first inner corner, x along the pattern's columns, y along its
rows, z out of the printed face (towards the camera). The square outside corner (0, 0) —
u, v in [−s, 0) — is black, which fixes the board's in-plane orientation (the pattern has an
even number of squares one way and an odd number the other, so it is not 180° symmetric).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.imaging import GEOMETRY_FLOAT


@dataclass(frozen=True, slots=True)
class Board:
    """A checkerboard: inner corners per row and column, and the square size.

    Attributes
    ----------
    columns, rows : int
        Inner corners along x and along y (OpenCV's pattern size is (columns, rows)).
    square_mm : float
    """

    columns: int = 11
    rows: int = 8
    square_mm: float = 12.0

    @property
    def corners_mm(self) -> np.ndarray:
        """Inner corners in the board frame, OpenCV order (row by row), shape (K, 3) [mm]."""
        v, u = np.mgrid[0 : self.rows, 0 : self.columns]
        grid = np.column_stack([u.ravel(), v.ravel(), np.zeros(u.size)])
        return grid.astype(GEOMETRY_FLOAT) * self.square_mm
