"""The explorer's speed, server-side and in the browser (issue 37's targets).

Run:  python benchmarks/bench_explore.py [--repeat 20]

* server-side (the view functions the page and the JSON API call, warm): the orbit at new
  parameters on the compiled engine (target 300 ms in the browser), the bifurcation diagram of
  400 eta values x 300 periods (first picture within 2 s), the domains of attraction 200 x 200
  (first rows within 2 s, the whole within the scan's own time + 10 %, the same ``basins``
  called directly in the same run);
* in the browser (Debian's chromium driven by Playwright against ``precise-impact explore``):
  from typing a new eta (Enter) to the orbit view showing it.

Writes ``benchmarks/results/explore.md`` and ``.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time
from pathlib import Path

from precise_impact.analysis.impact_surface.basins import basins, clear_caches
from precise_impact.explore import api
from precise_impact.explore.browser import ARGS, DEEP_TEXT, chromium, explorer, wait_text
from precise_impact.explore.state import State
from precise_impact.io.atomic import atomic_write

OUT = Path(__file__).resolve().parent / "results"


def _orbit_times(repeat: int) -> list[float]:
    api.orbit(State.from_query({"eta": "0.7"}))  # loads the kernels
    out = []
    for k in range(repeat):
        st = State.from_query({"eta": f"{0.70 + 0.002 * k:.3f}", "periods": "200"})
        t = time.perf_counter()
        api.orbit(st, full=False)  # as the page asks for it
        out.append(time.perf_counter() - t)
    return out


def _bifurcation_time() -> float:
    st = State.from_query({"n": "400", "bif_periods": "300", "bif_transient": "300"})
    t = time.perf_counter()
    api.bifurcation(st)
    return time.perf_counter() - t


def _basins_times(n: int) -> dict[str, float]:
    st = State.from_query({"eta": "4.85", "zeta": "0", "R": "0.5", "x_w": "-0.3", "x0": "-0.5"})
    first: list[float] = []
    clear_caches()  # each run finds its cycles afresh (the map caches them per process)
    t = time.perf_counter()
    api.basins(
        st,
        n,
        n,
        0.6,
        on_tile=lambda row: first.append(time.perf_counter() - t) if not first else None,
    )
    view = time.perf_counter() - t
    grid = ((0.0, 1.0, n), (0.6 / (2 * n), 0.6, n))
    clear_caches()
    t = time.perf_counter()
    basins(st.params, grid, transient=100, tile_size=n, progress=False)
    direct = time.perf_counter() - t
    return {"first_row_s": first[0], "view_s": view, "scan_s": direct}


def _browser_times(repeat: int) -> list[float]:
    """From Enter in the eta field to the orbit view's line naming that eta, timed in the
    browser (``performance.now()``; the check runs at each animation frame, in the page)."""
    from playwright.sync_api import sync_playwright  # noqa: PLC0415 -- optional: the browser part

    # the element is handed in (Panel renders in shadow DOM, where document.querySelector
    # does not look)
    shown = "([el, want, t0]) => (" + DEEP_TEXT + ")(el).includes(want) && performance.now() - t0"
    with explorer() as url, sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=chromium(), args=ARGS)
        page = b.new_page()
        page.goto(url + "?eta=0.7")
        wait_text(page, ".pi-orbit-info", "eta 0.7", 60)
        times = []
        for k in range(repeat):
            eta = f"{0.701 + 0.002 * k:.3f}"
            box = page.locator(".pi-field-eta input")
            box.fill(eta)
            el = page.locator(".pi-orbit-info").first.element_handle()
            t0 = page.evaluate("() => performance.now()")
            box.press("Enter")
            ms = page.wait_for_function(shown, arg=[el, f"eta {eta}", t0], polling="raf",
                                        timeout=30_000).json_value()  # fmt: skip
            times.append(ms / 1000)
        b.close()
    return times


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=20)
    ap.add_argument("--basins-n", type=int, default=200)
    ap.add_argument("--no-browser", action="store_true")
    args = ap.parse_args()
    orbit = _orbit_times(args.repeat)
    res = {
        "machine": f"{os.cpu_count()} CPUs, Python {platform.python_version()}, "
        f"load {os.getloadavg()[0]:.2f}",
        "orbit_s": {"median": statistics.median(orbit), "max": max(orbit)},
        "bifurcation_400x300_s": _bifurcation_time(),
        "basins": {"n": args.basins_n, **_basins_times(args.basins_n)},
    }
    if not args.no_browser:
        br = _browser_times(args.repeat)
        res["browser_orbit_s"] = {"median": statistics.median(br), "max": max(br)}
    OUT.mkdir(exist_ok=True)
    atomic_write(OUT / "explore.json", lambda fh: fh.write(json.dumps(res, indent=1)), binary=False)
    atomic_write(OUT / "explore.md", lambda fh: fh.write(_markdown(res)), binary=False)
    print(_markdown(res))


def _markdown(r: dict) -> str:
    b = r["basins"]
    rows = [
        (
            "orbit at new parameters, server (median / max)",
            f"{1e3 * r['orbit_s']['median']:.1f} / {1e3 * r['orbit_s']['max']:.1f} ms",
            "300 ms in the browser",
        ),
        (
            "bifurcation 400 eta x 300 periods (+300 transient), server",
            f"{r['bifurcation_400x300_s']:.2f} s",
            "2 s",
        ),
        (f"basins {b['n']} x {b['n']}: first row", f"{b['first_row_s']:.2f} s", "2 s"),
        (
            f"basins {b['n']} x {b['n']}: whole, view / the scan alone",
            f"{b['view_s']:.1f} / {b['scan_s']:.1f} s (ratio {b['view_s'] / b['scan_s']:.3f})",
            "<= 1.10",
        ),
    ]
    if "browser_orbit_s" in r:
        br = r["browser_orbit_s"]
        rows.append(
            (
                "orbit at new eta, typed in the browser to drawn (median / max)",
                f"{1e3 * br['median']:.0f} / {1e3 * br['max']:.0f} ms",
                "300 ms",
            )
        )
    lines = [
        "# The explorer's speed (bench_explore.py)", "",
        f"{r['machine']}.  Run: `python benchmarks/bench_explore.py`.", "",
        "| what | measured | target |", "|---|---|---|",
        *(f"| {a} | {b_} | {c} |" for a, b_, c in rows), "",
    ]  # fmt: skip
    return "\n".join(lines)


if __name__ == "__main__":
    main()
