"""The review app's speed in headless Chromium against the real service (the bars: a wheel
page drawn ≤ 1000 ms after the navigation, ≤ 500 ms after a click on its card, the next
wheel ≤ 300 ms after `]`; a pan/zoom redraw within a 60 Hz frame, 16.7 ms).

`wheelscan serve` runs on a temp data dir with SQLite (tests/faults/live.py); the browser
tests' simulated pass (1 vehicle, 2 axles: 4 wheels, 1600×1200 frames) is uploaded and
measured by both methods. Each of REPEATS rounds opens a fresh browser context (empty
cache, the app's modules loaded by the sign-in) and walks the pass as a reviewer does:
pass list → pass page → click a wheel card → `]` → pass list → a wheel by its address →
pan and zoom → worst wheels, each wheel seen for the first time in that context. Times are
the page's own clock: from the hash change, or from the click's or key's event timestamp,
to the end of the first `frame-draw` after that wheel's `frame-data` mark, or to the view's
first row in the DOM (tests/e2e/marks.py).

Run alone with `python -m benchmarks.run browser` (writes its section of BENCHMARKS.md).
"""

from __future__ import annotations

import os
import statistics
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from playwright.sync_api import Error, ViewportSize, sync_playwright

from tests.e2e.conftest import CHROMIUM, CHROMIUM_ARGS, simulated_pass_archive
from tests.e2e.marks import drawn_after
from tests.faults.live import LiveServer, upload, wait_for_job, wheels_of

REPEATS = 10
VIEWPORT: ViewportSize = {"width": 1600, "height": 1000}
MEASURE_TIMEOUT_S = 600.0
BARS_MS: dict[str, float | None] = {
    "wheel page": 1000.0,
    "wheel card click": 500.0,
    "next wheel (`]`)": 300.0,
    "pass page": None,
    "worst wheels": None,
    "pan/zoom redraw": 1000.0 / 60,
}
STEPS = {
    "wheel page": "hash change on the pass list → frame and both methods' centres drawn",
    "wheel card click": "click on the pass page → frame and centres drawn",
    "next wheel (`]`)": "key down on the wheel page → the next wheel drawn",
    "pass page": "hash change on the pass list → first wheel card in the DOM",
    "worst wheels": "hash change on a wheel page → first row in the DOM",
    "pan/zoom redraw": "one redraw of the frame (12 wheel zooms, 24 drag steps per round)",
}

INPUT_TIMES_JS = """window.lastInputMs = 0;
for (const type of ['click', 'keydown'])
  document.addEventListener(type, (e) => { window.lastInputMs = e.timeStamp; }, true);"""
"""Keeps the timestamp of the last click or key down (page clock, ms) in `lastInputMs`."""
APPEARS_JS = """([hash, selector]) => new Promise((resolve, reject) => {
  if (document.querySelector(selector)) return reject(new Error(`${selector} shown before`));
  const t0 = performance.now();
  const observer = new MutationObserver(() => {
    if (!document.querySelector(selector)) return;
    observer.disconnect();
    resolve(performance.now() - t0);
  });
  observer.observe(document.body, { childList: true, subtree: true, attributes: true });
  setTimeout(() => { observer.disconnect(); reject(new Error(`${selector} not shown`)); }, 30000);
  location.hash = hash;
})"""
"""Set the hash; the time until `selector` matches an element [ms]."""
LAST_INPUT_JS = "() => window.lastInputMs"
LOADED_AFTER_JS = """([t0, wheel]) => performance.getEntriesByName('wheel-loaded')
  .filter((e) => e.startTime > t0 && e.detail === wheel).map((e) => e.startTime - t0)[0]"""
"""The time from `t0` to this wheel's `wheel-loaded` mark (every side panel built) [ms]."""
NAVIGATE_JS = "(hash) => { const t = performance.now(); location.hash = hash; return t; }"


@dataclass
class Times:
    """Per step: its times [ms]; for the wheel steps also the time to every side panel
    built (the `wheel-loaded` mark) [ms] and the app's own time from the API requests to
    the state holding all their answers (`data-load-ms`) [ms]."""

    times: dict[str, list[float]] = field(default_factory=lambda: {n: [] for n in BARS_MS})
    whole: dict[str, list[float]] = field(default_factory=lambda: {n: [] for n in BARS_MS})
    api: dict[str, list[float]] = field(default_factory=lambda: {n: [] for n in BARS_MS})

    def extend(self, other: Times) -> None:
        for name in BARS_MS:
            self.times[name].extend(other.times[name])
            self.whole[name].extend(other.whole[name])
            self.api[name].extend(other.api[name])


