"""Wear trends with real wear in real headless Chromium: a train whose flanges thin 0.4 mm
a pass over four passes 20 days apart, uploaded as pass archives through the API. Its first
vehicle (W301, LMA wheels) reports its odometer in every manifest, so its wheels' wear is
fitted per 1,000 km and the forecast is an odometer reading; its second (W302, S1002) does
not, so its wheels' wear is fitted per day and the forecast is a date. Screenshots land in
tests/e2e/screenshots/latest/ (conftest `screenshots`).
"""

from __future__ import annotations

import json
import re
import subprocess
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pipeline.simulation.passes import read_truth
from tests.e2e.conftest import ROOT, WHEELSCAN, Service, zip_pass
from tests.e2e.test_depot_review import (
    TALL_VIEWPORT,
    api,
    new_page,
    open_wheel,
    rename_vehicles,
    screenshot_whole_trend,
    upload_all_measured,
    wheel_at,
)

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

WEAR_PER_PASS_MM = 0.4
FIRST_AT = datetime(2026, 7, 1, 8, tzinfo=UTC)
DAYS_APART = 20
ODOMETER_KM = (310_000.0, 316_500.0, 324_000.0, 330_500.0)
"""W301's odometer at the four passes: uneven distances between passes 20 days apart."""
NAMES = {"V001": "W301", "V002": "W302"}


@dataclass(frozen=True, slots=True)
class WornTrain:
    passes: list[int]
    """Oldest first."""
    truth_sd_mm: dict[str, list[float]]
    """True Sd (LM: at 12 mm, EN: at 10 mm) of each vehicle's axle 1 left wheel per pass."""

    @property
    def newest(self) -> int:
        return self.passes[-1]


@pytest.fixture(scope="module")
def worn_train(service: Service, tmp_path_factory: pytest.TempPathFactory) -> WornTrain:
    """Four measured passes of a wearing two-vehicle train, W301 with odometer readings."""
    out = tmp_path_factory.mktemp("worn")
    subprocess.run(
        [*WHEELSCAN, "synth-pass", str(out / "train"), "--vehicles", "2", "--axles", "1"]
        + ["--seed", "23", "--repeat", "4", "--field", "clean"]
        + ["--flange-wear-per-pass", str(WEAR_PER_PASS_MM)],
        capture_output=True,
        timeout=900,
        check=True,
        cwd=ROOT,
    )
    archives, truth = [], {"W301": [], "W302": []}
    for index, folder in enumerate(sorted((out / "train").glob("pass-*"))):
        rename_vehicles(folder, NAMES)
        path = folder / "manifest.json"
        manifest = json.loads(path.read_text())
        when = FIRST_AT + timedelta(days=DAYS_APART * index)
        manifest["started_at"] = when.isoformat().replace("+00:00", "Z")
        manifest["odometer_km"] = {"W301": ODOMETER_KM[index]}
        path.write_text(json.dumps(manifest, indent=2))
        for row in read_truth(folder):
            if row["axle"] == 1 and row["side"] == "left":
                key = (
                    "flange_thickness_mm"
                    if row["vehicle_id"] == "V001"
                    else "flange_thickness_10_mm"
                )
                truth[NAMES[row["vehicle_id"]]].append(row[key])
        archives.append(zip_pass(folder, out / f"{folder.name}.zip"))
    return WornTrain(upload_all_measured(service, archives), truth)


def forecast_of(service: Service, wheel_id: int, parameter: str) -> dict:
    trend = api(service, "viewer", "GET", f"/api/wheels/{wheel_id}/trend").json()
    return next(f for f in trend["forecasts"] if f["parameter"] == parameter)


LIMIT_ROWS_JS = """(canvas) => {
  const ctx = canvas.getContext('2d');
  const column = ctx.getImageData(Math.floor(canvas.width / 2), 0, 1, canvas.height).data;
  const rows = [];
  for (let i = 0; i < canvas.height; i += 1) {
    const [r, g, b, a] = column.slice(4 * i, 4 * i + 4);
    if (a > 200 && r > 200 && g < 110 && b < 110) rows.push('limit');
    else if (a > 20 && a < 90 && r > 200 && g > 120 && g < 190 && b < 60) rows.push('near');
    else rows.push('');
  }
  return rows;
}"""
"""What each row of a trend plot's canvas shows in its middle column: a limit line (red),
the near-limit band (amber, 18 % opaque) or something else."""


def runs(rows: list[str], kind: str) -> list[tuple[int, int]]:
    """The [first, last] rows of each run of `kind`."""
    found: list[tuple[int, int]] = []
    for i, row in enumerate(rows):
        if row != kind:
            continue
        if found and found[-1][1] == i - 1:
            found[-1] = (found[-1][0], i)
        else:
            found.append((i, i))
    return found


