"""``precise-impact impact-map``: an orbit of the impact map, its scatter plot on the impact
surface (chatter and sticking marked) and, optionally, the singularity set over it."""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from precise_impact.analysis.impact_surface.impact_map import ENGINES, impact_map_orbit
from precise_impact.analysis.impact_surface.singularity import singularity_set
from precise_impact.cli.args import (
    add_json,
    add_max_time,
    add_out,
    add_param_flags,
    max_time,
    orbit_params_from,
)
from precise_impact.core.params import check_count, exact
from precise_impact.errors import ParameterError
from precise_impact.io.jsonout import print_json, write_json


def register(sub) -> argparse.ArgumentParser:
    """Add ``impact-map`` to ``sub``."""
    p = sub.add_parser(
        "impact-map", help="impact map orbit (phase, v) and its impact-surface scatter plot"
    )
    add_param_flags(p)
    p.add_argument("--phase", default="0.3", help="start impact phase in [0, 1) (default 0.3)")
    p.add_argument("--v", default="1", help="start impact velocity > 0 (default 1)")
    p.add_argument("--n", default="2000", metavar="N", help="events to compute (default 2000)")
    p.add_argument(
        "--transient", default="100", metavar="N", help="first events not plotted (default 100)"
    )
    p.add_argument(
        "--engine", default="fast", choices=tuple(ENGINES), help="the engine (default fast)"
    )
    p.add_argument(
        "--singularity", action="store_true", help="draw the singularity set over the scatter"
    )
    add_out(
        p,
        "dir",
        "write impact_map.json and impact_map.png here",
        writes=("impact_map.json", "impact_map.png"),
    )
    add_max_time(p)
    add_json(p)
    p.set_defaults(run=run)
    return p


def run(ns: argparse.Namespace) -> int:
    """Run ``impact-map``; returns the exit status."""
    # the start is the grid's (or the impact's): x0 only defaults to the wall when it is < 0
    params = orbit_params_from(ns)
    phase = exact("phase", ns.phase)
    if not 0 <= phase < 1:
        raise ParameterError("phase", ns.phase, "0 <= phase < 1")
    v = exact("v", ns.v)
    if not v > 0:
        raise ParameterError("v", ns.v, "an impact velocity v > 0")
    n = check_count(ns.n, "n", 10**6, minimum=1)
    transient = check_count(ns.transient, "transient", 10**6)
    if transient >= n:
        raise ParameterError("transient", ns.transient, f"0 <= transient < n = {n}")
    r = impact_map_orbit(
        params,
        float(phase),
        float(v),
        n,
        engine=ns.engine,
        max_time=max_time(ns),
        progress=None if ns.json else True,
    )
    sing = None
    if ns.singularity:
        sing = singularity_set(params)
    if ns.out is not None:
        out = Path(ns.out)
        obj = r.to_dict()
        if sing is not None:
            obj["singularity"] = sing.to_dict()
        write_json(out / "impact_map.json", obj, indent=1)
        shown = dataclasses.replace(
            r, **{k: getattr(r, k)[transient:] for k in ("kind", "t", "phase", "v", "t_end")}
        )
        shown.plot(out / "impact_map.png", singularity=sing)
    if ns.json:
        print_json(r.to_dict())
        return 0
    kinds = {k: r.kind.count(k) for k in ("impact", "chatter", "sticking")}
    print(
        f"{n} events from (phase, v) = ({float(phase):g}, {float(v):g}) on {ns.engine}: "
        f"{kinds['impact']} impacts, {kinds['chatter']} chatter sequences, "
        f"{kinds['sticking']} sticking intervals; last at t = {r.t[-1]:.6f}"
    )
    if ns.out is not None:
        print(f"written: {Path(ns.out) / 'impact_map.json'}, {Path(ns.out) / 'impact_map.png'}")
    return 0
