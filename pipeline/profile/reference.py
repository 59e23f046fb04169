"""Reference wheel profiles (LMA, S1002) as data, in the profile frame (docs/coordinate-frames.md).

The coordinate tables ship as package data (`pipeline/profile/data/*.csv`, provenance in
`pipeline/profile/data/PROVENANCE.md`): x from the back face [mm], z up towards the flange tip [mm],
z = 0 at the reference point x = 70 mm.
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources

import numpy as np

from pipeline.imaging import GEOMETRY_FLOAT, freeze_geometry

REFERENCE_PROFILES = ("LMA", "S1002")


@dataclass(frozen=True, slots=True, eq=False)
class ReferenceProfile:
    """A published wheel profile as a polyline in the profile frame.

    Attributes
    ----------
    name : str
        "LMA" or "S1002".
    x_mm, z_mm : ndarray of shape (K,), float64
        Points in source order, x strictly increasing [mm].
    """

    name: str
    x_mm: np.ndarray
    z_mm: np.ndarray

    def __post_init__(self) -> None:
        freeze_geometry(self, "x_mm", "z_mm")


def load_reference_profile(name: str) -> ReferenceProfile:
    """Load reference profile `name` ("LMA" or "S1002") from the package data.

    Raises
    ------
    ValueError
        If `name` is not a known reference profile.

    Examples
    --------
    >>> profile = load_reference_profile("LMA")
    >>> float(profile.z_mm.max())
    28.0
    """
    if name not in REFERENCE_PROFILES:
        raise ValueError(f"name must be one of {', '.join(REFERENCE_PROFILES)}, got {name!r}")
    text = resources.files("pipeline.profile").joinpath("data", f"{name}.csv").read_text("utf-8")
    table = np.loadtxt(text.splitlines(), delimiter=",", skiprows=1, dtype=GEOMETRY_FLOAT)
    return ReferenceProfile(name=name, x_mm=table[:, 0], z_mm=table[:, 1])
