"""The review application in real headless Chromium against the real service.

One simulated pass (1 vehicle, 2 axles) is dropped on the upload page by an operator and
measured live; the other tests review it as a viewer. Screenshots of every view land in
tests/e2e/screenshots/latest/ (conftest `screenshots`), with measurements.json (pan/zoom
redraw times). How fast the pages load and draw is measured by benchmarks/browser.py
(BENCHMARKS.md), not here.
"""

from __future__ import annotations

import base64
import json
import statistics
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

from pipeline.profile.exchange import parse_profile_file
from tests.e2e.conftest import VIEWPORT_3D, Service, wait_for_3d_scene
from tests.e2e.marks import drawn_after
from tests.pipeline.test_profile_exchange import contour_samples, gauge_file

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

MEASURE_TIMEOUT_MS = 240_000
VIEWPORT = {"width": 1600, "height": 1000}

NEXT_FRAME_JS = "() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r)))"
DROP_FILE_JS = """async ([b64, name]) => {
  const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
  const transfer = new DataTransfer();
  transfer.items.add(new File([bytes], name, { type: 'application/zip' }));
  return transfer;
}"""


def record(screenshots: Path, name: str, value: Any) -> None:
    """Add one measurement to screenshots/measurements.json."""
    path = screenshots / "measurements.json"
    data = json.loads(path.read_text()) if path.exists() else {}
    data[name] = value
    path.write_text(json.dumps(data, indent=2))


@pytest.fixture(scope="module")
def measured_pass(browser: Any, service: Service, pass_archive: Path, screenshots: Path) -> int:
    """Drop the pass archive on the upload page as an operator; wait until it is measured."""
    context = browser.new_context(viewport=VIEWPORT)
    page = context.new_page()
    page.goto(f"{service.url}/#token={service.token('operator')}")
    page.get_by_role("link", name="Upload").click()
    zone = page.locator(".drop-zone")
    zone.wait_for()
    b64 = base64.b64encode(pass_archive.read_bytes()).decode()
    transfer = page.evaluate_handle(DROP_FILE_JS, [b64, pass_archive.name])
    zone.dispatch_event("drop", {"dataTransfer": transfer})
    page.locator(".upload-progress progress").first.wait_for()
    page.get_by_text("measurement").wait_for(timeout=60_000)
    page.screenshot(path=str(screenshots / "01-upload-progress.png"))
    done = page.locator("a.button", has_text="Open pass #")
    done.wait_for(timeout=MEASURE_TIMEOUT_MS)
    page.screenshot(path=str(screenshots / "02-upload-done.png"))
    pass_id = int(done.inner_text().split("#")[1])
    context.close()
    return pass_id


def signed_in_viewer(browser: Any, service: Service, viewport: dict) -> Iterator[Any]:
    """A page in a `viewport` window signed in with a viewer token through the link `make
    run` prints; no uncaught errors in it when the test is done."""
    context = browser.new_context(viewport=viewport, accept_downloads=True)
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.goto(f"{service.url}/#token={service.token('viewer')}")
    page.locator("header .role").wait_for()
    yield page
    context.close()
    assert errors == [], f"uncaught errors in the page: {errors}"


@pytest.fixture()
def viewer_page(browser: Any, service: Service) -> Iterator[Any]:
    """A viewer's page in a VIEWPORT window."""
    yield from signed_in_viewer(browser, service, VIEWPORT)


@pytest.fixture()
def viewer_page_3d(browser: Any, service: Service) -> Iterator[Any]:
    """A viewer's page in the smaller window of the 3D view's tests (VIEWPORT_3D)."""
    yield from signed_in_viewer(browser, service, VIEWPORT_3D)


def wheels_of(service: Service, pass_id: int) -> list[dict[str, Any]]:
    token = service.token("viewer")
    response = httpx.get(
        f"{service.url}/api/passes/{pass_id}/wheels",
        headers={"Authorization": f"Bearer {token}"},
        timeout=10,
    )
    response.raise_for_status()
    return list(response.json())


