"""Check your own solver against the shipped reference data (for users' pytest suites).

Example (errors are scipy-style, ``|y - y_ref| / (atol + rtol |y_ref|) <= 1``, computed exactly)::

    from precise_impact.testing import assert_stroboscopic_close

    def test_my_solver():   # my_solver(params, periods) -> x, v at t0 + k 2 pi / eta
        assert_stroboscopic_close(my_solver, "single-0.74", periods=30, atol=1e-6, rtol=1e-6)
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from collections.abc import Callable, Sequence
from fractions import Fraction
from pathlib import Path
from typing import Any

import mpmath
import numpy as np

from precise_impact.core.mpcontext import mp_context, mp_export, mp_import
from precise_impact.errors import ParameterError, ReferenceDataError, one_line
from precise_impact.verification.reference import checksum_problems, default_root

__all__ = [
    "ReferenceCase",
    "load_reference",
    "score_solver",
    "assert_stroboscopic_close",
    "SINGLE_CASES",
]

#: Cases with stroboscopic samples usable by :func:`score_solver`.
SINGLE_CASES = ("single-0.70", "single-0.712", "single-0.74")

_WORKPREC = 400  # bits; above every stored reference precision


def _root(root: str | os.PathLike | None) -> Path:

    return Path(root) if root is not None else default_root()


@dataclasses.dataclass
class ReferenceCase:
    """One single-oscillator reference case.

    Attributes
    ----------
    name : str
        Case name, e.g. ``'single-0.74'``.
    params : dict[str, str]
        Exact decimal parameters (``zeta, a, eta, x_w, R, x0, v0, t0``).
    precision : str
        Precision of the stored run (``'mp:320'``).
    accuracy : float
        Demonstrated accuracy: largest disagreement with the +64-bit run over all samples.
    t, x, v : list
        Stroboscopic samples ``k = 0..periods`` (``mpmath.mpf``, or ``float`` with
        ``as_float=True``).
    impacts : list[dict]
        Every impact: ``{'t', 'v_before', 'v_after'}`` (same number type).
    manifest : dict
        The case's ``manifest.json``.
    proven_x_err, proven_v_err : list of float or None
        Per sample, a *proven* bound of ``|stored - truth|`` (from the case's
        ``certificate.json``: ball arithmetic, :mod:`precise_impact.verification.certificate`;
        floats rounded up), or ``None`` when the case carries no proof.
    """

    name: str
    params: dict
    precision: str
    accuracy: float
    t: list
    x: list
    v: list
    impacts: list
    manifest: dict
    proven_x_err: list | None = None
    proven_v_err: list | None = None

    @property
    def periods(self) -> int:
        return len(self.t) - 1


def load_reference(
    case: str, *, as_float: bool = False, root: str | os.PathLike | None = None
) -> ReferenceCase:
    """Load a single-oscillator reference case.

    Parameters
    ----------
    case : str
        One of :data:`SINGLE_CASES` (``'single-0.70'``, ``'single-0.712'``, ``'single-0.74'``).
    as_float : bool, default ``False``
        ``False``: numbers are exact ``mpmath.mpf`` values of the stored decimals
        (independent of ``mpmath.mp.prec``); ``True``: Python floats.
    root : directory or None, default ``None``
        Where the datasets live; ``None`` means ``$PRECISE_IMPACT_REFERENCE`` if set,
        else the datasets shipped inside the installed package
        (:func:`~precise_impact.verification.reference.default_root`).

    Returns
    -------
    ReferenceCase
        Parameters (exact decimal strings), the stroboscopic samples ``t, x, v``
        (``periods + 1`` of them), the impacts, the precision and the demonstrated
        accuracy of the stored run.

    Raises
    ------
    ParameterError
        ``case`` is not one of :data:`SINGLE_CASES` (a ``ValueError``).
    ReferenceDataError
        The case is missing, or a file fails its sha256 checksum (checked before
        anything is read).
    """
    if not isinstance(case, str) or case not in SINGLE_CASES:
        raise ParameterError("case", case, f"one of {', '.join(SINGLE_CASES)}")

    d = _root(root) / case
    if not d.is_dir():
        raise ReferenceDataError(
            f"reference case {case!r} not found under {d.parent} (run `precise-impact reference "
            "generate`)"
        )
    # The checksums first: a damaged reference must be an error naming the file, never a
    # verdict on the solver being scored.
    problems = checksum_problems(d, case)
    if problems:
        raise ReferenceDataError(
            f"reference data under {d} cannot be trusted: " + "; ".join(problems)
        )
    with open(d / "samples.json") as fh:
        data = json.load(fh)
    with open(d / "manifest.json") as fh:
        manifest = json.load(fh)

    if as_float:
        conv: Callable[[str], Any] = float
    else:

        def conv(s: str) -> mpmath.mpf:
            return mp_export(mp_context(_WORKPREC).mpf(s))

    samples = data["samples"]
    px = pv = None
    cert_name = (manifest.get("proof") or {}).get("file")
    if cert_name and cert_name in manifest.get(
        "files", {}
    ):  # checksummed above with the other files
        with open(d / cert_name) as fh:
            rows = {r["period"]: r for r in json.load(fh)["samples"]}
        up = lambda s: math.nextafter(float(s), math.inf)  # noqa: E731 - a float never below the decimal bound
        px = [up(rows[r["period"]]["x_err"]) for r in samples]
        pv = [up(rows[r["period"]]["v_err"]) for r in samples]
    return ReferenceCase(
        name=case,
        params=dict(data["params"]),
        precision=data["precision"],
        accuracy=float(manifest["accuracy"]["max_sample_disagreement"]),
        t=[conv(r["t"]) for r in samples],
        x=[conv(r["x"]) for r in samples],
        v=[conv(r["v"]) for r in samples],
        impacts=[{k: conv(r[k]) for k in ("t", "v_before", "v_after")} for r in data["impacts"]],
        manifest=manifest,
        proven_x_err=px,
        proven_v_err=pv,
    )


def _to_mpf(value: Any) -> mpmath.mpf:
    """Exact mpmath value of a user number (float, numpy float, longdouble, heyoka real, str,
    Decimal)."""
    # in a context of this thread's own (mpmath's global precision is shared by every thread)
    return mp_export(_to_mpf_in(mp_context(_WORKPREC), value))


def _to_mpf_in(mp: Any, value: Any) -> Any:
    if isinstance(value, (float, np.float64, np.float32, int, np.integer)):
        return (
            mp.mpf(float(value)) if not isinstance(value, (int, np.integer)) else mp.mpf(int(value))
        )
    if isinstance(value, np.longdouble):
        n, d = value.as_integer_ratio()
        return mp.mpf(n) / d
    if isinstance(value, Fraction):
        return mp.mpf(value.numerator) / value.denominator
    if hasattr(value, "_mpf_"):
        return +mp_import(mp, value)
    return mp.mpf(str(value))


def _sample(value: Any, var: str, k: int) -> mpmath.mpf:
    """One sample the solver returned, as an exact mpmath number; a value that is not one
    number (a string that is not a decimal, a row of a 2-D array, ...) is refused naming
    ``solver`` and the sample."""
    if not isinstance(value, (bool, np.bool_)) and not (
        isinstance(value, np.ndarray) and value.ndim
    ):
        try:
            return _to_mpf(value)
        except (TypeError, ValueError, ArithmeticError):
            pass
    raise ParameterError(
        "solver",
        f"{var}[{k}] = {one_line(value, 60)}",
        "x and v sequences of numbers (float, numpy float, decimal string, mpmath or heyoka "
        "number), one per sample",
    )


def score_solver(
    solver: Callable[[dict, int], tuple[Sequence[Any], Sequence[Any]]],
    case: str = "single-0.712",
    periods: int | None = None,
    atol: float = 1e-6,
    rtol: float = 1e-6,
    *,
    root: str | os.PathLike | None = None,
) -> dict[str, Any]:
    """Run ``solver`` on a reference case and return its errors (never raises on a mismatch).

    Parameters
    ----------
    solver : callable ``solver(params, periods) -> (x, v)``
        ``params`` is a dict of exact decimal strings (``zeta, a, eta, x_w, R, x0,
        v0, t0``); ``x`` and ``v`` are sequences of ``periods + 1`` stroboscopic
        samples at ``t0 + k 2 pi / eta``, ``k = 0..periods`` (floats, numpy floats,
        longdoubles, decimal strings, mpmath or heyoka numbers).
    case : str, default ``'single-0.712'``
        One of :data:`SINGLE_CASES`.
    periods : int or None, default ``None``
        Periods to compare, ``1 <= periods <= stored``; ``None``: every stored
        period (300).
    atol : float, default 1e-6
        Absolute tolerance.
    rtol : float, default 1e-6
        Relative tolerance; ``error = |y - y_ref| / (atol + rtol |y_ref|)``.
    root : directory or None, default ``None``
        Dataset location (see :func:`load_reference`).

    Returns
    -------
    dict
        ``case``, ``periods``, ``atol``, ``rtol``; ``error_x``, ``error_v`` (numpy
        arrays of the scaled errors per sample); ``solver_x``, ``solver_v`` (the
        solver's samples as float64); ``abs_error_x``, ``abs_error_v`` (numpy arrays of
        ``|y - y_ref|``); ``max_error`` (largest scaled error); ``worst_period``;
        ``worst_variable`` (``'x'`` or ``'v'``); ``passed`` (``max_error <= 1``);
        ``reference_accuracy`` (the stored run's demonstrated accuracy);
        ``proven_error_x``, ``proven_error_v`` (numpy arrays: *proven* upper bounds of the
        solver's ``|y - truth|``, ``|y - y_ref|`` plus the certificate's bound of
        ``|y_ref - truth|``, rounded up; ``None`` for a case without a certificate);
        ``shape_error`` (a message if the solver returned the wrong number of samples,
        else ``None``; then every error is ``inf``).

    Raises
    ------
    ParameterError
        Bad ``case``, ``periods`` or tolerances, or a sample of the solver's ``x`` or ``v``
        that is not one number (named ``solver``, with its index).
    ReferenceDataError
        The reference is missing or damaged (never turned into a verdict).
    """
    if not callable(solver):
        raise ParameterError("solver", solver, "a callable solver(params, periods) -> (x, v)")
    ref = load_reference(case, root=root)
    periods = _check_score_options(ref, case, periods, atol, rtol)
    out = solver(dict(ref.params), periods)
    n = periods + 1
    result: dict[str, Any] = {
        "case": case,
        "periods": periods,
        "atol": atol,
        "rtol": rtol,
        "reference_accuracy": ref.accuracy,
        "shape_error": None,
    }
    try:
        x, v = out
        x, v = list(x), list(v)
    except (TypeError, ValueError):
        x = v = None
    if x is None or len(x) != n or len(v) != n:
        return _shape_failure(result, n, periods, x, v)
    x = [_sample(y, "x", k) for k, y in enumerate(x)]
    v = [_sample(y, "v", k) for k, y in enumerate(v)]
    result["solver_x"] = np.array([float(y) for y in x])
    result["solver_v"] = np.array([float(y) for y in v])
    ex, ev, ax, av = _scaled_errors(ref, x, v, n, atol, rtol)
    kx, kv = int(np.argmax(ex)), int(np.argmax(ev))
    if ev[kv] > ex[kx]:
        worst, var = kv, "v"
    else:
        worst, var = kx, "x"
    mx = float(max(ex[kx], ev[kv]))
    result.update(
        error_x=ex,
        error_v=ev,
        abs_error_x=ax,
        abs_error_v=av,
        max_error=mx,
        worst_period=worst,
        worst_variable=var,
        passed=bool(mx <= 1.0),
    )
    if ref.proven_x_err is not None:
        # |y - truth| <= |y - y_ref| + |y_ref - truth|; the float sum rounded up by one ulp
        result["proven_error_x"] = np.nextafter(ax + np.array(ref.proven_x_err[:n]), np.inf)
        result["proven_error_v"] = np.nextafter(av + np.array(ref.proven_v_err[:n]), np.inf)
    else:
        result["proven_error_x"] = result["proven_error_v"] = None
    return result


def _check_score_options(ref: Any, case: str, periods: Any, atol: Any, rtol: Any) -> int:
    """``periods`` (``None``: all stored) and the tolerances checked; the periods to compare."""
    if periods is None:
        periods = ref.periods
    if (
        isinstance(periods, bool)
        or not isinstance(periods, (int, np.integer))
        or not 1 <= periods <= ref.periods
    ):
        raise ParameterError(
            "periods", periods, f"an integer, 1 <= periods <= {ref.periods} for case {case!r}"
        )
    periods = int(periods)
    for name, tol in (("atol", atol), ("rtol", rtol)):
        ok = isinstance(tol, (int, float)) and not isinstance(tol, bool)
        try:  # an int too large for a float is not a tolerance either
            ok = ok and math.isfinite(float(tol)) and tol >= 0
        except OverflowError:
            ok = False
        if not ok:
            raise ParameterError(name, tol, f"a finite number, {name} >= 0")
    if atol == 0 and rtol == 0:
        raise ParameterError("atol", atol, "atol > 0 or rtol > 0 (they cannot both be 0)")
    return periods


def _shape_failure(result: dict[str, Any], n: int, periods: int, x: Any, v: Any) -> dict[str, Any]:
    """``result`` completed for a solver that returned the wrong shape: every error ``inf``."""
    got = "not a pair of sequences" if x is None else f"{len(x)} x and {len(v)} v samples"
    result["shape_error"] = (
        f"solver must return (x, v) with {n} samples each (k = 0..{periods}); got {got}"
    )
    inf = np.full(n, np.inf)
    result.update(
        error_x=inf,
        error_v=inf,
        abs_error_x=inf,
        abs_error_v=inf,
        max_error=np.inf,
        worst_period=0,
        worst_variable="x",
        passed=False,
        proven_error_x=inf,
        proven_error_v=inf,
    )
    return result


def _scaled_errors(ref: Any, x: Sequence[Any], v: Sequence[Any], n: int, atol: float, rtol: float):
    """Scaled and absolute errors of the samples against the reference: ``ex, ev, ax, av``."""
    ex, ev, ax, av = (np.empty(n) for _ in range(4))
    mp = mp_context(_WORKPREC)  # this thread's own: mpmath's global precision is shared
    for k in range(n):
        for y, yr, e, a in ((x[k], ref.x[k], ex, ax), (v[k], ref.v[k], ev, av)):
            ym = _to_mpf_in(mp, y)
            if not mp.isfinite(ym):
                a[k] = e[k] = np.inf
                continue
            d = abs(ym - yr)
            a[k] = float(d)
            scale = atol + rtol * abs(mp_import(mp, yr))  # 0 with atol = 0 where y_ref = 0
            e[k] = float(d / scale) if scale else (0.0 if d == 0 else np.inf)
    return ex, ev, ax, av


def assert_stroboscopic_close(
    solver: Callable[[dict, int], tuple[Sequence[Any], Sequence[Any]]],
    case: str = "single-0.712",
    periods: int | None = None,
    atol: float = 1e-6,
    rtol: float = 1e-6,
    *,
    root: str | os.PathLike | None = None,
) -> dict[str, Any]:
    """Assert that ``solver``'s stroboscopic samples match the reference case.

    Parameters
    ----------
    solver : callable ``solver(params, periods) -> (x, v)``
        As in :func:`score_solver`.
    case : str, default ``'single-0.712'``
        One of :data:`SINGLE_CASES`.
    periods : int or None, default ``None``
        Periods to compare; ``None``: every stored period (300).
    atol : float, default 1e-6
        Absolute tolerance.
    rtol : float, default 1e-6
        Relative tolerance; a sample fails when ``|y - y_ref| / (atol + rtol |y_ref|) > 1``.
    root : directory or None, default ``None``
        Dataset location (see :func:`load_reference`).

    Returns
    -------
    dict
        The :func:`score_solver` dict (``passed`` is true).

    Raises
    ------
    AssertionError
        A scaled error exceeds 1 (the message names the first offending period, the
        variable, both values, the absolute and scaled error and the tolerances), or
        the solver returned the wrong number of samples.
    ReferenceDataError
        The reference is missing or damaged.

    Notes
    -----
    At ``eta = 0.712`` (chaotic) errors grow ~0.12 decimal digits per period, so a
    float64 solver meets ``1e-6`` only for roughly the first 80 periods.
    """
    r = score_solver(solver, case, periods, atol, rtol, root=root)
    if r["shape_error"]:
        raise AssertionError(f"{case}: {r['shape_error']}")
    if not r["passed"]:
        ref = load_reference(case, root=root)
        e = np.maximum(r["error_x"], r["error_v"])
        first = int(np.argmax(e > 1.0))
        var = "x" if r["error_x"][first] >= r["error_v"][first] else "v"
        got_err = r[f"error_{var}"][first]
        absd = r[f"abs_error_{var}"][first]
        yref = float((ref.x if var == "x" else ref.v)[first])
        n_bad = int(np.sum(e > 1.0))
        raise AssertionError(
            f"solver differs from reference {case!r} (params {ref.params}):\n"
            f"  first failure at period {first}: solver {var} = {r['solver_' + var][first]:.17g}, "
            f"reference {var} = {yref:.17g}, |diff| = {absd:.3e}, "
            f"scaled error |diff|/(atol + rtol*|ref|) = {got_err:.3e} > 1 (atol={atol:g}, "
            f"rtol={rtol:g})\n  {n_bad} of {len(e)} samples fail; worst: period "
            f"{r['worst_period']} ({r['worst_variable']}), scaled error {r['max_error']:.3e}\n"
            f"  reference accuracy (demonstrated): {ref.accuracy:.1e}"
        )
    return r
