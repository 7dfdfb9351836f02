"""ngspice backend benchmark: error and wall time against TMAX, predictability, pitfalls.

Run:  python benchmarks/bench_spice.py [--quick] [--no-pitfalls]
Writes benchmarks/results/spice_tmax.md and benchmarks/results/spice_tmax.json.

* eta = 0.74 (period 3), 150 periods from rest, ideal parts: for TMAX in
  {100, 30, 10, 3, 1} us the ngspice wall time and the largest |x - x_ref|,
  |v - v_ref| over the last 30 stroboscopic samples; reference heyoka float64
  (the stable period-3 orbit does not amplify its ~1e-13 error).
* eta = 0.712 (chaotic), 150 periods: predictability = first period k with
  |x_k - x_ref,k| > 0.1; reference heyoka float128 (float64 itself drifts off
  by 2e-2 at period 100, README).
* Pitfalls: the ngspice 39 experiments quoted in precise_impact/_spice.py,
  re-run on variants of the module's netlist (XSPICE digital toggle, S-switch
  bridges, .options interp raw file, uic, trap, positive-feedback Schmitt
  trigger, algebraic saturating op-amps, batch vs shared library).

Needs ngspice (apt-get install ngspice); the batch-vs-shared-library check also
needs libngspice0 (apt-get install libngspice0) and is skipped without it.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from precise_impact import HeyokaSolver, Params, nominal_components
from precise_impact.io.atomic import atomic_write
from precise_impact.models.circuit.spice import OUTPUT_FILE, run_spice, spice_netlist

OUT = Path(__file__).resolve().parent / "results"
TMAXES = (100e-6, 30e-6, 10e-6, 3e-6, 1e-6)


# ====================================================================== accuracy
def tmax_table(tmaxes, periods: int = 150) -> list[dict]:
    p = Params.make(eta="0.74")
    comp = nominal_components(p)
    ref = HeyokaSolver("float64").solve(p, periods)
    rx, rv = np.asarray(ref.x, float), np.asarray(ref.v, float)
    rows = []
    for tm in tmaxes:
        t0 = time.perf_counter()
        r = run_spice(comp, None, periods, tm)
        total = time.perf_counter() - t0
        ex, ev = np.abs(r.x - rx)[-30:].max(), np.abs(r.v - rv)[-30:].max()
        n = min(r.n_impacts, ref.n_impacts)
        rows.append(
            {
                "tmax_s": tm,
                "ngspice_s": r.elapsed_s,
                "total_s": total,
                "points": r.stats["points"],
                "err_x_last30": float(ex),
                "err_v_last30": float(ev),
                "err_last30": float(max(ex, ev)),
                "impacts": r.n_impacts,
                "impacts_ref": ref.n_impacts,
                "impact_dt_max": float(
                    np.abs(r.impacts_t[:n] - np.asarray(ref.impacts_t[:n], float)).max()
                )
                if n
                else None,
                "overshoot_max": float(np.abs(r.impacts_x - 2).max()) if r.n_impacts else None,
                "restitution_dev_max": float(
                    np.abs(-r.impacts_v_after / r.impacts_v_before - 1).max()
                )
                if r.n_impacts
                else None,
            }
        )
        print(
            f"eta=0.74 TMAX={tm:g}: {r.elapsed_s:.2f} s, err {max(ex, ev):.2e}",
            file=sys.stderr,
            flush=True,
        )
    return rows


def predictability(tmaxes, periods: int = 150, threshold: float = 0.1) -> dict:
    p = Params.make(eta="0.712")
    comp = nominal_components(p)
    ref = HeyokaSolver("float128").solve(p, periods)
    P = ref.precision
    rx = np.array([P.to_float(v) for v in ref.x])
    ref64 = HeyokaSolver("float64").solve(p, periods)
    d64 = np.abs(np.asarray(ref64.x, float) - rx)
    rows = []
    for tm in tmaxes:
        r = run_spice(comp, None, periods, tm)
        d = np.abs(r.x - rx)
        bad = np.nonzero(d > threshold)[0]
        rows.append(
            {
                "tmax_s": tm,
                "ngspice_s": r.elapsed_s,
                "first_period_off": int(bad[0]) if len(bad) else None,
                "err_first_10": float(d[:11].max()),
            }
        )
        print(
            f"eta=0.712 TMAX={tm:g}: first period off {rows[-1]['first_period_off']}",
            file=sys.stderr,
            flush=True,
        )
    bad64 = np.nonzero(d64 > threshold)[0]
    return {
        "periods": periods,
        "threshold": threshold,
        "reference": "heyoka float128",
        "rows": rows,
        "heyoka_float64_first_period_off": int(bad64[0]) if len(bad64) else None,
    }


# ====================================================================== pitfalls
def _ngspice(net: str, wd: Path, extra_args=()) -> tuple[np.ndarray | None, list[str], float]:
    wd.mkdir(parents=True, exist_ok=True)
    (wd / "c.cir").write_text(net)
    out = wd / OUTPUT_FILE
    if out.exists():
        out.unlink()
    t0 = time.perf_counter()
    pr = subprocess.run(
        ["ngspice", "-b", *extra_args, "c.cir"], cwd=wd, capture_output=True, text=True, timeout=900
    )
    el = time.perf_counter() - t0
    errs = [
        ln.strip()
        for ln in (pr.stdout + pr.stderr).splitlines()
        if re.search(r"error|too small|abort", ln, re.I)
    ]
    data = np.fromfile(out, sep=" ").reshape(-1, 5) if out.exists() else None
    return data, errs, el


def _toggles(data: np.ndarray):
    """Polarity crossings of 1/2: indices, x there (interpolated), and |v+/v-|."""
    t, s, q, pol, _ = data.T
    sp = pol - 0.5
    cr = np.nonzero((sp[:-1] < 0) != (sp[1:] < 0))[0]
    fr = sp[cr] / (sp[cr] - sp[cr + 1])
    tc = t[cr] + fr * (t[cr + 1] - t[cr])
    x_at = -(s[cr] + fr * (s[cr + 1] - s[cr]))
    ratio = np.array([-np.interp(tt + 1e-6, t, q) / np.interp(tt - 2e-7, t, q) for tt in tc])
    return tc, x_at, ratio


_A1 = re.compile(r"^(BA1M|CA1M|BA1S|CA1S|BA1D|CA1D) .*$\n", re.M)
_DIGITAL = """* XSPICE digital toggle (pitfall experiment):
* comparator -> adc_bridge -> d_tff -> dac_bridge
AADC [cmp] [dclk] adcb
.model adcb adc_bridge(in_low=0.4 in_high=0.6)
AONE one pullup
.model pullup d_pullup
ATFF one dclk null null dq dqb tff
.model tff d_tff(clk_delay=1e-10 rise_delay=1e-10 fall_delay=1e-10 ic=0)
ADAC [dq dqb] [pol polb] dacb
.model dacb dac_bridge(out_low=0 out_high=1 t_rise=1e-10 t_fall=1e-10)
"""


def digital_variant(net: str, comparator_pole: bool) -> str:
    net = _A1.sub("", net)
    if not comparator_pole:  # algebraic comparator fed straight into the bridge
        net = re.sub(r"^BU5 0 cmp I = (.*) - V\(cmp\)$", r"BU5 cmp 0 V = \1", net, flags=re.M)
        net = re.sub(r"^CU5 .*$\n", "", net, flags=re.M)
    net = net.replace("* ---- U6/U7", _DIGITAL + "* ---- U6/U7")
    return net.replace(" V(pol)=0 V(ps)=0 V(m)=1", "")


def s_switch_variant(net: str, two_nodes: bool, ron: str) -> str:
    """ngspice S switches (VSWITCH) instead of the module's B-source bridge."""
    net = re.sub(r"^(BU6A|BU6B|BU7A|BU7B) .*$\n", "", net, flags=re.M)
    lines = [
        f".model swon sw vt=0.5 vh=0 ron={ron} roff=1e12",
        f".model swinv sw vt=-0.5 vh=0 ron={ron} roff=1e12",
    ]
    if two_nodes:  # pair A from a separately generated complement with twice the lag
        tau = float(re.search(r"^CA1D pol 0 (\S+)", net, re.M).group(1))
        lines += [
            "BA1DB 0 polb I = (1-V(ps))-V(polb)",
            f"CA1DB polb 0 {2 * tau!r} IC=1",
            "SU6A n2 ca polb 0 swon",
            "SU6B q cb polb 0 swon",
        ]
    else:
        lines += ["SU6A n2 ca 0 pol swinv", "SU6B q cb 0 pol swinv"]
    lines += ["SU7A n2 cb pol 0 swon", "SU7B q ca pol 0 swon"]
    return net.replace("* ---- breakpoints", "\n".join(lines) + "\n* ---- breakpoints")


