"""docs/figures/glare_chords.png: the polished flank's glare as drawn before and since
pipeline 0.11.8, on the outer sensor's view of an LMA flank (docs/simulator.md, "The
glare's chords").

`PYTHONPATH=. python docs/figures/glare_chords.py` rewrites the figure.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from pipeline.profile.reference import load_reference_profile
from pipeline.simulation.field import glare, shiny_bands
from pipeline.simulation.frame_render import draw_stripe
from pipeline.simulation.render import centred_view
from pipeline.simulation.station import build_station
from pipeline.simulation.wheel import wheel_profile

OUT = Path(__file__).with_suffix(".png")
SEED = 1
"""The draw of band edges and stretches shown."""


def main() -> None:
    station = build_station()
    profile = wheel_profile(load_reference_profile("LMA"))
    _, samples = centred_view(station, "right_outer", profile)
    sensor = station.calibration.sensor("right_outer")
    rng = np.random.default_rng(SEED)
    _, band = shiny_bands(profile, samples, rng)
    now, peak = glare(samples, band, rng)
    before = replace(now, run_id=samples.run_id[np.isin(samples.pixels[:, 0], now.pixels[:, 0])])
    shape = (sensor.image_height_px, sensor.image_width_px)
    top_x = profile.x_mm[np.argmax(profile.z_mm)]
    x, z = profile.x_mm[samples.outline_index], profile.z_mm[samples.outline_index]
    flank = (x > top_x) & (z > 3.0) & (z < 16.0)
    lo, hi = samples.pixels[flank].min(axis=0) - 25, samples.pixels[flank].max(axis=0) + 25
    c0, r0, c1, r1 = int(lo[0]), int(lo[1]), int(hi[0]), int(hi[1])
    fig, axes = plt.subplots(1, 2, figsize=(8.0, 4.2), sharey=True)
    titles = ("before 0.11.8: stretches joined", "0.11.8: one run per stretch")
    for ax, drawn, title in zip(axes, (before, now), titles, strict=True):
        image = np.zeros(shape, np.float32)
        draw_stripe(image, drawn, peak)
        ax.imshow(
            np.clip(image[r0:r1, c0:c1], 0, 255),
            cmap="gray",
            extent=(c0 - 0.5, c1 - 0.5, r1 - 0.5, r0 - 0.5),
            vmin=0,
            vmax=255,
        )
        at = (samples.pixels[:, 0] >= c0) & (samples.pixels[:, 0] < c1)
        at &= (samples.pixels[:, 1] >= r0) & (samples.pixels[:, 1] < r1)
        ax.plot(*samples.pixels[at].T, ",", color="tab:red", alpha=0.6)
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("column [px]")
    axes[0].set_ylabel("row [px]")
    fig.suptitle(
        "Glare of the polished flank band (right outer sensor, LMA, z = 3–16 mm);"
        " red: the true line",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(OUT, dpi=110)


if __name__ == "__main__":
    main()
