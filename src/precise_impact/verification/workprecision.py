"""Work-precision: every method's error against a demonstrated reference, and its cost.

heyoka, the closed form, scipy ``solve_ivp`` and ngspice on a periodic and a chaotic case, and
what chaos costs in bits (``docs/numerics.rst``).
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
import os
import shutil
import statistics
import time
from collections.abc import Callable
from fractions import Fraction
from functools import partial
from pathlib import Path
from typing import Any

import mpmath
import numpy as np

from precise_impact.core.mpcontext import mp_context, mp_import
from precise_impact.core.params import Params
from precise_impact.core.result import ResultMixin, record_columns
from precise_impact.errors import OptionalDependencyError
from precise_impact.io.atomic import atomic_write
from precise_impact.io.figures import (
    figure_legend,
    finish,
    new_figure,
    save_figure,
    series_styles,
    wrap_title,
)
from precise_impact.io.jsonout import write_json
from precise_impact.io.progress import say as _progress
from precise_impact.models.circuit.components import nominal_components
from precise_impact.models.circuit.opamp import CircuitSolver
from precise_impact.models.circuit.spice import run_spice
from precise_impact.solvers.closed_form import AnalyticalSolver
from precise_impact.solvers.heyoka.single import HeyokaSolver
from precise_impact.verification.metrics import reference_bits

__all__ = [
    "CASES",
    "LAMBDA",
    "predicted_bits",
    "scipy_solve",
    "work_precision",
    "format_table",
]

#: Largest Lyapunov exponent at eta = 0.712 (per unit time; README, ``lle``).
LAMBDA = 0.0305
#: Decimal digits of margin in the chaos-cost prediction.
MARGIN_DIGITS = 3
#: Error threshold defining the predictability horizon.
HORIZON_ERROR = 1e-3
#: Agreement required in the chaos-cost search.
CHAOS_TARGET = 1e-15

CASES = {
    "periodic": {"eta": "0.74", "periods": 50},
    "chaotic": {"eta": "0.712", "periods": 50},
}


def predicted_bits(
    N: int, eta: float = 0.712, lam: float = LAMBDA, margin: float = MARGIN_DIGITS
) -> float:
    """Bits needed to keep 15 digits after N periods:
    ``(15 + N T lam / ln 10 + margin) log2 10``."""
    T = 2 * math.pi / eta
    return (15 + N * T * lam / math.log(10) + margin) * math.log2(10)


# --------------------------------------------------------------------------- scipy


class ScipyResult:
    """Samples and impacts of :func:`scipy_solve` (float64)."""

    def __init__(self, t, x, v, impacts_t, nfev):
        self.t, self.x, self.v = t, x, v
        self.impacts_t = impacts_t
        self.nfev = nfev


def scipy_solve(
    params: Params,
    periods: int,
    method: str = "DOP853",
    rtol: float = 1e-10,
    atol: float | None = None,
    max_impacts: int = 100_000,
) -> ScipyResult:
    """The oscillator with ``scipy.integrate.solve_ivp``: terminal events and restarts.

    Event ``x - x_w`` (direction +1, terminal); at an event the state is set to
    ``(x_w, -R v)`` and integration restarts at the event time.  ``atol``
    defaults to ``rtol * 1e-3``.  Samples at ``k 2 pi / eta`` (float64).
    """
    try:
        from scipy.integrate import solve_ivp  # noqa: PLC0415 -- optional: loaded on first use
    except ImportError:
        raise OptionalDependencyError(
            "scipy", "pip install 'precise_impact[bench]'", "scipy_solve"
        ) from None

    eta, zeta, a = float(params.eta), float(params.zeta), float(params.a)
    xw, R = float(params.x_w), float(params.R)
    atol = rtol * 1e-3 if atol is None else atol
    T = 2 * math.pi / eta
    t0 = float(params.t0)
    ts = t0 + T * np.arange(periods + 1)

    def rhs(t, y):
        return [y[1], -2 * zeta * y[1] - y[0] + a * math.cos(eta * t)]

    def jac(t, y):
        return [[0.0, 1.0], [-1.0, -2 * zeta]]

    def wall(t, y):
        return y[0] - xw

    wall.terminal = True
    wall.direction = 1

    xs = np.empty(periods + 1)
    vs = np.empty(periods + 1)
    xs[0], vs[0] = float(params.x0), float(params.v0)
    filled = 1
    t, y = t0, [float(params.x0), float(params.v0)]
    t_end = ts[-1]
    impacts: list[float] = []
    nfev = 0
    kw = {"jac": jac} if method in ("Radau", "BDF", "LSODA") else {}
    while t < t_end:
        t_eval = ts[filled:][ts[filled:] > t]
        sol = solve_ivp(
            rhs,
            (t, t_end),
            y,
            method=method,
            rtol=rtol,
            atol=atol,
            events=wall,
            t_eval=t_eval,
            **kw,
        )
        nfev += sol.nfev
        if sol.status == -1:
            raise RuntimeError(f"solve_ivp {method} failed: {sol.message}")
        n = len(sol.t)
        if n:
            ys = np.asarray(sol.y)
            xs[filled : filled + n] = ys[0]
            vs[filled : filled + n] = ys[1]
        filled += n
        if sol.status == 1 and len(sol.t_events[0]):
            te = float(sol.t_events[0][0])
            ye = sol.y_events[0][0]
            impacts.append(te)
            if len(impacts) > max_impacts:
                raise RuntimeError("impact budget exceeded")
            t, y = te, [xw, -R * float(ye[1])]
        else:
            break
    if filled != periods + 1:
        raise RuntimeError(f"solve_ivp {method}: {filled} of {periods + 1} samples")
    return ScipyResult(ts, xs, vs, np.array(impacts), nfev)


def _have_scipy() -> bool:
    try:
        import scipy.integrate  # noqa: F401, PLC0415 -- optional: probed, not needed
    except ImportError:
        return False
    return True


# --------------------------------------------------------------------------- errors and timing


def _ref_states(traj) -> list[tuple]:
    return [traj.state_mpf(k)[1:] for k in range(len(traj.t))]


def _states(res) -> list[tuple]:
    if hasattr(res, "state_mpf"):
        return _ref_states(res)
    return [(float(x), float(v)) for x, v in zip(res.x, res.v, strict=True)]  # exact in mpmath


def _errors(res, ref_states: list[tuple], bits: int) -> list[float]:
    out = []
    ctx = mp_context(bits + 32)  # this thread's own: mpmath's global precision is shared
    for (x, v), (xr, vr) in zip(_states(res), ref_states, strict=True):
        x, v = mp_import(ctx, x), mp_import(ctx, v)
        out.append(float(max(abs(x - xr), abs(v - vr))))
    return out


def _timed(fn: Callable[[], Any], budget_s: float) -> tuple[Any, float, int]:
    """Warm-up run, then the median of repeats; ``(result, median_s, repeats)``.

    The warm-up itself is the measurement (``repeats = 1``) when it took longer
    than ``budget_s``.
    """
    t0 = time.perf_counter()
    res = fn()
    w = time.perf_counter() - t0
    if w > budget_s:
        return res, w, 1
    n = 5 if w < 0.05 else 3 if w < budget_s / 3 else 1
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        res = fn()
        times.append(time.perf_counter() - t0)
    return res, statistics.median(times), n


# --------------------------------------------------------------------------- configuration


def _config(quick: bool) -> dict[str, Any]:
    if quick:
        return {
            "cases": CASES,
            "heyoka": {
                "float64": ["1e-6", "1e-9", "1e-12", None],
                "longdouble": ["1e-12", None],
                "float128": ["1e-20", None],
            },
            "heyoka_mp": [128],
            "analytical_paper": [Fraction(1, 100), Fraction(1, 1000)],
            "analytical_robust": True,
            "analytical_mp_dps": [30],
            "scipy": {
                "DOP853": [1e-6, 1e-8, 1e-10, 1e-12, 1e-13],
                # Radau's Python stepper at 1e-9 took 46 of the quick run's 80 s; 1e-8 (a
                # point of the full run too) 16 s: the slope is the same
                "Radau": [1e-6, 1e-8],
                "LSODA": [1e-6, 1e-9],
            },
            "spice_tmax": ["30e-6"],
            "chaos_N": [50, 100, 200],
            "certify_N": 300,
            "budget_s": 2.0,
            "circuit": True,
        }
    return {
        "cases": CASES,
        "heyoka": {
            "float64": ["1e-6", "1e-8", "1e-10", "1e-12", "1e-14", None],
            "longdouble": ["1e-8", "1e-12", "1e-16", None],
            "float128": ["1e-12", "1e-20", "1e-28", None],
        },
        "heyoka_mp": [128, 160, 256],
        "analytical_paper": [Fraction(1, 100), Fraction(1, 1000), Fraction(1, 10000)],
        "analytical_robust": True,
        "analytical_mp_dps": [30, 50],
        "scipy": {
            "DOP853": [1e-4, 1e-6, 1e-8, 1e-10, 1e-11, 1e-12, 1e-13],
            "Radau": [1e-4, 1e-6, 1e-8],
            "LSODA": [1e-4, 1e-6, 1e-8, 1e-10, 1e-12],
        },
        "spice_tmax": ["30e-6", "10e-6"],
        "chaos_N": [50, 100, 200, 300, 500],
        "certify_N": 300,
        "budget_s": 5.0,
        "circuit": True,
    }


# --------------------------------------------------------------------------- main


def _row(case, family, method, setting, errs, elapsed, repeats, compile_s=None, note="", **extra):
    horizon = next((k for k, e in enumerate(errs) if e > HORIZON_ERROR), None)
    r = {
        "case": case,
        "family": family,
        "method": method,
        "setting": setting,
        "max_error": max(errs),
        "final_error": errs[-1],
        "horizon": horizon,
        "time_s": elapsed,
        "repeats": repeats,
        "compile_s": compile_s,
        "note": note,
    }
    r.update(extra)
    r["error"] = r["max_error"] if case == "periodic" else r["final_error"]
    return r


@dataclasses.dataclass
class _CaseRun:
    """What every method row of one case needs: the system, the reference, the budget, the sink."""

    case: str
    params: Params
    periods: int
    bits: int
    rs: Any
    budget: float
    add: Callable[[dict], None]

    def row(self, family, method, setting, traj, el, n, compile_s=None, **extra) -> None:
        """Score ``traj`` against the reference and add the row."""
        errs = _errors(traj, self.rs, self.bits)
        self.add(_row(self.case, family, method, setting, errs, el, n, compile_s, **extra))


def _case_rows(
    case: str, spec: dict, cfg: dict, progress: bool, notes: list[str]
) -> tuple[list, dict]:
    """One case's reference and its rows: heyoka, analytical, scipy and ngspice settings."""
    params = Params.make(eta=spec["eta"])
    periods = spec["periods"]
    bits = reference_bits(periods)
    t0 = time.perf_counter()
    ref = HeyokaSolver(f"mp:{bits}").solve(params, periods)
    check = HeyokaSolver(f"mp:{bits + 64}").solve(params, periods)
    rs = _ref_states(ref)
    agreement = max(_errors(check, rs, bits + 64))
    reference = {
        "precision": f"mp:{bits}",
        "check": f"mp:{bits + 64}",
        "agreement": agreement,
        "time_s": time.perf_counter() - t0,
        "impacts": ref.n_impacts,
    }
    _progress(f"[{case}] reference mp:{bits} vs mp:{bits + 64}: agree to {agreement:.1e}", progress)
    rows: list[dict] = []

    def add(r):
        rows.append(r)
        hz = "" if r["horizon"] is None else f", horizon {r['horizon']}"
        _progress(
            f"[{case}] {r['method']} {r['setting']}: error {r['error']:.2e}{hz}, "
            f"{r['time_s']:.4f} s",
            progress,
        )

    run = _CaseRun(case, params, periods, bits, rs, cfg["budget_s"], add)
    _heyoka_rows(run, cfg)
    _analytical_rows(run, cfg)
    _scipy_rows(run, cfg, notes)
    _spice_rows(run, cfg, notes)
    return rows, reference


