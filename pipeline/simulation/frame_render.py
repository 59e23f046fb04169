"""Grey frames from stripe samples: surface appearance, Gaussian stripes, artefacts, sensor.

The stripe cross-section is Gaussian with the sample's 1/e² width w (σ = w/4) about the true
centre line; its peak follows the irradiance, the surface reflectivity and the spreading of
the light over the width. Frames then get the paper's disturbances: a bright polished tread
band, a dull or rusty flange, a low-grey stretch at the flange root, laser speckle, specular
spots beside the stripe on the flange, stray light, and shot + read noise before
quantisation to 8 or 16 bit.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy.ndimage import gaussian_filter1d
from scipy.spatial import cKDTree

from pipeline.imaging import IMAGE_FLOAT
from pipeline.simulation.render import StripeSamples
from pipeline.simulation.wheel import WheelProfile

ELECTRONS_PER_DN = 40.0
"""Full well ≈ 10 000 e⁻ at 8-bit full scale: shot noise is √(40·g)/40 DN at grey level g."""
READ_NOISE_DN = 1.2
DARK_LEVEL_DN = 6.0
EXPOSURE_GAIN = 330.0
"""Peak grey level (8-bit scale) of a reflectivity-1 surface lit head-on with a 10 px stripe."""
REACH_SIGMAS = 3.2
"""The Gaussian is drawn out to 3.2 σ (0.6 % of the peak); beyond it the frame is background."""


@dataclass(frozen=True, slots=True, eq=False)
class Appearance:
    """How a wheel's surface looks along its outline (one value per outline point).

    Attributes
    ----------
    reflectivity : ndarray of shape (K,)
        Diffuse reflectivity (0..1) including speckle.
    scatter_mm : ndarray of shape (K,)
        Spread of the light inside the rough surface at normal incidence [mm].
    """

    reflectivity: np.ndarray
    scatter_mm: np.ndarray


def wheel_appearance(profile: WheelProfile, rng: np.random.Generator) -> Appearance:
    """A wheel's surface: bright worn tread, rusty flange, dull root, machined faces.

    Parameters
    ----------
    profile : WheelProfile
    rng : numpy.random.Generator
        Draws this wheel's band edges, levels and rust texture.
    """
    x, z = profile.x_mm, profile.z_mm
    top_x = x[np.argmax(z)]
    face = (x <= x.min()) | (x >= x.max())
    root_start, tread_start = top_x + rng.uniform(8, 14), rng.uniform(47, 55)
    tread_end = rng.uniform(95, 105)
    reflectivity = np.full(x.size, rng.uniform(0.45, 0.6))
    scatter = np.full(x.size, 0.6)
    flange = (x < root_start) & ~face
    reflectivity[flange] = rng.uniform(0.22, 0.35)
    scatter[flange] = 1.0
    root = (x >= root_start) & (x < tread_start) & ~face
    reflectivity[root] = rng.uniform(0.07, 0.11)
    tread = (x >= tread_start) & (x < tread_end) & ~face
    reflectivity[tread] = rng.uniform(0.85, 1.0)
    scatter[tread] = 0.25
    rust = gaussian_filter1d(rng.normal(0.0, 1.0, x.size), 30.0)
    rust /= max(float(np.std(rust)), 1e-9)
    reflectivity *= np.where(flange, np.exp(0.3 * rust), np.exp(0.08 * rust))
    reflectivity = gaussian_filter1d(reflectivity, 20.0)
    return Appearance(reflectivity=reflectivity, scatter_mm=gaussian_filter1d(scatter, 20.0))


def pass_appearance(base: Appearance, rng: np.random.Generator) -> Appearance:
    """The same wheel on another pass: new lighting level and new laser speckle."""
    speckle = gaussian_filter1d(rng.normal(0.0, 1.0, base.reflectivity.size), 2.0)
    speckle /= max(float(np.std(speckle)), 1e-9)
    level = rng.uniform(0.85, 1.15)
    return Appearance(
        reflectivity=base.reflectivity * level * np.exp(0.12 * speckle),
        scatter_mm=base.scatter_mm,
    )


def _nearest_on_runs(samples: StripeSamples, pixels: np.ndarray) -> tuple[np.ndarray, ...]:
    """Distance of each pixel to the sample polyline, and the foot's sample and fraction."""
    tree = cKDTree(samples.pixels)
    _, nearest = tree.query(pixels)
    best_d = np.full(pixels.shape[0], np.inf)
    best_i = nearest.copy()
    best_t = np.zeros(pixels.shape[0])
    count = samples.pixels.shape[0]
    for start in (nearest - 1, nearest):
        a = np.clip(start, 0, count - 2)
        joined = samples.run_id[a] == samples.run_id[a + 1]
        seg = samples.pixels[a + 1] - samples.pixels[a]
        rel = pixels - samples.pixels[a]
        t = np.clip(np.einsum("ij,ij->i", rel, seg) / np.maximum((seg**2).sum(1), 1e-12), 0, 1)
        t = np.where(joined, t, np.where(nearest == a, 0.0, 1.0))
        d = np.linalg.norm(rel - t[:, None] * seg, axis=1)
        better = d < best_d
        best_d[better], best_i[better], best_t[better] = d[better], a[better], t[better]
    return best_d, best_i, best_t


