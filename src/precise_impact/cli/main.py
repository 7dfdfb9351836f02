"""Command-line interface: ``precise-impact`` (also ``python -m precise_impact``)."""

from __future__ import annotations

import argparse
import json
import re
import sys
from collections.abc import Sequence

from precise_impact.analysis.sync import MAX_ENSEMBLE
from precise_impact.errors import (
    BudgetExceededError,
    IntegrationError,
    Interrupted,
    OptionalDependencyError,
    ParameterError,
)

# Exit statuses: 0 ok, 2 bad input (argparse uses 2 as well), 3 a budget was hit,
# 4 an I/O error during the run (finished files are complete: every write is atomic).
EXIT_BAD_INPUT = 2
EXIT_BUDGET = 3
EXIT_IO = 4
EXIT_INTERRUPTED = 130  # 128 + SIGINT, the shell's convention

_PARAM_FLAGS = (
    ("--eta", "eta", "forcing frequency ratio, > 0 (default 0.712)"),
    ("--zeta", "zeta", "damping ratio, >= 0 (default 0.05)"),
    ("--a", "a", "forcing amplitude (default 1)"),
    ("--x_w", "x_w", "wall position (default 2; --xw is accepted too)"),
    ("--R", "R", "restitution coefficient, 0 <= R <= 1 (default 1)"),
    ("--x0", "x0", "initial position, <= x_w (default 0)"),
    ("--v0", "v0", "initial velocity (default 0)"),
    ("--t0", "t0", "initial time / forcing phase (default 0)"),
)


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # no usage dump: one clear line, exit 2
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message}\n")