def _heyoka_rows(run: _CaseRun, cfg: dict) -> None:
    """heyoka in its fixed precisions (each tolerance) and in multiprecision."""
    hey = [(p, tol) for p, tols in cfg["heyoka"].items() for tol in tols]
    hey += [(f"mp:{b}", None) for b in cfg["heyoka_mp"]]
    for prec, tol in hey:
        solver = HeyokaSolver(prec, tol=tol)
        c0 = time.perf_counter()
        solver.integrator()
        compile_s = time.perf_counter() - c0
        traj, el, n = _timed(partial(solver.solve, run.params, run.periods), run.budget)
        fam = "heyoka mp" if prec.startswith("mp:") else f"heyoka {prec}"
        tol_s = "eps" if tol is None else tol
        run.row(
            fam,
            f"heyoka {prec}",
            f"tol={tol_s}",
            traj,
            el,
            n,
            compile_s,
            tol=None if tol is None else float(tol),
            impacts=traj.n_impacts,
        )


def _analytical_rows(run: _CaseRun, cfg: dict) -> None:
    """The closed-form solver: the paper's finder (each scan fraction), the robust one, mpmath."""
    settings = [
        (dict(finder="paper", scan_fraction=sf), "paper float64", f"scan={sf}")
        for sf in cfg["analytical_paper"]
    ]
    if cfg["analytical_robust"]:
        settings.append((dict(finder="robust"), "robust float64", "robust"))
    settings += [
        (
            dict(finder="robust", precision=f"mp:{mpmath.libmp.dps_to_prec(dps)}"),
            "robust mpmath",
            f"dps={dps}",
        )
        for dps in cfg["analytical_mp_dps"]
    ]
    for kwargs, name, setting in settings:
        solver = AnalyticalSolver(**kwargs)
        traj, el, n = _timed(partial(solver.solve, run.params, run.periods), run.budget)
        name = f"analytical {name}"
        run.row(name, name, setting, traj, el, n, impacts=traj.n_impacts)


