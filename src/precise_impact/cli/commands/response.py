"""``precise-impact response``: the (1,n) response curve, impact velocity against x_w or eta."""

from __future__ import annotations

import argparse

from precise_impact.analysis.impact_surface.response import response_curve
from precise_impact.cli.args import (
    PARAM_FLAGS,
    add_json,
    add_max_time,
    add_out,
    add_param_flags,
    max_time,
    orbit_params_from,
)
from precise_impact.errors import ParameterError
from precise_impact.io.jsonout import print_json


def register(sub) -> argparse.ArgumentParser:
    """Add ``response`` to ``sub``."""
    rp = sub.add_parser(
        "response",
        help="(1,n) response curve: impact velocity V against x_w (sigma) or eta (omega), "
        "stable / unstable / unphysical / virtual parts, folds, period-doublings, grazings",
    )
    rp.add_argument(
        "--param",
        nargs=3,
        required=True,
        metavar=("NAME", "FROM", "TO"),
        help="x_w or eta and its range",
    )
    rp.add_argument("--n", default="1", metavar="N", help="forcing periods per impact (default 1)")
    rp.add_argument(
        "--at",
        default=None,
        metavar="VALUE",
        help="where in the range the branches start, at a physical (1,n) orbit (default FROM)",
    )
    rp.add_argument(
        "--max-points",
        dest="max_points",
        default="400",
        metavar="N",
        help="points per branch and direction at most (default 400)",
    )
    add_param_flags(rp)
    add_max_time(rp)
    add_json(rp)
    add_out(
        rp,
        "dir",
        "write response.json and response.png here",
        writes=("response.json", "response.png"),
    )
    rp.set_defaults(run=run)
    return rp


def run(ns: argparse.Namespace) -> int:
    """Run ``response``; returns the exit status."""
    name, lo, hi = ns.param
    if name not in ("x_w", "eta"):
        raise ParameterError("param", name, "x_w or eta")
    fixed = {dest: getattr(ns, dest) for _, dest, _ in PARAM_FLAGS}
    if fixed.get(name) is not None:
        raise ParameterError(
            name, fixed[name], f"not given twice: --{name} is set by --param {name} FROM TO"
        )
    walls = tuple(w for w in (lo, hi, ns.at) if w is not None) if name == "x_w" else ()
    params = orbit_params_from(ns, walls)
    res = response_curve(
        params,
        ns.n,
        name,
        lo,
        hi,
        at=ns.at,
        max_points=ns.max_points,
        progress=None if ns.json else True,
        max_time=max_time(ns),
    )
    if ns.out is not None:
        files = res.save_all(ns.out)
        if not ns.json:
            print("wrote " + ", ".join(str(f) for f in files.values()))
    if ns.json:
        print_json(res.to_dict())
        return 0
    c = res.counts()
    print(
        f"(1,{res.n}) response in {name} {lo} .. {hi}: {len(res.values)} points, "
        + ", ".join(f"{v} {k}" for k, v in c.items() if v)
        + f" ({'; '.join(res.stop_reasons)})"
    )
    for b in res.bifurcations:
        where = "" if b.admissible else " (virtual or unphysical part)"
        V = b.impact_v[0] if b.impact_v else float("nan")
        print(f"{b.type} at {name} = {b.value!r}, V = {V!r}{where}")
    return 0
