"""``precise-impact lle``: the largest Lyapunov exponent (variational, two-trajectory or fast)."""

from __future__ import annotations

import argparse
import sys

from precise_impact.analysis.lyapunov import lyapunov
from precise_impact.cli.args import (
    add_json,
    add_max_time,
    add_param_flags,
    add_periods,
    add_precision,
    max_time,
    params_from,
)
from precise_impact.core.params import check_count
from precise_impact.errors import Interrupted
from precise_impact.io.jsonout import print_json


def register(sub) -> argparse.ArgumentParser:
    """Add ``lle`` to ``sub``."""
    ly = sub.add_parser(
        "lle", help="largest Lyapunov exponent (variational with saltation, or two-trajectory)"
    )
    add_param_flags(ly)
    add_periods(ly, "20000", "measured forcing periods")
    ly.add_argument(
        "--transient",
        default="1000",
        metavar="N",
        help="discarded transient periods (default 1000)",
    )
    add_max_time(ly)
    ly.add_argument(
        "--method",
        default="variational",
        help="the algorithm: variational or two-trajectory (default variational; 'fast' is the "
        "deprecated spelling of --method variational --model fast)",
    )
    ly.add_argument(
        "--model",
        default="heyoka",
        help="the engine: heyoka (every precision) or fast (the variational method on the "
        "compiled closed form, float64) (default heyoka)",
    )
    add_precision(ly, "float64, longdouble, float128 or mp:BITS")
    add_json(ly)
    ly.set_defaults(run=run)
    return ly


def run(ns: argparse.Namespace) -> int:
    """Run ``lle``; returns the exit status."""
    params = params_from(ns)
    periods = check_count(ns.periods)
    transient = check_count(ns.transient, "transient")
    method, model = ns.method, ns.model
    if method == "fast":  # the 0.2 spelling
        print(
            "precise-impact: --method fast is deprecated, use --method variational --model fast",
            file=sys.stderr,
        )
        method, model = "variational", "fast"
    try:
        r = lyapunov(
            params,
            method,
            model=model,
            periods=periods,
            transient=transient,
            precision=ns.precision,
            progress=not ns.json,
            max_time=max_time(ns),
        )
    except Interrupted as e:  # say how far it got (nothing is written: no file to keep)
        e.kept = str(e)  # type: ignore[attr-defined]
        raise
    if ns.json:
        print_json(r.to_dict())
        return 0
    spec = "" if r.spectrum is None else f"  spectrum = ({r.spectrum[0]:.6f}, {r.spectrum[1]:.6f})"
    print(
        f"LLE = {r.lle:.6f} +- {r.lle_stderr:.6f} per unit time ({r.method}, {r.precision}){spec}"
    )
    groups = r.stats.get("attractors", [])
    head = next((g for g in groups if g["id"] == r.stats.get("headline_attractor")), None)
    if r.stats.get("lle_source") == "floquet" and head is not None:
        ft = r.stats["finite_time"]
        print(
            f"periodic attractor: period {head['period']}, {head['impacts']} impact(s); the LLE "
            f"is its Floquet value ln|mu_max| / (p T) (finite-time estimate {ft['lle']:.6f} +- "
            f"{ft['stderr']:.2g}, 1/t offset included)"
        )
    if "warning" in r.stats:
        print("warning: " + r.stats["warning"])
    if len(r.stats.get("per_start", [])) > 1:
        for j, s in enumerate(r.stats["per_start"]):
            rate = s.get("impact_rate")
            print(
                f"  start {j}: LLE {s['lle']:.6f} +- {s['stderr']:.2g}, "
                + (f"{rate:.4f} impacts/period, " if rate is not None and rate == rate else "")
                + f"attractor #{s.get('attractor')}"
            )
    refined = r.stats.get("refined_flights")
    print(
        f"{r.periods} periods after {r.transient} transient, {r.n_impacts} impacts, "
        + ("" if refined is None else f"{refined} flights refined in double-double, ")
        + f"{r.elapsed_s:.3f} s"
    )
    return 0