def _add_param_flags(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("system parameters (exact decimals, e.g. 0.712 or 102/53)")
    for flag, dest, helptext in _PARAM_FLAGS:
        # Flags are the Params names (as in sweep axes and scenes); --xw is the 0.1.0 spelling.
        names = (flag, "--xw") if dest == "x_w" else (flag,)
        g.add_argument(*names, dest=dest, default=None, metavar="DEC", help=helptext)


def _params_from(ns):
    from precise_impact.core.params import Params

    return Params.make(**{dest: getattr(ns, dest) for _, dest, _ in _PARAM_FLAGS})


def _add_orbit_flags(p: argparse.ArgumentParser, which: str) -> None:
    """``--period --impacts --guess --transient`` of the orbit commands (``which``: whose orbit)."""
    p.add_argument(
        "--period", default="1", metavar="P", help="forcing periods of the orbit (default 1)"
    )
    p.add_argument(
        "--impacts",
        default=None,
        metavar="N",
        help=f"required impacts per orbit{which} (default: any)",
    )
    p.add_argument(
        "--guess",
        nargs=2,
        default=None,
        metavar=("X", "V"),
        help=f"starting state at t0{which} (default: the state after --transient periods)",
    )
    p.add_argument(
        "--transient",
        default="2000",
        metavar="N",
        help="periods run for the default guess (default 2000)",
    )


def build_parser() -> argparse.ArgumentParser:
    from precise_impact.solvers.simulate import MODELS

    parser = _Parser(
        prog="precise-impact",
        description="Verification suite for the piecewise-linear impact oscillator and its electronic equivalent.",
    )
    from precise_impact.version import __version__

    parser.add_argument("--version", action="version", version=f"precise-impact {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    s = sub.add_parser("simulate", help="simulate one model and print samples and impacts")
    _add_param_flags(s)
    s.add_argument("--periods", default="200", metavar="N", help="forcing periods (default 200)")
    s.add_argument(
        "--model", default="heyoka", help="one of: " + ", ".join(MODELS) + " (default heyoka)"
    )
    s.add_argument(
        "--precision",
        default="float64",
        metavar="P",
        help="float64, longdouble, float128 or mp:BITS (default float64)",
    )
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
        "--out",
        default=None,
        metavar="FILE",
        help="write samples and impacts to FILE.npz, .csv or .json",
    )
    s.add_argument("--force", action="store_true", help="overwrite --out if it exists")
    s.add_argument("--json", action="store_true", help="print one JSON object to stdout")
    _add_max_time(s)

    ly = sub.add_parser(
        "lle", help="largest Lyapunov exponent (variational with saltation, or two-trajectory)"
    )
    _add_param_flags(ly)
    ly.add_argument(
        "--periods", default="20000", metavar="N", help="measured forcing periods (default 20000)"
    )
    ly.add_argument(
        "--transient",
        default="1000",
        metavar="N",
        help="discarded transient periods (default 1000)",
    )
    _add_max_time(ly)
    ly.add_argument(
        "--method",
        default="variational",
        help="variational, two-trajectory or fast (compiled closed form, float64) (default variational)",
    )
    ly.add_argument(
        "--precision",
        default="float64",
        metavar="P",
        help="float64, longdouble, float128 or mp:BITS",
    )
    ly.add_argument("--json", action="store_true", help="print one JSON object to stdout")

    ob = sub.add_parser(
        "orbit",
        help="a periodic orbit by Newton's method: its point, impacts, Floquet "
        "multipliers, stability and exact LLE",
    )
    _add_param_flags(ob)
    _add_orbit_flags(ob, "")
    ob.add_argument(
        "--precision",
        default="float64",
        metavar="P",
        help="float64 or mp:BITS (Newton refined to that precision)",
    )
    ob.add_argument(
        "--seed",
        default="auto",
        choices=("auto", "simulation", "closed-form"),
        help="where Newton starts without --guess: the closed-form orbit with one impact per P periods "
        "(closed-form), the state after --transient periods (simulation), or auto: the closed form "
        "when --impacts 1 is given and one exists, else the simulation (default auto)",
    )
    ob.add_argument(
        "--json",
        action="store_true",
        help="print one JSON object to stdout (state.x and state.v: JSON numbers in float64, decimal "
        "strings with every digit at mp:BITS; stability: stable, unstable or elliptic)",
    )

    ce = sub.add_parser(
        "certify",
        help="a certified trajectory: every sample and impact in a proven ball "
        "(ball arithmetic, python-flint)",
    )
    _add_param_flags(ce)
    ce.add_argument("--periods", default="300", metavar="N", help="forcing periods (default 300)")
    ce.add_argument(
        "--bits",
        default=None,
        metavar="B",
        help="working precision (default: chosen from --target and the measured radius growth)",
    )
    ce.add_argument(
        "--target",
        default=None,
        metavar="R",
        help="radius wanted at every sample, the single oscillator's automatic bits (default 1e-30)",
    )
    ce.add_argument(
        "--max-bits",
        dest="max_bits",
        default="8192",
        metavar="B",
        help="bits are doubled after a failed proof up to this (default 8192)",
    )
    ce.add_argument(
        "--k",
        default=None,
        metavar="K",
        help="certify the master-slave pair with coupling K >= 0 (default: the single oscillator)",
    )
    ce.add_argument(
        "--form",
        default="first-order",
        help="the pair's slave equation: first-order, paper or reduced",
    )
    ce.add_argument(
        "--y0",
        nargs=2,
        default=None,
        metavar=("Y", "W"),
        help="the slave's start (position, velocity variable); default: on the master (the diagonal)",
    )
    ce.add_argument("--json", action="store_true", help="print one JSON object to stdout")

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
    _add_param_flags(co)
    _add_orbit_flags(co, " of the starting orbit (at FROM)")
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
        help="fraction of the range a branch may run on past grazing as a virtual orbit (default 0.1)",
    )
    co.add_argument(
        "--diagram",
        default="200",
        metavar="N",
        help="values of the brute-force diagram drawn beneath the branches with --out (default 200; 0: none)",
    )
    co.add_argument("--json", action="store_true", help="print one JSON object to stdout")
    co.add_argument(
        "--out",
        default=None,
        metavar="DIR",
        help="write continuation.json and continuation.png here",
    )

    b = sub.add_parser(
        "bifurcation", help="stroboscopic x against eta with the LLE beneath (PNG + NPZ)"
    )
    b.add_argument(
        "--eta", nargs=3, required=True, metavar=("MIN", "MAX", "N"), help="eta grid: MIN MAX N"
    )
    g = b.add_argument_group("other system parameters (exact decimals)")
    for flag, dest, helptext in _PARAM_FLAGS:
        if dest != "eta":
            g.add_argument(flag, dest=dest, default=None, metavar="DEC", help=helptext)
    b.add_argument(
        "--periods", default="2000", metavar="P", help="measured periods per value (default 2000)"
    )
    b.add_argument(
        "--transient",
        default="1000",
        metavar="T",
        help="transient periods per value (default 1000)",
    )
    b.add_argument(
        "--workers", default=None, metavar="W", help="worker processes (default: all cores)"
    )
    b.add_argument(
        "--out", required=True, metavar="DIR", help="write bifurcation.png and bifurcation.npz here"
    )
    _add_max_time(b)

    sy = sub.add_parser(
        "sync", help="master-slave synchronisation threshold against the LLE (paper Fig. 7)"
    )
    sy.add_argument(
        "--form", default="first-order", help="first-order, paper or reduced (default first-order)"
    )
    sy.add_argument(
        "--k",
        nargs=3,
        default=["0.02", "0.045", "6"],
        metavar=("MIN", "MAX", "N"),
        help="coupling grid (default 0.02 0.045 6)",
    )
    _add_param_flags(sy)
    sy.add_argument(
        "--periods",
        default="500",
        metavar="P",
        help="forcing periods per run (default 500, as the paper)",
    )
    sy.add_argument(
        "--ensemble", default="8", metavar="M", help="slave initial conditions per k (default 8)"
    )
    sy.add_argument(
        "--seed", default="0", metavar="S", help="seed of the initial conditions (default 0)"
    )
    sy.add_argument(
        "--fig7",
        nargs=2,
        default=["0.031", "0.032"],
        metavar=("K1", "K2"),
        help="couplings of the Fig. 7 plot (default the paper's 0.031 0.032)",
    )
    sy.add_argument(
        "--out", default="results", metavar="DIR", help="plots and JSON go here (default results)"
    )
    sy.add_argument(
        "--engine",
        choices=("fast", "heyoka"),
        default="fast",
        help="fast (compiled closed forms, float64; default) or heyoka (Taylor integration)",
    )
    sy.add_argument("--json", action="store_true", help="print one JSON object to stdout")
    _add_max_time(sy)

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
    _add_param_flags(sw)
    sw.add_argument(
        "--periods", default="2000", metavar="P", help="measured periods per point (default 2000)"
    )
    sw.add_argument(
        "--transient",
        default="1000",
        metavar="T",
        help="transient periods per point (default 1000)",
    )
    sw.add_argument("--tile", default="64", metavar="K", help="points per tile (default 64)")
    sw.add_argument(
        "--engine",
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
    sw.add_argument(
        "--out", required=True, metavar="DIR", help="tiles, sweep.npz, sweep.csv, sweep.png"
    )
    sw.add_argument("--json", action="store_true", help="print the summary as one JSON object")

    sub.add_parser("scenes", help="list the built-in scenes, one line each")
    rn = sub.add_parser("run", help="run a scene (built-in name or FILE.toml)")
    rn.add_argument(
        "scene", help="built-in scene name (see: precise-impact scenes) or a .toml file"
    )
    rn.add_argument("--model", default=None, help="override the scene's model")
    rn.add_argument("--json", action="store_true", help="print one JSON object to stdout")
    rn.add_argument(
        "--out", default=None, metavar="DIR", help="write <scene>_<model>.json and .png here"
    )
    _add_max_time(rn)

    from precise_impact.cli import (
        bench as _cli_bench,
    )
    from precise_impact.cli import (
        compare as _cli_compare,
    )
    from precise_impact.cli import (
        reference as _cli_reference,
    )

    _cli_compare.add_parser(sub)
    _cli_reference.add_parser(sub)
    _cli_bench.add_parser(sub)
    rp = sub.add_parser(
        "reproduce", help="the main job: the paper's Figs. 4-7, LLE, sync thresholds, report.md"
    )
    rp.add_argument(
        "--out", default="results", metavar="DIR", help="output directory (default results)"
    )
    rp.add_argument("--quick", action="store_true", help="shorter runs (about a minute)")

    a = sub.add_parser(
        "accuracy",
        help="the paper's three frequencies: every model and precision against a demonstrated reference",
    )
    a.add_argument(
        "--periods", default="100", metavar="N", help="forcing periods from rest (default 100)"
    )
    a.add_argument(
        "--out", default=None, metavar="DIR", help="write accuracy.json and accuracy.png here"
    )
    a.add_argument("--json", action="store_true", help="print the result as one JSON object")
    for (
        name,
        sp,
    ) in sub.choices.items():  # every directory --out: no silent overwrite without --force
        opts = {o for a in sp._actions for o in a.option_strings}
        if "--out" in opts and "--force" not in opts and name != "sweep":
            sp.add_argument(
                "--force",
                action="store_true",
                help="write into an existing non-empty --out directory (files of the same name are replaced)",
            )
    return parser


def _add_max_time(p) -> None:
    p.add_argument(
        "--max-time",
        default=None,
        metavar="S",
        help="time budget in seconds, checked against an estimate before any work (default 3600)",
    )


def _max_time(ns) -> float:
    from precise_impact.core.budget import DEFAULT_MAX_TIME, parse_max_time

    return DEFAULT_MAX_TIME if ns.max_time is None else parse_max_time(ns.max_time)


def _cmd_simulate(ns) -> int:
    from pathlib import Path

    from precise_impact.core.params import check_count
    from precise_impact.solvers.simulate import make_solver

    params = _params_from(ns)
    periods = check_count(ns.periods)
    dense = check_count(ns.dense, "dense", 100_000)
    if ns.out is not None and Path(ns.out).suffix not in (".npz", ".csv", ".json"):
        raise ParameterError("out", ns.out, "output file must end in .npz, .csv or .json")
    solver = make_solver(ns.model, ns.precision, ns.tol)
    from precise_impact.core.budget import check_cost, estimate_cost
    from precise_impact.core.precision import Precision
    from precise_impact.io.progress import Progress
    from precise_impact.solvers.heyoka.single import HeyokaSolver

    cost = estimate_cost(
        getattr(solver, "precision", None) or Precision.parse(ns.precision), periods, dense
    )
    check_cost(cost, _max_time(ns))
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
    if ns.out is not None:
        traj.save(ns.out)
    if ns.json:
        json.dump(traj.to_dict(), sys.stdout)
        sys.stdout.write("\n")
    else:
        s = traj.precision.to_str
        print(
            f"{traj.model} {traj.precision.name}: {periods} periods, {traj.n_impacts} impacts, {traj.elapsed_s:.4f} s"
        )
        print(f"params: {', '.join(f'{k}={v}' for k, v in params.decimal().items())}")
        print(f"final state at t={s(traj.t[-1])}:\n  x = {s(traj.x[-1])}\n  v = {s(traj.v[-1])}")
        if ns.out is not None:
            print(f"written: {ns.out}")
    return 0


def _cmd_lle(ns) -> int:
    from precise_impact.analysis.lyapunov import LYAPUNOV_METHODS, lyapunov
    from precise_impact.core.params import check_count
    from precise_impact.core.precision import Precision

    params = _params_from(ns)
    periods = check_count(ns.periods)
    transient = check_count(ns.transient, "transient")
    if ns.method not in LYAPUNOV_METHODS:
        raise ParameterError("method", ns.method, "one of " + ", ".join(LYAPUNOV_METHODS))
    from precise_impact.core.budget import check_cost, estimate_cost

    # four starting conditions; the variational equations cost about twice a trajectory
    # the compiled engine costs ~1/30 of heyoka's variational run (benchmarks/results/fast.md)
    factor = 2 / 30 if ns.method == "fast" else 2
    check_cost(
        estimate_cost(
            Precision.parse(ns.precision), periods + transient, runs=4, factor=factor, stored=False
        ),
        _max_time(ns),
    )
    r = lyapunov(
        params,
        ns.method,
        periods=periods,
        transient=transient,
        precision=ns.precision,
        progress=not ns.json,
    )
    if ns.json:
        json.dump(r.to_dict(), sys.stdout)
        sys.stdout.write("\n")
    else:
        spec = (
            "" if r.spectrum is None else f"  spectrum = ({r.spectrum[0]:.6f}, {r.spectrum[1]:.6f})"
        )
        print(
            f"LLE = {r.lle:.6f} +- {r.stderr:.6f} per unit time ({r.method}, {r.precision}){spec}"
        )
        groups = r.stats.get("attractors", [])
        head = next((g for g in groups if g["id"] == r.stats.get("headline_attractor")), None)
        if r.stats.get("lle_source") == "floquet" and head is not None:
            ft = r.stats["finite_time"]
            print(
                f"periodic attractor: period {head['period']}, {head['impacts']} impact(s); the LLE is its Floquet "
                f"value ln|mu_max| / (p T) (finite-time estimate {ft['lle']:.6f} +- {ft['stderr']:.2g}, "
                "1/t offset included)"
            )
        if "warning" in r.stats:
            print("warning: " + r.stats["warning"])
        if len(r.stats.get("per_start", [])) > 1:
            for j, s in enumerate(r.stats["per_start"]):
                rate = s.get("impact_rate")
                print(
                    f"  start {j}: LLE {s['lle']:.6f} +- {s['stderr']:.2g}, "
                    + (f"{rate:.4f} impacts/period, " if rate is not None and rate == rate else "")
                    + f"attractor #{s.get('attractor')}"
                )
        print(
            f"{r.periods} periods after {r.transient} transient, {r.impacts} impacts, {r.elapsed_s:.3f} s"
        )
    return 0


def _cmd_orbit(ns) -> int:
    from precise_impact.analysis.orbits import find_orbit
    from precise_impact.core.params import check_count

    params = _params_from(ns)
    period = check_count(ns.period, "period", 1000, minimum=1)
    impacts = None if ns.impacts is None else check_count(ns.impacts, "impacts", 10**6)
    o = find_orbit(
        params,
        period,
        guess=ns.guess,
        impacts=impacts,
        transient=check_count(ns.transient, "transient"),
        precision=ns.precision,
        seed=ns.seed,
    )
    if ns.json:
        json.dump(o.to_dict(), sys.stdout)
        sys.stdout.write("\n")
        return 0
    mus = ", ".join(
        f"{m.real:.12g}{m.imag:+.12g}i" if m.imag else f"{m.real:.12g}" for m in o.multipliers
    )
    st = o.to_dict()["state"]
    print(
        f"period-{o.period} orbit with {o.impacts} impact(s): x = {st['x']}, v = {st['v']} at t = {o.t!r} "
        f"({o.precision})"
    )
    kind = o.stability + (
        " (neutral: zeta = 0 and R = 1 make det M = 1, the pair on the unit circle)"
        if o.stability == "elliptic"
        else ""
    )
    print(f"Floquet multipliers {mus}: {kind}; LLE = ln|mu_max| / (p T) = {o.lle:.10g}")
    print(f"residual |P^p(z) - z| = {o.residual:.3g} after {o.iterations} Newton iteration(s)")
    return 0


def _cmd_certify(ns) -> int:
    from precise_impact.core.params import check_count
    from precise_impact.solvers.certified.single import MAX_BITS, certify

    params = _params_from(ns)
    max_bits = check_count(ns.max_bits, "max_bits", MAX_BITS, minimum=64)
    bits = None if ns.bits is None else check_count(ns.bits, "bits", max_bits, minimum=64)
    progress = None if ns.json else True
    if ns.k is not None:
        from precise_impact.solvers.certified.coupled import certify_coupled

        if ns.target is not None:
            raise ParameterError(
                "target", ns.target, "only for the single oscillator (the pair takes --bits)"
            )
        r = certify_coupled(
            params,
            ns.k,
            ns.form,
            ns.periods,
            y0=ns.y0,
            bits=256 if bits is None else bits,
            max_bits=max_bits,
            progress=progress,
        )
        lines = [
            f"certified pair ({r.form}, k = {ns.k}): {r.periods} periods, {len(r.master_impacts)} master and "
            f"{len(r.slave_impacts)} slave impacts, at {r.bits} bits in {r.elapsed_s:.2f} s; largest radius "
            f"1e{r.max_log10_radius():.1f}"
        ]
        names = "xvyw"
    else:
        if ns.y0 is not None:
            raise ParameterError("y0", " ".join(ns.y0), "only with --k (the coupled pair)")
        r = certify(
            params,
            ns.periods,
            bits=bits,
            target_radius="1e-30" if ns.target is None else ns.target,
            max_bits=max_bits,
            progress=progress,
        )
        lines = [
            f"certified {r.periods} periods, {len(r.impacts)} impacts, at {r.bits} bits ({r.bits_choice}) "
            f"in {r.elapsed_s:.2f} s",
            f"largest radius 1e{r.max_log10_radius():.1f}; radius growth {r.growth_digits_per_period():.3f} decimal "
            f"digits per period",
        ]
        names = "xv"
    d = r.to_dict()
    if ns.json:
        json.dump(d, sys.stdout)
        sys.stdout.write("\n")
        return 0
    last = d["samples"][-1]
    lines += [f"{n}({last['period']} T) = {last[n]} +- {last[n + '_rad']}" for n in names]
    print("\n".join(lines))
    return 0


def _cmd_continue(ns) -> int:
    from precise_impact.analysis.orbits import continue_orbit
    from precise_impact.core.params import check_count

    name, lo, hi = ns.param
    fixed = {dest: getattr(ns, dest) for _, dest, _ in _PARAM_FLAGS}
    if name in fixed and fixed[name] is not None:
        raise ParameterError(
            name, fixed[name], f"not given twice: --{name} is set by --param {name} FROM TO"
        )
    params = _params_from(ns)
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
    )
    if ns.out is not None:
        from precise_impact.analysis.orbits.branch import brute_force_diagram

        diagram = None
        if n_diagram:
            diagram = brute_force_diagram(
                res.params, name, float(res.start), float(res.stop), n_diagram
            )
        files = res.save_all(ns.out, diagram=diagram)
        if not ns.json:
            print("wrote " + ", ".join(str(f) for f in files.values()))
    if ns.json:
        json.dump(res.to_dict(), sys.stdout)
        sys.stdout.write("\n")
        return 0
    for k, b in enumerate(res.branches):
        n_st = int(b.stable.sum())
        n_el = int((b.stability == "elliptic").sum())
        print(
            f"branch {k}: period {b.period}, {b.impacts} impact(s), {len(b.values)} points, {name} "
            f"{b.values.min():.10g} .. {b.values.max():.10g}, {n_st} stable, "
            + (f"{n_el} elliptic (neutral), " if n_el else "")
            + f"{int((~b.admissible).sum())} virtual ({b.origin}; {b.stop_reason})"
        )
    if not res.bifurcations:
        print("no bifurcation in the range")
    for bif in res.bifurcations:
        mus = ", ".join(
            f"{m[0]:.8g}{m[1]:+.3g}i" if m[1] else f"{m[0]:.8g}" for m in bif.multipliers
        )
        where = "" if bif.admissible else " (virtual orbit)"
        print(
            f"{bif.type} on branch {bif.branch} at {name} = {bif.value!r}{where}: multipliers {mus}"
            + (f"; {bif.detail}" if bif.detail else "")
        )
    return 0


