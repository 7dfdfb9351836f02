"""``precise-impact certify``: a certified trajectory, every sample and impact in a proven ball."""

from __future__ import annotations

import argparse
import sys
from fractions import Fraction

from precise_impact.analysis.orbits.proof_landmarks import (
    check_width,
    locate_landmark,
    prove_landmark,
)
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
from precise_impact.solvers.certified.single import MAX_BITS, certify, log10_str, radius_str


def register(sub) -> argparse.ArgumentParser:
    """Add ``certify`` to ``sub``."""
    ce = sub.add_parser(
        "certify",
        help="a certified trajectory: every sample and impact in a proven ball "
        "(ball arithmetic, python-flint)",
    )
    add_param_flags(ce)
    add_periods(ce, "300", "forcing periods")
    _add_enclosure_flags(ce)
    _add_pair_flags(ce)
    _add_point_flags(ce)
    add_max_time(ce)
    add_json(ce)
    ce.set_defaults(run=run)
    return ce


def _add_enclosure_flags(ce) -> None:
    """The balls' precision and enclosure: --precision, --bits, --target, --max-bits, --method."""
    ce.add_argument(
        "--precision",
        default=None,
        metavar="P",
        help="working precision of the balls: auto (chosen from --target and the radius growth "
        "measured by a pilot run; the single oscillator's default, and the pair's with --target) "
        "or mp:BITS (the pair's default mp:256)",
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
        help="radius wanted at every sample by the automatic bits, 1e-3000 to 1e-3 (default "
        "1e-30; with --k it "
        "makes the pair's bits automatic; not with --precision mp:BITS / --bits, which fix them)",
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
        help="the enclosure, of the single oscillator and of the pair (--k): lohner (default: "
        "point + matrix x box in a QR frame, grows at the dynamics' rate) or interval (a ball "
        "per coordinate, wrapped every period)",
    )


def _add_pair_flags(ce) -> None:
    """The master-slave pair: --k, --form, --y0."""
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


def _add_point_flags(ce) -> None:
    """A proven bifurcation point: --point, --side, --orbit-period, --width."""
    pt = ce.add_argument_group("a proven bifurcation point (instead of a trajectory)")
    pt.add_argument(
        "--point",
        default=None,
        choices=("grazing", "period-doubling", "fold"),
        help="prove this landmark (Krawczyk on its augmented system): without --side the "
        "non-impacting orbit's grazing nearest --eta; with --side that end of the "
        "--orbit-period orbit's interval around --eta",
    )
    pt.add_argument("--side", default=None, choices=("low", "high"), help="with --point: which end")
    pt.add_argument(
        "--orbit-period",
        dest="orbit_period",
        default="1",
        metavar="P",
        help="with --point --side: the orbit's period in forcing periods (default 1)",
    )
    pt.add_argument(
        "--width",
        default="1e-40",
        metavar="W",
        help="with --point: largest width of the proven interval, 1e-1000 to 1e-6 (default 1e-40)",
    )


def run(ns: argparse.Namespace) -> int:
    """Run ``certify``; returns the exit status."""
    params = params_from(ns)
    if ns.point is not None:
        for flag in ("k", "form", "y0", "precision", "bits", "target"):
            if getattr(ns, flag) is not None:
                raise ParameterError(flag, str(getattr(ns, flag)), "not with --point")
        return _run_point(ns, params)
    for flag, default in (("side", None), ("width", "1e-40"), ("orbit_period", "1")):
        if getattr(ns, flag) != default:
            raise ParameterError(flag, getattr(ns, flag), "only with --point")
    max_bits = _check_bits(ns)
    progress = None if ns.json else True
    if ns.k is not None:
        _, d, lines, names = _certify_pair(ns, params, max_bits, progress)
    else:
        _, d, lines, names = _certify_single(ns, params, max_bits, progress)
    if ns.json:
        print_json(d)
        return 0
    last = d["samples"][-1]
    lines += [f"{n}({last['period']} T) = {last[n]} +- {last[n + '_rad']}" for n in names]
    print("\n".join(lines))
    return 0


def _check_bits(ns: argparse.Namespace) -> int:
    """--max-bits checked, --bits turned into --precision (deprecated), --target and --form
    refused where they would be ignored; the max bits."""
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
    return max_bits