def _scipy_rows(run: _CaseRun, cfg: dict, notes: list[str]) -> None:
    """scipy's integrators with event location, each at its relative tolerances."""
    if not cfg["scipy"]:
        return
    for method, rtols in cfg["scipy"].items():
        for rtol in rtols:
            try:
                res, el, n = _timed(
                    partial(scipy_solve, run.params, run.periods, method, rtol), run.budget
                )
            except RuntimeError as exc:
                notes.append(f"{run.case}: scipy {method} rtol={rtol:g} failed: {exc}")
                continue
            run.row(
                f"scipy {method}",
                f"scipy {method}",
                f"rtol={rtol:g}",
                res,
                el,
                n,
                rtol=rtol,
                atol=rtol * 1e-3,
                impacts=len(res.impacts_t),
                nfev=res.nfev,
            )


def _spice_rows(run: _CaseRun, cfg: dict, notes: list[str]) -> None:
    """ngspice on the nominal circuit at each maximum time step (a note if it is not installed)."""
    if not cfg["spice_tmax"]:
        return
    if shutil.which("ngspice"):
        comps = nominal_components(run.params)
        for tmax in cfg["spice_tmax"]:
            res, el, n = _timed(partial(run_spice, comps, {}, run.periods, tmax=tmax), run.budget)
            run.row(
                "ngspice",
                "ngspice",
                f"tmax={float(tmax) * 1e6:g}us",
                res,
                el,
                n,
                ngspice_s=res.elapsed_s,
                impacts=len(res.impacts_t),
            )
    elif not any("ngspice" in s for s in notes):
        notes.append("ngspice not on PATH: circuit-simulator rows skipped")


