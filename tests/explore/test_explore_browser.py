"""The explorer in a real browser: Debian's chromium driven by Playwright, against
``precise-impact explore`` started on the loopback.

Each step leaves a screenshot in ``PRECISE_IMPACT_ARTIFACTS`` (default: the test's temporary
directory), so CI keeps what the browser showed.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("panel", reason="pip install 'precise_impact[explore]'")
sync_api = pytest.importorskip("playwright.sync_api", reason="pip install playwright")

from precise_impact.errors import PreciseImpactError  # noqa: E402
from precise_impact.explore.browser import (  # noqa: E402
    ARGS,
    chromium,
    draw_bifurcation,
    explorer,
    text,
    wait_text,
)

try:
    CHROMIUM = chromium()
except PreciseImpactError as e:  # pragma: no cover - CI installs it
    pytest.skip(str(e), allow_module_level=True)

#: Milliseconds a view may take to show its numbers (the first orbit may compile the kernels:
#: ~40 s with a cold cache on a busy 2-core machine).
WAIT_MS = 180_000


@pytest.fixture(scope="module")
def server_log(tmp_path_factory) -> Path:
    """Where the server's output goes: ``explore-server.log`` beside the screenshots."""
    out = Path(os.environ.get("PRECISE_IMPACT_ARTIFACTS", tmp_path_factory.mktemp("server")))
    out.mkdir(parents=True, exist_ok=True)
    return out / "explore-server.log"


@pytest.fixture(scope="module")
def server(server_log):
    """``precise-impact explore`` on a free loopback port, until the module's tests end."""
    with explorer(server_log) as url:
        yield url


@pytest.fixture(scope="module")
def browser():
    with sync_api.sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        yield b
        b.close()


@pytest.fixture
def page(browser, server, server_log, tmp_path):
    """A new page on the explorer; at the end, no console errors, no request to another
    host (every asset is served locally) and no traceback in the server's log (a handler that
    raised leaves the page unchanged: the test would only see a timeout)."""
    out = Path(os.environ.get("PRECISE_IMPACT_ARTIFACTS", tmp_path))
    out.mkdir(parents=True, exist_ok=True)
    ctx = browser.new_context(viewport={"width": 1500, "height": 1100}, accept_downloads=True)
    pg = ctx.new_page()
    errors, hosts = [], set()
    pg.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    pg.on("request", lambda r: hosts.add(r.url.split("/")[2]))
    pg.shots = out  # type: ignore[attr-defined]
    yield pg
    ctx.close()
    assert not errors, errors
    assert hosts <= {server.split("/")[2]}, hosts
    log = server_log.read_text(encoding="utf-8")
    assert "Traceback" not in log, log[log.index("Traceback") :][-3000:]


def _text(pg, css: str) -> str:
    return text(pg, css)


def _wait_text(pg, css: str, want: str) -> str:
    return wait_text(pg, css, want, WAIT_MS / 1000)


def _info(pg) -> str:
    return _text(pg, ".pi-orbit-info")


def _wait_info(pg, text: str) -> str:
    return _wait_text(pg, ".pi-orbit-info", text)


def _set(pg, field: str, value: str) -> None:
    box = pg.locator(f".pi-field-{field} input")
    box.fill(value)
    box.press("Enter")


def test_eta_074_shows_period_3_and_circuit_units_read_volts(page, server):
    page.goto(server)
    _wait_info(page, "period")
    _set(page, "transient", "300")
    _set(page, "eta", "0.74")
    _wait_info(page, "eta 0.74")
    info = _wait_info(page, "period 3")
    rate = float(re.search(r"impacts per period ([\d.]+)", info).group(1))
    assert abs(rate - 2 / 3) <= 1 / 200, info  # two impacts every three periods, of 200
    info = _wait_info(page, "(eta 0.74)")  # the LLE of this eta: the period-3 orbit's, < 0
    assert float(re.search(r"LLE (-?[\d.e-]+)", info).group(1)) < 0, info
    page.screenshot(path=str(page.shots / "01-eta-074-period-3.png"))
    page.locator(".pi-field-units button", has_text="circuit").click()
    info = _wait_info(page, "V_s [V]")
    assert "t [ms]" in info, info
    page.screenshot(path=str(page.shots / "02-circuit-units.png"))