def draw_stripe(
    image: np.ndarray,
    samples: StripeSamples,
    peak_dn: np.ndarray,
    *,
    skew: np.ndarray | None = None,
) -> None:
    """Add a Gaussian stripe along the samples (peak grey per sample) to `image` in place.

    With `skew` (α per sample, |α| < 1) the cross-section is two-sided: σ(1 + α) on the
    left of the samples' direction of travel and σ(1 − α) on the right, its peak still on
    the true line (a slope or reflectance change across the lit band).
    """
    if samples.pixels.shape[0] < 2:
        return
    mask = np.zeros(image.shape, np.uint8)
    most = 1.0 if skew is None else 1.0 + float(np.abs(skew).max())
    reach = int(np.ceil(REACH_SIGMAS * most * samples.width_px.max() / 4)) + 1
    for run in np.unique(samples.run_id):
        pts = np.round(samples.pixels[samples.run_id == run] * 16).astype(np.int32)
        cv2.polylines(mask, [pts], False, 255, 2 * reach + 1, cv2.LINE_8, shift=4)
    rows, cols = np.nonzero(mask)
    pixels = np.column_stack([cols, rows]).astype(np.float64)
    distance, index, t = _nearest_on_runs(samples, pixels)
    nxt = np.minimum(index + 1, samples.pixels.shape[0] - 1)
    width = (1 - t) * samples.width_px[index] + t * samples.width_px[nxt]
    peak = (1 - t) * peak_dn[index] + t * peak_dn[nxt]
    sigma = width / 4.0
    if skew is not None:
        seg = samples.pixels[nxt] - samples.pixels[index]
        rel = pixels - samples.pixels[index]
        left = seg[:, 0] * rel[:, 1] - seg[:, 1] * rel[:, 0] > 0
        alpha = (1 - t) * skew[index] + t * skew[nxt]
        sigma = sigma * np.where(left, 1 + alpha, 1 - alpha)
    near = distance <= REACH_SIGMAS * sigma
    value = peak * np.exp(-0.5 * (distance / sigma) ** 2)
    np.add.at(image, (rows[near], cols[near]), value[near].astype(IMAGE_FLOAT))


def stripe_peaks(samples: StripeSamples, reflectivity: np.ndarray) -> np.ndarray:
    """Peak grey level (8-bit scale) per sample: the line's power spread over its width."""
    return EXPOSURE_GAIN * reflectivity * samples.irradiance**0.8 * np.sqrt(10.0 / samples.width_px)


def add_specular_spots(
    image: np.ndarray, samples: StripeSamples, near: np.ndarray, rng: np.random.Generator
) -> None:
    """Stray specular spots beside the stripe where `near` (e.g. on the flange), in place."""
    candidates = np.flatnonzero(near)
    if candidates.size == 0:
        return
    for i in rng.choice(candidates, size=min(int(rng.integers(3, 8)), candidates.size)):
        sigma = rng.uniform(1.5, 4.0)
        # Beside the stripe: clear of its 1/e² edge (0.5 w) by at least the spot's 3 σ.
        clearance = 0.5 * samples.width_px[i] + 3.0 * sigma + rng.uniform(3.0, 25.0)
        cx = samples.pixels[i, 0] + rng.normal(0, 6.0)
        cy = samples.pixels[i, 1] + rng.choice([-1.0, 1.0]) * clearance
        r0, r1 = int(max(cy - 4 * sigma, 0)), int(min(cy + 4 * sigma + 1, image.shape[0]))
        c0, c1 = int(max(cx - 4 * sigma, 0)), int(min(cx + 4 * sigma + 1, image.shape[1]))
        if r0 >= r1 or c0 >= c1:
            continue
        d2 = (np.arange(r0, r1)[:, None] - cy) ** 2 + (np.arange(c0, c1)[None, :] - cx) ** 2
        image[r0:r1, c0:c1] += rng.uniform(60.0, 255.0) * np.exp(-0.5 * d2 / sigma**2)


def add_stray_light(image: np.ndarray, rng: np.random.Generator) -> None:
    """A broad, faint glow (light scattered by the bogie and the rail), in place."""
    height, width = image.shape
    glow = np.zeros((height // 8, width // 8), IMAGE_FLOAT)
    cy, cx = rng.uniform(0, glow.shape[0]), rng.uniform(0, glow.shape[1])
    yy, xx = np.mgrid[0 : glow.shape[0], 0 : glow.shape[1]]
    spread = rng.uniform(15.0, 40.0)
    glow += rng.uniform(4.0, 14.0) * np.exp(-((yy - cy) ** 2 + (xx - cx) ** 2) / (2 * spread**2))
    image += cv2.resize(glow, (width, height), interpolation=cv2.INTER_LINEAR)


def expose(image_dn8: np.ndarray, bit_depth: int, rng: np.random.Generator) -> np.ndarray:
    """Sensor model: dark level, shot noise, read noise, clipping and quantisation.

    Parameters
    ----------
    image_dn8 : ndarray of shape (M, N), float32
        Expected signal on the 8-bit grey scale.
    bit_depth : int
        8 → uint8; 16 → uint16 (8-bit scale × 257).
    rng : numpy.random.Generator
        Draws one standard normal per pixel whatever the image, so a frame's noise stays
        the same when its pixels change (paired renderings, docs/simulator.md).

    Notes
    -----
    Shot noise in its Gaussian form: λ electrons give λ + √λ·z. The dark level alone holds
    λ ≥ DARK_LEVEL_DN × ELECTRONS_PER_DN = 240 e⁻, where Poisson and Gaussian differ by far
    less than a quantisation step. Shot and read noise add as one normal per pixel of
    variance λ / ELECTRONS_PER_DN² + READ_NOISE_DN² [DN²].
    """
    z = rng.standard_normal(image_dn8.shape, dtype=np.float32)
    mean_dn = np.clip(image_dn8 + DARK_LEVEL_DN, 0, None)
    signal = mean_dn + np.sqrt(mean_dn / ELECTRONS_PER_DN + READ_NOISE_DN**2) * z
    if bit_depth == 8:
        return np.clip(np.round(signal), 0, 255).astype(np.uint8)
    return np.clip(np.round(signal * 257.0), 0, 65535).astype(np.uint16)
