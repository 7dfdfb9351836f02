"""Every measured figure the README and docs/*.rst state comes from a file the code writes,
and agrees with it (issue 27).

A claim is one row of :data:`CLAIMS`: the document, a regular expression on its text
(whitespace collapsed, so a figure may wrap across lines) with one group per number, and for
each group the source file (``benchmarks/results/*``, the main job's report, the accuracy
table) with the key that holds the figure.  The pattern must match exactly once; each number
must equal its source to the digits printed (half a unit of the last printed digit: ``0.43``
stands for 0.425..0.435, ``38`` for 37.5..38.5).  A figure whose text is approximate says
so with ``~`` and is checked to the tolerance its row gives.

What was wrong when the table was made (be00663 + this branch): the "What the main job
shows" table came from ``accuracy``, not the main job; ``accuracy`` "scores every model"
(4 of 8); "the ideal circuit costs the same as the mechanics (within 10 %)" (the bench's
headline: 2.7-4x for a 50-period solve; per period over 200 periods 0.91x); "bifurcation
~14 s" and "14.4 s" (4.4 s with the compiled engine); float128 "39x" (38.5); certify "22x"
and "11x" less than heyoka (37x, 19x); the overhead paragraph "3.43 ms -> 2.11 ms (1.63x)",
``simulate()`` "1.23x", ``lle`` "1.15x" (3.57 -> 1.77 ms, 2.02x, 1.89x, 1.43x); the fast
LLE "~7-10 ms" (10 ms); the first compile "~10 s" (13 s); the README's "about 25 s" for the
quick main job (48 s in the committed report; 118 s under heavier load); numerics.rst's mp
cost "1.2 ms at 128 bits, 8.2 ms at 320" (1.35, 8.76); design.rst's "~200 ms to compile"
(266 ms).
"""

from __future__ import annotations

import json
import re
from decimal import Decimal
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
RESULTS = "benchmarks/results/"


@cache
def _load(path: str):
    return json.loads((ROOT / path).read_text(encoding="utf-8"))


@cache
def _text(doc: str) -> str:
    return " ".join((ROOT / doc).read_text(encoding="utf-8").split())


def _row(rows, **match):
    (hit,) = [r for r in rows if all(r.get(k) == v for k, v in match.items())]
    return hit


def _engine(model, precision):
    return _row(_load(RESULTS + "engine.json")["runs"], model=model, precision=precision)


def _lyap(what):
    return _row(_load(RESULTS + "lyapunov.json")["lle"], what=what)


def _circuit(run):
    return _row(_load(RESULTS + "circuit.json")["rows"], run=run)


def _overhead(job):
    return _row(_load(RESULTS + "overhead.json")["rows"], job=job)


def _fast(key):
    return _load(RESULTS + "fast.json")[key]


def _ratio_getter(model, precision):
    return lambda d: _engine(model, precision)["ratio_per_period_to_heyoka_float64"]


def _lyap_getter(precision):
    return lambda d: _lyap(f"LLE variational {precision}")["per_period_vs_float64"]


def _cost_getter(bits):
    """Measured ms per period of an mp:BITS run without samples (cost_model.json)."""
    return lambda d: (
        1e3 * (r := _row(d, precision=f"mp:{bits}", per_period=0))["measured_s"] / (r["periods"])
    )


SPICE = RESULTS + "spice_tmax.json"


def _bridge(tmax, chain):
    """Median wall overshoot of one comparator chain at one TMAX (spice_tmax.json)."""
    return lambda d: _row(d["pitfalls"]["digital_bridge"], tmax_s=tmax)[chain]["overshoot_median"]


def _drive(ron, drive):
    return lambda d: _row(d["pitfalls"]["two_drive_nodes"], ron=ron, drive=drive)["v_ratio_median"]


def _shared(netlist):
    return _row(_load(SPICE)["pitfalls"]["batch_vs_shared"], netlist=netlist)


MAIN_JOB = RESULTS + "main-job/report.json"


def _ds(report, fig):
    """The datasheet switched-capacitor model's attractor entry in the main job's report."""
    return report["figures"][fig]["attractors"]["models"]["switched-capacitor (datasheet)"]