def test_sign_in_link_shows_the_passes_list_without_upload_for_a_viewer(
    viewer_page: Any, measured_pass: int, screenshots: Path
) -> None:
    page = viewer_page
    assert page.locator("header .role").inner_text() == "viewer"
    assert page.get_by_role("link", name="Upload").count() == 0
    row = page.locator(f"tr[data-pass-id='{measured_pass}']")
    row.wait_for()
    assert "done" in row.inner_text()
    assert "#token=" not in page.url, "the token must not stay in the address bar"
    page.screenshot(path=str(screenshots / "03-passes.png"))
    page.keyboard.press("?")
    page.locator("#help").wait_for(state="visible")
    page.screenshot(path=str(screenshots / "03-passes-keys.png"))
    page.keyboard.press("Escape")
    page.locator("#help").wait_for(state="hidden")
    page.keyboard.press("Enter")  # the selected (newest) pass
    page.wait_for_url(f"**#/passes/{measured_pass}")


def test_pass_view_shows_every_wheel_with_both_methods_and_their_difference(
    viewer_page: Any, service: Service, measured_pass: int, screenshots: Path
) -> None:
    page = viewer_page
    page.goto(f"{service.url}/#/passes/{measured_pass}")
    cards = page.locator("a.wheel-card")
    cards.first.wait_for()
    assert cards.count() == len(wheels_of(service, measured_pass)) == 4
    first = cards.first.inner_text()
    assert "Sh" in first and "Sd" in first and "qR" in first
    # the values without a limit and the axle's λe on every card, their definitions a click away
    for key in ("tread_hollow_mm", "flange_angle_deg", "rim_width_mm", "equivalent_conicity"):
        assert cards.first.locator(f"tr[data-parameter={key}]").count() == 1, key
    title = cards.first.locator("tr[data-parameter=flange_angle_deg] th").get_attribute("title")
    assert "Nadal" in title
    definitions = page.locator("details.definitions")
    definitions.locator("summary").click()
    assert "EN 15302" in definitions.locator("dd[data-parameter=equivalent_conicity]").inner_text()
    assert page.locator(".wheel-card.ok, .wheel-card.alarm").count() >= 1
    page.screenshot(path=str(screenshots / "04-pass-adaptive.png"))
    page.get_by_role("button", name="Steger", exact=True).click()
    page.wait_for_url("**mode=steger")
    page.get_by_role("button", name="Δ adaptive − Steger").click()
    page.wait_for_url("**mode=difference")
    # The cards re-render after the route changes: wait for the signed differences.
    page.wait_for_function(
        "() => /[+−]/.test(document.querySelector('a.wheel-card').innerText)", timeout=10_000
    )
    assert any(sign in cards.first.inner_text() for sign in "+−")
    page.screenshot(path=str(screenshots / "05-pass-difference.png"))


def open_wheel(page: Any, service: Service, pass_id: int, wheel_id: int) -> None:
    """Open a wheel page as a click on a link would (hash change) and wait until its frame
    and centres are drawn."""
    started_ms = page.evaluate(
        "(hash) => { const t = performance.now(); location.hash = hash; return t; }",
        f"#/passes/{pass_id}/wheels/{wheel_id}",
    )
    page.locator(f".wheel[data-loaded-wheel='{pass_id}/{wheel_id}']").wait_for()
    drawn_after(page, started_ms, pass_id, wheel_id)


def measured_wheels(service: Service, pass_id: int) -> list[int]:
    measured = [int(w["wheel_id"]) for w in wheels_of(service, pass_id) if w["state"] == "measured"]
    assert len(measured) >= 2, "fewer than two wheels of the simulated pass were measured"
    return measured


def measured_wheel(service: Service, pass_id: int) -> int:
    return measured_wheels(service, pass_id)[0]


