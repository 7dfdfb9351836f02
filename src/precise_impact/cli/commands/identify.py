"""``precise-impact identify``: the impact oscillator a scope capture realises, with standard
errors, confidence intervals and correlations (:func:`precise_impact.lab.identify.identify`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from precise_impact.cli.args import (
    add_capture_reading,
    add_json,
    add_max_time,
    add_out,
    max_time,
)
from precise_impact.core.budget import check_work
from precise_impact.core.params import check_count
from precise_impact.io.jsonout import print_json, write_json
from precise_impact.io.progress import say
from precise_impact.lab.identify import SECONDS_PER_SAMPLE, identify
from precise_impact.lab.scope_files import READ_FORMATS, read_capture


def register(sub) -> argparse.ArgumentParser:
    """Add ``identify`` to ``sub``."""
    p = sub.add_parser(
        "identify",
        help="the oscillator a capture realises: eta, zeta, a, x_w, R with standard errors",
    )
    p.add_argument("file", help="capture file (or a Tektronix ALLnnnn directory)")
    add_capture_reading(p, READ_FORMATS)
    p.add_argument(
        "--scene",
        default="fig5-chaotic-ideal",
        help="the design whose volts and seconds per unit map the channels (default: the paper's)",
    )
    p.add_argument("--bootstrap", default="0", help="parametric bootstrap refits (default 0)")
    p.add_argument("--seed", default="0", help="the bootstrap's seed (default 0)")
    add_out(
        p,
        "dir",
        "write identify.json and identify.png here",
        writes=("identify.json", "identify.png"),
    )
    add_max_time(p)
    add_json(p)
    p.set_defaults(run=run)
    return p


def run(ns: argparse.Namespace) -> int:
    """Run ``identify``; returns the exit status."""
    boot = check_count(ns.bootstrap, "bootstrap", 1000, minimum=0)
    seed = check_count(ns.seed, "seed", 2**31 - 1, minimum=0)
    cap = read_capture(ns.file, ns.channels, ns.format)
    check_work(
        f"identify: {len(cap.t)} samples x {1 + boot} fits",
        len(cap.t) * (1 + boot),
        SECONDS_PER_SAMPLE,
        400.0,
        max_time(ns),
        "bootstrap",
    )
    r = identify(
        cap,
        ns.scene,
        bootstrap=boot,
        seed=seed,
        say=None if ns.json else (lambda line: say(line, True)),
    )
    if ns.out is not None:
        out = Path(ns.out)
        write_json(out / "identify.json", r.to_dict(), indent=1)
        r.plot(out / "identify.png")
    if ns.json:
        print_json(r.to_dict())
        return 0
    print(r.summary())
    if r.bootstrap:
        ratios = ", ".join(f"{k} {v:.2f}" for k, v in r.bootstrap["ratio"].items() if v)
        print(
            f"bootstrap / Jacobian standard errors ({r.bootstrap['replicates']} refits): {ratios}"
        )
    if ns.out is not None:
        print(f"written: {Path(ns.out) / 'identify.json'}, {Path(ns.out) / 'identify.png'}")
    return 0