VAR = "LLE eta=0.712 float64, variational, default run"
TWO = "LLE eta=0.712 float64, two-trajectory, default run"
SWEEP = "sweep 100 x 100 (2000 + 1000 periods)"

#: (document, pattern, [(source file, value getter)], relative tolerance or None: printed digits)
CLAIMS = [
    # ---- README.md
    (
        "README.md",
        r"a `--quick` run took (\d+) s on 2 shared cores",
        [(RESULTS + "main-job/report.json", lambda d: d["elapsed_s"])],
        None,
    ),
    (
        "README.md",
        r"error bar \((0\.\d+) \+- (0\.\d+) at eta = 0\.712\)",
        [
            (RESULTS + "lyapunov.json", lambda d: _lyap(VAR)["lle"]),
            (RESULTS + "lyapunov.json", lambda d: _lyap(VAR)["stderr"]),
        ],
        None,
    ),
    # ---- docs/results.rst: Lyapunov exponents, sync, bifurcation
    (
        "docs/results.rst",
        r"At eta = 0\.712: \*\*(0\.\d+) \+- (0\.\d+)\*\* \(variational\) and \*\*(0\.\d+) \+- "
        r"(0\.\d+)\*\* \(two-trajectory\) per unit time, ([\d.]+) s and ([\d.]+) s in float64",
        [
            (RESULTS + "lyapunov.json", lambda d: _lyap(VAR)["lle"]),
            (RESULTS + "lyapunov.json", lambda d: _lyap(VAR)["stderr"]),
            (RESULTS + "lyapunov.json", lambda d: _lyap(TWO)["lle"]),
            (RESULTS + "lyapunov.json", lambda d: _lyap(TWO)["stderr"]),
            (RESULTS + "lyapunov.json", lambda d: _lyap(VAR)["median_s"]),
            (RESULTS + "lyapunov.json", lambda d: _lyap(TWO)["median_s"]),
        ],
        None,
    ),
    (
        "docs/results.rst",
        r"4 x 6000 periods in (\d+) ms, (0\.\d+) \+- (0\.\d+)\.",
        [
            (RESULTS + "fast.json", lambda d: 1e3 * _fast("lle 4 x 6000 periods")["fast_s"]),
            (RESULTS + "fast.json", lambda d: _fast("lle 4 x 6000 periods")["fast_lle"]),
            (RESULTS + "fast.json", lambda d: _fast("lle 4 x 6000 periods")["fast_stderr"]),
        ],
        None,
    ),
    (
        "docs/results.rst",
        r"First-order, 500 periods: k\* = (0\.\d+) \+- (0\.\d+) \((0\.\d+) with ``--model heyoka``",
        [
            (RESULTS + "fast.json", lambda d: _fast("sync scan")["fast_k_star"][0]),
            (RESULTS + "fast.json", lambda d: _fast("sync scan")["fast_k_star"][1]),
            (RESULTS + "fast.json", lambda d: _fast("sync scan")["heyoka_k_star"][0]),
        ],
        None,
    ),
    (
        "docs/results.rst",
        r"400-value diagram with 1000 \+ 2000 periods each takes ([\d.]+) s on 2 cores",
        [(RESULTS + "lyapunov.json", lambda d: d["bifurcation"]["wall_s"])],
        None,
    ),
    # ---- the fast engine
    (
        "docs/results.rst",
        r"200 chaotic periods ([\d.]+) ms \(heyoka ([\d.]+) ms\), ``lle`` (\d+) ms \(heyoka "
        r"variational ([\d.]+) s\), sweeps (\d+)x heyoka's points per second, a sync scan (\d+)x",
        [
            (RESULTS + "fast.json", lambda d: 1e3 * _fast("simulate 200 periods")["fast_s"]),
            (
                RESULTS + "fast.json",
                lambda d: 1e3 * _fast("simulate 200 periods")["heyoka_solver_s"],
            ),
            (RESULTS + "fast.json", lambda d: 1e3 * _fast("lle 4 x 6000 periods")["fast_s"]),
            (
                RESULTS + "fast.json",
                lambda d: _fast("lle 4 x 6000 periods")["heyoka_variational_s"],
            ),
            (
                RESULTS + "fast.json",
                lambda d: (
                    _fast(SWEEP)["fast_points_per_s_per_core"]
                    / _fast(SWEEP)["heyoka_points_per_s_per_core"]
                ),
            ),
            (
                RESULTS + "fast.json",
                lambda d: _fast("sync scan")["heyoka_s"] / _fast("sync scan")["fast_s"],
            ),
        ],
        None,
    ),
    (
        "docs/results.rst",
        r"compiles \((\d+) s, cached on disk\); afterwards a one-shot ``lle --model fast`` CLI "
        r"run takes ([\d.]+) s against ([\d.]+) s",
        [
            (
                RESULTS + "fast.json",
                lambda d: _fast("cli lle one-shot (fresh process)")["fast_empty_cache_s"],
            ),
            (
                RESULTS + "fast.json",
                lambda d: _fast("cli lle one-shot (fresh process)")["fast_warm_cache_s"],
            ),
            (
                RESULTS + "fast.json",
                lambda d: _fast("cli lle one-shot (fresh process)")["variational_s"],
            ),
        ],
        None,
    ),
    (
        "docs/results.rst",
        r"``simulate`` ([\d.]+)x, the variational ``lle`` ([\d.]+)x; heyoka alone \(a callback "
        r"that only flips ``v``\) would give ([\d.]+)x and ([\d.]+)x at most",
        [
            (RESULTS + "overhead.json", lambda d: _overhead("simulate")["ratio"]),
            (RESULTS + "overhead.json", lambda d: _overhead("lle")["ratio"]),
            (RESULTS + "overhead.json", lambda d: _overhead("simulate")["ratio_limit"]),
            (RESULTS + "overhead.json", lambda d: _overhead("lle")["ratio_limit"]),
        ],
        None,
    ),
    # ---- sweeps
    (
        "docs/results.rst",
        r"takes ([\d.]+) s on 2 cores with the fast engine, end to end with the plot \((\d+) "
        r"points/s, (\d+) points/s over the tiles; ([\d.]+) s on a Dask LocalCluster, "
        r"bit-identical; a 1000 x 1000 map ([\d.]+) h\); with ``--model heyoka`` ([\d.]+) "
        r"points/s per core in the steady state, ~(\d+) min for the map, (\d+)x less",
        [
            (RESULTS + "fast.json", lambda d: _fast(SWEEP)["fast_map_s"]),
            (RESULTS + "fast.json", lambda d: _fast(SWEEP)["fast_points_per_s"]),
            (RESULTS + "fast.json", lambda d: _fast(SWEEP)["fast_tiles_points_per_s"]),
            (RESULTS + "fast.json", lambda d: _fast(SWEEP)["fast_dask_local_map_s"]),
            (RESULTS + "fast.json", lambda d: _fast(SWEEP)["fast_1000x1000_h_extrapolated"]),
            (RESULTS + "fast.json", lambda d: _fast(SWEEP)["heyoka_points_per_s_per_core"]),
            (RESULTS + "fast.json", lambda d: _fast(SWEEP)["heyoka_map_s_extrapolated"] / 60),
            (
                RESULTS + "fast.json",
                lambda d: (
                    _fast(SWEEP)["fast_points_per_s_per_core"]
                    / _fast(SWEEP)["heyoka_points_per_s_per_core"]
                ),
            ),
        ],
        None,
    ),
    (
        "docs/results.rst",
        r"\((\d+) s, (\d+) points/s; Dask LocalCluster (\d+) points/s; a plain per-point loop "
        r"([\d.]+) points/s on one core; peak memory (\d+) MiB in the driver and (\d+) MiB",
        [
            (RESULTS + "sweep.json", lambda d: d["runs"]["processes"]["wall_s"]),
            (RESULTS + "sweep.json", lambda d: d["runs"]["processes"]["points_per_s"]),
            (RESULTS + "sweep.json", lambda d: d["runs"]["dask"]["points_per_s"]),
            (RESULTS + "sweep.json", lambda d: d["runs"]["plain loop (1 process)"]["points_per_s"]),
            (RESULTS + "sweep.json", lambda d: d["memory"]["driver_peak_rss_MiB"]),
            (RESULTS + "sweep.json", lambda d: d["memory"]["largest_child_peak_rss_MiB"]),
        ],
        None,
    ),
    # ---- work-precision, certified
    (
        "docs/results.rst",
        r"heyoka float64 is (\d+)x faster than scipy DOP853 at error 1e-12 on the periodic case; "
        r"300 chaotic periods are certified to 1e-15 in ([\d.]+) s",
        [
            (RESULTS + "work_precision.json", lambda d: d["headlines"]["heyoka_vs_dop853"]),
            (RESULTS + "work_precision.json", lambda d: d["chaos_cost"]["certify"]["time_s"]),
        ],
        None,
    ),
    (
        "docs/results.rst",
        r"loses ([\d.]+) decimal digits per period at eta = 0\.712 over 3,000 periods, the true "
        r"sensitivity LLE T / ln 10 = 0\.116; the interval scheme loses ([\d.]+), about twice it "
        r".*? 3,000 periods to radius <= 1e-30 are certified in ([\d.]+) s \((\d+) bits\), "
        r"10,000 in ([\d.]+) s \((\d+) bits\); the interval scheme took ([\d.]+) s",
        [
            (RESULTS + "certified.json", lambda d: _long(d, "lohner_3000")),
            (RESULTS + "certified.json", lambda d: _long(d, "interval_3000")),
            (RESULTS + "certified.json", lambda d: d["long_horizons"]["lohner_3000"]["seconds"]),
            (RESULTS + "certified.json", lambda d: d["long_horizons"]["lohner_3000"]["bits"]),
            (RESULTS + "certified.json", lambda d: d["long_horizons"]["lohner_10000"]["seconds"]),
            (RESULTS + "certified.json", lambda d: d["long_horizons"]["lohner_10000"]["bits"]),
            (RESULTS + "certified.json", lambda d: d["long_horizons"]["interval_3000"]["seconds"]),
        ],
        None,
    ),
    (
        "docs/results.rst",
        r"loses ([\d.]+) decimal digits per period over 300 periods \(reduced form,\s+k = 0\.02, "
        r"512 bits\), the interval pair ([\d.]+); over 1,000 periods at 2048 bits ([\d.]+) against"
        r"\s+([\d.]+), in ([\d.]+) s against ([\d.]+) s .*? largest radius is 1e(-[\d.]+) against "
        r"1e(-[\d.]+)\)",
        [
            (RESULTS + "certified.json", lambda d: d["pair"]["lohner"]["growth_digits_per_period"]),
            (
                RESULTS + "certified.json",
                lambda d: d["pair"]["interval"]["growth_digits_per_period"],
            ),
            (
                RESULTS + "certified.json",
                lambda d: d["pair_long"]["lohner"]["growth_digits_per_period"],
            ),
            (
                RESULTS + "certified.json",
                lambda d: d["pair_long"]["interval"]["growth_digits_per_period"],
            ),
            (RESULTS + "certified.json", lambda d: d["pair_long"]["lohner"]["seconds"]),
            (RESULTS + "certified.json", lambda d: d["pair_long"]["interval"]["seconds"]),
            (RESULTS + "certified.json", lambda d: d["pair_long"]["lohner"]["log10_max_radius"]),
            (RESULTS + "certified.json", lambda d: d["pair_long"]["interval"]["log10_max_radius"]),
        ],
        None,
    ),
    (
        "docs/results.rst",
        r"to radius <= 1e-30: ([\d.]+) s \((\d+) bits chosen\), (\d+)x less than the heyoka "
        r"mp:256 \+ mp:320 pair that demonstrates the same digits \(([\d.]+) s\) and (\d+)x less",
        [
            (RESULTS + "certified.json", lambda d: d["certified_auto"]["seconds"]),
            (RESULTS + "certified.json", lambda d: d["certified_auto"]["bits"]),
            (RESULTS + "certified.json", lambda d: d["ratio_demonstration_over_certified"]),
            (RESULTS + "certified.json", lambda d: d["heyoka_demonstration"]["seconds_both"]),
            (RESULTS + "certified.json", lambda d: d["ratio_single_heyoka_run_over_certified"]),
        ],
        None,
    ),
    # ---- Benchmarks section
    (
        "docs/results.rst",
        r"200 chaotic periods in heyoka float64 take ([\d.]+) ms after compilation",
        [(RESULTS + "engine.json", lambda d: 1e3 * _engine("heyoka", "float64")["median_s"])],
        None,
    ),
    (
        "docs/results.rst",
        r"long double ([\d.]+)x, float128 (\d+)x, mp:256 (\d+)x per period; the robust "
        r"analytical finder ([\d.]+)x, the paper's scan (\d+)x",
        [
            (RESULTS + "engine.json", _ratio_getter("heyoka", p))
            for p in ("longdouble", "float128", "mp:256")
        ]
        + [
            (RESULTS + "engine.json", _ratio_getter(m, "float64"))
            for m in ("analytical", "analytical-paper")
        ],
        {2: 0.005},  # "410x": two significant digits of 409.6
    ),
    (
        "docs/results.rst",
        r"reused ``HeyokaSolver`` ([\d.]+) ms -> ([\d.]+) ms \(([\d.]+)x: .*?``simulate\(\)``, "
        r"which makes a new solver .*?, ([\d.]+)x; the variational ``lle`` ([\d.]+)x\.",
        [
            (RESULTS + "overhead.json", lambda d: 1e3 * _overhead("solve")["baseline_s"]),
            (RESULTS + "overhead.json", lambda d: 1e3 * _overhead("solve")["current_s"]),
            (RESULTS + "overhead.json", lambda d: _overhead("solve")["ratio"]),
            (RESULTS + "overhead.json", lambda d: _overhead("simulate")["ratio"]),
            (RESULTS + "overhead.json", lambda d: _overhead("lle")["ratio"]),
        ],
        None,
    ),
    (
        "docs/results.rst",
        r"over 200 periods: the ideal circuit model ([\d.]+)x; the ideal switched-capacitor model "
        r"([\d.]+)x; datasheet parts ([\d.]+)x; dynamic single-pole op-amps need (\d+)x more "
        r"Taylor steps \(stiff\), the quasi-static reduction ([\d.]+)x",
        [
            (
                RESULTS + "circuit.json",
                lambda d: _circuit("circuit, no effects")["per_period_vs_mechanical"],
            ),
            (
                RESULTS + "circuit.json",
                lambda d: _circuit("switched-capacitor, no effects")["per_period_vs_mechanical"],
            ),
            (
                RESULTS + "circuit.json",
                lambda d: _circuit("switched-capacitor, datasheet parts")[
                    "per_period_vs_mechanical"
                ],
            ),
            (
                RESULTS + "circuit.json",
                lambda d: (
                    d["taylor_steps_per_period"]["gbw_dynamic"]
                    / d["taylor_steps_per_period"]["mechanical"]
                ),
            ),
            (
                RESULTS + "circuit.json",
                lambda d: _circuit("circuit, GBW quasi-static")["per_period_vs_mechanical"],
            ),
        ],
        {3: 0.01},  # "2700x": two significant digits of 2720.8
    ),
    (
        "docs/results.rst",
        r"\(10 us: ([\d.]+) s for 150 periods, error (\de-\d)\)",
        [
            (RESULTS + "spice_tmax.json", lambda d: _row(d["tmax_074"], tmax_s=1e-5)["ngspice_s"]),
            (
                RESULTS + "spice_tmax.json",
                lambda d: _row(d["tmax_074"], tmax_s=1e-5)["err_last30"],
            ),
        ],
        None,
    ),
    (
        "docs/results.rst",
        r"LLE \+- 0\.0005 at eta = 0\.712 in ([\d.]+) s \(variational\) and ([\d.]+) s "
        r"\(two-trajectory\); per period, long double ([\d.]+)x, float128 (\d+)x, mp:256 (\d+)x "
        r"float64; the 400-value bifurcation diagram ([\d.]+) s on 2 cores",
        [
            (RESULTS + "lyapunov.json", lambda d: _lyap(VAR)["median_s"]),
            (RESULTS + "lyapunov.json", lambda d: _lyap(TWO)["median_s"]),
        ]
        + [
            (RESULTS + "lyapunov.json", _lyap_getter(p))
            for p in ("longdouble", "float128", "mp:256")
        ]
        + [(RESULTS + "lyapunov.json", lambda d: d["bifurcation"]["wall_s"])],
        None,
    ),
    (
        "docs/results.rst",
        r"closed form of the difference equation, ~(\d+)x heyoka",
        [
            (
                RESULTS + "fast.json",
                lambda d: _fast("sync scan")["heyoka_s"] / _fast("sync scan")["fast_s"],
            )
        ],
        0.05,
    ),
    (
        "docs/results.rst",
        r"every op-amp output a state, ~(\d+)x more Taylor steps",
        [
            (
                RESULTS + "circuit.json",
                lambda d: (
                    d["taylor_steps_per_period"]["gbw_dynamic"]
                    / d["taylor_steps_per_period"]["mechanical"]
                ),
            )
        ],
        0.01,
    ),
    (
        "docs/results.rst",
        r"give zeta (0\.\d+) \(R_on alone adds 2 R_on/R3 = (0\.\d+) to 2 zeta\) and omega "
        r"([\d.]+) rad/s instead of 1000, so Fig\. 4's eta 0\.70 becomes (0\.\d+), above that "
        r"system's grazing frequency (0\.\d+): .*? on a period-(\d) orbit with ([\d.]+) impacts "
        r"per period",
        [
            (MAIN_JOB, lambda d: _ds(d, "4")["effective"]["zeta"]),
            (MAIN_JOB, lambda d: _ds(d, "4")["effective"]["ron_damping"]),
            (MAIN_JOB, lambda d: _ds(d, "4")["effective"]["omega"]),
            (MAIN_JOB, lambda d: _ds(d, "4")["effective"]["eta"]),
            (MAIN_JOB, lambda d: _ds(d, "4")["effective"]["grazing_eta"]),
            (MAIN_JOB, lambda d: _ds(d, "6")["period"]),
            (MAIN_JOB, lambda d: _ds(d, "6")["impacts_per_period"]),
        ],
        None,
    ),
    (
        "docs/numerics.rst",
        r"measured ([\d.]+) ms at 128 bits, ([\d.]+) ms at 320, (\d+) ms at 640",
        [(RESULTS + "cost_model.json", _cost_getter(b)) for b in (128, 320, 640)],
        None,
    ),
    (
        "docs/circuit.rst",
        r"measured ~(\d+)x more Taylor steps \(benchmarks/results/circuit\.md\)",
        [
            (
                RESULTS + "circuit.json",
                lambda d: (
                    d["taylor_steps_per_period"]["gbw_dynamic"]
                    / d["taylor_steps_per_period"]["mechanical"]
                ),
            )
        ],
        0.01,
    ),
    (
        "docs/design.rst",
        r"compiling the float64 oscillator again took (\d+) ms",
        [
            (
                RESULTS + "engine.json",
                lambda d: 1e3 * d["compile_s"]["float64"]["recompile_s"],
            )
        ],
        None,
    ),
    (
        "docs/circuit.rst",
        r"median overshoot ``x - x_w`` ([\d.e-]+) / ([\d.e-]+) / ([\d.e-]+) at TMAX = 1 / 10 / "
        r"100 us \(this netlist: < (\de-\d) at all three\)\. A comparator with an output pole "
        r"in front of the bridge lands better \(median ([\d.e-]+) at 1 us\) but the digital "
        r"toggle then fires spuriously \((\d+) toggles instead of (\d+)\)",
        [(SPICE, _bridge(t, "algebraic comparator -> bridge")) for t in (1e-6, 1e-5, 1e-4)]
        + [
            (
                SPICE,
                lambda d: max(
                    r["analog (module)"]["overshoot_max"] for r in d["pitfalls"]["digital_bridge"]
                ),
            ),
            (SPICE, _bridge(1e-6, "comparator with pole -> bridge")),
            (
                SPICE,
                lambda d: _row(d["pitfalls"]["digital_bridge"], tmax_s=1e-6)[
                    "comparator with pole -> bridge"
                ]["toggles"],
            ),
            (
                SPICE,
                lambda d: _row(d["pitfalls"]["digital_bridge"], tmax_s=1e-6)["analog (module)"][
                    "toggles"
                ],
            ),
        ],
        {3: 0.2},  # "< 6e-7": a bound, the largest is 5.6e-7
    ),
    (
        "docs/circuit.rst",
        r"``\|v\+/v-\|`` = ([\d.]+) per impact \(one drive node: ([\d.]+)\)",
        [
            (SPICE, _drive("1", "two nodes")),
            (SPICE, _drive("1", "one node")),
        ],
        None,
    ),
    (
        "docs/circuit.rst",
        r"\((\d+) toggles, the second at ([\d.]+) ms instead of ([\d.]+) ms\)",
        [
            (SPICE, lambda d: _shared("XSPICE digital toggle")["shared_toggles"]),
            (SPICE, lambda d: _shared("XSPICE digital toggle")["shared_toggle_times_ms"][1]),
            (SPICE, lambda d: _shared("analog (module)")["batch_toggle_times_ms"][1]),
        ],
        None,
    ),
    (
        "docs/guide/cli.rst",
        r"within ([\d.]+)-([\d.]+)x of measured times",
        [
            (RESULTS + "cost_model.json", lambda d: min(r["ratio"] for r in d)),
            (RESULTS + "cost_model.json", lambda d: max(r["ratio"] for r in d)),
        ],
        None,
    ),
]


