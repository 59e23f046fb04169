"""Field mode of the simulator: what a wayside station's frames show beyond a clean stripe.

Each effect is physically motivated, has its parameters here (units in the names) and can
be switched off alone (`FieldEffects`), so its cost to each extraction method can be
measured. The truth never moves: it stays the laser plane's geometric intersection with
the wheel, whatever the effects do to the stripe's appearance.

- scene: daylight through the bandpass filter lights the rim, web, rail head and axle-box
  face at grey 15–90 with grain, and bright thin corners (`pipeline.simulation.scene`).
- texture: reflectance grain of the wheel at the stripe's scale (correlation 3–15 px,
  contrast 0.2–0.6) multiplies the stripe.
- shiny_bands: wheel-rail contact polishes the running band and the flange root: the
  diffuse stripe is at 6–35 % of its surroundings there (the running band is dimmed; the
  root is that dim already), next to stretches where the specular lobe of the lit line
  reaches the camera: narrow, saturated glare on the line (the paper's Fig. 3d).
- asymmetry: where the reflectance (or, much less, the slope) changes across the lit band,
  the two sides of the cross-section differ (a two-sided Gaussian, peak on the true line).
  The band runs across the laser plane, so its slope turns with the wheel's circumference
  (|α| < 0.02, computed from the geometry), not with the profile's curvature.
- ghost: light reflected off the flange flank draws a faint, wide copy (10–30 %) of the
  flange's stripe on the tread beside the stripe.
- spots: specular glints on the lit line itself (the clean mode has them beside it only).
- long_part_stripe: the axle-box or brake part's stripe is 1.15–1.6× longer than a piece
  of the wheel's stripe (its shortest of ≥ 50 px), so "keep the longest lines" keeps it.
- flange_cut: the flange shades the flange root from the outer sensor's laser, cutting the
  stripe there with abrupt ends.
- blooming: charge above full well spills into the neighbouring pixels at glints (a halo;
  no column streak: the cameras are CMOS).
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import cv2
import numpy as np

from pipeline.calibration.model import SensorCalibration
from pipeline.imaging import IMAGE_FLOAT
from pipeline.simulation.render import StripeSamples, WheelPose, band_edge_pixels
from pipeline.simulation.scene import grain
from pipeline.simulation.wheel import WheelProfile

TEXTURE_CORRELATION_PX = (3.0, 15.0)
TEXTURE_CONTRAST = (0.2, 0.6)
"""Reflectance grain multiplying the stripe: std/mean and correlation length [px]."""
SHINY_DIFFUSE_FRACTION = (0.06, 0.35)
"""Diffuse level of a polished band relative to the surrounding surface."""
SHINY_BAND_MM = {"running": (62.0, 82.0), "root": (14.0, 24.0)}
"""Polished bands: the running band (profile x) and the flank's contact band at the root,
z ≈ 12 → 4 mm (x beyond the flange top) [mm]; each band's edges are drawn again per pass
within ±3 mm."""
DIMMED_BANDS = ("running",)
"""Bands whose diffuse level drops to `SHINY_DIFFUSE_FRACTION`: the running band. The
flange root is dim already in the clean appearance (reflectivity 0.07–0.11 against the
tread's 0.85–1.0, i.e. 7–13 %), so there the polish adds only its glare."""
GLARE_PEAK_DN = (260.0, 900.0)
"""Peak of the specular glare on the 8-bit scale (above 255: saturated)."""
GLARE_WIDTH_FRACTION = (0.4, 0.8)
"""Width of the glare relative to the diffuse stripe's (the specular lobe images the thin
sheet without the light's spread inside the rough surface)."""
GLARE_RUN_STEP = 100_000
"""Added to the run id once per glare stretch, so each stretch is a run of its own (run ids
of a wheel's samples stay below 20 000: `render._runs` counts runs, `cut_at_flange` adds
10 000)."""
BAND_HALF_MM = 1.0
"""Half-thickness of the lit band taken for its own asymmetry [mm]: more than the sheet's
(0.25 mm, `render.SHEET_THICKNESS_MM` / 2), so the band's α is an upper bound."""
SKEW_RANDOM = 0.06
"""Random part of α from reflectance changes across the band (smooth along the outline)."""
SKEW_LIMIT = 0.25
"""Two-sided Gaussian: σ(1 ± α) on the two sides of the true line, |α| ≤ 0.25."""
GHOST_FRACTION = (0.10, 0.30)
GHOST_WIDENING = (1.8, 3.0)
GHOST_OFFSET_PX = (25.0, 60.0)
"""Flange ghost: relative peak, width factor and offset from the tread stripe [px]."""
SPOT_ON_STRIPE_PEAK_DN = (80.0, 400.0)
SPOT_ON_STRIPE_SIGMA_PX = (1.0, 2.5)
SPOTS_ON_STRIPE = (2, 6)
"""Glints on the lit line: count, peak (8-bit scale) and size; centred within ±w/8."""
LONG_PART_FACTOR = (1.15, 1.6)
MIN_PIECE_PX = 50.0
"""Other part's stripe length relative to the shortest piece (≥ 50 px) of the wheel's
stripe: longer than a piece of the wheel's, so "keep the longest lines" keeps it."""
FLANGE_CUT_MM = (2.0, 6.0)
FLANGE_CUT_START_Z_MM = (3.0, 6.0)
"""Profile x-length shaded at the flange root (from the outer sensor's laser), starting
where the flank comes down to z = 3–6 mm [mm]."""
FULL_WELL_DN = 255.0
BLOOM_SIGMA_PX = 2.5
BLOOM_FRACTION = 0.5
"""Charge above full well: half spreads as a 2.5 px halo (crosstalk into the neighbouring
pixels), the rest is drained by the pixels' anti-blooming gates. The station's cameras
are global-shutter CMOS (1600 × 1200 px of 4.5 µm at 60 frames/s, `station`): no charge
moves along a column, so a glint draws no column streak (docs/simulator.md, "A glare's
bloom column drawn as a line")."""


@dataclass(frozen=True, slots=True)
class FieldEffects:
    """Which field effects a simulated frame shows (all on: the harsh field)."""

    scene: bool = True
    texture: bool = True
    shiny_bands: bool = True
    asymmetry: bool = True
    ghost: bool = True
    spots: bool = True
    long_part_stripe: bool = True
    flange_cut: bool = True
    blooming: bool = True

    @staticmethod
    def names() -> tuple[str, ...]:
        """The effect names, in drawing order."""
        return tuple(f.name for f in fields(FieldEffects))

    def without(self, name: str) -> FieldEffects:
        """These effects with `name` switched off."""
        if name not in FieldEffects.names():
            raise ValueError(f"unknown field effect {name!r}; one of {FieldEffects.names()}")
        return replace(self, **{name: False})


FIELD_MODES: dict[str, FieldEffects | None] = {"clean": None, "harsh": FieldEffects()}
"""Named simulator modes: "clean" (the stripe on black, unit tests) and "harsh" (every
field effect)."""


def subset(samples: StripeSamples, keep: np.ndarray) -> StripeSamples:
    """The samples at `keep` (indices or a mask), runs kept apart."""
    return StripeSamples(
        pixels=samples.pixels[keep],
        width_px=samples.width_px[keep],
        irradiance=samples.irradiance[keep],
        outline_index=samples.outline_index[keep],
        run_id=samples.run_id[keep],
        points_track_mm=samples.points_track_mm[keep],
    )


def image_normals(samples: StripeSamples) -> np.ndarray:
    """Unit image normal (tangent turned by +90°) of each sample, per run, (K, 2)."""
    normals = np.zeros(samples.pixels.shape)
    for run in np.unique(samples.run_id):
        at = np.flatnonzero(samples.run_id == run)
        if at.size < 2:
            continue
        tangent = np.gradient(samples.pixels[at], axis=0)
        tangent /= np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True), 1e-12)
        normals[at] = np.column_stack([-tangent[:, 1], tangent[:, 0]])
    return normals