def _cmd_bifurcation(ns) -> int:
    from precise_impact.analysis.bifurcation import bifurcation
    from precise_impact.core.params import Params, check_count

    params = Params.make(
        **{dest: getattr(ns, dest) for _, dest, _ in _PARAM_FLAGS if dest != "eta"}
    )
    workers = None if ns.workers is None else check_count(ns.workers, "workers", 1024)
    from precise_impact.core.budget import check_cost, estimate_cost
    from precise_impact.core.precision import Precision

    n = check_count(ns.eta[2], "n", 1_000_000, minimum=1)
    length = check_count(ns.periods, "periods") + check_count(ns.transient, "transient")
    # one variational run per value (x2), spread over the workers
    check_cost(
        estimate_cost(Precision.parse("float64"), length, runs=n, factor=2, stored=False),
        _max_time(ns) * (workers or __import__("os").cpu_count() or 1),
    )
    res = bifurcation(
        params,
        ns.eta[0],
        ns.eta[1],
        ns.eta[2],
        periods=ns.periods,
        transient=ns.transient,
        workers=workers,
        progress=True,
    )
    files = res.save_all(ns.out)
    print(
        f"{len(res.eta)} values of eta in {res.elapsed_s:.1f} s on {res.workers} worker(s); "
        f"grazing eta (closed form): {', '.join(f'{g:.6f}' for g in res.grazing) or 'none in range'}"
    )
    print(
        f"LLE range: {res.lle.min():.4f} .. {res.lle.max():.4f}; written: {files['png']}, {files['npz']}"
    )
    return 0