def _long(d: dict, key: str) -> float:
    """The growth (digits per period) of one of ``certified.json``'s long runs."""
    return d["long_horizons"][key]["growth_digits_per_period"]


def agrees(printed: str, value: float, rel: float | None) -> bool:
    """``printed`` is ``value`` to its printed digits (or within ``rel``, relative)."""
    p = Decimal(printed)
    if rel is not None:
        return abs(float(p) - value) <= rel * abs(value)
    half = Decimal(1).scaleb(p.as_tuple().exponent) / 2
    return abs(Decimal(repr(float(value))) - p) <= half


def _claims():
    for i, (doc, pattern, sources, tol) in enumerate(CLAIMS):
        yield pytest.param(doc, pattern, sources, tol, id=f"{doc}:{i}")


@pytest.mark.parametrize("doc, pattern, sources, tol", list(_claims()))
def test_claim_agrees_with_its_source(doc, pattern, sources, tol):
    hits = list(re.finditer(pattern, _text(doc)))
    assert len(hits) == 1, f"{doc}: {len(hits)} matches of {pattern!r}"
    groups = hits[0].groups()
    assert len(groups) == len(sources), (pattern, groups)
    wrong = []
    for k, (printed, (path, get)) in enumerate(zip(groups, sources, strict=True)):
        value = get(_load(path))
        rel = tol.get(k) if isinstance(tol, dict) else tol
        if not agrees(printed, value, rel):
            wrong.append(f"{printed} (source {path}: {value:.6g})")
    assert not wrong, f"{doc}: {wrong}"