def _certify_pair(ns: argparse.Namespace, params, max_bits: int, progress) -> tuple:
    """``certify --k``: the certified pair; ``(result, its dict, the summary lines, names)``."""
    if ns.precision is None:  # the pair's default: mp:256, automatic with a --target
        ns.precision = "mp:256" if ns.target is None else "auto"
    r = certify_coupled(
        params,
        ns.k,
        "first-order" if ns.form is None else ns.form,
        ns.periods,
        y0=ns.y0,
        precision=ns.precision,
        **_shared_options(ns, max_bits, progress),
    )
    d = r.to_dict()
    lines = [
        f"certified pair ({r.form}, k = {ns.k}): {r.periods} periods, "
        f"{len(r.master_impacts)} master and {len(r.slave_impacts)} slave impacts, at "
        f"{r.bits} bits ({r.bits_choice}) in {r.elapsed_s:.2f} s",
        _growth_line(r, d),
    ]
    names = "xvyw"
    return r, d, lines, names


def _shared_options(ns: argparse.Namespace, max_bits: int, progress) -> dict:
    """The options ``certify`` and ``certify_coupled`` take alike."""
    return {
        "target_radius": "1e-30" if ns.target is None else ns.target,
        "max_bits": max_bits,
        "progress": progress,
        "max_time": max_time(ns),
        "method": "lohner" if ns.method is None else ns.method,
    }


def _growth_line(r, d: dict) -> str:
    """The summary's second line: the largest radius and how fast the radii grew."""
    return (
        f"largest radius {d['max_radius']}; {r.method} enclosure, radius growth "
        f"{r.growth_digits_per_period():.3f} decimal digits per period"
    )


def _certify_single(ns: argparse.Namespace, params, max_bits: int, progress) -> tuple:
    """``certify``: the single oscillator; ``(result, its dict, the summary lines, names)``."""
    if ns.y0 is not None:
        raise ParameterError("y0", " ".join(ns.y0), "only with --k (the coupled pair)")
    r = certify(
        params,
        ns.periods,
        precision="auto" if ns.precision is None else ns.precision,
        **_shared_options(ns, max_bits, progress),
    )
    d = r.to_dict()
    lines = [
        f"certified {r.periods} periods, {len(r.impacts)} impacts, at {r.bits} bits "
        f"({r.bits_choice}) in {r.elapsed_s:.2f} s",
        _growth_line(r, d),
    ]
    names = "xv"
    return r, d, lines, names


def _run_point(ns: argparse.Namespace, params) -> int:
    """``certify --point``: a landmark located in float64, then proven."""
    period = check_count(ns.orbit_period, "orbit_period", 1000, minimum=1)
    check_width(ns.width)  # refused before any work
    theta = {"zeta": params.zeta, "a": params.a, "x_w": params.x_w, "R": params.R}
    if ns.side is None and ns.point != "grazing":
        raise ParameterError("side", "none", f"low or high with --point {ns.point}")
    bp = locate_landmark(
        ns.point,
        tuple(float(theta[n]) for n in ("zeta", "a", "x_w")),
        float(params.eta),
        period,
        ns.side,
        R=float(params.R),
    )
    r = prove_landmark(bp, ns.width, theta=theta)
    if ns.json:
        print_json(r.to_dict())
        return 0
    side = r.sides
    print(
        "\n".join(
            [
                f"proven {ns.point} ({r.kind}, period {r.period}, {r.impacts} impacts) at "
                f"{r.bits} bits in {r.elapsed_s:.2f} s",
                # from the exact decimals and the log10: the floats are 5e-324 below 1e-308
                f"eta in [{r.eta_lower}, {r.eta_upper}] (width "
                f"{radius_str(Fraction(r.eta_upper) - Fraction(r.eta_lower))}; "
                f"Krawczyk contraction {log10_str(r.log10_contraction)})",
                f"{r.test_function}: {side[0]['g'][0]} at {side[0]['coordinate']} - 2r, "
                f"{side[1]['g'][0]} at + 2r (a crossing)",
                f"float64 landmark {r.eta_float64!r} ({r.float64_offset_ulps:.2f} ulp from the "
                "proven midpoint)",
            ]
        )
    )
    return 0
