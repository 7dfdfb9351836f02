"""``precise-impact sweep``: LLE, period and impact rate on a 1-D or 2-D parameter grid."""

from __future__ import annotations

import argparse

from precise_impact.analysis.sweep import MAX_WORK, SweepSpec, run_sweep
from precise_impact.cli.args import add_json, add_out, add_param_flags, add_periods, params_from
from precise_impact.core.params import check_count, exact
from precise_impact.errors import ParameterError
from precise_impact.io.jsonout import print_json


def register(sub) -> argparse.ArgumentParser:
    """Add ``sweep`` to ``sub``."""
    sw = sub.add_parser(
        "sweep",
        help="LLE, period and impact rate on a 1-D or 2-D parameter grid (tiled, resumable)",
    )
    sw.add_argument(
        "--axis",
        nargs=4,
        action="append",
        required=True,
        metavar=("NAME", "MIN", "MAX", "N"),
        help="a swept parameter (eta, x_w, zeta, a, R); give once or twice",
    )
    add_param_flags(sw)
    add_periods(sw, "2000", "measured periods per point", metavar="P")
    sw.add_argument(
        "--transient",
        default="1000",
        metavar="T",
        help="transient periods per point (default 1000)",
    )
    sw.add_argument("--tile", default="64", metavar="K", help="points per tile (default 64)")
    sw.add_argument(
        "--model",
        "--engine",  # the 0.2 name
        dest="model",
        default="fast",
        choices=("fast", "heyoka"),
        help="fast (compiled closed form) or heyoka (SIMD batch variational) (default fast)",
    )
    sw.add_argument(
        "--max-work",
        default=None,
        metavar="W",
        help="work budget in point-periods, points x (periods + transient) (default 1e10)",
    )
    sw.add_argument(
        "--max-time",
        default=None,
        metavar="S",
        help="time budget in seconds per worker, checked against an estimate before any work "
        "(default: none, --max-work holds)",
    )
    sw.add_argument(
        "--workers",
        default=None,
        metavar="W",
        help="local processes / Dask workers (default: all cores)",
    )
    grp = sw.add_mutually_exclusive_group()
    grp.add_argument("--dask", choices=["local"], default=None, help="run on a Dask LocalCluster")
    grp.add_argument(
        "--scheduler", default=None, metavar="tcp://HOST:PORT", help="run on this Dask scheduler"
    )
    # a sweep resumes in its directory: finished tiles are kept, so no --force
    add_out(sw, "resume", "tiles, sweep.npz, sweep.csv, sweep.png", required=True)
    add_json(sw, "print the summary as one JSON object")
    sw.set_defaults(run=run)
    return sw


def run(ns: argparse.Namespace) -> int:
    """Run ``sweep``; returns the exit status."""
    base = params_from(ns)
    max_work = MAX_WORK
    if ns.max_work is not None:
        q = exact("max_work", ns.max_work, max_exponent=15)  # '1e12' is fine
        if q.denominator != 1 or not 1 <= q <= 10**15:
            raise ParameterError(
                "max_work", ns.max_work, "a whole number of point-periods, 1 <= max_work <= 1e15"
            )
        max_work = int(q)
    spec = SweepSpec.make(
        base,
        [tuple(a) for a in ns.axis],
        periods=ns.periods,
        transient=ns.transient,
        tile_size=ns.tile,
        max_work=max_work,
        model=ns.model,
    )
    workers = None if ns.workers is None else check_count(ns.workers, "workers", 1024)
    if ns.scheduler is not None and not ns.scheduler.startswith("tcp://"):
        raise ParameterError("scheduler", ns.scheduler, "a Dask scheduler address tcp://HOST:PORT")
    res = run_sweep(
        spec,
        ns.out,
        workers=workers,
        dask=ns.dask or ns.scheduler,
        progress=not ns.json,
        max_time=ns.max_time,
    )
    st = res.stats
    if ns.json:  # the run, not the grid (that is in sweep.npz / sweep.csv)
        print_json(dict(st, complete=res.complete, **res.files))
        return 0
    print(
        f"{spec.n_points} points in {spec.n_tiles} tiles: {st['tiles_computed']} computed, "
        f"{st['tiles_reused']} reused, {st['elapsed_s']:.1f} s on {st['workers']} "
        f"{st['backend']} worker(s)"
    )
    if res.files:
        print(f"written: {res.files['npz']}, {res.files['csv']}, {res.files['png']}")
    return 0