def _chaos_cost(Ns: list[int], certify_N: int, progress: bool) -> dict[str, Any]:
    """Smallest mp:64k precision reaching 1e-15 at period N, per N; certification time."""
    params = Params.make(eta="0.712")
    runs = _chaos_runs(params, max(Ns), progress)
    top = max(runs)
    rows = [_chaos_row(params, runs, top, N, progress) for N in Ns]
    return {
        "lambda": LAMBDA,
        "margin_digits": MARGIN_DIGITS,
        "target": CHAOS_TARGET,
        "reference_precision": f"mp:{top}",
        "rows": rows,
        "certify": _chaos_certify(params, certify_N, progress),
    }


def _chaos_runs(params: Params, Nmax: int, progress: bool) -> dict[int, Any]:
    """mp:64, mp:128, ... runs of ``Nmax`` periods, up to the first converged reference."""
    runs: dict[int, Any] = {}
    b = 64
    top_need = 64 * math.ceil(predicted_bits(Nmax) / 64) + 64
    # Sweep precisions upward until two consecutive precisions agree at Nmax and we
    # are at least one step past the prediction (so the top run is a genuine reference).
    while True:
        runs[b] = HeyokaSolver(f"mp:{b}").solve(params, Nmax)
        _progress(f"[chaos] mp:{b} x {Nmax} periods: {runs[b].elapsed_s:.2f} s", progress)
        if b - 64 in runs and b >= top_need:
            ctx = mp_context(b + 32)
            _, x1, v1 = runs[b].state_mpf(Nmax)
            _, x0, v0 = runs[b - 64].state_mpf(Nmax)
            x1, v1 = mp_import(ctx, x1), mp_import(ctx, v1)
            if max(abs(x1 - x0), abs(v1 - v0)) < 1e-30:
                break
        if b > 2048:
            break
        b += 64
    return runs


