"""``precise-impact sync``: the master-slave synchronisation threshold against the LLE (Fig. 7)."""

from __future__ import annotations

import argparse
from pathlib import Path

from precise_impact.analysis.sync import MAX_ENSEMBLE, plot_fig7, plot_sync_fraction, sync_scan
from precise_impact.cli.args import (
    add_json,
    add_max_time,
    add_out,
    add_param_flags,
    add_periods,
    add_units,
    max_time,
    params_from,
)
from precise_impact.core.params import check_count, exact_grid
from precise_impact.io.jsonout import print_json, write_json
from precise_impact.solvers.heyoka.coupled import check_form, check_k


def register(sub) -> argparse.ArgumentParser:
    """Add ``sync`` to ``sub``."""
    sy = sub.add_parser(
        "sync", help="master-slave synchronisation threshold against the LLE (paper Fig. 7)"
    )
    sy.add_argument(
        "--form", default="first-order", help="first-order, paper or reduced (default first-order)"
    )
    sy.add_argument(
        "--k",
        nargs=3,
        default=["0.02", "0.045", "6"],
        metavar=("MIN", "MAX", "N"),
        help="coupling grid (default 0.02 0.045 6)",
    )
    add_param_flags(sy)
    add_periods(
        sy, "500", "forcing periods per run", metavar="P", default_text="default 500, as the paper"
    )
    sy.add_argument(
        "--ensemble", default="8", metavar="M", help="slave initial conditions per k (default 8)"
    )
    sy.add_argument(
        "--seed", default="0", metavar="S", help="seed of the initial conditions (default 0)"
    )
    sy.add_argument(
        "--fig7",
        nargs=2,
        default=["0.031", "0.032"],
        metavar=("K1", "K2"),
        help="couplings of the Fig. 7 plot (default the paper's 0.031 0.032)",
    )
    add_out(
        sy,
        "dir",
        "write sync_<form>.json, sync_<form>_fraction.png, sync_<form>_fig7.png here "
        "(default results)",
        default="results",
        writes=lambda ns: (f"sync_{ns.form}.json", f"sync_{ns.form}_*.png"),
    )
    sy.add_argument(
        "--model",
        "--engine",  # the 0.2 name
        dest="model",
        choices=("fast", "heyoka"),
        default="fast",
        help="fast (compiled closed forms, float64; default) or heyoka (Taylor integration)",
    )
    add_json(sy)
    add_max_time(sy)
    add_units(sy)
    sy.set_defaults(run=run)
    return sy


def run(ns: argparse.Namespace) -> int:
    """Run ``sync``; returns the exit status."""
    params = params_from(ns)
    form = check_form(ns.form)
    ks = exact_grid(ns.k[0], ns.k[1], ns.k[2], "k")
    periods = check_count(ns.periods)
    ensemble = check_count(ns.ensemble, "ensemble", MAX_ENSEMBLE, minimum=1)
    seed = check_count(ns.seed, "seed", 2**32)
    k1, k2 = check_k(ns.fig7[0], "fig7"), check_k(ns.fig7[1], "fig7")
    res = sync_scan(
        params,
        form,
        ks,
        periods=periods,
        ensemble=ensemble,
        seed=seed,
        progress=not ns.json,
        model=ns.model,
        max_time=max_time(ns),
    )
    out = Path(ns.out)
    stem = f"sync_{form}"
    write_json(out / f"{stem}.json", res.to_dict(), indent=1)
    plot_sync_fraction(res, out / f"{stem}_fraction.png")
    plot_fig7(params, form, k1, k2, periods, out / f"{stem}_fig7.png", units=ns.units)
    if ns.json:
        obj = res.to_dict()
        obj.pop("runs", None)
        print_json(obj)
        return 0
    print(
        f"form {form}: {periods} periods, ensemble {ensemble}, sync = |x - y| < "
        f"{res.threshold:g} over the last {res.tail:.0%} of the run"
    )
    print(f"{'k':>8} {'synchronised':>12} {'intermittent':>12} {'rate + k':>9}")
    for k, fs, fi, r in zip(
        res.k_values,
        res.fraction_synchronised,
        res.fraction_intermittent,
        res.mean_rate,
        strict=False,
    ):
        print(f"{float(k):8.4f} {fs:12.3f} {fi:12.3f} {r + float(k):9.4f}")
    print(f"threshold k* = {res.k_star:.4f} +- {res.k_star_err:.4f} ({res.message})")
    lle_method = "fast" if ns.model == "fast" else "variational"
    print(f"LLE ({lle_method}) = {res.lle:.4f} +- {res.lle_stderr:.4f}")
    print(
        f"written: {out / (stem + '.json')}, {out / (stem + '_fraction.png')}, "
        f"{out / (stem + '_fig7.png')}"
    )
    return 0
