"""``precise-impact reproduce``: the main job, the paper's Figs. 4-7, LLE, sync thresholds."""

from __future__ import annotations

import argparse

from precise_impact.cli.args import add_out, add_units
from precise_impact.verification.reproduce import OUTPUT_FILES, RUNS, reproduce


def register(sub) -> argparse.ArgumentParser:
    """Add ``reproduce`` to ``sub``."""
    rp = sub.add_parser(
        "reproduce", help="the main job: the paper's Figs. 4-7, LLE, sync thresholds, report.md"
    )
    add_out(
        rp,
        "dir",
        "write report.md, report.json and the figures here (default results)",
        default="results",
        writes=OUTPUT_FILES,
    )
    q, f = RUNS[True], RUNS[False]
    rp.add_argument(
        "--quick",
        action="store_true",
        help=f"shorter runs: {q['periods']} instead of {f['periods']} periods per figure, "
        f"{q['sync_periods']} instead of {f['sync_periods']} per Fig. 7 run, {q['ensemble']} "
        f"instead of {f['ensemble']} slave starts per k",
    )
    add_units(rp)
    rp.set_defaults(run=run)
    return rp


def run(ns: argparse.Namespace) -> int:
    """Run ``reproduce``; returns the exit status."""
    res = reproduce(ns.out, quick=ns.quick, progress=True, units=ns.units)
    print(f"report: {ns.out}/report.md ({res['elapsed_s']:.0f} s)")
    for fig, row in res["figures"].items():
        print(
            f"Fig. {fig} eta={row['eta']}: "
            + ", ".join(f"{n} {m['max_error_second_half']:.1e}" for n, m in row["models"].items())
        )
    v = res["lle"]["variational"]
    print(
        f"LLE(0.712) = {v[0]:.4f} +- {v[1]:.4f}; sync k*: "
        + ", ".join(f"{f} {s['k_star']:.4f}" for f, s in res["sync"].items())
    )
    return 0
