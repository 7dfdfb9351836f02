"""``precise-impact bifurcation``: stroboscopic x against eta with the LLE beneath."""

from __future__ import annotations

import argparse

from precise_impact.analysis.bifurcation import bifurcation
from precise_impact.cli.args import (
    add_max_time,
    add_out,
    add_param_flags,
    add_periods,
    max_time,
    params_from,
)
from precise_impact.core.params import check_count


def register(sub) -> argparse.ArgumentParser:
    """Add ``bifurcation`` to ``sub``."""
    b = sub.add_parser(
        "bifurcation", help="stroboscopic x against eta with the LLE beneath (PNG + NPZ)"
    )
    b.add_argument(
        "--eta", nargs=3, required=True, metavar=("MIN", "MAX", "N"), help="eta grid: MIN MAX N"
    )
    add_param_flags(b, exclude=("eta",), title="other system parameters (exact decimals)")
    add_periods(b, "2000", "measured periods per value", metavar="P")
    b.add_argument(
        "--transient",
        default="1000",
        metavar="T",
        help="transient periods per value (default 1000)",
    )
    b.add_argument(
        "--workers", default=None, metavar="W", help="worker processes (default: all cores)"
    )
    add_out(
        b,
        "dir",
        "write bifurcation.png and bifurcation.npz here",
        required=True,
        writes=("bifurcation.png", "bifurcation.npz"),
    )
    add_max_time(b)
    b.set_defaults(run=run)
    return b


def run(ns: argparse.Namespace) -> int:
    """Run ``bifurcation``; returns the exit status."""
    params = params_from(ns, exclude=("eta",))
    workers = None if ns.workers is None else check_count(ns.workers, "workers", 1024)
    check_count(ns.eta[2], "n", 1_000_000, minimum=1)
    res = bifurcation(
        params,
        ("eta", ns.eta[0], ns.eta[1], ns.eta[2]),
        periods=ns.periods,
        transient=ns.transient,
        workers=workers,
        progress=True,
        max_time=max_time(ns),
    )
    files = res.save_all(ns.out)
    grazing = ", ".join(f"{g:.6f}" for g in res.grazing) or "none in range"
    print(
        f"{len(res.eta)} values of eta in {res.elapsed_s:.1f} s on {res.workers} worker(s); "
        f"grazing eta (closed form): {grazing}"
    )
    refused = [(e, why) for e, why in zip(res.eta, res.status, strict=True) if why != "ok"]
    if refused:  # values refused per point (status in the npz), never a wrong number
        e, why = refused[0]
        print(f"{len(refused)} of {len(res.eta)} values refused (eta = {float(e):g}: {why})")
    ok = res.lle[[why == "ok" for why in res.status]]
    lle_range = f"{ok.min():.4f} .. {ok.max():.4f}" if len(ok) else "none"
    print(f"LLE range: {lle_range}; written: {files['png']}, {files['npz']}")
    return 0