def _load_1min() -> float:
    with open("/proc/loadavg") as loadavg:
        return float(loadavg.read().split()[0])


@contextmanager
def _measured_pass(folder: Path) -> Iterator[tuple[LiveServer, int, list[int]]]:
    """The service with the simulated pass uploaded and measured: (server, pass id, its
    measured wheels in the pass's order)."""
    archive = simulated_pass_archive(folder)
    server = LiveServer(folder / "data", workers=1)
    server.start()
    try:
        with server.client("operator") as client:
            accepted = upload(client, archive.read_bytes(), archive.name)
            accepted.raise_for_status()
            pass_id = int(accepted.json()["pass_id"])
            wait_for_job(client, int(accepted.json()["job_id"]), MEASURE_TIMEOUT_S)
            wheels = [int(w["wheel_id"]) for w in wheels_of(client, pass_id)]
            measured = [
                int(w["wheel_id"]) for w in wheels_of(client, pass_id) if w["state"] == "measured"
            ]
        if measured != wheels:
            raise RuntimeError(f"pass {pass_id}: wheels {wheels}, measured only {measured}")
        yield server, pass_id, wheels
    finally:
        server.close()


def _next_wheel(page: Any) -> int:
    """The wheel the page's `a[rel=next]` leads to."""
    link = page.locator("a[rel=next]")
    link.wait_for()
    return int(str(link.get_attribute("href")).split("?")[0].rstrip("/").rsplit("/", 1)[1])


def _drawn(
    page: Any, step: str, started_ms: float, pass_id: int, wheel_id: int, into: Times
) -> None:
    """Wait for this wheel's first draw, then for all its panels; add both times and the
    app's API → state time."""
    into.times[step].append(drawn_after(page, started_ms, pass_id, wheel_id))
    page.locator(f".wheel[data-loaded-wheel='{pass_id}/{wheel_id}']").wait_for()
    into.whole[step].append(page.evaluate(LOADED_AFTER_JS, [started_ms, f"{pass_id}/{wheel_id}"]))
    into.api[step].append(float(page.locator("[data-load-ms]").get_attribute("data-load-ms")))


def _round(page: Any, pass_id: int, wheels: list[int], start: int, into: Times) -> None:
    """One walk through the pass in a fresh context; adds one time per step."""
    times = into.times
    times["pass page"].append(page.evaluate(APPEARS_JS, [f"#/passes/{pass_id}", "a.wheel-card"]))
    clicked = wheels[start % (len(wheels) - 1)]  # never the last wheel: it has no next
    page.locator(f"a.wheel-card[data-wheel-id='{clicked}']").click()
    _drawn(page, "wheel card click", page.evaluate(LAST_INPUT_JS), pass_id, clicked, into)
    following = _next_wheel(page)
    page.locator(".frame-canvas").focus()
    page.keyboard.press("]")
    _drawn(page, "next wheel (`]`)", page.evaluate(LAST_INPUT_JS), pass_id, following, into)
    unseen = next(w for w in wheels[start:] + wheels[:start] if w not in (clicked, following))
    page.evaluate(NAVIGATE_JS, "#/passes")
    page.locator("tr[data-pass-id]").first.wait_for()
    started = page.evaluate(NAVIGATE_JS, f"#/passes/{pass_id}/wheels/{unseen}")
    _drawn(page, "wheel page", started, pass_id, unseen, into)
    times["pan/zoom redraw"].extend(_pan_zoom(page))
    times["worst wheels"].append(
        page.evaluate(APPEARS_JS, ["#/review", "table.worst tbody tr[data-wheel-id]"])
    )


def _pan_zoom(page: Any) -> list[float]:
    """Zoom in with 12 wheel steps, drag 24 steps; the redraws' durations [ms]."""
    box = page.locator(".frame-canvas").bounding_box()
    x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.evaluate("() => performance.clearMeasures('frame-draw')")
    page.mouse.move(x, y)
    for _ in range(12):
        page.mouse.wheel(0, -120)
        page.wait_for_timeout(30)
    page.mouse.down()
    for step in range(24):
        page.mouse.move(x - 10 * step, y)
    page.mouse.up()
    page.wait_for_timeout(100)
    return list(
        page.evaluate("() => performance.getEntriesByName('frame-draw').map((e) => e.duration)")
    )


