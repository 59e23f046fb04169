"""Validation of input frames and the one place that decides the working float type."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

IMAGE_FLOAT = np.float32
"""Float type for image filtering (px intensities)."""

GEOMETRY_FLOAT = np.float64
"""Float type for geometry and fits (mm, sub-px coordinates)."""


def validate_image(image: object, *, name: str = "image") -> np.ndarray:
    """Check that `image` is a usable 2-D grey frame and return it as an ndarray.

    Parameters
    ----------
    image : ndarray of shape (M, N), uint8 or uint16
        Grey camera frame [px]. Float frames are accepted when finite (tests, simulators).
    name : str
        Argument name used in error messages.

    Returns
    -------
    ndarray of shape (M, N)
        The same data (no copy when already an ndarray).

    Raises
    ------
    TypeError
        If `image` is not an array of a real number type.
    ValueError
        If it is not 2-D (colour frames included), is empty, or holds NaN or infinity.
    """
    if not isinstance(image, np.ndarray):
        raise TypeError(f"{name} must be a numpy ndarray, got {type(image).__name__}")
    if image.ndim == 3 and image.shape[2] in (3, 4):
        raise ValueError(
            f"{name} must be a 2-D grey frame, got a colour image of shape {image.shape}; "
            "convert it to grey first"
        )
    if image.ndim != 2:
        raise ValueError(f"{name} must be 2-D (rows, columns), got shape {image.shape}")
    if image.size == 0 or min(image.shape) < 3:
        raise ValueError(f"{name} must be at least 3x3 px, got shape {image.shape}")
    kind = image.dtype.kind
    if kind == "b" or kind not in "uif":
        raise TypeError(
            f"{name} must be uint8 or uint16 (or finite float), got dtype {image.dtype}"
        )
    if kind == "f" and not np.all(np.isfinite(image)):
        raise ValueError(f"{name} holds NaN or infinite values")
    return image


def to_float_image(image: np.ndarray) -> np.ndarray:
    """Return a validated frame as a contiguous IMAGE_FLOAT array (grey levels unchanged) [px]."""
    return np.ascontiguousarray(validate_image(image), dtype=IMAGE_FLOAT)


@dataclass(frozen=True, slots=True)
class PixelRegion:
    """A rectangle of the frame: rows row_start … row_stop − 1, columns col_start … col_stop − 1."""

    row_start: int
    row_stop: int
    col_start: int
    col_stop: int

    @property
    def area_px(self) -> int:
        """Pixels inside the region."""
        return (self.row_stop - self.row_start) * (self.col_stop - self.col_start)

    def validate(self, shape: tuple[int, int]) -> None:
        """Raise ValueError unless the region is non-empty and inside a frame of `shape`."""
        rows, cols = shape
        if not (0 <= self.row_start < self.row_stop <= rows) or not (
            0 <= self.col_start < self.col_stop <= cols
        ):
            raise ValueError(
                f"region must be a non-empty part of a {rows}×{cols} frame, got {self}"
            )


def freeze_geometry(instance: object, *fields: str) -> None:
    """In a frozen dataclass's __post_init__: make `fields` read-only float64 copies."""
    for field in fields:
        array = np.array(getattr(instance, field), dtype=GEOMETRY_FLOAT)
        array.flags.writeable = False
        object.__setattr__(instance, field, array)