ACCURACY_COLUMNS = [
    ("heyoka", "float64"),
    ("heyoka", "longdouble"),
    ("heyoka", "float128"),
    ("analytical", "float64"),
    ("analytical-paper", "float64"),
    ("fast", "float64"),
    ("certified", "mp:REF"),  # the reference's precision (REF: its bits)
    ("circuit", "float64"),
    ("switched-capacitor", "float64"),
    ("spice", "float64"),
    (None, None),  # the reference: its disagreement with 64 more bits
]


def test_accuracy_table_is_the_accuracy_job():
    """docs/results.rst's table (was headed "What the main job shows") is
    ``precise-impact accuracy``'s output, cell by cell, with its reference precisions."""
    acc = _load(RESULTS + "accuracy.json")
    text = (ROOT / "docs/results.rst").read_text(encoding="utf-8")
    section = text[text.index("What ``accuracy`` shows (") :]
    section = section[: section.index("\n\n\n")] if "\n\n\n" in section else section
    head = re.search(r"reference \(mp:(\d+) vs mp:(\d+)\)", section)
    assert head and int(head.group(1)) == acc["reference_bits"], head
    assert int(head.group(2)) == acc["reference_bits"] + 64
    assert f"({acc['periods']} periods from rest)" in section
    n = len(ACCURACY_COLUMNS)
    rows = re.findall(rf"\* - (0\.\d+)\n((?:\s+- \S+\n){{{n}}})", section)
    assert [eta for eta, _ in rows] == ["0.70", "0.712", "0.74"]
    checked = 0
    for eta, cells in rows:
        for (model, precision), printed in zip(
            ACCURACY_COLUMNS, re.findall(r"- (\S+)", cells), strict=True
        ):
            if model is None:
                row = _row(
                    acc["rows"], eta=eta, model="heyoka", precision=f"mp:{acc['reference_bits']}"
                )
            else:
                precision = precision.replace("REF", str(acc["reference_bits"]))
                row = _row(acc["rows"], eta=eta, model=model, precision=precision)
            assert agrees(printed, row["max_error"], None), (eta, model, precision, printed)
            checked += 1
    assert checked == 3 * len(ACCURACY_COLUMNS)