def test_wheel_page_draws_both_methods_centres_and_toggles_every_overlay(
    viewer_page: Any, service: Service, measured_pass: int, screenshots: Path
) -> None:
    page = viewer_page
    wheel_id = measured_wheels(service, measured_pass)[1]
    page.goto(f"{service.url}/#/passes")
    page.locator("tr[data-pass-id]").first.wait_for()
    open_wheel(page, service, measured_pass, wheel_id)
    points = int(page.locator(".frame-canvas").get_attribute("data-points-drawn"))
    assert points > 1000, f"both methods' centres drawn, got {points}"
    assert float(page.locator("[data-load-ms]").get_attribute("data-load-ms")) > 0
    page.screenshot(path=str(screenshots / "06-wheel-default.png"))
    for key, layer in (("m", "mask"), ("o", "sigma"), ("a", "adaptive"), ("s", "steger")):
        page.locator(".frame-canvas").focus()
        page.keyboard.press(key)
        page.wait_for_url(f"**{layer}=*")
        if layer == "sigma":
            page.locator(".legend").wait_for(state="visible")  # σ colour scale, in px
        page.wait_for_function("() => !document.querySelector('.layer-note').textContent")
        page.evaluate(NEXT_FRAME_JS)
        page.screenshot(path=str(screenshots / f"07-wheel-toggle-{layer}.png"))
    assert page.locator("input[data-layer='adaptive']").is_checked() is False
    page.locator("input[data-layer='adaptive']").check()
    page.locator("input[data-layer='steger']").check()
    page.locator("input[data-layer='sigma']").uncheck()
    page.wait_for_url("**sigma=0*")


def centre_on_screen(
    page: Any, service: Service, pass_id: int, wheel_id: int
) -> tuple[float, float]:
    """Screen position of the middle adaptive centre of the frame the page shows first."""
    record = next(w for w in wheels_of(service, pass_id) if w["wheel_id"] == wheel_id)
    sensor = sorted(record["frames"])[0]
    centres = httpx.get(
        f"{service.url}/api/passes/{pass_id}/wheels/{wheel_id}/centres/{sensor.split('_')[1]}",
        params={"method": "adaptive", "index": 0},
        headers={"Authorization": f"Bearer {service.token('viewer')}"},
        timeout=10,
    ).json()
    i = len(centres["x"]) // 2
    viewport = json.loads(page.locator(".frame-canvas").get_attribute("data-viewport"))
    box = page.locator(".frame-canvas").bounding_box()
    return (
        box["x"] + centres["x"][i] * viewport["scale"] + viewport["offsetX"],
        box["y"] + centres["y"][i] * viewport["scale"] + viewport["offsetY"],
    )


def test_hover_reads_out_a_centre_and_pan_zoom_redraws_fast(
    viewer_page: Any, service: Service, measured_pass: int, screenshots: Path
) -> None:
    page = viewer_page
    wheel_id = measured_wheel(service, measured_pass)
    open_wheel(page, service, measured_pass, wheel_id)
    canvas = page.locator(".frame-canvas")
    box = canvas.bounding_box()
    x, y = centre_on_screen(page, service, measured_pass, wheel_id)
    page.mouse.move(x, y)
    readout = page.locator(".readout")
    page.wait_for_function("() => document.querySelector('.readout').dataset.method")
    text = readout.inner_text()
    assert "σ" in text and "strength" in text and "px" in text, text
    page.screenshot(path=str(screenshots / "08-wheel-hover.png"))
    page.evaluate("() => performance.clearMeasures('frame-draw')")
    for _ in range(12):
        page.mouse.wheel(0, -120)
        page.wait_for_timeout(30)
    page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    page.mouse.down()
    for step in range(24):
        page.mouse.move(box["x"] + box["width"] / 2 - 10 * step, box["y"] + box["height"] / 2)
    page.mouse.up()
    page.wait_for_timeout(100)
    draws = page.evaluate("() => performance.getEntriesByName('frame-draw').map((e) => e.duration)")
    assert len(draws) >= 10, f"pan/zoom redrew only {len(draws)} times"
    figures = {
        "redraws": len(draws),
        "median_ms": round(statistics.median(draws), 2),
        "p95_ms": round(sorted(draws)[int(0.95 * (len(draws) - 1))], 2),
        "max_ms": round(max(draws), 2),
    }
    # The redraw time is a figure (recorded, and a bar in the benchmarks), not a timed test:
    # on a loaded 2-core machine its median crossed a 60 Hz frame and failed the suite.
    record(screenshots, "pan_zoom_redraw", figures)
    page.screenshot(path=str(screenshots / "09-wheel-zoomed.png"))


