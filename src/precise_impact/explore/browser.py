"""The explorer in a real browser: ``precise-impact explore`` started on a free loopback port
and Debian's chromium driven by Playwright (nothing downloaded), for the guide's screenshots
(made by the docs build from the running application), the browser tests and the benchmark.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import socket
import subprocess
import sys
import time
import urllib.request
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from precise_impact.errors import PreciseImpactError

__all__ = [
    "ARGS", "DEEP_TEXT", "SHOTS", "chromium", "draw_bifurcation", "explorer", "screenshots", "text",
    "wait_text",
]  # fmt: skip

#: Debian's chromium, headless, with no network of its own (its background connections are
#: refused by a closed machine, many at a time).
ARGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
]  # fmt: skip

#: The text of an element and of every shadow root under it (Panel's panes render in shadow
#: DOM, which ``innerText`` leaves out), styles and scripts left out.
DEEP_TEXT = """el => { const walk = n => { if (n.tagName === 'STYLE' || n.tagName === 'SCRIPT')
  return ''; let t = n.shadowRoot ? walk(n.shadowRoot) : '';
  for (const c of n.childNodes) t += c.nodeType === 3 ? c.textContent : walk(c); return t; };
  return walk(el); }"""


def chromium() -> str:
    """Debian's chromium, or an error naming how to install it."""
    path = shutil.which("chromium") or "/usr/bin/chromium"
    if not Path(path).exists():
        raise PreciseImpactError("no chromium: apt-get install chromium (Debian's chromium)")
    return path


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextlib.contextmanager
def explorer(log: str | Path | None = None, timeout_s: float = 60.0) -> Iterator[str]:
    """``precise-impact explore`` on a free loopback port (this interpreter's package) until
    the block ends, its output into the file ``log`` (default: discarded); yields its URL once
    its API answers."""
    port = _free_port()
    with open(log if log is not None else os.devnull, "w", encoding="utf-8") as sink:
        p = subprocess.Popen(
            [sys.executable, "-m", "precise_impact", "explore", "--port", str(port)],
            stdout=sink, stderr=subprocess.STDOUT,
        )  # fmt: skip
        url = f"http://127.0.0.1:{port}/"
        try:
            _wait_until_serving(p, url, timeout_s)
            yield url
        finally:
            p.terminate()
            p.wait(timeout=30)


def _wait_until_serving(p: subprocess.Popen, url: str, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while True:
        with contextlib.suppress(OSError):
            urllib.request.urlopen(url + "api", timeout=2).close()
            return
        if p.poll() is not None or time.monotonic() > deadline:
            raise PreciseImpactError(f"the explorer did not start on {url} (exit {p.poll()})")
        time.sleep(0.3)


def text(page: Any, css: str) -> str:
    """The deep text of the first element ``css`` selects."""
    return str(page.locator(css).first.evaluate(DEEP_TEXT))


def wait_text(page: Any, css: str, want: str, timeout_s: float = 180.0) -> str:
    """The element's deep text once it contains ``want`` (polled every 0.1 s)."""
    deadline = time.monotonic() + timeout_s
    while True:
        got = text(page, css) if page.locator(css).count() else ""
        if want in got:
            return got
        if time.monotonic() > deadline:
            raise PreciseImpactError(f"{css}: {want!r} not shown within {timeout_s} s: {got!r}")
        page.wait_for_timeout(100)


def _tab(name: str) -> Callable[[Any], None]:
    return lambda page: page.locator(".bk-tab", has_text=name).click()


def draw_bifurcation(page: Any) -> None:
    """The diagram's tab opened and the diagram computed and drawn (its info line shown)."""
    _tab("bifurcation")(page)
    page.locator(".pi-bif-run button").click()
    wait_text(page, ".pi-bif-info", "values of eta")
    page.wait_for_timeout(2000)  # the points are drawn after the line that announces them


def _impact_surface(page: Any) -> None:
    _tab("impact surface")(page)
    page.locator(".pi-impacts-run button").click()
    wait_text(page, ".pi-impacts-info", "singularity curves")
    page.locator(".pi-basins-run button").click()
    wait_text(page, ".pi-basins-info", "done")
    page.wait_for_timeout(1000)


def _proof(page: Any) -> None:
    _tab("proof")(page)
    page.locator(".pi-certify-run button").click()
    wait_text(page, ".pi-proof-info", "certified")
    page.wait_for_timeout(1000)


def _overlay(page: Any) -> None:
    page.locator(".pi-overlay input").check()
    wait_text(page, ".pi-circuit-info", "switched-capacitor: max")
    wait_text(page, ".pi-circuit-info", "circuit: max")
    page.wait_for_timeout(500)


#: The guide's screenshots: (file name, query string, what is done before the picture).
SHOTS: tuple[tuple[str, str, Callable[[Any], None] | None], ...] = (
    ("explore_orbit.png", "?eta=0.74&transient=300&periods=30", None),
    ("explore_circuit.png", "?eta=0.74&transient=300&periods=12&units=circuit", _overlay),
    ("explore_bifurcation.png", "?eta=0.712", draw_bifurcation),
    ("explore_impact_surface.png", "?eta=0.74&transient=100", _impact_surface),
    ("explore_proof.png", "?eta=0.712", _proof),
)


def screenshots(
    out: str | Path = ".",
    shots: Any = SHOTS,
    width: int = 1500,
    browser: Any = None,
    url: str | None = None,
) -> list[Path]:
    """Each of ``shots`` (name, query, action) from the running application in Debian's
    chromium (or in ``browser``, a Playwright browser already open), written as PNG files
    into ``out``; returns their paths.  The application is the explorer at ``url`` when given,
    else one started for these shots."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with explorer() if url is None else contextlib.nullcontext(url) as app:
        if browser is not None:
            return [_shot(browser, app, out / name, q, a, width) for name, q, a in shots]
        from playwright.sync_api import sync_playwright  # noqa: PLC0415 -- optional: [test]

        with sync_playwright() as pw:
            b = pw.chromium.launch(executable_path=chromium(), args=ARGS)
            try:
                return [_shot(b, app, out / name, q, a, width) for name, q, a in shots]
            finally:
                b.close()


def _shot(browser: Any, url: str, path: Path, query: str, action: Any, width: int) -> Path:
    page = browser.new_page(viewport={"width": width, "height": 1000})
    try:
        page.goto(url + query)
        wait_text(page, ".pi-orbit-info", "LLE")
        if action is not None:
            action(page)
        page.screenshot(path=str(path), full_page=True)
    finally:
        page.close()
    return path
