"""``precise-impact reproduce``: the main job, the paper's Figs. 4-7, LLE, sync thresholds."""

from __future__ import annotations

import argparse

from precise_impact.cli.args import add_out, add_units
from precise_impact.verification.reproduce import reproduce


def register(sub) -> argparse.ArgumentParser:
    """Add ``reproduce`` to ``sub``."""
    rp = sub.add_parser(
        "reproduce", help="the main job: the paper's Figs. 4-7, LLE, sync thresholds, report.md"
    )
    add_out(rp, "dir", "output directory (default results)", default="results")
    rp.add_argument("--quick", action="store_true", help="shorter runs (about a minute)")
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