def test_switching_methods_redraws_the_profile_and_parameter_table(
    viewer_page: Any, service: Service, measured_pass: int, screenshots: Path
) -> None:
    page = viewer_page
    wheel_id = measured_wheel(service, measured_pass)
    open_wheel(page, service, measured_pass, wheel_id)
    assert page.locator("th.selected", has_text="Adaptive").count() == 1
    page.locator("button[data-method='steger']").click()
    page.locator("th.selected", has_text="Steger").wait_for()
    assert page.locator(".param-table tr[data-parameter]").count() == 9
    assert page.locator(".diff-plot + .note").inner_text().split(" ")[0].isdigit()
    box = page.locator(".profile-plot").bounding_box()
    note = page.locator(".profile-plot + .note")
    for dy in range(10, int(box["height"]), 4):  # down a vertical line until the flange
        page.mouse.move(box["x"] + box["width"] * 0.2, box["y"] + dy)
        if "mm · z" in note.inner_text():
            break
    assert note.inner_text().startswith("steger: x "), note.inner_text()
    page.locator(".side-panel").screenshot(path=str(screenshots / "10-wheel-side-steger.png"))


def test_wheel_page_shows_tread_values_their_definitions_and_the_axle_delta_r(
    viewer_page: Any, service: Service, measured_pass: int, screenshots: Path
) -> None:
    page = viewer_page
    wheel_id = measured_wheel(service, measured_pass)
    open_wheel(page, service, measured_pass, wheel_id)
    row = page.locator(".param-table tr[data-parameter='equivalent_conicity']")
    adaptive = row.locator("td").first.inner_text()
    served = next(
        r["equivalent_conicity"]
        for w in wheels_of(service, measured_pass)
        if w["wheel_id"] == wheel_id
        for r in w["results"]
        if r["method"] == "adaptive"
    )
    assert adaptive == f"{served:.3f}"
    assert row.locator("td").nth(3).inner_text() == "≤ 0.4"
    definition = page.locator(".param-table p.definition")
    assert not definition.is_visible()
    row.locator("button.definition-link").click()
    assert "EN 15302" in definition.inner_text() and definition.is_visible()
    hollow = page.locator(".param-table tr[data-parameter='tread_hollow_mm'] td").first
    assert float(hollow.inner_text()) >= 0
    assert "Wheel diameter is not measured" in page.locator(".diameter-note").inner_text()
    plot = page.locator(".delta-r")
    plot.locator("canvas").first.wait_for()
    assert f"adaptive: λe(3 mm) {served:.3f}" in plot.locator(".note").inner_text()
    assert "rails 60E1 at 1:40, gauge 1435 mm" in plot.locator(".note").inner_text()
    page.locator(".side-panel").screenshot(path=str(screenshots / "12-wheel-tread-conicity.png"))


def test_exports_download_a_pdf_and_a_csv(
    viewer_page: Any, service: Service, measured_pass: int, screenshots: Path
) -> None:
    page = viewer_page
    wheel_id = measured_wheel(service, measured_pass)
    open_wheel(page, service, measured_pass, wheel_id)
    for fmt, magic in (("pdf", b"%PDF"), ("csv", None)):
        with page.expect_download() as info:
            page.locator(f".titlebar button[data-export='{fmt}']").click()
        path = screenshots / f"11-export.{fmt}"
        info.value.save_as(path)
        content = path.read_bytes()
        if magic:
            assert content.startswith(magic)
        else:
            header = content.decode().splitlines()[0]
            assert "flange_height_mm" in header, header


