"""The review app's own performance marks, read from a Playwright page: when a wheel's
frame data reached the canvas (`frame-data`, detail "pass/wheel") and the end of the first
draw after it (`frame-draw`). Used by the browser tests and benchmarks/browser.py."""

from __future__ import annotations

from typing import Any

DRAWN_AFTER_JS = """([t0, wheel]) => {
  const data = performance.getEntriesByName('frame-data')
    .find((e) => e.startTime > t0 && e.detail === wheel);
  if (!data) return undefined;
  return performance.getEntriesByName('frame-draw')
    .filter((e) => e.startTime >= data.startTime).map((e) => e.startTime + e.duration)[0];
}"""


def drawn_after(page: Any, started_ms: float, pass_id: int, wheel_id: int) -> float:
    """Wait until this wheel's frame and centres are drawn after `started_ms` (page time,
    ms) and return the time from `started_ms` to the end of that first draw [ms] (not a
    redraw of the wheel before it)."""
    arg = [started_ms, f"{pass_id}/{wheel_id}"]
    page.wait_for_function(f"(a) => ({DRAWN_AFTER_JS})(a) !== undefined", arg=arg)
    return float(page.evaluate(DRAWN_AFTER_JS, arg) - started_ms)