def _cmd_sync(ns) -> int:
    from pathlib import Path

    from precise_impact.analysis.sync import plot_fig7, plot_sync_fraction, sync_scan
    from precise_impact.core.params import check_count, exact_grid
    from precise_impact.io.atomic import atomic_write
    from precise_impact.solvers.heyoka.coupled import check_form, check_k

    params = _params_from(ns)
    form = check_form(ns.form)
    ks = exact_grid(ns.k[0], ns.k[1], ns.k[2], "k")
    periods = check_count(ns.periods)
    ensemble = check_count(ns.ensemble, "ensemble", MAX_ENSEMBLE, minimum=1)
    seed = check_count(ns.seed, "seed", 2**32)
    k1, k2 = check_k(ns.fig7[0], "fig7"), check_k(ns.fig7[1], "fig7")
    from precise_impact.core.budget import check_cost, estimate_cost
    from precise_impact.core.precision import Precision

    # master + slave (4 states, x4) for every k and ensemble member, plus the master's LLE
    check_cost(
        estimate_cost(
            Precision.parse("float64"),
            periods,
            20,
            runs=len(ks) * ensemble,
            factor=4 if ns.engine == "heyoka" else 4 / 5,
            stored=False,
        ),
        _max_time(ns),
    )
    res = sync_scan(
        params,
        form,
        ks,
        periods=periods,
        ensemble=ensemble,
        seed=seed,
        progress=not ns.json,
        engine=ns.engine,
    )
    out = Path(ns.out)
    stem = f"sync_{form}"
    text = json.dumps(res.to_dict(), indent=1)
    atomic_write(out / f"{stem}.json", lambda fh: fh.write(text), binary=False)
    plot_sync_fraction(res, out / f"{stem}_fraction.png")
    plot_fig7(params, form, k1, k2, periods, out / f"{stem}_fig7.png")
    if ns.json:
        obj = res.to_dict()
        obj.pop("runs", None)
        json.dump(obj, sys.stdout)
        sys.stdout.write("\n")
        return 0
    print(
        f"form {form}: {periods} periods, ensemble {ensemble}, sync = |x - y| < {res.threshold:g} over the last "
        f"{res.tail:.0%} of the run"
    )
    print(f"{'k':>8} {'synchronised':>12} {'intermittent':>12} {'rate + k':>9}")
    for k, fs, fi, r in zip(
        res.k_values, res.fraction_synchronised, res.fraction_intermittent, res.mean_rate
    ):
        print(f"{float(k):8.4f} {fs:12.3f} {fi:12.3f} {r + float(k):9.4f}")
    print(f"threshold k* = {res.k_star:.4f} +- {res.k_star_err:.4f} ({res.message})")
    print(
        f"LLE ({'fast' if ns.engine == 'fast' else 'variational'}) = {res.lle:.4f} +- {res.lle_stderr:.4f}"
    )
    print(
        f"written: {out / (stem + '.json')}, {out / (stem + '_fraction.png')}, {out / (stem + '_fig7.png')}"
    )
    return 0