def test_wheel_page_exports_profiles_and_compares_a_handheld_reference(
    viewer_page: Any, service: Service, measured_pass: int, screenshots: Path
) -> None:
    page = viewer_page
    wheel_id = measured_wheels(service, measured_pass)[1]
    wheel = next(w for w in wheels_of(service, measured_pass) if w["wheel_id"] == wheel_id)
    name = wheel["results"][0]["reference_profile"]
    x, z = contour_samples(name, 0.5)
    imported = httpx.post(
        f"{service.url}/api/wheels/{wheel_id}/references",
        headers={"Authorization": f"Bearer {service.token('operator')}"},
        files={
            "file": ("gauge.whl", gauge_file(x, z, reverse=True, z_offset_mm=0.2), "text/plain")
        },
        timeout=30,
    )
    assert imported.status_code == 201, imported.text
    reference = imported.json()
    open_wheel(page, service, measured_pass, wheel_id)
    table = page.locator(f"table[data-comparison='{reference['id']}']")
    table.wait_for()
    adaptive = next(r for r in wheel["results"] if r["method"] == "adaptive")
    cells = table.locator("tr[data-parameter='flange_height_mm'] td")
    assert cells.nth(0).inner_text() == f"{reference['flange_height_mm']:.2f}"
    expected = adaptive["flange_height_mm"] - reference["flange_height_mm"]
    assert float(cells.nth(1).inner_text().replace("−", "-")) == pytest.approx(expected, abs=0.006)
    assert "interpolated" in page.locator(".comparison .note").inner_text()
    page.locator(".side-panel").screenshot(path=str(screenshots / "12-wheel-handheld.png"))
    with page.expect_download() as info:
        page.locator(".titlebar button[data-export-profile='whl']").click()
    path = screenshots / "12-profile.whl"
    info.value.save_as(path)
    exported = parse_profile_file(path.read_text(), suffix=".whl")
    assert exported.value("Method") == "adaptive" and exported.x_mm.size > 100
    # hold the PDF back half a second: the button shows its progress meanwhile
    page.route("**/report.pdf", lambda route: (page.wait_for_timeout(500), route.continue_()))
    with page.expect_download():
        page.locator(".titlebar button[data-export='pdf']").click()
        progress = page.locator(".exports.report .export-progress")
        progress.wait_for(state="visible")
        assert "preparing PDF" in progress.inner_text()
        page.locator(".titlebar").screenshot(path=str(screenshots / "13-pdf-progress.png"))
    progress.wait_for(state="hidden")


def test_an_operator_imports_a_gauge_file_on_the_wheel_page(
    browser: Any, service: Service, measured_pass: int, screenshots: Path, tmp_path: Path
) -> None:
    wheel_id = measured_wheels(service, measured_pass)[0]
    wheel = next(w for w in wheels_of(service, measured_pass) if w["wheel_id"] == wheel_id)
    x, z = contour_samples(wheel["results"][0]["reference_profile"], 0.5)
    gauge = tmp_path / "gauge.prr"
    gauge.write_text(gauge_file(x, z, tape_circle=True, header="ProgramName=MiniProf\n"))
    context = browser.new_context(viewport=VIEWPORT)
    page = context.new_page()
    page.goto(f"{service.url}/#token={service.token('operator')}")
    page.locator("header .role").wait_for()
    open_wheel(page, service, measured_pass, wheel_id)
    page.locator("input[data-action='import-reference']").set_input_files(str(gauge))
    table = page.locator(".comparison table[data-comparison]")
    table.wait_for()
    assert "MiniProf · gauge.prr" in page.locator(".comparison .note").inner_text()
    page.locator(".comparison").screenshot(path=str(screenshots / "14-reference-imported.png"))
    context.close()


def test_3d_view_embeds_the_viser_scene(
    viewer_page_3d: Any, service: Service, measured_pass: int, screenshots: Path
) -> None:
    page = viewer_page_3d
    wheel_id = measured_wheel(service, measured_pass)
    open_wheel(page, service, measured_pass, wheel_id)
    page.locator("button[data-action='open-3d']").click()
    wait_for_3d_scene(page)
    page.screenshot(path=str(screenshots / "12-wheel-3d.png"), timeout=60_000)
    page.locator(".viewer-bar button[data-action='close-3d']").click()
    page.locator(".viewer-overlay").wait_for(state="hidden")
    assert int(page.locator(".frame-canvas").get_attribute("data-points-drawn")) > 0


def test_api_errors_are_shown_in_words(
    viewer_page: Any, service: Service, screenshots: Path
) -> None:
    page = viewer_page
    page.goto(f"{service.url}/#/passes/987654")
    banner = page.locator("#banner .error")
    banner.wait_for()
    assert "987654" in banner.inner_text() and "404" in banner.inner_text()
    page.screenshot(path=str(screenshots / "13-error-missing-pass.png"))
    page.goto(f"{service.url}/#token=wst_not-a-real-token")
    page.locator(".sign-in").wait_for()
    assert "sign-in" in page.locator("#banner .error").inner_text().lower()
    page.screenshot(path=str(screenshots / "14-error-bad-token.png"))
