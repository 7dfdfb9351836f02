"""``precise-impact basins``: domains of attraction on the impact surface or Poincaré section."""

from __future__ import annotations

import argparse
from pathlib import Path

from precise_impact.analysis.impact_surface.basins import SECTIONS, basins
from precise_impact.cli.args import (
    add_json,
    add_max_time,
    add_out,
    add_param_flags,
    max_time,
    orbit_params_from,
)
from precise_impact.core.params import check_count
from precise_impact.errors import ParameterError
from precise_impact.io.jsonout import print_json, write_json


def register(sub) -> argparse.ArgumentParser:
    """Add ``basins`` to ``sub``."""
    b = sub.add_parser(
        "basins",
        help="domains of attraction (periodic orbits, chatter + sticking, chaos) on the impact "
        "surface (phase, v) or the stroboscopic section (x, v)",
    )
    b.add_argument("--section", choices=SECTIONS, default="impact", help="default impact")
    b.add_argument(
        "--phase", nargs=3, default=["0", "1", "100"], metavar=("MIN", "MAX", "N"),
        help="columns on the impact section: the impact phase in [0, 1] (default 0 1 100)",
    )  # fmt: skip
    b.add_argument(
        "--x", nargs=3, default=None, metavar=("MIN", "MAX", "N"),
        help="columns on the stroboscopic section: x at t0 (required there)",
    )  # fmt: skip
    b.add_argument(
        "--v", nargs=3, default=["0", "1", "100"], metavar=("MIN", "MAX", "N"),
        help="rows: incoming speed v > 0, or the velocity (default 0 1 100)",
    )  # fmt: skip
    add_param_flags(b)
    b.add_argument("--transient", default="200", metavar="P", help="periods (default 200)")
    b.add_argument("--max-period", default="16", metavar="P", help="default 16")
    b.add_argument("--no-refine", action="store_true", help="do not re-run the boundary points")
    b.add_argument(
        "--subgrid", default="0", metavar="K",
        help="sample every boundary cell again on a K x K sub-grid (K 2..32; default 0: off)",
    )  # fmt: skip
    b.add_argument("--tile", default="200", metavar="N", help="points per tile (default 200)")
    b.add_argument("--workers", default="1", metavar="W", help="local processes (default 1)")
    b.add_argument(
        "--dask", default=None, metavar="local|tcp://HOST:PORT",
        help="run the tiles on a Dask LocalCluster ('local') or on this scheduler",
    )  # fmt: skip
    add_out(b, "resume", "tiles (resumed), basins.json, basins.png", required=True)
    add_json(b, "print the attractors and the run's figures as one JSON object")
    add_max_time(b)
    b.set_defaults(run=run)
    return b


def run(ns: argparse.Namespace) -> int:
    """Run ``basins``; returns the exit status."""
    # the start is the grid's (or the impact's): x0 only defaults to the wall when it is < 0
    params = orbit_params_from(ns)
    if ns.section == "stroboscopic" and ns.x is None:
        raise ParameterError("x", None, "an axis MIN MAX N on the stroboscopic section")
    if ns.section == "impact" and ns.x is not None:
        raise ParameterError("x", " ".join(ns.x), "given only with --section stroboscopic")
    u = ns.x if ns.section == "stroboscopic" else ns.phase
    grid = tuple((a[0], a[1], check_count(a[2], name + " n", 10**5, minimum=1))
                 for a, name in ((u, "phase" if ns.x is None else "x"), (ns.v, "v")))  # fmt: skip
    res = basins(
        params, grid, section=ns.section, transient=check_count(ns.transient, "transient", 10**7),
        max_period=check_count(ns.max_period, "max_period", 1000), refine=not ns.no_refine,
        subgrid=ns.subgrid,
        tile_size=check_count(ns.tile, "tile", 10**7, minimum=1),
        workers=check_count(ns.workers, "workers", 1024, minimum=1), dask=ns.dask, out=ns.out,
        max_time=max_time(ns), progress=not ns.json,
    )  # fmt: skip
    out = Path(ns.out)
    write_json(out / "basins.json", res.to_dict(), indent=1)
    res.plot(out / "basins.png")
    if ns.json:
        obj = res.to_dict()
        obj.pop("labels")
        print_json(obj)
        return 0
    st = res.stats
    print(
        f"{st['points']} points ({st['backend']}, {st['workers']} worker(s)) in "
        f"{st['elapsed_s']:.1f} s; {st['refined']} boundary points re-run, {st['changed']} "
        f"changed; boundary fraction {st['boundary_fraction']:.3f}"
    )
    if st["subgrid"]:
        agree = st["subgrid_agreement"]
        print(
            f"sub-grid {st['subgrid']} x {st['subgrid']}: {st['subgrid_points']} sub-points, "
            f"{st['mixed_cells']} mixed cells"
            + ("" if agree is None else f", {100 * agree:.1f} % agree with their cell")
        )
    for a in res.attractors:
        print(f"  {a['name']:<24} {a['points']:>8} points  LLE {a['lle']:.4g}")
    print(f"written: {out / 'basins.json'}, {out / 'basins.png'}")
    return 0