def test_accuracy_claim_of_coverage():
    """ "4 of the 8 registered models": counted from the registry and the accuracy job."""
    from precise_impact.solvers.base import MODELS
    from precise_impact.verification.accuracy import CANDIDATES

    n = len({m for m, _ in CANDIDATES})
    assert f"{n} of the {len(MODELS)} registered models" in _text("docs/results.rst")


#: A duration, speed ratio or percentage in prose.
FIGURE = re.compile(r"~?\b\d+(\.\d+)?(-\d+(\.\d+)?)?\s?(x|s|ms|us|min|h|%)(?![\w/])")

#: Figures that are not measurements from a file: (text around the figure, why).  Settings,
#: targets, definitions and model constants are not measurements; "development note" marks a
#: figure measured once while developing that no file records (kept, and named as such here).
EXEMPT = [
    (
        "within one error bar 66 % of the time and within two 92-94 % (Student t: 67 %, 94 %",
        "coverage rates asserted by tests/analysis/test_attractors.py (the test is the source)",
    ),
    ("at every point of the last 10 %", "a definition (the synchronisation criterion)"),
    ("That 100 x 100 map", "a grid size"),
    ("(target < 5 ms)", "a target"),
    ("(target < 20 s;", "a target"),
    ("resistors 1 % (E96), capacitors 5 % (E24)", "the tolerance effect's defaults"),
    ("(measured during development at TMAX = 3 us", "a setting (development note)"),
    ("far below the error at any TMAX >= 1 us", "a setting"),
    ("with the same 50 % step delay", "a definition"),
    ("ngspice crawled: > 600 s for 60 periods", "development note"),
    ("With R_on = 160 Ohm, ``R_on C2`` = 16 us", "a product of component values"),
    ("the first written point is t = 1e-7 s", "ngspice's behaviour (dctran.c)"),
    (
        "its truncation error is about 4x trap's at equal TMAX (ideal parts, 10 us",
        "development note",
    ),
    ("narrows it to ~5e-6 (+35 % points)", "development note"),
    ("eta = 0.74, 150 periods, TMAX = 10 us", "a setting"),
    ("(measured offset <= 2.2e-16 s)", "a bound (one ulp of the sample times)"),
    (
        "float64 1e-5 s, longdouble 6e-5 s, float128 6e-4 s, ``mp:B`` 1.2e-3 s",
        "the cost model's constants (core/budget.py; cost_model.json measures the estimates)",
    ),
    ("1e-6 s float64, 1.2e-5 s longdouble, 2e-5 s float128", "the cost model's constants"),
    ("at most every 0.2 s; elsewhere it writes whole lines at most every 5 s", "settings"),
    ("(over ~10 s on 2 cores)", "the test suite's policy for the slow mark"),
]

PAGES = [
    "README.md",
    *sorted(p.relative_to(ROOT).as_posix() for p in (ROOT / "docs").glob("*.rst")),
]


@pytest.mark.parametrize("doc", PAGES)
def test_every_measured_figure_is_a_claim(doc):
    """Each duration, speed ratio and percentage of the README and of docs/*.rst is inside a
    claim of :data:`CLAIMS` (so checked against its file) or exempt with a reason."""
    text = _text(doc)
    spans = [m.span() for d, p, _, _ in CLAIMS if d == doc for m in re.finditer(p, text)]
    spans += [(i, i + len(t)) for t, _ in EXEMPT for i in [text.find(t)] if i >= 0]
    loose = [
        text[max(0, m.start() - 50) : m.end() + 10]
        for m in FIGURE.finditer(text)
        if not any(a <= m.start() < b for a, b in spans)
    ]
    assert not loose, f"{doc}: figures without a source: {loose}"


def test_every_exemption_is_used():
    """An exemption whose text no page holds any more is stale."""
    pages = [_text(doc) for doc in PAGES]
    stale = [t for t, _ in EXEMPT if not any(t in p for p in pages)]
    assert not stale, stale
