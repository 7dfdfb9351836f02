"""``precise-impact certify``: a certified trajectory, every sample and impact in a proven ball."""

from __future__ import annotations

import argparse
import sys

from precise_impact.cli.args import (
    add_json,
    add_max_time,
    add_param_flags,
    add_periods,
    max_time,
    params_from,
)
from precise_impact.core.params import check_count
from precise_impact.errors import ParameterError
from precise_impact.io.jsonout import print_json
from precise_impact.solvers.certified.coupled import certify_coupled
from precise_impact.solvers.certified.single import MAX_BITS, certify


def register(sub) -> argparse.ArgumentParser:
    """Add ``certify`` to ``sub``."""
    ce = sub.add_parser(
        "certify",
        help="a certified trajectory: every sample and impact in a proven ball "
        "(ball arithmetic, python-flint)",
    )
    add_param_flags(ce)
    add_periods(ce, "300", "forcing periods")
    ce.add_argument(
        "--precision",
        default=None,
        metavar="P",
        help="working precision of the balls: auto (chosen from --target and the measured radius "
        "growth; the single oscillator's default) or mp:BITS (the pair's default mp:256)",
    )
    ce.add_argument(
        "--bits",
        default=None,
        metavar="B",
        help="deprecated: --precision mp:B",
    )
    ce.add_argument(
        "--target",
        default=None,
        metavar="R",
        help="radius wanted at every sample, the single oscillator's automatic bits "
        "(default 1e-30; not with --precision mp:BITS / --bits, which fix the bits)",
    )
    ce.add_argument(
        "--max-bits",
        dest="max_bits",
        default="8192",
        metavar="B",
        help="bits are doubled after a failed proof up to this (default 8192)",
    )
    ce.add_argument(
        "--method",
        default=None,
        choices=("lohner", "interval"),
        help="the single oscillator's enclosure: lohner (default: point + matrix x box in a "
        "QR frame, grows at the dynamics' rate) or interval (two balls, wrapped every period)",
    )
    ce.add_argument(
        "--k",
        default=None,
        metavar="K",
        help="certify the master-slave pair with coupling K >= 0 (default: the single oscillator)",
    )
    ce.add_argument(
        "--form",
        default=None,
        help="the pair's slave equation, with --k: first-order (default), paper or reduced",
    )
    ce.add_argument(
        "--y0",
        nargs=2,
        default=None,
        metavar=("Y", "W"),
        help="the slave's start (position, velocity variable); default: on the master "
        "(the diagonal)",
    )
    add_max_time(ce)
    add_json(ce)
    ce.set_defaults(run=run)
    return ce


def run(ns: argparse.Namespace) -> int:
    """Run ``certify``; returns the exit status."""
    params = params_from(ns)
    max_bits = check_count(ns.max_bits, "max_bits", MAX_BITS, minimum=64)
    if ns.bits is not None:  # the 0.2 spelling
        if ns.precision is not None:
            raise ParameterError("bits", ns.bits, "not with --precision (--bits is deprecated)")
        bits = check_count(ns.bits, "bits", max_bits, minimum=64)
        print("precise-impact: --bits is deprecated, use --precision mp:BITS", file=sys.stderr)
        ns.precision = f"mp:{bits}"
    if ns.target is not None and ns.precision not in (None, "auto"):
        # one of them would be ignored: the target only steers the automatic bits
        given = "--bits" if ns.bits is not None else "--precision"
        raise ParameterError(
            "target",
            ns.target,
            f"only with the automatic bits (--precision auto), not with {given}",
        )
    if ns.form is not None and ns.k is None:
        raise ParameterError("form", ns.form, "only with --k (the coupled pair)")
    progress = None if ns.json else True
    if ns.k is not None:
        if ns.target is not None:
            raise ParameterError(
                "target", ns.target, "only for the single oscillator (the pair takes --precision)"
            )
        if ns.method is not None:
            raise ParameterError("method", ns.method, "only for the single oscillator, not --k")
        r = certify_coupled(
            params,
            ns.k,
            "first-order" if ns.form is None else ns.form,
            ns.periods,
            y0=ns.y0,
            precision="mp:256" if ns.precision is None else ns.precision,
            max_bits=max_bits,
            progress=progress,
            max_time=max_time(ns),
        )
        d = r.to_dict()
        lines = [
            f"certified pair ({r.form}, k = {ns.k}): {r.periods} periods, "
            f"{len(r.master_impacts)} master and {len(r.slave_impacts)} slave impacts, at "
            f"{r.bits} bits in {r.elapsed_s:.2f} s; largest radius {d['max_radius']}"
        ]
        names = "xvyw"
    else:
        if ns.y0 is not None:
            raise ParameterError("y0", " ".join(ns.y0), "only with --k (the coupled pair)")
        r = certify(
            params,
            ns.periods,
            precision="auto" if ns.precision is None else ns.precision,
            target_radius="1e-30" if ns.target is None else ns.target,
            max_bits=max_bits,
            progress=progress,
            max_time=max_time(ns),
            method="lohner" if ns.method is None else ns.method,
        )
        d = r.to_dict()
        lines = [
            f"certified {r.periods} periods, {len(r.impacts)} impacts, at {r.bits} bits "
            f"({r.bits_choice}) in {r.elapsed_s:.2f} s",
            f"largest radius {d['max_radius']}; {r.method} enclosure, radius growth "
            f"{r.growth_digits_per_period():.3f} decimal digits per period",
        ]
        names = "xv"
    if ns.json:
        print_json(d)
        return 0
    last = d["samples"][-1]
    lines += [f"{n}({last['period']} T) = {last[n]} +- {last[n + '_rad']}" for n in names]
    print("\n".join(lines))
    return 0