def _cmd_sweep(ns) -> int:
    from precise_impact.analysis.sweep import SweepSpec, run_sweep
    from precise_impact.core.params import check_count

    base = _params_from(ns)
    from precise_impact.analysis.sweep import MAX_WORK

    max_work = MAX_WORK
    if ns.max_work is not None:
        from precise_impact.core.params import exact

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
        engine=ns.engine,
    )
    workers = None if ns.workers is None else check_count(ns.workers, "workers", 1024)
    if ns.scheduler is not None and not ns.scheduler.startswith("tcp://"):
        raise ParameterError("scheduler", ns.scheduler, "a Dask scheduler address tcp://HOST:PORT")
    res = run_sweep(
        spec, ns.out, workers=workers, dask=ns.dask or ns.scheduler, progress=not ns.json
    )
    st = res.stats
    if ns.json:  # the run, not the grid (that is in sweep.npz / sweep.csv)
        json.dump(dict(st, complete=res.complete, **res.files), sys.stdout)
        sys.stdout.write("\n")
    else:
        print(
            f"{spec.n_points} points in {spec.n_tiles} tiles: {st['tiles_computed']} computed, "
            f"{st['tiles_reused']} reused, {st['elapsed_s']:.1f} s on {st['workers']} {st['backend']} worker(s)"
        )
        if res.files:
            print(f"written: {res.files['npz']}, {res.files['csv']}, {res.files['png']}")
    return 0