def _chaos_row(params: Params, runs: dict[int, Any], top: int, N: int, progress: bool) -> dict:
    """The smallest precision of ``runs`` within the target of the ``top`` one at period
    ``N``, and the time of one run of ``N`` periods at it."""
    chosen, diff_at = None, None
    ctx = mp_context(top + 32)
    _, xt, vt = runs[top].state_mpf(N)
    for bb in sorted(runs):
        if bb == top:
            continue
        _, x, v = runs[bb].state_mpf(N)
        x, v = mp_import(ctx, x), mp_import(ctx, v)
        d = float(max(abs(x - xt), abs(v - vt)))
        if d <= CHAOS_TARGET:
            chosen, diff_at = bb, d
            break
    if chosen is None:
        chosen, diff_at = top, 0.0
    solver = HeyokaSolver(f"mp:{chosen}")
    t0 = time.perf_counter()
    solver.solve(params, N)
    el = time.perf_counter() - t0
    pred = predicted_bits(N)
    _progress(f"[chaos] N={N}: mp:{chosen} (predicted {pred:.0f} bits), {el:.2f} s", progress)
    return {
        "N": N,
        "bits": chosen,
        "agreement": diff_at,
        "time_s": el,
        "predicted_bits": pred,
        "predicted_bits_64": 64 * math.ceil(pred / 64),
    }


def _chaos_certify(params: Params, certify_N: int, progress: bool) -> dict:
    """Certification of ``certify_N`` periods: the predicted precision and +64 bits agree to
    the target."""
    bc = 64 * math.ceil(predicted_bits(certify_N) / 64)
    t0 = time.perf_counter()
    a = HeyokaSolver(f"mp:{bc}").solve(params, certify_N)
    c = HeyokaSolver(f"mp:{bc + 64}").solve(params, certify_N)
    ctx = mp_context(bc + 96)
    _, xa, va = a.state_mpf(certify_N)
    _, xc, vc = c.state_mpf(certify_N)
    xa, va = mp_import(ctx, xa), mp_import(ctx, va)
    agree = float(max(abs(xa - xc), abs(va - vc)))
    cert_s = time.perf_counter() - t0
    _progress(
        f"[chaos] certify {certify_N} periods: mp:{bc} vs mp:{bc + 64} agree to {agree:.1e}, "
        f"{cert_s:.2f} s",
        progress,
    )
    return {
        "periods": certify_N,
        "precision": f"mp:{bc}",
        "check": f"mp:{bc + 64}",
        "agreement": agree,
        "certified": agree <= CHAOS_TARGET,
        "time_s": cert_s,
        "target_s": 10.0,
    }


def _time_at_error(rows: list[dict], family: str, target: float) -> float | None:
    pts = sorted(
        (math.log10(max(r["error"], 1e-300)), math.log10(r["time_s"]))
        for r in rows
        if r["family"] == family
    )
    if len(pts) < 2:
        return None
    le = math.log10(target)
    # Interpolate between the two bracketing points (by error); None when not bracketed.
    for (e0, t0), (e1, t1) in zip(pts, pts[1:], strict=False):
        if e0 <= le <= e1:
            return 10 ** (t0 if e1 == e0 else t0 + (t1 - t0) * (le - e0) / (e1 - e0))
    return None


