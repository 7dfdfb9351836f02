"""``precise-impact continue``: a branch of periodic orbits continued in one parameter."""

from __future__ import annotations

import argparse
import math

from precise_impact.analysis.orbits import continue_orbit
from precise_impact.analysis.orbits.branch import brute_force_diagram
from precise_impact.cli.args import (
    PARAM_FLAGS,
    add_json,
    add_max_time,
    add_orbit_flags,
    add_out,
    add_param_flags,
    max_time,
    orbit_params_from,
)
from precise_impact.core.params import check_count
from precise_impact.errors import ParameterError
from precise_impact.io.jsonout import print_json


def register(sub) -> argparse.ArgumentParser:
    """Add ``continue`` to ``sub``."""
    co = sub.add_parser(
        "continue",
        help="continue a branch of periodic orbits in one parameter: stability, "
        "grazing, period-doubling (with branch switching), fold",
    )
    co.add_argument(
        "--param",
        nargs=3,
        required=True,
        metavar=("NAME", "FROM", "TO"),
        help="the continued parameter (eta, x_w, zeta, a or R) and its range",
    )
    add_param_flags(co)
    add_orbit_flags(co, " of the starting orbit (at FROM)")
    co.add_argument(
        "--max-points",
        dest="max_points",
        default="400",
        metavar="N",
        help="points per branch at most (default 400)",
    )
    co.add_argument(
        "--doublings",
        default="2",
        metavar="K",
        help="period-doubling branch switches followed (default 2)",
    )
    co.add_argument(
        "--virtual",
        default="0.1",
        metavar="F",
        help="fraction of the range a branch may run on past grazing as a virtual orbit "
        "(default 0.1)",
    )
    co.add_argument(
        "--diagram",
        default="200",
        metavar="N",
        help="values of the brute-force diagram drawn beneath the branches with --out "
        "(default 200; 0: none)",
    )
    add_max_time(co)
    add_json(co)
    add_out(
        co,
        "dir",
        "write continuation.json and continuation.png here",
        writes=("continuation.json", "continuation.png"),
    )
    co.set_defaults(run=run)
    return co


def run(ns: argparse.Namespace) -> int:
    """Run ``continue``; returns the exit status."""
    name, lo, hi = ns.param
    fixed = {dest: getattr(ns, dest) for _, dest, _ in PARAM_FLAGS}
    if name in fixed and fixed[name] is not None:
        raise ParameterError(
            name, fixed[name], f"not given twice: --{name} is set by --param {name} FROM TO"
        )
    params = orbit_params_from(ns, (lo, hi) if name == "x_w" else ())
    n_diagram = check_count(ns.diagram, "diagram", 5000)
    res = continue_orbit(
        params,
        name,
        lo,
        hi,
        ns.period,
        impacts=None if ns.impacts is None else ns.impacts,
        guess=ns.guess,
        transient=ns.transient,
        max_points=ns.max_points,
        doublings=ns.doublings,
        virtual=ns.virtual,
        progress=None if ns.json else True,
        max_time=max_time(ns),
    )
    if ns.out is not None:
        _save(res, ns, name, n_diagram)
    if ns.json:
        print_json(res.to_dict())
        return 0
    _print_branches(res, name)
    _print_bifurcations(res, name)
    return 0


def _save(res, ns: argparse.Namespace, name: str, n_diagram: int) -> None:
    """Write the result (and the brute-force diagram, if asked) into ``--out``."""
    diagram = None
    if n_diagram:
        diagram = brute_force_diagram(
            res.params, name, float(res.start), float(res.stop), n_diagram
        )
    files = res.save_all(ns.out, diagram=diagram)
    if not ns.json:
        print("wrote " + ", ".join(str(f) for f in files.values()))


def _print_branches(res, name: str) -> None:
    """One line per branch: period, impacts, range, stability counts, origin and stop."""
    for k, b in enumerate(res.branches):
        n = b.counts()  # virtual orbits counted once, as virtual, never as stable or unstable
        print(
            f"branch {k}: period {b.period}, {b.impacts} impact(s), {len(b.values)} points, {name} "
            f"{b.values.min():.10g} .. {b.values.max():.10g}, {n['stable']} stable, "
            f"{n['unstable']} unstable, "
            + (f"{n['elliptic']} elliptic (neutral), " if n["elliptic"] else "")
            + f"{n['virtual']} virtual ({b.origin}; {b.stop_reason})"
        )


def _print_bifurcations(res, name: str) -> None:
    """One line per bifurcation: type, branch, value, multipliers (or that there is none)."""
    if not res.bifurcations:
        print("no bifurcation in the range")
    for bif in res.bifurcations:
        mus = ", ".join(
            f"{m[0]:.8g}{m[1]:+.3g}i" if m[1] else f"{m[0]:.8g}" for m in bif.multipliers
        )
        if not all(math.isfinite(c) for m in bif.multipliers for c in m):
            mus = "undefined (a tangential impact: the saltation matrix is unbounded)"
        where = "" if bif.admissible else " (virtual orbit)"
        print(
            f"{bif.type} on branch {bif.branch} at {name} = {bif.value!r}{where}: "
            f"multipliers {mus}" + (f"; {bif.detail}" if bif.detail else "")
        )
