"""``precise-impact orbit``: a periodic orbit by Newton's method, its multipliers and exact LLE."""

from __future__ import annotations

import argparse

from precise_impact.analysis.orbits import find_orbit
from precise_impact.cli.args import (
    add_json,
    add_max_time,
    add_orbit_flags,
    add_param_flags,
    add_precision,
    max_time,
    orbit_params_from,
)
from precise_impact.core.params import check_count
from precise_impact.io.jsonout import print_json


def register(sub) -> argparse.ArgumentParser:
    """Add ``orbit`` to ``sub``."""
    ob = sub.add_parser(
        "orbit",
        help="a periodic orbit by Newton's method: its point, impacts, Floquet "
        "multipliers, stability and exact LLE",
    )
    add_param_flags(ob)
    add_orbit_flags(ob, "")
    add_precision(ob, "float64 or mp:BITS (Newton refined to that precision)")
    add_max_time(ob)
    ob.add_argument(
        "--guess-from",
        "--seed",  # the 0.2 name
        dest="guess_from",
        default="auto",
        choices=("auto", "simulation", "closed-form"),
        help="where Newton starts without --guess: the closed-form orbit with one impact per P "
        "periods (closed-form), the state after --transient periods (simulation), or auto: the "
        "closed form when --impacts 1 is given and one exists, else the simulation "
        "(default auto)",
    )
    add_json(
        ob,
        "print one JSON object to stdout (state.x and state.v: JSON numbers in float64, decimal "
        "strings with every digit at mp:BITS; stability: stable, unstable or elliptic)",
    )
    ob.set_defaults(run=run)
    return ob


def run(ns: argparse.Namespace) -> int:
    """Run ``orbit``; returns the exit status."""
    params = orbit_params_from(ns)
    period = check_count(ns.period, "period", 1000, minimum=1)
    impacts = None if ns.impacts is None else check_count(ns.impacts, "impacts", 10**6)
    o = find_orbit(
        params,
        period,
        guess=ns.guess,
        impacts=impacts,
        transient=check_count(ns.transient, "transient"),
        precision=ns.precision,
        guess_from=ns.guess_from,
        max_time=max_time(ns),
    )
    if ns.json:
        print_json(o.to_dict())
        return 0
    mus = ", ".join(
        f"{m.real:.12g}{m.imag:+.12g}i" if m.imag else f"{m.real:.12g}" for m in o.multipliers
    )
    st = o.to_dict()["state"]
    print(
        f"period-{o.period} orbit with {o.impacts} impact(s): x = {st['x']}, v = {st['v']} "
        f"at t = {o.t!r} ({o.precision})"
    )
    kind = o.stability + (
        " (neutral: zeta = 0 and R = 1 make det M = 1, the pair on the unit circle)"
        if o.stability == "elliptic"
        else ""
    )
    print(f"Floquet multipliers {mus}: {kind}; LLE = ln|mu_max| / (p T) = {o.lle:.10g}")
    print(f"residual |P^p(z) - z| = {o.residual:.3g} after {o.iterations} Newton iteration(s)")
    return 0