def _shared_library_run(net: str, wd: Path) -> np.ndarray | None:
    """Run ``net`` through libngspice (ctypes) in a subprocess; None without libngspice0."""
    code = r"""
import ctypes, re, sys, os
from ctypes import CFUNCTYPE, c_int, c_char_p, c_void_p, c_bool
lib = ctypes.CDLL("libngspice.so.0")
P = CFUNCTYPE(c_int, c_char_p, c_int, c_void_p)
E = CFUNCTYPE(c_int, c_int, c_bool, c_bool, c_int, c_void_p)
noop = P(lambda s, i, p: 0); ex = E(lambda a, b, c, d, p: 0)
lib.ngSpice_Init(noop, noop, ex, None, None, None, None)
text = open("c.cir").read()
ctrl = re.search(r"\.control\n(.*?)\.endc\n", text, re.S).group(1)
open("c_noctl.cir", "w").write(re.sub(r"\.control\n.*?\.endc\n", "", text, flags=re.S))
lib.ngSpice_Command(b"source c_noctl.cir")
for line in ctrl.splitlines():
    if not line.startswith("quit"):
        lib.ngSpice_Command(line.encode())
"""
    try:
        ctypes.CDLL("libngspice.so.0")
    except OSError:
        return None
    wd.mkdir(parents=True, exist_ok=True)
    (wd / "c.cir").write_text(net)
    out = wd / OUTPUT_FILE
    if out.exists():
        out.unlink()
    subprocess.run(
        [sys.executable, "-c", code], cwd=wd, capture_output=True, text=True, timeout=900
    )
    return np.fromfile(out, sep=" ").reshape(-1, 5) if out.exists() else None


