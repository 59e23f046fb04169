"""Validation of input frames, the one place that decides the working float type, and the
conversion of a colour frame to its laser's grey."""

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


LASER_CHANNELS = ("red", "green", "blue")
"""Laser colours `laser_grey` takes, in the channel order of an RGB frame."""


def laser_grey(frame: object, laser: str) -> np.ndarray:
    """The grey frame of a colour camera's laser light: its channel's excess over the others.

    Parameters
    ----------
    frame : ndarray of shape (M, N, 3), uint8 or uint16
        Colour frame, channels in RGB order (OpenCV reads BGR: convert first) [grey levels].
    laser : {"red", "green", "blue"}
        The channel the laser lights.

    Returns
    -------
    ndarray of shape (M, N), the frame's dtype
        Per pixel the laser's channel minus the brighter of the other two, at least 0; full
        scale where the laser's channel is clipped at full scale.

    Raises
    ------
    TypeError
        If `frame` is not an ndarray of uint8 or uint16.
    ValueError
        If it is not (M, N, 3) with M, N ≥ 3, or `laser` is not one of LASER_CHANNELS.

    Notes
    -----
    A narrow-band laser lights mostly its own channel; ambient light, white paper, print and
    bare steel light all three about equally, so the excess keeps the laser's light and drops
    the achromatic scene, as a bandpass filter does before a grey camera (the station's
    cameras have one and give grey frames, which need none of this). A plain grey conversion
    keeps the scene and dims the laser to its channel's weight (0.30 for red in ITU-R 601),
    so a printed board's white grid outshines a red line. Where the laser's channel clips, the
    colour is lost (a bright line's core turns white on white paper, its excess 0 there); a
    frame exposed for its scene clips that channel only under the laser, so such a pixel is
    taken as full-scale laser light. A coloured object of the laser's colour stays, as it
    would behind a filter.

    Examples
    --------
    >>> import numpy as np
    >>> frame = np.full((3, 3, 3), 200, np.uint8)  # white paper
    >>> frame[1, :, 0] = 255  # a red line, clipped in red
    >>> frame[2, :] = (120, 40, 30)  # a dim red line on a dark square
    >>> laser_grey(frame, "red")[:, 0].tolist()
    [0, 255, 80]
    """
    if not isinstance(frame, np.ndarray):
        raise TypeError(f"frame must be a numpy ndarray, got {type(frame).__name__}")
    if frame.dtype not in (np.uint8, np.uint16):
        raise TypeError(f"frame must be uint8 or uint16, got dtype {frame.dtype}")
    if frame.ndim != 3 or frame.shape[2] != 3 or min(frame.shape[:2]) < 3:
        raise ValueError(f"frame must have shape (M, N, 3) with M, N ≥ 3, got {frame.shape}")
    if laser not in LASER_CHANNELS:
        raise ValueError(f"laser must be one of {', '.join(LASER_CHANNELS)}, got {laser!r}")
    own = LASER_CHANNELS.index(laser)
    others = [k for k in range(3) if k != own]
    channel = frame[..., own]
    excess = channel.astype(np.int64) - np.maximum(frame[..., others[0]], frame[..., others[1]])
    full = np.iinfo(frame.dtype).max
    grey = np.where(channel == full, full, np.clip(excess, 0, None))
    return grey.astype(frame.dtype)


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
