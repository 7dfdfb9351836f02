"""``precise-impact budget``: the tolerance budget of a circuit design (the paper's landmarks
against every component)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from precise_impact.cli.args import add_json, add_max_time, add_out, max_time
from precise_impact.core.params import check_count
from precise_impact.errors import ParameterError
from precise_impact.io.atomic import atomic_write
from precise_impact.io.jsonout import print_json, write_json
from precise_impact.lab import budget as lab_budget  # called through the module: tests patch it


def register(sub) -> argparse.ArgumentParser:
    """Add ``budget`` to ``sub``."""
    bp = sub.add_parser(
        "budget",
        help="tolerance budget: how the paper's landmarks move with every component",
    )
    bp.add_argument(
        "--scene",
        default="fig6-period2-datasheet",
        metavar="NAME|FILE",
        help="the design: a scene name or .toml (default fig6-period2-datasheet)",
    )
    bp.add_argument(
        "--tolerance",
        default=None,
        metavar="TOL",
        help="part tolerances: '1%%' (every part) or 'R=1%%,C=5%%,R6=0.1%%' (default the "
        "scene's tolerance effect, else R 1 %%, C 5 %%)",
    )
    bp.add_argument(
        "--landmarks",
        default=",".join(lab_budget.LANDMARKS),
        metavar="LIST",
        help="comma-separated subset of " + ", ".join(lab_budget.LANDMARKS) + " (default all)",
    )
    bp.add_argument(
        "--ron",
        default=None,
        metavar="OHM",
        help="switch R_on replacing the scene's (below where zeta reaches 1: 1.05 R3 for the "
        "paper's designs)",
    )
    bp.add_argument("--mc", default="400", metavar="N", help="Monte Carlo draws (default 400)")
    bp.add_argument(
        "--sobol",
        default="256",
        metavar="N",
        help="Sobol base sample, a power of 2, or 0 for none (no Sobol indices; default 256)",
    )
    bp.add_argument(
        "--lle-mc", default="32", metavar="N", help="draws for the LLE at 0.712 (default 32)"
    )
    bp.add_argument("--seed", default="0", metavar="S", help="seed of the draws (default 0)")
    bp.add_argument(
        "--no-scans", action="store_true", help="skip the R_on / R3 and GBW existence scans"
    )
    add_out(
        bp,
        "dir",
        "write tolerance_budget.json, .md, .png here (default results)",
        default="results",
        writes=lambda ns: ("tolerance_budget.json", "tolerance_budget.md", "tolerance_budget.png"),
    )
    add_json(bp)
    add_max_time(bp)
    bp.set_defaults(run=run)
    return bp


def run(ns: argparse.Namespace) -> int:
    """Run ``budget``; returns the exit status."""
    landmarks = tuple(s.strip() for s in ns.landmarks.split(",") if s.strip())
    mc = check_count(ns.mc, "mc", 100000)
    sobol = check_count(ns.sobol, "sobol", 65536)
    lle_mc = check_count(ns.lle_mc, "lle_mc", 10000)
    seed = check_count(ns.seed, "seed", 2**32)
    if sobol & (sobol - 1):
        raise ParameterError("sobol", str(sobol), "a power of 2 (Sobol sequences)")
    lab_budget.parse_tolerances(ns.tolerance)  # bad input: one line, before any work
    lab_budget.check_budget(
        max_time(ns),
        landmarks=landmarks,
        mc=mc,
        sobol=sobol,
        lle_mc=lle_mc,
        lle_periods=2000,
        scans=not ns.no_scans,
    )
    say = None if ns.json else (lambda m: print(f"budget: {m}", file=sys.stderr, flush=True))
    try:
        res = lab_budget.tolerance_budget(
            ns.scene,
            tolerances=ns.tolerance,
            landmarks=landmarks,
            seed=seed,
            mc=mc,
            sobol=sobol,
            lle_mc=lle_mc,
            ron=ns.ron,
            scans=not ns.no_scans,
            progress=say,
            max_time=max_time(ns),
        )
    except KeyboardInterrupt as e:  # files are written only when the budget is complete
        e.kept = "interrupted; nothing written (a budget is written only when complete)"  # type: ignore[attr-defined]
        raise
    out = Path(ns.out)
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "tolerance_budget.json", res.to_dict(), indent=1)
    text = res.markdown()
    atomic_write(out / "tolerance_budget.md", lambda fh: fh.write(text), binary=False)
    res.plot(out / "tolerance_budget.png")
    if ns.json:
        print_json(res.to_dict())
        return 0
    print(res.markdown())
    print(f"written: {out / 'tolerance_budget.json'}, .md, .png ({res.elapsed_s:.1f} s)")
    return 0