def test_bad_input_shows_the_clis_line_next_to_the_field(page, server):
    page.goto(server)
    _wait_info(page, "period")
    _set(page, "R", "2")
    line = _wait_text(page, ".pi-error-R", "R = '2' is not allowed")
    assert "0 <= R <= 1" in line or "R <= 1" in line, line
    page.screenshot(path=str(page.shots / "03-bad-input.png"))


def test_a_permalink_reopens_the_same_state(page, server):
    page.goto(server + "?eta=0.74&transient=300&periods=30&x_w=2")
    _wait_info(page, "eta 0.74")
    _wait_info(page, "period 3")  # Fig. 6's orbit after 300 periods
    assert page.locator(".pi-field-periods input").input_value() == "30"
    assert "eta=0.74" in page.url
    page.screenshot(path=str(page.shots / "04-permalink.png"))


def test_the_diagram_downloads_its_numbers_and_a_tap_picks_eta_for_the_orbit(page, server):
    """The 400-value diagram, drawn once (~10 s of the server's work): its CSV and JSON
    downloads hold its numbers, and a tap on it picks eta for the orbit view."""
    page.goto(server + "?eta=0.74")
    _wait_info(page, "eta 0.74")
    draw_bifurcation(page)
    assert "400 values of eta" in _text(page, ".pi-bif-info")
    page.screenshot(path=str(page.shots / "05-bifurcation.png"))
    _downloads_hold_the_diagrams_numbers(page)
    # the diagram: the tallest canvas shown (Bokeh draws each figure on stacked canvases)
    boxes = [b for b in (c.bounding_box() for c in page.locator("canvas").all()) if b]
    box = max((b for b in boxes if b["width"] > 800), key=lambda b: b["height"])
    page.mouse.click(box["x"] + 0.25 * box["width"], box["y"] + 0.5 * box["height"])
    field = page.locator(".pi-field-eta input")
    deadline = time.monotonic() + WAIT_MS / 1000
    while field.input_value() == "0.74":  # the tap's eta arrives from the server
        assert time.monotonic() < deadline, "the tap did not pick an eta"
        page.wait_for_timeout(100)
    eta = float(field.input_value())
    assert 0.68 < eta < 0.82
    page.locator(".bk-tab", has_text="orbit").click()
    _wait_info(page, f"eta {page.locator('.pi-field-eta input').input_value()}")
    page.screenshot(path=str(page.shots / "06-tapped-eta.png"))


def test_the_downloaded_json_is_the_clis(page, server):
    page.goto(server + "?eta=0.74&periods=20")
    _wait_info(page, "eta 0.74")
    with page.expect_download() as dl:
        page.locator(".pi-download-json button, .pi-download-json a").first.click()
    got = json.loads(Path(dl.value.path()).read_text())
    cmd = page.locator("textarea").input_value().splitlines()[0]
    assert cmd.startswith("precise-impact simulate") and "--eta 0.74" in cmd
    r = subprocess.run(
        [sys.executable, "-m", "precise_impact", *cmd.split()[1:]],
        capture_output=True, text=True, timeout=120, check=True,
    )  # fmt: skip
    cli = json.loads(r.stdout)
    cli.pop("elapsed_s")
    assert got == cli


def test_a_basins_map_starts_drawing_and_cancels(page, server):
    """200 x 200 cells (tens of seconds): rows are drawn as they finish; cancel stops it and
    the rows drawn stay; no row arrives after the cancel."""
    page.goto(server + "?eta=0.74")
    _wait_info(page, "eta 0.74")
    page.locator(".bk-tab", has_text="impact surface").click()
    box = page.locator(".pi-basins-n input")
    box.fill("200")
    box.press("Enter")
    page.locator(".pi-basins-run button").click()
    got = _wait_text(page, ".pi-basins-info", "rows ")
    assert "/ 200" in got, got
    page.screenshot(path=str(page.shots / "07-basins-drawing.png"))
    page.locator(".pi-basins-cancel button").click()
    _wait_text(page, ".pi-basins-info", "cancelled")
    page.wait_for_timeout(3000)  # a row finishing now would overwrite the line
    assert "cancelled" in _text(page, ".pi-basins-info")
    page.screenshot(path=str(page.shots / "08-basins-cancelled.png"))