def _raw_consistency(path: Path) -> dict:
    b = path.read_bytes()
    i = b.index(b"Binary:\n") + len(b"Binary:\n")
    hdr = b[:i].decode(errors="replace")
    nv = int(re.search(r"No. Variables:\s*(\d+)", hdr).group(1))
    npts = int(re.search(r"No. Points:\s*(\d+)", hdr).group(1))
    nbytes = len(b) - i
    n = nbytes // (nv * 8)
    a = np.frombuffer(b[i : i + n * nv * 8], dtype="<f8").reshape(n, nv)
    return {
        "header_points": npts,
        "data_points": nbytes / (nv * 8),
        "nan_values": int(np.isnan(a).sum()),
        "time_monotone": bool(np.all(np.diff(a[:, 0]) > 0)),
        "abs_max": float(np.nanmax(np.abs(a))),
    }


def pitfalls(work: Path) -> dict:
    p = Params.make(eta="0.74")
    comp = nominal_components(p)
    res: dict = {}

    # 1. comparator into a digital bridge: overshoot vs TMAX
    rows = []
    for tm in (1e-6, 10e-6, 100e-6):
        base = spice_netlist(comp, None, 20, tm)
        row = {"tmax_s": tm}
        for tag, net in (
            ("analog (module)", base),
            ("algebraic comparator -> bridge", digital_variant(base, False)),
            ("comparator with pole -> bridge", digital_variant(base, True)),
        ):
            data, errs, _ = _ngspice(net, work / f"p1_{tag[:6]}_{tm:g}".replace(" ", "_"))
            _, x_at, _ = _toggles(data)
            row[tag] = {
                "toggles": len(x_at),
                "overshoot_median": float(np.median(x_at - 2)),
                "overshoot_max": float(np.max(x_at - 2)),
                "errors": errs[:1],
            }
        rows.append(row)
    res["digital_bridge"] = rows

    # 2. switch pairs from one node vs two nodes (ngspice S switches), flip-flop delay 14 ns
    rows = []
    for ron in ("1", "160"):
        for two in (False, True):
            net = s_switch_variant(spice_netlist(comp, {"flipflop": {}}, 20, 10e-6), two, ron)
            data, errs, _ = _ngspice(net, work / f"p2_{ron}_{two}")
            _, _, ratio = _toggles(data)
            rows.append(
                {
                    "ron": ron,
                    "drive": "two nodes" if two else "one node",
                    "toggles": len(ratio),
                    "v_ratio_median": float(np.median(ratio)),
                    "v_ratio_min": float(np.min(ratio)),
                    "errors": errs[:1],
                }
            )
    res["two_drive_nodes"] = rows

    # 3. XSPICE flip-flop: batch vs shared library (and the analogue netlist in both)
    rows = []
    base = spice_netlist(comp, None, 20, 10e-6)
    for tag, net in (
        ("XSPICE digital toggle", digital_variant(base, True)),
        ("analog (module)", base),
    ):
        batch, _, _ = _ngspice(net, work / f"p3_batch_{tag[:6]}")
        shared = _shared_library_run(net, work / f"p3_shared_{tag[:6]}")
        tb, _, _ = _toggles(batch)
        row = {
            "netlist": tag,
            "batch_toggles": len(tb),
            "batch_toggle_times_ms": [round(float(t) * 1e3, 6) for t in tb[:6]],
        }
        if shared is None:
            row["shared"] = "skipped: libngspice0 not installed (apt-get install libngspice0)"
        else:
            ts, _, _ = _toggles(shared)
            row["shared_toggles"] = len(ts)
            row["shared_toggle_times_ms"] = [round(float(t) * 1e3, 6) for t in ts[:6]]
            n = min(len(tb), len(ts))
            row["identical"] = bool(
                len(tb) == len(ts) and np.allclose(tb[:n], ts[:n], rtol=0, atol=1e-12)
            )
        rows.append(row)
    res["batch_vs_shared"] = rows

    # 4. .options interp with -r: raw file consistency
    net = re.sub(r"\.control\n.*?\.endc\n", "", spice_netlist(comp, None, 20, 10e-6), flags=re.S)
    out = {}
    for tag, n in (
        ("interp", net.replace(".options method=gear", ".options method=gear interp")),
        ("no interp", net),
    ):
        wd = work / f"p4_{tag.replace(' ', '_')}"
        wd.mkdir(parents=True, exist_ok=True)
        (wd / "c.cir").write_text(n)
        subprocess.run(
            ["ngspice", "-b", "-r", "out.raw", "c.cir"],
            cwd=wd,
            capture_output=True,
            text=True,
            timeout=600,
        )
        out[tag] = _raw_consistency(wd / "out.raw")
    res["interp_raw"] = out

    # 5. uic: first written time point
    data, _, _ = _ngspice(spice_netlist(comp, None, 2, 10e-6), work / "p5")
    res["uic_first_time_s"] = float(data[0, 0])

    # 6. trapezoidal vs gear with the 14 ns flip-flop delay, 60 periods (40 impacts expected)
    rows = []
    for method in ("trap", "gear"):
        net = spice_netlist(comp, {"flipflop": {}}, 60, 10e-6).replace(
            ".options method=gear", f".options method={method}"
        )
        data, errs, _ = _ngspice(net, work / f"p6_{method}")
        tc, _, _ = _toggles(data)
        rows.append(
            {
                "method": method,
                "toggles": len(tc),
                "pol_min": float(data[:, 3].min()),
                "pol_max": float(data[:, 3].max()),
                "errors": errs[:1],
            }
        )
    ref = HeyokaSolver("float64").solve(p, 60)
    res["trap_ringing"] = {"impacts_ref": ref.n_impacts, "rows": rows}

    # 7. Schmitt trigger with positive feedback (0.01 V hysteresis: trip at x = 2.005)
    eff = {"comparator": {"delay": "0", "hysteresis": "0.01"}}
    mod = spice_netlist(comp, eff, 20, 10e-6)
    pf = re.sub(
        r"^BU5 0 cmp I = .*$",
        "BU5 0 cmp I = 0.5*(1+tanh((-2.005+0.01*V(cmp)-V(s))/1e-06)) - V(cmp)",
        mod,
        flags=re.M,
    )
    rows = []
    for tag, net in (("set/reset cell (module)", mod), ("positive feedback", pf)):
        data, errs, _ = _ngspice(net, work / f"p7_{tag[:8].replace(' ', '_').replace('/', '_')}")
        t, s = data[:, 0], data[:, 1]
        tc, _, _ = _toggles(data)
        # deepest penetration around each reversal (accepted points up to 1 us after it)
        peaks = [float(-s[(t <= tt + 1e-6) & (t > tt - 1e-3)].min()) for tt in tc]
        rows.append(
            {
                "comparator": tag,
                "toggles": len(tc),
                "x_peak_min": min(peaks),
                "x_peak_max": max(peaks),
                "errors": errs[:1],
            }
        )
    res["schmitt"] = {"threshold_x": 2.005, "rows": rows}

    # 8. saturating op-amps as algebraic tanh B-sources
    net = spice_netlist(comp, None, 5, 10e-6)
    net = re.sub(
        r"^EU(\d) (\w+) 0 0 (\w+) 1000000000.0$",
        lambda m: f"BU{m.group(1)} {m.group(2)} 0 V = 13.5*tanh(1e9*(-V({m.group(3)}))/13.5)",
        net,
        flags=re.M,
    )
    data, errs, _ = _ngspice(net, work / "p8")
    res["algebraic_saturation"] = {
        "errors": errs[:2],
        "last_time_s": float(data[-1, 0]) if data is not None and len(data) else None,
    }
    return res