def _measure(url: str, token: str, pass_id: int, wheels: list[int]) -> Times:
    measured = Times()
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(
            executable_path=str(CHROMIUM), headless=True, args=CHROMIUM_ARGS
        )
        try:
            for start in range(-1, REPEATS):  # round -1 warms the service's caches
                context = browser.new_context(viewport=VIEWPORT)
                context.add_init_script(script=INPUT_TIMES_JS)
                page = context.new_page()
                errors: list[Error] = []

                def keep(exc: Error, errors: list[Error] = errors) -> None:
                    errors.append(exc)

                page.on("pageerror", keep)
                page.goto(f"{url}/#token={token}")
                page.locator("tr[data-pass-id]").first.wait_for()
                walked = Times()
                _round(page, pass_id, wheels, max(start, 0), walked)
                context.close()
                if errors:
                    raise RuntimeError(f"uncaught errors in the page: {errors}")
                if start >= 0:
                    measured.extend(walked)
        finally:
            browser.close()
    return measured


def _row(name: str, values: list[float], whole: list[float], api: list[float]) -> str:
    median, p90 = statistics.median(values), float(np.percentile(values, 90))
    bar = BARS_MS[name]
    digits = 1 if bar is not None and bar < 100 else 0
    verdict = "–" if bar is None else ("ok" if median <= bar else "**over**")
    shown = "–" if bar is None else f"≤ {bar:.{digits}f} ms"
    panels = f"{statistics.median(whole):.0f}" if whole else "–"
    of_which = f"{statistics.median(api):.0f}" if api else "–"
    return (
        f"| {name} | {STEPS[name]} | {len(values)} | {median:.{digits}f} | {p90:.{digits}f} | "
        f"{max(values):.{digits}f} | {panels} | {of_which} | {shown} | {verdict} |"
    )


def run() -> str:
    """The Markdown section: the review app's times per step, median and p90 of REPEATS."""
    if not CHROMIUM.exists():
        raise RuntimeError(f"{CHROMIUM} is missing: run `make system-deps`")
    with tempfile.TemporaryDirectory() as folder, _measured_pass(Path(folder)) as measured:
        server, pass_id, wheels = measured
        load_before = _load_1min()
        times = _measure(server.url, server.token("viewer"), pass_id, wheels)
        load_after = _load_1min()
    lines = [
        "## Review app in the browser (benchmarks/browser.py)",
        "",
        f"Headless Chromium (Playwright, {CHROMIUM}, viewport "
        f"{VIEWPORT['width']}×{VIEWPORT['height']}) against `wheelscan serve` (SQLite, 1 "
        f"measurement worker, on this machine) holding the browser tests' simulated pass "
        f"({len(wheels)} wheels, 1600×1200 frames, adaptive and Steger measured). "
        f"{REPEATS} rounds after one warm-up round, each in a fresh browser context (empty "
        "cache, signed in as a viewer): pass list → pass page → click a wheel card → `]` → "
        "pass list → a wheel by its address → pan and zoom → worst wheels, every wheel seen "
        "for the first time in its context. Times on the page's clock, from the hash change "
        "or the input event's timestamp to the end of the first `frame-draw` after that "
        "wheel's `frame-data` mark, or to the view's first row in the DOM. The wheel page "
        "loads in two steps: the frame, both methods' centres and the parameter table first, "
        "then the side panels (profiles, Δr, trend, handheld comparison, dispositions); "
        "'all side panels' is the time to the page's `wheel-loaded` mark, 'API → state' the "
        "app's own time from its requests to the state holding every answer. While a wheel "
        "is on screen the app fetches the next wheel's frame and centres; here `]` follows "
        "the card click's draw at once (no time spent looking at the wheel). The bar is on "
        "the median; the pass page and the worst-wheels view have none of their own.",
        "",
        "| step | from → to | runs | median ms | p90 ms | max ms | all side panels, median "
        "ms | API → state, median ms | bar | |",
        "|---|---|---|---|---|---|---|---|---|---|",
        *(_row(name, times.times[name], times.whole[name], times.api[name]) for name in BARS_MS),
        "",
        f"1-min load average {load_before:.1f} before the rounds and {load_after:.1f} after "
        f"({os.cpu_count()} cores; client, server and other work share them). The browser tests "
        "(tests/e2e) check that these pages draw; their speed is measured here only.",
        "",
    ]
    return "\n".join(lines)


if __name__ == "__main__":
    sys.stdout.write(run())