def test_the_impact_map_with_its_singularity_set(page, server):
    page.goto(server + "?eta=0.712&transient=100")
    _wait_info(page, "eta 0.712")
    page.locator(".bk-tab", has_text="impact surface").click()
    page.locator(".pi-impacts-run button").click()
    got = _wait_text(page, ".pi-impacts-info", "singularity curves")
    assert re.search(r"2000 events \(impact \d+", got), got
    assert int(re.search(r"(\d+) singularity curves", got).group(1)) >= 1, got
    page.screenshot(path=str(page.shots / "09-impact-map.png"))


def test_the_circuit_models_overlay_the_orbit(page, server):
    page.goto(server + "?eta=0.74&transient=100&periods=20")
    _wait_info(page, "eta 0.74")
    page.locator(".pi-overlay input").check()
    _wait_text(page, ".pi-circuit-info", "switched-capacitor: max")
    got = _wait_text(page, ".pi-circuit-info", "circuit: max")  # the op-amp circuit: seconds
    page.screenshot(path=str(page.shots / "10-circuit-overlay.png"))
    # the ideal circuit is the mechanics in volts: its samples on the orbit's (see test_api)
    dx = re.search(r"(?:^|\s)circuit: max \|x - x_mechanics\| on the strobe ([\d.e+-]+)", got)
    assert dx and float(dx.group(1)) < 1e-8, got
    page.locator(".pi-overlay input").uncheck()  # the circuits' lines and their line go
    deadline = time.monotonic() + 30
    while _text(page, ".pi-circuit-info") and time.monotonic() < deadline:
        page.wait_for_timeout(100)
    assert _text(page, ".pi-circuit-info") == ""


def test_the_guides_screenshots_come_from_the_running_application(browser, server, tmp_path):
    """``screenshots`` (the docs build's pictures): a PNG of the page as it showed the orbit,
    not a blank one (the figures' lines and the text make many distinct colours)."""
    import matplotlib.image

    from precise_impact.explore.browser import SHOTS, screenshots

    (path,) = screenshots(tmp_path, shots=SHOTS[:1], browser=browser, url=server)
    img = matplotlib.image.imread(path)
    assert path.name == "explore_orbit.png" and img.shape[1] == 1500, img.shape
    colours = {tuple(p) for p in (img[::7, ::7, :3] * 255).astype(int).reshape(-1, 3)}
    assert len(colours) > 50, len(colours)


def test_a_scene_is_loaded_into_the_fields(page, server):
    page.goto(server + "?eta=0.9&transient=300")
    _wait_info(page, "eta 0.9")
    page.locator(".pi-scene select").select_option("fig6-period3-ideal")
    _wait_info(page, "eta 0.74")
    info = _wait_info(page, "period 3")  # Fig. 6's orbit, after the transient kept from the URL
    assert page.locator(".pi-field-eta input").input_value() == "0.74", info
    page.screenshot(path=str(page.shots / "11-scene.png"))


def _downloads_hold_the_diagrams_numbers(page) -> None:
    files = {}
    for kind in ("json", "csv"):
        css = f".pi-download-bifurcation-{kind}"
        with page.expect_download() as dl:
            page.locator(f"{css} button, {css} a").first.click()
        files[kind] = Path(dl.value.path()).read_text()
    got = json.loads(files["json"])
    rows = files["csv"].splitlines()
    n = len(got["x"][0])
    assert rows[0] == "eta,x,lle,lle_stderr" and len(rows) == 1 + len(got["eta"]) * n
    assert [float(r.split(",")[1]) for r in rows[1 : 1 + n]] == got["x"][0]