# ====================================================================== report
def markdown(result: dict) -> str:
    md = ["# ngspice backend: error and wall time against TMAX", ""]
    m = result["machine"]
    md.append(
        f"ngspice {m['ngspice']}, Python {m['python']}, {m['cpus']} CPUs; ideal parts "
        "(nominal_components of Params.make(eta=...)), `method=gear`, other ngspice options "
        "default."
    )
    md += [
        "",
        "## eta = 0.74 (period 3), 150 periods from rest",
        "",
        "Error: largest |x - x_ref| and |v - v_ref| over the last 30 stroboscopic samples "
        "(reference heyoka float64).  `ngspice` is the subprocess wall time, `total` adds "
        "netlist writing and reading the `wrdata` text.",
        "",
        "| TMAX | ngspice | total | accepted points | error x | error v | impacts (ref) | max "
        "abs(x - x_w) at reversal |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in result["tmax_074"]:
        md.append(
            f"| {r['tmax_s'] * 1e6:g} us | {r['ngspice_s']:.2f} s | {r['total_s']:.2f} s | "
            f"{r['points']} | {r['err_x_last30']:.2e} | {r['err_v_last30']:.2e} | {r['impacts']} "
            f"({r['impacts_ref']}) | {r['overshoot_max']:.1e} |"
        )
    pr = result["predictability_0712"]
    md += [
        "",
        f"## eta = 0.712 (chaotic): predictability over {pr['periods']} periods",
        "",
        f"First period k with |x_k - x_ref,k| > {pr['threshold']} (reference {pr['reference']}; "
        "heyoka float64 itself leaves float128 by > 0.1 at period "
        f"{pr['heyoka_float64_first_period_off']}).",
        "",
        "| TMAX | ngspice | first period off | max error, periods 0-10 |",
        "|---:|---:|---:|---:|",
    ]
    for r in pr["rows"]:
        k = r["first_period_off"] if r["first_period_off"] is not None else f"> {pr['periods']}"
        md.append(
            f"| {r['tmax_s'] * 1e6:g} us | {r['ngspice_s']:.2f} s | {k} | {r['err_first_10']:.1e} |"
        )
    pf = result.get("pitfalls")
    if pf:
        md += [
            "",
            "## Pitfalls (ngspice 39.3), re-measured",
            "",
            "### 1. Comparator straight into an XSPICE digital bridge (20 periods, eta = 0.74; 13 "
            "impacts expected)",
            "",
            "| TMAX | netlist | toggles | median x - x_w at reversal | max |",
            "|---:|---|---:|---:|---:|",
        ]
        for row in pf["digital_bridge"]:
            for tag, v in row.items():
                if tag == "tmax_s":
                    continue
                md.append(
                    f"| {row['tmax_s'] * 1e6:g} us | {tag} | {v['toggles']} | "
                    f"{v['overshoot_median']:.1e} | {v['overshoot_max']:.1e} |"
                )
        md += [
            "",
            "### 2. Switch pairs driven from one node vs two nodes (ngspice S switches, flip-flop "
            "delay 14 ns)",
            "",
            "`|v+/v-|` per impact (1 = no loss).",
            "",
            "| R_on | drive | toggles | median | min |",
            "|---:|---|---:|---:|---:|",
        ]
        for r in pf["two_drive_nodes"]:
            md.append(
                f"| {r['ron']} Ohm | {r['drive']} | {r['toggles']} | {r['v_ratio_median']:.4f} | "
                f"{r['v_ratio_min']:.4f} |"
            )
        md += [
            "",
            "### 3. Batch (`ngspice -b`) vs shared library (libngspice via ctypes), 20 periods, "
            "TMAX = 10 us",
            "",
        ]
        for r in pf["batch_vs_shared"]:
            if "shared_toggles" in r:
                md.append(
                    f"* {r['netlist']}: batch {r['batch_toggles']} toggles, shared "
                    f"{r['shared_toggles']}; identical: {r['identical']}.  First toggle times "
                    f"[ms]: batch {r['batch_toggle_times_ms']}, shared "
                    f"{r['shared_toggle_times_ms']}"
                )
            else:
                md.append(
                    f"* {r['netlist']}: batch {r['batch_toggles']} toggles; shared: {r['shared']}"
                )
        ir = pf["interp_raw"]
        md += [
            "",
            "### 4. `.options interp` with `-r` (binary raw file)",
            "",
            "| options | header points | data points (bytes / 8 / vars) | NaN values | time "
            "monotone |",
            "|---|---:|---:|---:|---|",
        ]
        for k, v in ir.items():
            md.append(
                f"| {k} | {v['header_points']} | {v['data_points']:.1f} | {v['nan_values']} | "
                f"{v['time_monotone']} |"
            )
        md += [
            "",
            f"### 5. `uic`: first written time point {pf['uic_first_time_s']:.3g} s (no t = 0 row)",
            "",
            "### 6. Trapezoidal ringing (flip-flop delay 14 ns, 60 periods, "
            f"{pf['trap_ringing']['impacts_ref']} impacts in the reference)",
            "",
            "| method | toggles | min pol | max pol |",
            "|---|---:|---:|---:|",
        ]
        for r in pf["trap_ringing"]["rows"]:
            md.append(
                f"| {r['method']} | {r['toggles']} | {r['pol_min']:.3f} | {r['pol_max']:.3f} |"
            )
        md += [
            "",
            f"### 7. Hysteresis 0.01 V (trip threshold x = {pf['schmitt']['threshold_x']}), 20 "
            "periods",
            "",
            "| comparator | toggles | deepest x around each reversal: min | max |",
            "|---|---:|---:|---:|",
        ]
        for r in pf["schmitt"]["rows"]:
            md.append(
                f"| {r['comparator']} | {r['toggles']} | {r['x_peak_min']:.5f} | "
                f"{r['x_peak_max']:.5f} |"
            )
        a = pf["algebraic_saturation"]
        md += [
            "",
            "### 8. Op-amps as algebraic `13.5 tanh(1e9 (V+ - V-)/13.5)` B-sources",
            "",
            f"ngspice: {'; '.join(a['errors']) or 'no error'} (last time point {a['last_time_s']} "
            "s of 0.042 s).",
        ]
    return "\n".join(md) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="TMAX 100, 30, 10 us only")
    ap.add_argument("--no-pitfalls", action="store_true", help="skip the pitfall experiments")
    args = ap.parse_args()
    if shutil.which("ngspice") is None:
        print("ngspice not installed: apt-get install ngspice", file=sys.stderr)
        return 2
    tmaxes = TMAXES[:3] if args.quick else TMAXES
    ver = subprocess.run(["ngspice", "-v"], capture_output=True, text=True).stdout
    m = re.search(r"ngspice-(\S+)", ver)
    result = {
        "machine": {
            "python": platform.python_version(),
            "cpus": os.cpu_count(),
            "ngspice": m.group(1) if m else "?",
            "processor": platform.processor(),
        },
        "tmax_074": tmax_table(tmaxes),
        "predictability_0712": predictability(tmaxes),
    }
    if not args.no_pitfalls:
        with tempfile.TemporaryDirectory(prefix="bench_spice_") as tmp:
            result["pitfalls"] = pitfalls(Path(tmp))
    OUT.mkdir(parents=True, exist_ok=True)
    text = json.dumps(result, indent=2)
    atomic_write(OUT / "spice_tmax.json", lambda fh: fh.write(text), binary=False)
    md = markdown(result)
    atomic_write(OUT / "spice_tmax.md", lambda fh: fh.write(md), binary=False)
    print(md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