def _cmd_scenes(ns) -> int:
    from precise_impact.core.params import decimal_str
    from precise_impact.scenes.scene import builtin_scenes, load_scene

    for name, path in sorted(builtin_scenes().items()):
        sc = load_scene(path)
        extra = f" k={decimal_str(sc.k)} form={sc.form}" if sc.kind == "coupled" else ""
        print(
            f"{name:28s} {sc.model:18s} eta={sc.params.decimal()['eta']:<6s}{extra}  {sc.description}"
        )
    return 0


def _cmd_run(ns) -> int:
    from precise_impact.scenes.run import run_scene, save_scene_outputs, scene_json
    from precise_impact.scenes.scene import SCENE_MODELS, load_scene

    scene = load_scene(ns.scene)
    if ns.model is not None and ns.model not in SCENE_MODELS:
        raise ParameterError("model", ns.model, "one of " + ", ".join(SCENE_MODELS))
    if ns.model is not None:
        scene = scene.with_model(ns.model)  # validated before any work
    result = run_scene(scene, max_time=_max_time(ns))
    obj = scene_json(scene, result)
    files = save_scene_outputs(scene, result, ns.out) if ns.out is not None else []
    if ns.json:
        json.dump(obj, sys.stdout)
        sys.stdout.write("\n")
    else:
        last = obj["samples"][-1]
        n_imp = (
            len(obj["impacts"])
            if isinstance(obj["impacts"], list)
            else sum(map(len, obj["impacts"].values()))
        )
        print(
            f"{scene.name}: model {obj['model']}, effects {', '.join(obj['effects']) or 'none'}, "
            f"{len(obj['samples']) - 1} periods, {n_imp} impacts, {obj['elapsed_s']:.3f} s"
        )
        print(
            f"last sample: x = {last['x']}, v = {last['v']}"
            + (f", y = {last['y']}" if "y" in last else "")
        )
        for f in files:
            print(f"written: {f}")
    return 0