def test_trend_fits_wear_per_1000_km_with_limits_band_and_the_odometer_at_the_limit(
    browser: Any, service: Service, worn_train: WornTrain, screenshots: Path
) -> None:
    target = wheel_at(service, worn_train.newest, 1, "left")
    wheel_id = target["wheel_id"]
    assert target["vehicle_id"] == "W301"
    sd = forecast_of(service, wheel_id, "flange_thickness_mm")
    assert sd["per"] == "1000 km" and sd["points"] == 4
    truth_rate = np.polyfit(np.array(ODOMETER_KM) / 1000, worn_train.truth_sd_mm["W301"], 1)[0]
    assert truth_rate == pytest.approx(-0.059, abs=0.005), "the simulated wear per 1,000 km"
    assert sd["rate_mm"] == pytest.approx(truth_rate, abs=0.02), (sd, truth_rate)
    assert sd["rate_low_mm"] <= sd["rate_mm"] <= sd["rate_high_mm"]
    assert sd["bound"] == "min" and sd["limit_mm"] == 23.0 and sd["last_km"] == ODOMETER_KM[-1]
    assert ODOMETER_KM[-1] < sd["reached_km"] < 1_000_000 and sd["reached_at"] is None
    page = new_page(browser, service, "viewer", TALL_VIEWPORT)
    open_wheel(page, service, worn_train.newest, wheel_id)
    plot = page.locator(".trend-plot[data-parameter=flange_thickness_mm]")
    plot.locator("canvas").first.wait_for()
    limits = [float(plot.get_attribute(f"data-{k}-mm")) for k in ("low", "high", "band")]
    assert limits == pytest.approx([23.0, 34.0, 1.1]), "LM Sd limits and the inner 10 % band"
    rows = plot.locator("canvas").first.evaluate(LIMIT_ROWS_JS)
    lines, bands = runs(rows, "limit"), runs(rows, "near")
    assert len(lines) == 2, f"two limit lines drawn, found rows {lines}"
    # the amber band inside each line: below the upper limit, above the lower one
    assert any(lines[0][1] < first <= lines[0][1] + 3 for first, _ in bands), (lines, bands)
    assert any(lines[1][0] - 3 <= last < lines[1][0] for _, last in bands), (lines, bands)
    text = page.locator(".forecast[data-parameter=flange_thickness_mm]").inner_text()
    reached = f"{round(sd['reached_km']):,} km on the odometer"
    left = f"{round(sd['reached_km'] - ODOMETER_KM[-1]):,} km after the last pass"
    assert re.search(r"mm/1000 km \(−\d\.\d{3} to [−+]\d\.\d{3}\)", text), text
    assert f"{sd['rate_mm']:.3f}".replace("-", "−") in text, text
    assert "reaches ≥ 23.0 mm at " + reached in text and left in text, text
    assert re.search(r"\(90 %: [\d,]+ km – ([\d,]+ km|later)\)", text), text
    screenshot_whole_trend(page, screenshots / "37-wheel-trend-odometer.png")
    page.context.close()
    assert page.errors == [], page.errors


def test_trend_without_odometer_fits_wear_per_day_and_forecasts_a_date(
    browser: Any, service: Service, worn_train: WornTrain, screenshots: Path
) -> None:
    wheels = api(service, "viewer", "GET", f"/api/passes/{worn_train.newest}/wheels").json()
    target = next(
        w for w in wheels if (w["vehicle_id"], w["axle"], w["side"]) == ("W302", 1, "left")
    )
    sd = forecast_of(service, target["wheel_id"], "flange_thickness_10_mm")
    assert sd["per"] == "day" and sd["reached_km"] is None
    truth_rate = np.polyfit(DAYS_APART * np.arange(4.0), worn_train.truth_sd_mm["W302"], 1)[0]
    assert truth_rate == pytest.approx(-WEAR_PER_PASS_MM / DAYS_APART, abs=0.002)
    assert sd["rate_mm"] == pytest.approx(truth_rate, abs=0.006), (sd, truth_rate)
    assert sd["bound"] == "min" and sd["limit_mm"] == 22.0 and sd["reached_at"]
    page = new_page(browser, service, "viewer", TALL_VIEWPORT)
    open_wheel(page, service, worn_train.newest, target["wheel_id"])
    forecast = page.locator(".forecast[data-parameter=flange_thickness_10_mm]")
    text = forecast.inner_text()
    assert re.search(r"mm/day \(−\d\.\d{3} to [−+]\d\.\d{3}\)", text), text
    assert f"reaches ≥ 22.0 mm on {sd['reached_at'][:10]} UTC (90 %: " in text, text
    screenshot_whole_trend(page, screenshots / "38-wheel-trend-days.png")
    page.context.close()
    assert page.errors == [], page.errors
