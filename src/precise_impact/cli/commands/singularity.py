"""``precise-impact singularity``: the singularity set of the impact map (impacts whose next
flight grazes the wall), by continuation, with its images, over an impact-map scatter."""

from __future__ import annotations

import argparse
from pathlib import Path

from precise_impact.analysis.impact_surface.impact_map import (
    BYTES_PER_EVENT,
    SECONDS_PER_EVENT,
    impact_map_orbit,
)
from precise_impact.analysis.impact_surface.singularity import singularity_set
from precise_impact.cli.args import (
    add_json,
    add_max_time,
    add_out,
    add_param_flags,
    max_time,
    orbit_params_from,
)
from precise_impact.core.budget import check_work
from precise_impact.core.params import check_count, exact
from precise_impact.errors import ParameterError
from precise_impact.io.jsonout import print_json, write_json
from precise_impact.io.progress import say


def register(sub) -> argparse.ArgumentParser:
    """Add ``singularity`` to ``sub``."""
    p = sub.add_parser("singularity", help="singularity set of the impact map (grazing impacts)")
    add_param_flags(p)
    p.add_argument("--v-max", default="4", help="largest impact velocity (default 4)")
    p.add_argument("--step", default="0.01", help="continuation arclength step (default 0.01)")
    p.add_argument(
        "--orbit",
        default="1500",
        metavar="N",
        help="impact-map events drawn under the set (fast engine; 0: none; default 1500)",
    )
    add_out(
        p,
        "dir",
        "write singularity.json and singularity.png here",
        writes=("singularity.json", "singularity.png"),
    )
    add_max_time(p)
    add_json(p)
    p.set_defaults(run=run)
    return p


def run(ns: argparse.Namespace) -> int:
    """Run ``singularity``; returns the exit status."""
    # the start is the grid's (or the impact's): x0 only defaults to the wall when it is < 0
    params = orbit_params_from(ns)
    v_max = exact("v-max", ns.v_max)
    if not 0 < v_max <= 1000:
        raise ParameterError("v-max", ns.v_max, "0 < v-max <= 1000")
    step = exact("step", ns.step)
    if not 0 < step <= 0.1:
        raise ParameterError("step", ns.step, "0 < step <= 0.1")
    n_orbit = check_count(ns.orbit, "orbit", 10**6)
    # the set: ~13 continuation points per unit of 1 / step at v_max = 4 (1294 at step 0.01,
    # 9955 at 0.001), at most 4 branches of 4000, 3.5 ms a point and ~5 s of seeds (measured,
    # eta = 0.74: 9.7 s and 44 s); then the orbit's events on the fast engine
    points = min(4 * 4000, 13 * float(v_max) / 4 / float(step))
    orbit = n_orbit if ns.out is not None else 0
    seconds = 5 + points * 3.5e-3 + orbit * SECONDS_PER_EVENT["fast"]
    check_work(f"singularity: {points:.0f} set points + {orbit} orbit events", 1, seconds,
               orbit * BYTES_PER_EVENT, max_time(ns), "orbit")  # fmt: skip
    say("continuing the grazing condition ...", not ns.json)
    r = singularity_set(params, v_max=float(v_max), step=float(step))
    orbit = None
    if n_orbit > 0 and ns.out is not None:
        orbit = impact_map_orbit(
            params, 0.3, 1.0, n_orbit, engine="fast", max_time=max_time(ns),
            progress=None if ns.json else True,
        )  # fmt: skip
    if ns.out is not None:
        out = Path(ns.out)
        write_json(out / "singularity.json", r.to_dict(), indent=1)
        r.plot(out / "singularity.png", orbit=orbit)
    if ns.json:
        print_json(r.to_dict())
        return 0
    for i, b in enumerate(r.branches):
        print(
            f"branch {i}: {len(b['phase'])} points, phase {min(b['phase']):.4f}..."
            f"{max(b['phase']):.4f}, v {min(b['v']):.4f}...{max(b['v']):.4f}, "
            f"{sum(b['physical'])} physical"
        )
    print(f"largest step between neighbours: {r.max_step:.4g}")
    if ns.out is not None:
        print(f"written: {Path(ns.out) / 'singularity.json'}, {Path(ns.out) / 'singularity.png'}")
    return 0