def _cmd_reproduce(ns) -> int:
    from precise_impact.verification.reproduce import reproduce

    res = reproduce(ns.out, quick=ns.quick, progress=True)
    print(f"report: {ns.out}/report.md ({res['elapsed_s']:.0f} s)")
    for fig, row in res["figures"].items():
        print(
            f"Fig. {fig} eta={row['eta']}: "
            + ", ".join(f"{n} {m['max_error_second_half']:.1e}" for n, m in row["models"].items())
        )
    v = res["lle"]["variational"]
    print(
        f"LLE(0.712) = {v[0]:.4f} +- {v[1]:.4f}; sync k*: "
        + ", ".join(f"{f} {s['k_star']:.4f}" for f, s in res["sync"].items())
    )
    return 0


def _cmd_bench(ns) -> int:
    from precise_impact.cli.bench import run

    return run(ns)


def _cmd_compare(ns) -> int:
    from precise_impact.cli.compare import run

    return run(ns)


def _cmd_reference(ns) -> int:
    from precise_impact.cli.reference import run

    return run(ns)


def _cmd_accuracy(ns) -> int:
    from precise_impact.core.params import check_count
    from precise_impact.verification.accuracy import accuracy_table, format_table

    periods = check_count(ns.periods, maximum=2000, minimum=1)
    result = accuracy_table(periods=periods, out=ns.out, progress=not ns.json)
    if ns.json:
        json.dump(result.to_dict(), sys.stdout)
        sys.stdout.write("\n")
    else:
        print(format_table(result))
        if ns.out is not None:
            print(f"written: {ns.out}/accuracy.json, {ns.out}/accuracy.png")
    return 0