def _outline_x(profile: WheelProfile, samples: StripeSamples) -> tuple[np.ndarray, float]:
    top_x = float(profile.x_mm[np.argmax(profile.z_mm)])
    return profile.x_mm[samples.outline_index], top_x


def stripe_texture(shape: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
    """Reflectance grain of the wheel at the stripe's scale (mean 1), shape `shape`."""
    return grain(shape, rng.uniform(*TEXTURE_CORRELATION_PX), rng.uniform(*TEXTURE_CONTRAST), rng)


def shiny_bands(profile: WheelProfile, samples: StripeSamples, rng) -> tuple[np.ndarray, ...]:
    """Diffuse factor per sample (1 outside the polished bands) and the band mask."""
    x, top_x = _outline_x(profile, samples)
    factor = np.ones(x.size)
    band = np.zeros(x.size, bool)
    for name, (lo, hi) in SHINY_BAND_MM.items():
        base = top_x if name == "root" else 0.0
        lo, hi = base + lo + rng.uniform(-3, 3), base + hi + rng.uniform(-3, 3)
        edge = np.clip(np.minimum(x - lo, hi - x) / 2.0, 0.0, 1.0)  # 2 mm soft edges
        fraction = rng.uniform(*SHINY_DIFFUSE_FRACTION)
        if name in DIMMED_BANDS:
            factor *= 1.0 - (1.0 - fraction) * edge
        band |= edge > 0.5
    return factor, band


def glare(samples: StripeSamples, band: np.ndarray, rng) -> tuple[StripeSamples, np.ndarray]:
    """The polished band's specular glare: stretches of the lit line whose specular lobe
    reaches the camera, narrower than the diffuse stripe and saturated; samples and peak."""
    width = samples.width_px * rng.uniform(*GLARE_WIDTH_FRACTION)
    shiny = replace_pixels(samples, samples.pixels, width)
    period, length = int(rng.integers(60, 160)), int(rng.integers(15, 60))
    keep = band & (np.cumsum(band) % period < length)
    peak = rng.uniform(*GLARE_PEAK_DN) * np.ones(int(keep.sum()))
    # Each stretch is its own run: `draw_stripe` joins consecutive samples of a run, and
    # stretches joined across their gaps drew the glare along straight chords off the
    # curved line (docs/simulator.md, "The glare's chords").
    stretch = np.cumsum(keep & ~np.concatenate([[False], keep[:-1]]))
    pieces = subset(shiny, keep)
    return replace(pieces, run_id=pieces.run_id + GLARE_RUN_STEP * stretch[keep]), peak


def replace_pixels(samples: StripeSamples, pixels: np.ndarray, width_px) -> StripeSamples:
    """The same samples drawn at other pixels with another width [px]."""
    return StripeSamples(
        pixels=pixels,
        width_px=np.broadcast_to(np.asarray(width_px, float), samples.width_px.shape).copy(),
        irradiance=samples.irradiance,
        outline_index=samples.outline_index,
        run_id=samples.run_id,
        points_track_mm=samples.points_track_mm,
    )


def band_skew(
    profile: WheelProfile, samples: StripeSamples, pose: WheelPose, sensor: SensorCalibration
) -> np.ndarray:
    """α per sample of the lit band itself: its two edges (where the planes ±`BAND_HALF_MM`
    from the laser plane meet the wheel) imaged at different distances from the line, the
    farther one on the wider side (+ along `image_normals`, `draw_stripe`'s left).

    The band runs across the laser plane, so the surface turns across it by the wheel's
    curvature in that direction, not by the profile's (which runs along the stripe): for a
    laser plane through the wheel's lowest section that is the rim's circumference, 1/r ≈
    1/400 mm, and |α| stays below 0.02. Where the band images along the stripe (its edges
    within 0.5 px of the line) it adds no width and α is 0. The lens and defocus spread
    (symmetric) are left out, so this α is an upper bound.
    """
    normals = image_normals(samples)
    reach = [
        np.einsum("ij,ij->i", band_edge_pixels(profile, pose, sensor, samples, h_mm), normals)
        - np.einsum("ij,ij->i", samples.pixels, normals)
        for h_mm in (BAND_HALF_MM, -BAND_HALF_MM)
    ]
    left = np.maximum(np.maximum(*reach), 0.0)
    right = np.maximum(-np.minimum(*reach), 0.0)
    across = left + right
    return np.where(across > 0.5, (left - right) / np.maximum(across, 0.5), 0.0)


def skew(
    profile: WheelProfile, samples: StripeSamples, pose: WheelPose, sensor: SensorCalibration, rng
) -> np.ndarray:
    """α per sample of the two-sided cross-section: the lit band's own asymmetry
    (`band_skew`) and a smooth random part (reflectance changing across the band: rust and
    wear patches; the polished bands are rings, constant across it)."""
    noise = np.convolve(rng.normal(0, 1, profile.x_mm.size), np.ones(100) / 10.0, mode="same")
    alpha = band_skew(profile, samples, pose, sensor) + SKEW_RANDOM * noise[samples.outline_index]
    return np.clip(alpha, -SKEW_LIMIT, SKEW_LIMIT)


def ghost(profile: WheelProfile, samples: StripeSamples, peak_dn: np.ndarray, rng):
    """The flange's stripe reflected onto the tread: samples and peak grey (or None)."""
    x, top_x = _outline_x(profile, samples)
    flange = np.flatnonzero(np.abs(x - top_x) < 12.0)
    tread = np.flatnonzero((x > top_x + 20.0) & (x < top_x + 40.0))
    if flange.size < 10 or tread.size < 2:
        return None
    normals = image_normals(samples)
    anchor = tread[tread.size // 2]
    side = rng.choice([-1.0, 1.0])
    move = samples.pixels[anchor] - samples.pixels[flange].mean(axis=0)
    move += side * rng.uniform(*GHOST_OFFSET_PX) * normals[anchor]
    copy = subset(samples, flange)
    copy = replace_pixels(copy, copy.pixels + move, copy.width_px * rng.uniform(*GHOST_WIDENING))
    return copy, peak_dn[flange] * rng.uniform(*GHOST_FRACTION)


def add_spots_on_stripe(image: np.ndarray, samples: StripeSamples, rng) -> None:
    """Specular glints centred on the lit line (within ±w/8 across it), in place."""
    if samples.pixels.shape[0] == 0:
        return
    normals = image_normals(samples)
    count = int(rng.integers(*SPOTS_ON_STRIPE))
    for i in rng.choice(samples.pixels.shape[0], size=min(count, samples.pixels.shape[0])):
        sigma = rng.uniform(*SPOT_ON_STRIPE_SIGMA_PX)
        centre = samples.pixels[i] + rng.normal(0, samples.width_px[i] / 8) * normals[i]
        _add_spot(image, centre, sigma, rng.uniform(*SPOT_ON_STRIPE_PEAK_DN))


def _add_spot(image: np.ndarray, centre: np.ndarray, sigma: float, peak: float) -> None:
    cx, cy = centre
    r0, r1 = int(max(cy - 4 * sigma, 0)), int(min(cy + 4 * sigma + 1, image.shape[0]))
    c0, c1 = int(max(cx - 4 * sigma, 0)), int(min(cx + 4 * sigma + 1, image.shape[1]))
    if r0 >= r1 or c0 >= c1:
        return
    d2 = (np.arange(r0, r1)[:, None] - cy) ** 2 + (np.arange(c0, c1)[None, :] - cx) ** 2
    image[r0:r1, c0:c1] += peak * np.exp(-0.5 * d2 / sigma**2)


def cut_at_flange(profile: WheelProfile, samples: StripeSamples, rng) -> StripeSamples:
    """The samples without the stretch of flange root the flange shades (where the flank
    comes down to z = 3–6 mm, clear of the heights Sd and qR are read at); the cut splits
    the run there."""
    x, top_x = _outline_x(profile, samples)
    z = profile.z_mm[samples.outline_index]
    flank = np.flatnonzero((x > top_x) & (z < rng.uniform(*FLANGE_CUT_START_Z_MM)))
    if flank.size == 0:
        return samples
    start = x[flank[0]]
    shaded = (x >= start) & (x < start + rng.uniform(*FLANGE_CUT_MM))
    kept = subset(samples, ~shaded)
    after = np.cumsum(shaded)[~shaded] > 0
    return StripeSamples(
        pixels=kept.pixels,
        width_px=kept.width_px,
        irradiance=kept.irradiance,
        outline_index=kept.outline_index,
        run_id=kept.run_id + np.where(after, 10_000, 0),
        points_track_mm=kept.points_track_mm,
    )


def run_lengths_px(samples: StripeSamples) -> np.ndarray:
    """Image length of each run of the samples [px]."""
    lengths = []
    for run in np.unique(samples.run_id):
        p = samples.pixels[samples.run_id == run]
        lengths.append(np.hypot(*np.diff(p, axis=0).T).sum() if p.shape[0] > 1 else 0.0)
    return np.asarray(lengths)


def long_part(part: StripeSamples, wheel: StripeSamples, rng) -> StripeSamples:
    """A piece of the other part's stripe 1.15–1.6× as long as the wheel's shortest piece
    of at least `MIN_PIECE_PX` (all of it when it is not that long)."""
    lengths = run_lengths_px(wheel) if wheel.pixels.shape[0] > 1 else np.zeros(0)
    pieces = lengths[lengths >= MIN_PIECE_PX]
    if part.pixels.shape[0] < 2 or pieces.size == 0:
        return part
    target = rng.uniform(*LONG_PART_FACTOR) * pieces.min()
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(part.pixels, axis=0).T))])
    if arc[-1] <= target:
        return part
    start = rng.uniform(0.0, arc[-1] - target)
    return subset(part, (arc >= start) & (arc <= start + target))


def bloom(image: np.ndarray) -> None:
    """Spill `BLOOM_FRACTION` of the charge above full well into a halo, in place."""
    excess = np.clip(image - FULL_WELL_DN, 0.0, None).astype(IMAGE_FLOAT)
    if not excess.any():
        return
    image += BLOOM_FRACTION * cv2.GaussianBlur(excess, (0, 0), BLOOM_SIGMA_PX)
