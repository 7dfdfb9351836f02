"""``precise-impact simulate``: one model's stroboscopic samples and impacts."""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

from precise_impact.cli.args import (
    add_json,
    add_max_time,
    add_out,
    add_param_flags,
    add_periods,
    add_precision,
    max_time,
    params_from,
)
from precise_impact.core.budget import check_cost, estimate_cost
from precise_impact.core.digits import basis_text, demonstrate, format_claimed
from precise_impact.core.params import check_count
from precise_impact.core.precision import Precision
from precise_impact.errors import Interrupted, ParameterError
from precise_impact.io.jsonout import print_json
from precise_impact.io.progress import Progress
from precise_impact.solvers.heyoka.single import HeyokaSolver
from precise_impact.solvers.simulate import (
    MODELS,
    demonstration_model,
    make_solver,
    reference_precision,
)


def register(sub) -> argparse.ArgumentParser:
    """Add ``simulate`` to ``sub`` (the object ``add_subparsers`` returns)."""
    s = sub.add_parser("simulate", help="simulate one model and print samples and impacts")
    add_param_flags(s)
    add_periods(s, "200", "forcing periods")
    s.add_argument(
        "--model", default="heyoka", help="one of: " + ", ".join(MODELS) + " (default heyoka)"
    )
    add_precision(s, "float64, longdouble, float128 or mp:BITS (default float64)")
    s.add_argument(
        "--tol",
        default=None,
        metavar="T",
        help="heyoka tolerance (default: the precision's epsilon)",
    )
    s.add_argument(
        "--dense",
        default="0",
        metavar="K",
        help="dense output points per period (saved with --out)",
    )
    s.add_argument(
        "--demonstrate",
        nargs="?",
        const="auto",
        default=None,
        metavar="P",
        help="run again at precision P (P left out: 64 bits more, at least mp:128) and claim, per "
        "sample, the digits both runs agree on; without it the digits are estimated from the "
        "precision and the run's error amplification (proven for --model certified)",
    )
    add_out(s, "file", "write samples and impacts to FILE.npz, .csv or .json")
    add_json(s)
    add_max_time(s)
    s.set_defaults(run=run)
    return s


def run(ns: argparse.Namespace) -> int:
    """Run ``simulate``; returns the exit status."""
    params = params_from(ns)
    periods = check_count(ns.periods)
    dense = check_count(ns.dense, "dense", 100_000)
    if ns.out is not None and Path(ns.out).suffix not in (".npz", ".csv", ".json"):
        raise ParameterError("out", ns.out, "output file must end in .npz, .csv or .json")
    solver = make_solver(ns.model, ns.precision, ns.tol)
    prec = getattr(solver, "precision", None) or Precision.parse(ns.precision)
    second = None
    if ns.demonstrate is not None:
        ref = reference_precision(prec, True if ns.demonstrate == "auto" else ns.demonstrate)
        second = make_solver(demonstration_model(ns.model, ref), ref, None)
    cost = estimate_cost("simulate", periods=periods, per_period=dense, precision=prec)
    if second is not None:  # both runs against one budget
        more = estimate_cost("simulate", periods=periods, precision=ref)
        cost = dataclasses.replace(
            cost, seconds=cost.seconds + more.seconds, what=cost.what + " and " + more.what
        )
    check_cost(cost, max_time(ns))
    if isinstance(
        solver, HeyokaSolver
    ):  # long runs: progress on stderr, a partial file on interrupt
        bar = Progress(
            periods, "simulate periods", None if not ns.json and cost.seconds > 2 else False
        )
        try:
            traj = solver.solve(
                params, periods, per_period=dense, progress=lambda k, n: bar.update(k)
            )
        except Interrupted as e:
            bar.close()
            if ns.out is not None and e.partial is not None:
                part = Path(ns.out)
                part = part.with_name(part.stem + ".partial" + part.suffix)
                e.partial.save(part)
                e.kept = f"{e}; the finished periods are in {part}"
            raise
        bar.close()
    else:
        traj = solver.solve(params, periods, per_period=dense)
    if second is not None:
        traj.claim = demonstrate(traj, second.solve(params, periods))
    claim = traj.claimed_digits()
    if claim.final <= 0:
        first = claim.first_unclaimed()
        print(
            f"warning: no significant digit of the final state can be claimed ({claim.basis}; "
            f"none from period {first} on): x and v are shown to 3 digits, marked unclaimed"
            + (f" ({claim.note})" if claim.note else ""),
            file=sys.stderr,
        )
    if ns.out is not None:
        traj.save(ns.out)
    if ns.json:
        print_json(traj.to_dict())
        return 0
    s = traj.precision.to_str
    print(
        f"{traj.model} {traj.precision.name}: {periods} periods, {traj.n_impacts} impacts, "
        f"{traj.elapsed_s:.4f} s"
    )
    print(f"params: {', '.join(f'{k}={v}' for k, v in params.decimal().items())}")
    P = traj.precision
    print(
        f"final state at t={s(traj.t[-1])}:\n"
        f"  x = {format_claimed(P, traj.x[-1], int(claim.x[-1]))}\n"
        f"  v = {format_claimed(P, traj.v[-1], int(claim.v[-1]))}"
    )
    print(
        f"digits: x {claim.x[-1]}, v {claim.v[-1]} of {claim.cap} significant digits claimed "
        f"({basis_text(claim)}); --json gives every sample's"
    )
    if ns.out is not None:
        print(f"written: {ns.out}")
    return 0