def _headlines(rows: list[dict], cfg: dict, progress: bool) -> dict[str, Any]:
    per = [r for r in rows if r["case"] == "periodic"]
    th = _time_at_error(per, "heyoka float64", 1e-12)
    ts = _time_at_error(per, "scipy DOP853", 1e-12)
    out: dict[str, Any] = {
        "error_target": 1e-12,
        "heyoka_float64_time_s": th,
        "scipy_dop853_time_s": ts,
        "heyoka_vs_dop853": None if (th is None or ts is None) else ts / th,
        "heyoka_vs_dop853_target": 100.0,
    }
    if cfg.get("circuit"):
        spec = cfg["cases"]["periodic"]
        p = Params.make(eta=spec["eta"])
        comps = nominal_components(p)
        cs = CircuitSolver()
        hs = HeyokaSolver("float64")
        _, tc, nc = _timed(lambda: cs.solve(comps, spec["periods"]), cfg["budget_s"])
        _, tm, nm = _timed(lambda: hs.solve(p, spec["periods"]), cfg["budget_s"])
        out.update(
            {
                "circuit_time_s": tc,
                "mechanical_time_s": tm,
                "circuit_vs_mechanical": tc / tm,
                # what was timed: a whole solve each, set-up included (no target: the ratio
                # falls with the periods, benchmarks/bench_circuit.py times it per period)
                "circuit_vs_mechanical_periods": spec["periods"],
            }
        )
        _progress(f"circuit {tc:.4f} s vs mechanical {tm:.4f} s: ratio {tc / tm:.2f}", progress)
    return out


def work_precision(
    quick: bool = False,
    out: str | Path | None = None,
    progress: bool | None = None,
    *,
    config: dict[str, Any] | None = None,
) -> WorkPrecisionResult:
    """Measure error and wall time of every method on the periodic and chaotic cases.

    Parameters
    ----------
    quick : bool, default ``False``
        Fewer tolerances and methods, chaos cost for N in (50, 100, 200).
    out : directory or None, default ``None``
        Writes ``work_precision.json``, ``work_precision.csv``, ``work_precision.png``
        (both cases) and ``chaos_cost.png``; ``None`` writes nothing.
    progress : bool or None, default ``None``
        One line per run on stderr (``None``: only when stderr is a terminal).
    config : dict or None, default ``None``
        Overrides of the internal configuration (tests use it to shrink the run).

    Returns
    -------
    WorkPrecisionResult
        Per method, precision and tolerance: error against the demonstrated
        reference and wall time; the chaos cost table.

    See Also
    --------
    precise_impact.verification.accuracy.accuracy_table : errors alone, at several eta.
    precise_impact.verification.workprecision.WorkPrecisionResult : the result's fields.
    precise_impact.verification.reproduce.reproduce : the main job.

    References
    ----------
    .. [1] F. Biscani, D. Izzo, "Revisiting high-order Taylor methods for
           astrodynamics and celestial mechanics", MNRAS 504 (2021) 2614 (heyoka).

    Examples
    --------
    >>> import precise_impact as pi
    >>> import dataclasses
    >>> [f.name for f in dataclasses.fields(pi.WorkPrecisionResult)][:4]    # what a run returns
    ['quick', 'cases', 'references', 'rows']
    """
    cfg = _config(quick)
    if config:
        cfg.update(config)
    if cfg["scipy"] and not _have_scipy():  # refuse before any work, not after it
        raise OptionalDependencyError(
            "scipy", "pip install 'precise_impact[bench]'", "the work-precision benchmark"
        )
    t_start = time.perf_counter()
    notes: list[str] = [
        "scipy solve_ivp: atol = rtol * 1e-3; terminal event on x - x_w (direction +1), restart "
        "with v -> -R v",
        "times: median of repeats after one warm-up (repeats column); heyoka compile time separate",
        "periodic error: max over stroboscopic samples; chaotic error: at the last period",
    ]
    rows: list[dict] = []
    references: dict[str, Any] = {}
    for case, spec in cfg["cases"].items():
        r, ref = _case_rows(case, spec, cfg, progress, notes)
        rows += r
        references[case] = {"eta": spec["eta"], "periods": spec["periods"], **ref}
    chaos = (
        _chaos_cost(list(cfg["chaos_N"]), cfg["certify_N"], progress) if cfg["chaos_N"] else None
    )
    headlines = _headlines(rows, cfg, progress)
    result = {
        "quick": quick,
        "cases": {k: dict(v) for k, v in cfg["cases"].items()},
        "references": references,
        "rows": rows,
        "chaos_cost": chaos,
        "headlines": headlines,
        "notes": notes,
        "elapsed_s": time.perf_counter() - t_start,
    }
    if out is not None:
        write_outputs(result, Path(out))
    return WorkPrecisionResult(**result)


