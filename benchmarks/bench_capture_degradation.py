"""How the capture scores degrade with ADC bits, noise and record length (issue 24).

Run:  python benchmarks/bench_capture_degradation.py [--quick] [--out DIR]

Writes ``capture_degradation.{json,md,png}`` (default ``benchmarks/results/``).  Around the
issue's bench (the ideal circuit of ``fig6-period3-ideal`` through an 8-bit ADC with 1 % white
noise, 200 forcing periods, 20 kSa/s) one of bits, noise or record length is varied at a time;
for each value and each of ``--seeds`` seeds (independent records: seed k starts after
``100 + 450 k`` forcing periods, so no two records of a point share a stretch of the attractor,
and draws its own noise):

* ``freq_err_v3`` / ``freq_err_vs``: the largest relative error of the forcing frequency from
  ``V_3`` / from ``V_s`` alone, over the seeds and eta = 0.74 and 0.712;
* ``period3_rate``: the fraction of records at eta = 0.74 whose detected period is 3;
* ``false_period_rate``: the fraction at eta = 0.712 (chaotic) where a period is detected;
* ``sep_ratio``: the datasheet switched-capacitor capture (``fig6-period2-datasheet``) scored
  against the ideal model: sliced Wasserstein distance / the largest floor pair
  (> SEPARATION_THRESHOLD = 3: ``separated``), at eta = 0.74 and at 0.712 (the first seed);
* ``same_ratio``: an ideal capture scored against the ideal model, the same ratio (< 3 when the
  floor is honest).

A fourth axis adds 1/f noise (of full scale) to the bench's white noise.
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import numpy as np

from precise_impact.io.atomic import atomic_write
from precise_impact.io.jsonout import write_json
from precise_impact.io.markdown import table
from precise_impact.lab.attractor import (
    SEPARATION_THRESHOLD,
    analyse_capture,
    estimate_forcing,
    score_capture,
)
from precise_impact.lab.capture import Capture
from precise_impact.lab.synth import synth_capture

OUT = Path(__file__).resolve().parent / "results"
#: The docs' text on these figures, generated from the JSON (tests/lab check it is current).
DOC = Path(__file__).resolve().parents[1] / "docs" / "guide" / "capture_degradation.inc"
IDEAL, DATASHEET = "fig6-period3-ideal", "fig6-period2-datasheet"
BASE = {"bits": 8, "noise": 0.01, "periods": 200, "flicker": 0.0}
AXES = {
    "bits": [4, 5, 6, 8, 10, 12],
    "noise": [0.001, 0.003, 0.01, 0.03, 0.1],
    "periods": [25, 50, 100, 200, 400],
    "flicker": [0.0, 0.003, 0.01, 0.03],
}
QUICK_AXES = {"bits": [4, 8], "noise": [0.01, 0.1], "periods": [50, 200]}


def _rel(f, c: Capture) -> float:
    return abs(f.omega / c.source["truth"]["forcing_omega_rad_s"] - 1)


def point(meas: dict, seeds: int) -> dict:
    """The figures for one measurement model."""
    t0 = time.perf_counter()
    errs3, errs_s, p3, pfalse = [], [], [], []
    first = {}
    for seed in range(seeds):
        for eta in ("0.74", "0.712"):
            # a stretch of its own (records up to 400 periods: 450 apart) and its own noise
            c = synth_capture(IDEAL, eta=eta, seed=100 + seed, transient=100 + 450 * seed, **meas)
            errs3.append(_rel(estimate_forcing(c, 740.0), c))
            no3 = Capture.make(c.t, c.V_s, c.V_q, source=c.source)
            errs_s.append(_rel(estimate_forcing(no3, 740.0), c))
            per = analyse_capture(c, IDEAL)["period"]
            (p3 if eta == "0.74" else pfalse).append(per == 3 if eta == "0.74" else per != 0)
            if seed == 0:
                first[eta] = c
    ratios = {}
    for eta in ("0.74", "0.712"):
        ds = synth_capture(DATASHEET, eta=eta, seed=200, **meas)
        s = score_capture(ds, IDEAL, eta=eta, floor_captures=3, seed=300, lle=False)
        ratios[eta] = s.sliced_wasserstein / s.sw_floor_max
    same = score_capture(first["0.74"], IDEAL, floor_captures=3, seed=300, lle=False)
    return {
        **meas,
        "freq_err_v3": float(max(errs3)),
        "freq_err_vs": float(max(errs_s)),
        "period3_rate": float(np.mean(p3)),
        "false_period_rate": float(np.mean(pfalse)),
        "sep_ratio_074": float(ratios["0.74"]),
        "sep_ratio_0712": float(ratios["0.712"]),
        "same_ratio_074": float(same.sliced_wasserstein / same.sw_floor_max),
        "elapsed_s": time.perf_counter() - t0,
    }


def plot(rows: list[dict], path: Path) -> None:
    from matplotlib.ticker import NullFormatter

    from precise_impact.io.figures import new_figure, save_figure

    fig, axes = new_figure(3, len(AXES), figsize=(4.0 * len(AXES), 9.0))
    for j, axis in enumerate(AXES):
        rs = [r for r in rows if r["axis"] == axis]
        if not rs:
            continue
        x = [r[axis] for r in rs]
        ax = axes[0, j]
        ax.semilogy(x, [max(r["freq_err_v3"], 1e-12) for r in rs], "o-", label="from V_3")
        ax.semilogy(x, [max(r["freq_err_vs"], 1e-12) for r in rs], "s--", label="from V_s only")
        ax.axhline(1e-4, color="k", lw=0.8, ls=":", label="target 1e-4")
        ax.set_ylabel("largest relative frequency error")
        if j == 0:
            ax.legend(fontsize=8, loc="center right")
        ax = axes[1, j]
        ax.plot(x, [r["period3_rate"] for r in rs], "o-", label="period 3 found at eta 0.74")
        ax.plot(x, [r["false_period_rate"] for r in rs], "x--", label="a period claimed at 0.712")
        ax.set_ylim(-0.05, 1.05)
        ax.set_ylabel("fraction of records")
        if j == 0:
            ax.legend(fontsize=8, loc="center right")
        ax = axes[2, j]
        ax.semilogy(x, [r["sep_ratio_074"] for r in rs], "o-", label="datasheet vs ideal, 0.74")
        ax.semilogy(x, [r["sep_ratio_0712"] for r in rs], "s-", label="datasheet vs ideal, 0.712")
        ax.semilogy(x, [r["same_ratio_074"] for r in rs], "x--", label="ideal vs ideal, 0.74")
        ax.axhline(2, color="k", lw=0.8, ls=":", label="separated above 2")
        ax.set_ylabel("SW distance / largest floor")
        ax.set_xlabel(
            {
                "bits": "ADC bits",
                "noise": "white noise / full scale",
                "periods": "record length [forcing periods]",
                "flicker": "1/f noise / full scale (symlog)",
            }[axis]
        )
        if j == 0:  # the same lines in every column: one legend per row
            ax.legend(fontsize=7, loc="center right")
        if axis in ("noise", "periods"):
            for a in axes[:, j]:
                a.set_xscale("log")
        elif axis == "flicker":
            for a in axes[:, j]:
                a.set_xscale("symlog", linthresh=1e-3)
        for a in axes[:, j]:
            a.grid(alpha=0.3, which="major")
            a.set_xticks(x)
            a.set_xticklabels([f"{v:g}" for v in x], fontsize=8)
            a.xaxis.set_minor_formatter(NullFormatter())
        if axis == "flicker":
            for a in axes[:, j]:
                a.set_xlim(-2e-4, max(x) * 1.3)
        axes[0, j].set_title(f"varying {axis}", fontsize=10)
    fig.suptitle(
        "capture scores against bits, white noise, record length and 1/f noise, one at a time "
        "around 8 bits, 1 % white noise, 200 periods, no 1/f noise (ideal circuit, eta 0.74 / "
        "0.712, 20 kSa/s)",
        fontsize=11,
    )
    save_figure(fig, path, dpi=110)


def _fmt(v: float) -> str:
    return f"{v:.2g}" if v < 0.01 else f"{v:.3g}"


def degradation_rst(data: dict) -> str:
    """The docs' paragraph and table on ``data`` (the benchmark's JSON), every figure from it."""
    rows = data["rows"]
    base = [r for r in rows if all(r[k] == v for k, v in data["base"].items())]
    b = base[0]
    n = data["seeds"]
    label = {a: a for a in AXES}

    def where(pred) -> str:
        hits = [f"{label[r['axis']]} = {r[r['axis']]:g}" for r in rows if pred(r)]
        return ", ".join(dict.fromkeys(hits)) or "none"

    lines = [
        f"At the bench ({b['bits']} bits, {b['noise'] * 100:g} % white noise, "
        f"{b['periods']:g} periods, no 1/f noise) the largest relative error of the forcing "
        f"frequency over {n} records at eta = 0.74 and 0.712 is {_fmt(b['freq_err_v3'])} "
        "from ``V_3`` and "
        f"{_fmt(b['freq_err_vs'])} from ``V_s`` alone (target 1e-4); period 3 is found at 0.74 "
        f"in {b['period3_rate'] * n:.0f} of {n} records and a period is claimed at 0.712 in "
        f"{b['false_period_rate'] * n:.0f}; the datasheet capture lies "
        f"{_fmt(b['sep_ratio_074'])} times the largest floor from the ideal model at 0.74 "
        f"({_fmt(b['sep_ratio_0712'])} at 0.712), an ideal capture {_fmt(b['same_ratio_074'])} "
        "times.",
        "",
        "Away from the bench: the frequency error exceeds 1e-4 from ``V_3`` at: "
        + where(lambda r: r["freq_err_v3"] >= 1e-4)
        + ", from ``V_s`` alone at: "
        + where(lambda r: r["freq_err_vs"] >= 1e-4)
        + "; period 3 is missed in some record at: "
        + where(lambda r: r["period3_rate"] < 1)
        + "; a period is claimed in the chaos at: "
        + where(lambda r: r["false_period_rate"] > 0)
        + f"; the datasheet capture is not separated (ratio <= {SEPARATION_THRESHOLD:g}) at: "
        + where(lambda r: min(r["sep_ratio_074"], r["sep_ratio_0712"]) <= SEPARATION_THRESHOLD)
        + "; an ideal capture is wrongly separated at: "
        + where(lambda r: r["same_ratio_074"] > SEPARATION_THRESHOLD)
        + ".  A period ``p`` is tested only on records of at least ``3 p`` periods.",
        "",
    ]
    head = [
        "varied",
        "f err (V_3)",
        "f err (V_s)",
        "period 3 found",
        "period at 0.712",
        "datasheet/floor 0.74",
        "datasheet/floor 0.712",
        "ideal/floor",
    ]
    body = [
        [
            f"{r['axis']} = {r[r['axis']]:g}",
            _fmt(r["freq_err_v3"]),
            _fmt(r["freq_err_vs"]),
            f"{r['period3_rate'] * n:.0f}/{n}",
            f"{r['false_period_rate'] * n:.0f}/{n}",
            _fmt(r["sep_ratio_074"]),
            _fmt(r["sep_ratio_0712"]),
            _fmt(r["same_ratio_074"]),
        ]
        for r in rows
    ]
    widths = [max(len(str(c)) for c in col) for col in zip(head, *body, strict=True)]
    rule = "  ".join("=" * w for w in widths)
    lines += [
        rule,
        "  ".join(h.ljust(w) for h, w in zip(head, widths, strict=True)).rstrip(),
        rule,
    ]
    lines += [
        "  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)).rstrip() for row in body
    ]
    lines += [rule, ""]
    return "\n".join(lines)


def degradation_md(out: dict) -> str:
    """The Markdown report of ``out`` (the benchmark's JSON)."""
    cols = ["axis", "bits", "noise", "periods", "flicker", "freq_err_v3", "freq_err_vs"]
    cols += ["period3_rate", "false_period_rate", "sep_ratio_074", "sep_ratio_0712"]
    cols += ["same_ratio_074"]
    rows = out["rows"]
    md = [
        "# Capture scores against bits, noise, record length and 1/f noise",
        "",
        f"`python benchmarks/bench_capture_degradation.py{' --quick' if out['quick'] else ''}`, "
        f"{out['seeds']} seeds per point, {out['elapsed_s']:.0f} s. Base: 8-bit ADC, 1 % white "
        "noise (of full scale), 200 forcing periods, no 1/f noise, 20 kSa/s, ideal circuit of "
        "fig6-period3-ideal. freq_err: largest relative error of the forcing frequency (eta "
        "0.74 and 0.712, every seed); period3_rate: records at 0.74 with period 3 detected; "
        "false_period_rate: records at 0.712 with a period claimed; sep_ratio: datasheet "
        "switched-capacitor capture vs the ideal model, SW / largest floor (separated > "
        f"{SEPARATION_THRESHOLD:g}); "
        "same_ratio: an ideal capture vs the ideal model.",
        "",
        *table(
            cols,
            [[f"{r[c]:.3g}" if isinstance(r[c], float) else r[c] for c in cols] for r in rows],
        ),
    ]
    return "\n".join(md) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="2 values per axis, 2 seeds")
    ap.add_argument("--seeds", type=int, default=None, help="records per point (default 5)")
    ap.add_argument("--out", type=Path, default=OUT)
    args = ap.parse_args(argv)
    axes = QUICK_AXES if args.quick else AXES
    seeds = args.seeds or (2 if args.quick else 5)
    t0 = time.perf_counter()
    rows = []
    done: dict[tuple, dict] = {}  # the bench itself is on every axis: measured once
    for axis, values in axes.items():
        for v in values:
            meas = dict(BASE, **{axis: v})
            key = tuple(sorted(meas.items()))
            if key not in done:
                done[key] = point(meas, seeds)
            r = dict(done[key], axis=axis)
            rows.append(r)
            print(
                f"{axis}={v}: f err {r['freq_err_v3']:.2e} (V_s {r['freq_err_vs']:.2e}), "
                f"period3 {r['period3_rate']:.2f}, false {r['false_period_rate']:.2f}, "
                f"sep {r['sep_ratio_074']:.3g}/{r['sep_ratio_0712']:.3g}, "
                f"same {r['same_ratio_074']:.3g} ({r['elapsed_s']:.1f} s)",
                file=sys.stderr,
            )
    out = {
        "base": BASE,
        "seeds": seeds,
        "quick": args.quick,
        "sample_rate": 20000.0,
        "rows": rows,
        "elapsed_s": time.perf_counter() - t0,
        "machine": platform.platform(),
    }
    args.out.mkdir(parents=True, exist_ok=True)
    write_json(args.out / "capture_degradation.json", out)
    md = degradation_md(out)
    atomic_write(args.out / "capture_degradation.md", lambda fh: fh.write(md), binary=False)
    plot(rows, args.out / "capture_degradation.png")
    if args.out == OUT and not args.quick:
        atomic_write(DOC, lambda fh: fh.write(degradation_rst(out)), binary=False)
    print(f"written: {args.out}/capture_degradation.{{json,md,png}}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