def _glue_negative_values(argv: list[str]) -> list[str]:
    """``--tol -1e-9`` -> ``--tol=-1e-9``: argparse would read ``-1e-9`` as an option.

    Lets the validators, not argparse, report a negative value with its allowed range.
    """
    out: list[str] = []
    i = 0
    while i < len(argv):
        a = argv[i]
        if (
            a.startswith("--")
            and "=" not in a
            and i + 1 < len(argv)
            and argv[i + 1].startswith("-")
        ):
            nxt = argv[i + 1]
            plain = re.fullmatch(r"-\d+|-\d*\.\d+", nxt)  # argparse itself reads these as values
            if (
                not plain
                and len(nxt) > 1
                and (
                    nxt[1].isdigit()
                    or nxt[1] == "."
                    or nxt[1:].lower() in ("inf", "infinity", "nan")
                )
            ):
                out.append(f"{a}={nxt}")
                i += 2
                continue
        # Any other token that is a negative number (``--axis x_w -1e-3 2 3``): a leading
        # space makes argparse take it as a value; the number parser strips it.
        if len(a) > 1 and a[0] == "-" and not a.startswith("--") and _is_number(a):
            a = " " + a
        out.append(a)
        i += 1
    return out


def _is_number(s: str) -> bool:
    try:
        float(s)
    except ValueError:
        return False
    return True


def _terminate_as_interrupt() -> None:
    """SIGTERM ends a run like Ctrl-C: the same cleanup, one line, exit 130."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        return  # signal handlers can only be set from the main thread (e.g. main() called in a test thread)

    def handler(signum, frame):
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, handler)


def _check_outputs(ns) -> None:
    """Every --out checked before any work: the right kind of path, writable, no silent overwrite."""
    from precise_impact.io.atomic import check_output_dir, check_output_file

    out = getattr(ns, "out", None)
    if out is None:
        return
    if ns.command == "simulate":
        check_output_file(out, force=ns.force)
    else:  # a sweep and a reference dataset resume in their own directory (checked there)
        check_output_dir(
            out, force=ns.command in ("sweep", "reference") or getattr(ns, "force", False)
        )


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    ns = parser.parse_args(_glue_negative_values(list(sys.argv[1:] if argv is None else argv)))
    # heyoka logs its warnings (e.g. root finding near grazing) to stdout, which would
    # corrupt --json output; the CLI keeps only errors.
    import heyoka

    heyoka.set_logger_level_error()
    _terminate_as_interrupt()
    try:
        _check_outputs(ns)
        return {
            "simulate": _cmd_simulate,
            "lle": _cmd_lle,
            "orbit": _cmd_orbit,
            "continue": _cmd_continue,
            "certify": _cmd_certify,
            "bifurcation": _cmd_bifurcation,
            "sync": _cmd_sync,
            "sweep": _cmd_sweep,
            "scenes": _cmd_scenes,
            "run": _cmd_run,
            "reproduce": _cmd_reproduce,
            "compare": _cmd_compare,
            "reference": _cmd_reference,
            "bench": _cmd_bench,
            "accuracy": _cmd_accuracy,
        }[ns.command](ns)
    except (
        ParameterError,
        OptionalDependencyError,
    ) as e:  # bad input, or a component this request needs
        print(f"precise-impact: error: {e}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except BudgetExceededError as e:
        print(f"precise-impact: budget exceeded: {e}", file=sys.stderr)
        return EXIT_BUDGET
    except IntegrationError as e:  # ConvergenceError (a Newton that found no orbit) says so
        what = (
            "no periodic orbit" if type(e).__name__ == "ConvergenceError" else "integration stopped"
        )
        print(f"precise-impact: {what}: {e}", file=sys.stderr)
        return EXIT_BUDGET
    except BrokenPipeError:  # e.g. piped into `head`
        sys.stderr.close()
        return 0
    except (
        KeyboardInterrupt
    ) as e:  # Ctrl-C or SIGTERM: finished files (tiles, outputs) are complete
        print(
            f"precise-impact: {getattr(e, 'kept', 'interrupted; finished results are kept')}",
            file=sys.stderr,
        )
        return EXIT_INTERRUPTED
    except OSError as e:  # a full or read-only file system mid-run: one line, finished files intact
        print(
            f"precise-impact: I/O error: {e.strerror or e}: {e.filename or ''}".rstrip(": "),
            file=sys.stderr,
        )
        return EXIT_IO


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