@dataclasses.dataclass
class WorkPrecisionResult(ResultMixin):
    """Error against the demonstrated reference versus wall time, per method
    (:func:`work_precision`).

    Attributes
    ----------
    quick : bool
        The reduced configuration was run.
    cases : dict
        Case name -> its eta and periods.
    references : dict
        Case name -> the reference used and its demonstrated agreement.
    rows : list of dict
        One row per method and setting: ``case``, ``family``, ``method``, ``setting``,
        ``error``, ``time_s``, ...
    chaos_cost : dict or None
        Bits and time needed to certify N chaotic periods to 1e-15.
    headlines : dict
        Speed ratios at matched error.
    notes : list of str
        What was skipped and why.
    elapsed_s : float
        Wall time.

    See Also
    --------
    precise_impact.verification.workprecision.work_precision : returns it.
    precise_impact.verification.accuracy.AccuracyResult : errors alone.
    """

    quick: bool
    cases: dict
    references: dict
    rows: list
    chaos_cost: Any
    headlines: dict
    notes: list
    elapsed_s: float

    def plot(self, path: str | os.PathLike | None = None):
        """Error against wall time per method (:func:`wp_figure`): one style per method
        family, the legend beneath the panels.

        Parameters
        ----------
        path : str, os.PathLike or None, default ``None``
            Also write the figure there (``.png``, ``.pdf``, ``.svg``, atomically).

        Returns
        -------
        matplotlib.figure.Figure
        """
        return finish(wp_figure(self.to_dict()), path, dpi=110)

    def _tables(self) -> dict:
        """``to_dataframe()`` tables: ``rows`` (default: one per method and setting, as
        ``work_precision.csv``) and ``chaos_cost`` (bits and time per chaotic length)."""
        tab = {"rows": lambda: record_columns(self.rows)}
        if self.chaos_cost:
            tab["chaos_cost"] = lambda: record_columns(self.chaos_cost["rows"])
        return tab


# --------------------------------------------------------------------------- outputs

CSV_FIELDS = [
    "case",
    "family",
    "method",
    "setting",
    "error",
    "max_error",
    "final_error",
    "horizon",
    "time_s",
    "repeats",
    "compile_s",
    "impacts",
    "note",
]


def write_outputs(result: dict[str, Any], out: Path) -> None:
    write_json(out / "work_precision.json", result, indent=2, default=str)
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=CSV_FIELDS, extrasaction="ignore")
    w.writeheader()
    for r in result["rows"]:
        w.writerow(r)
    atomic_write(out / "work_precision.csv", lambda fh: fh.write(buf.getvalue()), binary=False)
    _plot_wp(result, out / "work_precision.png")
    if result.get("chaos_cost"):
        _plot_chaos(result["chaos_cost"], out / "chaos_cost.png")


def _save(fig, path: Path) -> None:
    save_figure(fig, path, fmt="png", dpi=110)


def _plot_wp(result: dict[str, Any], path: Path) -> None:
    _save(wp_figure(result), path)


def wp_figure(result: dict[str, Any]):
    """Error against wall time per method family, one panel per case: every family has its
    own colour x marker x line style (the same in every panel), one legend beneath."""
    cases = list(result["cases"])
    fams = list(dict.fromkeys(r["family"] for r in result["rows"]))
    style = dict(zip(fams, series_styles(len(fams)), strict=True))
    fig, axes = new_figure(1, len(cases), figsize=(7 * len(cases), 6.5), layout="constrained")
    for ax, case in zip(axes[0], cases, strict=True):
        rows = [r for r in result["rows"] if r["case"] == case]
        for fam in dict.fromkeys(r["family"] for r in rows):
            pts = sorted((r["time_s"], max(r["error"], 1e-40)) for r in rows if r["family"] == fam)
            ax.loglog(
                [p[0] for p in pts], [p[1] for p in pts], label=fam, ms=5, lw=1.1, **style[fam]
            )
        ref = result["references"][case]
        ax.axhline(
            max(ref["agreement"], 1e-40),
            color="k",
            ls=":",
            lw=0.8,
            label="reference agreement (reference vs +64 bits)",
        )
        what = (
            "max error over samples" if case == "periodic" else f"error at period {ref['periods']}"
        )
        ax.set_title(
            f"{case}: eta = {ref['eta']}, {ref['periods']} periods; reference {ref['precision']} "
            f"vs {ref['check']}",
            fontsize=10,
        )
        ax.set_xlabel("wall time [s] (median)")
        ax.set_ylabel(what + " (dimensionless; floor 1e-40)")
        ax.grid(True, which="both", alpha=0.3)
    figure_legend(fig, axes[0], ncol=4, fontsize=8)
    fig.suptitle(
        wrap_title(
            "Work-precision: error against the demonstrated multiprecision reference vs wall time",
            fig,
        )
    )
    return fig


def _plot_chaos(chaos: dict[str, Any], path: Path) -> None:
    _save(chaos_figure(chaos), path)


def chaos_figure(chaos: dict[str, Any]):
    """Bits and time needed to keep N chaotic periods to the target; the legend beneath."""
    rows = chaos["rows"]
    N = [r["N"] for r in rows]
    fig, axes = new_figure(figsize=(7.5, 5.2), layout="constrained")
    ax = axes[0, 0]
    ax.plot(N, [r["bits"] for r in rows], "o-", label="measured: smallest mp:64k reaching 1e-15")
    ax.plot(
        N,
        [r["predicted_bits"] for r in rows],
        "s--",
        label="predicted (15 + N T lambda/ln10 + margin) log2 10",
    )
    ax.set_xlabel("chaotic periods N (eta = 0.712)")
    ax.set_ylabel("bits")
    ax.grid(True, alpha=0.3)
    ax2 = ax.twinx()
    ax2.semilogy(
        N, [r["time_s"] for r in rows], "^:", color="C3", label="time at that precision [s]"
    )
    ax2.set_ylabel("wall time [s]")
    figure_legend(fig, (ax, ax2), ncol=1)
    c = chaos["certify"]
    ax.set_title(f"What chaos costs; certify {c['periods']} periods: {c['time_s']:.2f} s")
    return fig


def format_table(result: WorkPrecisionResult | dict[str, Any]) -> str:
    """The ``bench work-precision`` table of a :class:`WorkPrecisionResult` (or its fields
    as a dict)."""
    lines = []
    for case, ref in result["references"].items():
        lines.append(
            f"{case}: eta={ref['eta']}, {ref['periods']} periods; reference {ref['precision']} vs "
            f"{ref['check']} agree to {ref['agreement']:.1e}"
        )
        lines.append(
            f"  {'method':<28} {'setting':<14} {'error':>9} {'horizon':>7} {'time [s]':>10} "
            f"{'compile':>8} {'rep':>3}"
        )
        for r in result["rows"]:
            if r["case"] != case:
                continue
            hz = "-" if r["horizon"] is None else str(r["horizon"])
            cs = "" if r["compile_s"] is None else f"{r['compile_s']:.3f}"
            lines.append(
                f"  {r['method']:<28} {r['setting']:<14} {r['error']:>9.2e} {hz:>7} "
                f"{r['time_s']:>10.5f} {cs:>8} {r['repeats']:>3}"
            )
    ch = result["chaos_cost"] if "chaos_cost" in result else None
    if ch:
        lines.append(
            f"What chaos costs (eta=0.712, target {ch['target']:g}, reference "
            f"{ch['reference_precision']}):"
        )
        lines.append(f"  {'N':>4} {'bits':>5} {'predicted':>9} {'time [s]':>9}")
        for r in ch["rows"]:
            lines.append(
                f"  {r['N']:>4} {r['bits']:>5} {r['predicted_bits']:>9.0f} {r['time_s']:>9.3f}"
            )
        c = ch["certify"]
        lines.append(
            f"  certify {c['periods']} periods: {c['precision']} vs {c['check']} agree to "
            f"{c['agreement']:.1e} in {c['time_s']:.2f} s (target < {c['target_s']:g} s)"
        )
    h = result["headlines"]
    r = h.get("heyoka_vs_dop853")
    lines.append("Headlines:")
    lines.append(
        f"  heyoka float64 vs scipy DOP853 at error {h['error_target']:g} (periodic): "
        + (
            "n/a (error not bracketed by both curves)"
            if r is None
            else f"{r:.0f}x ({h['scipy_dop853_time_s']:.4f} s "
            f"vs {h['heyoka_float64_time_s']:.5f} s)"
        )
    )
    if "circuit_vs_mechanical" in h:
        lines.append(
            f"  ideal circuit vs mechanical (heyoka float64), one "
            f"{h.get('circuit_vs_mechanical_periods', '?')}-period solve each, set-up included: "
            f"{h['circuit_vs_mechanical']:.2f}x "
            f"({h['circuit_time_s']:.5f} s vs {h['mechanical_time_s']:.5f} s)"
        )
    for n in result["notes"]:
        lines.append(f"  note: {n}")
    return "\n".join(lines)
