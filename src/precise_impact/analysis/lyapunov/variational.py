"""Lyapunov spectrum from the variational equations with the impact's saltation matrix.

Ensemble of starts, per-period QR logs, batch-means error bar, attractor attribution; the
integrator is :mod:`precise_impact.solvers.heyoka.variational`.  References: Benettin et al.,
Meccanica 15 (1980) 9-30; Müller, Chaos Solitons Fractals 5 (1995) 1671.
"""

from __future__ import annotations

import math
import time as _time
from fractions import Fraction
from typing import Any

import numpy as np

from precise_impact.analysis.lyapunov.attractors import (
    MAX_PERIOD,
    TEST_BLOCK_PERIODS,
    TEST_BLOCKS,
    attribute,
)
from precise_impact.analysis.lyapunov.result import LyapunovResult, block_stderr
from precise_impact.core.params import RUNTIME_PARAMS, Params, check_count
from precise_impact.core.precision import Precision
from precise_impact.core.stats import lle_stderr
from precise_impact.errors import MissedImpactError, ParameterError
from precise_impact.solvers.heyoka.variational import (
    CHUNK,
    GUARD_FACTOR,
    build_variational_integrator,
    depth_for,
    grazing_depth_coefficient,
    integrate_orbit,
    steady_amplitude,
)

__all__ = [
    "variational_spectrum",
    "initial_condition",
    "build_variational_integrator",
    "MissedImpactError",
    "grazing_depth_coefficient",
    "steady_amplitude",
    "CHUNK",
    "GUARD_FACTOR",
]


def initial_condition(params: Params, j: int) -> Params:
    """The ``j``-th initial condition of an ensemble: ``v0 + j/4`` (j = 0 is ``params`` itself)."""
    return params if j == 0 else params.replace(v0=params.v0 + Fraction(j, 4))


def _check_counts(
    periods: Any, initial_conditions: Any, transient: Any, segments: Any
) -> tuple[int, int, int, int]:
    """:func:`variational_spectrum`'s counts checked in that order:
    ``(periods, initial_conditions, transient, segments)``."""
    periods = check_count(periods, "periods")
    n_ic = check_count(initial_conditions, "initial_conditions", 1000)
    if n_ic < 1:
        raise ParameterError(
            "initial_conditions",
            initial_conditions,
            "an integer with 1 <= initial_conditions <= 1000",
        )
    if periods < n_ic:
        raise ParameterError(
            "periods", periods, f"an integer >= initial_conditions = {n_ic} (>= 1 period per orbit)"
        )
    transient = check_count(transient, "transient")
    segments = check_count(segments, "segments", 10**6)
    if segments < 2:
        raise ParameterError(
            "segments", segments, "an integer >= 2 (the error bar needs independent blocks)"
        )
    return periods, n_ic, transient, segments


def _new_diag() -> dict[str, Any]:
    """The counters of ``stats`` before the first orbit (:func:`_add_diag` sums them)."""
    return {
        "impacts": 0,
        "grazing": 0,
        "min_impact_speed": math.inf,
        "max_contact_speed": 0.0,
        "max_saltation": 0.0,
        "maxima": 0,
        "max_overshoot": -math.inf,
        "missed": 0,
    }


def _add_diag(diag: dict[str, Any], rec: Any, grd: Any) -> None:
    """Add one orbit's impact-callback (``rec``) and guard (``grd``) counters to ``diag``."""
    diag["impacts"] += rec.count
    diag["grazing"] += rec.grazing
    diag["min_impact_speed"] = min(diag["min_impact_speed"], rec.min_speed)
    diag["max_contact_speed"] = max(diag["max_contact_speed"], rec.max_contact_speed)
    diag["max_saltation"] = max(diag["max_saltation"], rec.max_saltation)
    diag["maxima"] += grd.maxima
    diag["max_overshoot"] = max(diag["max_overshoot"], grd.max_overshoot)
    diag["missed"] += grd.missed


def _orbit_blocks(
    l1: np.ndarray, dt: np.ndarray, ni: np.ndarray, n: int, blocks_per_orbit: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One orbit's blocks for the error bar, and the attractors' per-start tests: finer blocks
    (``TEST_BLOCKS`` of ``>= TEST_BLOCK_PERIODS`` periods) and the impacts per period in the
    same blocks (:func:`block_stderr`'s split)."""
    blocks = block_stderr(l1, dt, min(blocks_per_orbit, n))[0]
    nt = min(n, max(blocks_per_orbit, min(TEST_BLOCKS, n // TEST_BLOCK_PERIODS)))
    test_blocks = block_stderr(l1, dt, nt)[0]
    rates = np.array([ni[i].mean() for i in np.array_split(np.arange(n), nt) if len(i)])
    return blocks, test_blocks, rates


def _attribute_starts(
    result: LyapunovResult,
    logs: tuple[list, list, list],
    test_blocks: list,
    tails: list,
    rates: list,
    P: Precision,
    per_orbit: list[int],
) -> None:
    """Group the starts by attractor (:func:`attribute`); ``logs = (L1, L2, DT)``, the
    per-orbit logs of ``r11``, ``r22`` and the period lengths."""
    L1, L2, DT = logs
    per_start = [
        (float(np.sum(a) / np.sum(d)), float(np.sum(b) / np.sum(d)), blk)
        for a, b, d, blk in zip(L1, L2, DT, test_blocks, strict=True)
    ]
    attribute(
        result,
        tails,
        per_start,
        P.name if P.kind in ("float64", "mp") else "float64",
        impact_blocks=rates,
        periods=per_orbit,
    )


def variational_spectrum(
    params: Params,
    periods: int = 20000,
    transient: int = 1000,
    precision: str | Precision = "float64",
    tol: Any = None,
    segments: int = 20,
    initial_conditions: int = 4,
    max_impacts: int = 10**7,
    progress: bool = False,
    guard: bool = True,
    grazing_depth: Any = None,
    attractors: bool = True,
) -> LyapunovResult:
    """Both Lyapunov exponents from the variational equations with saltation matrices.

    Parameters
    ----------
    params : Params
        System and initial condition (the paper's defaults: eta = 0.712 chaotic).
    periods : int, default 20000
        Measured forcing periods in all (each ``T = 2 pi / eta`` long), spread evenly
        over the initial conditions; ``>= initial_conditions``.
    transient : int, default 1000
        Periods integrated first from each initial condition and discarded (the
        tangents are renormalised during it and carry on after it: its logs are
        discarded, not its basis).
    precision : str, default ``'float64'``
        Any precision of :class:`~precise_impact.Precision`.
    tol : decimal or None, default ``None``
        heyoka's tolerance; ``None`` is the precision's epsilon.
    segments : int, default 20
        Independent blocks for the standard error (batch means, :func:`block_stderr`),
        spread over the initial conditions; ``>= 2``.
    initial_conditions : int, default 4
        Orbits started from ``(x0, v0 + j/4)``, ``j = 0..n-1`` (:func:`initial_condition`);
        their blocks enter one error bar, so an attractor that depends on the initial
        condition shows up as a large error bar rather than a confident wrong value.
    max_impacts : int, default 10**7
        Impact budget per orbit (raises :class:`~precise_impact.BudgetExceededError`).
    progress : bool or None, default ``False``
        Periods done on stderr (:class:`~precise_impact.io.progress.Progress`: throttled;
        ``None``: only when stderr is a terminal).
    guard : bool, default ``True``
        Raise :class:`~precise_impact.MissedImpactError` when a maximum of ``x`` lies
        beyond the wall by more than ``4 delta(t)`` (an impact heyoka's event detection
        missed; module docstring, *the guard*).  ``False``: only count it
        (``stats["missed"]``).
    grazing_depth : decimal or None, default ``None``
        Excursion depth ``delta`` below which an event is a tangential contact, not an
        impact (module docstring, 3.).  ``None``: ``16 u (|x_w| + |a| + A_p (1 + eta |t|))``,
        ``u = 2^-bits``, ``A_p`` the steady-state amplitude (:func:`steady_amplitude`),
        ``t`` the local clock (:func:`grazing_depth_coefficient`);
        a number ``>= 0``: that fixed depth (``0``: every event with ``v- > 0`` is an
        impact, as :class:`~precise_impact.HeyokaSolver` treats them).
    attractors : bool, default ``True``
        Group the starts by attractor and give a periodic attractor's exact (Floquet) LLE
        (:func:`~precise_impact.analysis.lyapunov.attractors.attribute`; Newton in this
        precision if it is ``mp:BITS``, else in float64).

    Returns
    -------
    LyapunovResult
        ``spectrum = (lambda1, lambda2)`` per unit time, ``lle = lambda1`` with its
        batch-means ``stderr``, and the first orbit's stroboscopic samples.  Its
        ``stats`` dict holds counters summed over all orbits (transients included):
        ``impacts`` (applied), ``grazing`` (contacts), ``min_impact_speed`` (smallest
        ``v-`` of an impact, ``inf`` if none), ``max_contact_speed``, ``max_saltation``
        (largest ``|s|``, ``s = S[1][0]``), ``maxima`` (checked by the guard),
        ``max_overshoot`` (largest ``x - x_w`` at a maximum), ``missed``,
        ``max_period_log`` (largest per-period ``ln r11``, in-callback parts included)
        and ``finite_logs`` (every per-period ``ln r11`` finite); with ``attractors``
        also ``per_start`` (each start's ``lle``, ``stderr``, ``impact_rate``,
        ``impact_rate_stderr``, ``periods``, ``attractor`` id), ``attractors``,
        ``headline_attractor``, ``lle_source`` and ``finite_time``
        (:func:`~precise_impact.analysis.lyapunov.attractors.attribute`).

    Raises
    ------
    ParameterError
        Bad input, before any work.
    BudgetExceededError
        An orbit needed more than ``max_impacts`` impacts.
    MissedImpactError
        With ``guard=True``: an impact missed by heyoka's event detection.

    Notes
    -----
    Exact properties: ``lambda1 + lambda2 = -2 zeta + (impacts / time) ln R^2``
    (``det Phi`` of the smooth flow is ``exp(-2 zeta t)``, ``det S = R^2``); without
    impacts both exponents equal ``-zeta`` (underdamped linear flow).  For a periodic
    orbit the estimate converges as O(1/t) (a bias, which the batch-means error bar
    does not see).

    References
    ----------
    .. [1] G. Benettin et al., Meccanica 15 (1980) 9-30 (QR re-orthonormalisation).
    .. [2] P. C. Müller, Chaos Solitons Fractals 5 (1995) 1671-1681 (saltation
           matrices for impacting systems).
    .. [3] M. di Bernardo et al., Piecewise-smooth Dynamical Systems (2008), sec. 2.5.
    .. [4] A. B. Nordmark, J. Sound Vib. 145 (1991) 279-297 (grazing).
    .. [5] H. Flyvbjerg, H. G. Petersen, J. Chem. Phys. 91 (1989) 461 (batch means).
    .. [6] heyoka.py tutorial "Event detection" (limitations and caveats) and heyoka
           ``src/detail/event_detection.cpp`` (cooldown, root-finding failures).
    """
    P = Precision.parse(precision)
    periods, n_ic, transient, segments = _check_counts(
        periods, initial_conditions, transient, segments
    )
    q = P.check_tol(tol)
    tol = None if q is None else P.from_fraction(q)
    depth = depth_for(P, grazing_depth, params)
    ics = [initial_condition(params, j) for j in range(n_ic)]  # validated before any work

    ta = build_variational_integrator(P, tol)
    ta.pars[:] = P.array([P.from_fraction(getattr(params, n)) for n in RUNTIME_PARAMS])
    rec = ta.t_events[0].callback
    grd = ta.nt_events[0].callback
    fns = (math.sqrt, math.log, math.cos) if P.kind == "float64" else (np.sqrt, np.log, np.cos)
    start = _time.perf_counter()
    per_orbit = [periods // n_ic + (1 if j < periods % n_ic else 0) for j in range(n_ic)]
    blocks_per_orbit = max(2, -(-segments // n_ic))
    L1, L2, DT, blocks, tails, rates, test_blocks = [], [], [], [], [], [], []
    impacts = 0
    strobe = None
    diag = _new_diag()
    for j, (ic, n) in enumerate(zip(ics, per_orbit, strict=True)):
        rec.reset(max_impacts, depth, *fns, pars=ta.pars)
        rec.eps = P.eps_float
        grd.reset(depth, rec.f64)
        label = f" (orbit {j + 1}/{n_ic})" if n_ic > 1 else ""
        l1, l2, dt, sx, sv, imp, ni = integrate_orbit(
            ta, rec, grd, P, ic, transient, n, progress, label, guard
        )
        if strobe is None:
            strobe = (sx, sv)
        tails.append((sx[-3 * MAX_PERIOD :], sv[-3 * MAX_PERIOD :]))
        L1.append(l1)
        L2.append(l2)
        DT.append(dt)
        impacts += imp
        blk, test_blk, rate = _orbit_blocks(l1, dt, ni, n, blocks_per_orbit)
        blocks.append(blk)
        test_blocks.append(test_blk)
        rates.append(rate)
        _add_diag(diag, rec, grd)
    elapsed = _time.perf_counter() - start
    l1, l2, dt = np.concatenate(L1), np.concatenate(L2), np.concatenate(DT)
    diag["max_period_log"] = float(np.max(l1)) if len(l1) else -math.inf
    diag["finite_logs"] = bool(np.all(np.isfinite(l1)))
    all_blocks = np.concatenate(blocks)
    total = float(np.sum(dt))
    lam1, lam2 = float(np.sum(l1) / total), float(np.sum(l2) / total)
    # one log per step and per impact, each rounded in the working precision
    se = lle_stderr(all_blocks, lam1, len(l1) + impacts, float(P.eps), total)
    result = LyapunovResult(
        params=params,
        method="variational",
        precision=P.name,
        lle=lam1,
        spectrum=(lam1, lam2),
        lle_stderr=se,
        periods=periods,
        transient=transient,
        n_impacts=impacts,
        running=np.cumsum(l1) / np.cumsum(dt),
        segments=all_blocks,
        elapsed_s=elapsed,
        initial_conditions=n_ic,
        strobe_x=strobe[0],
        strobe_v=strobe[1],
        stats=diag,
    )
    if attractors:
        _attribute_starts(result, (L1, L2, DT), test_blocks, tails, rates, P, per_orbit)
    result.order_spectrum()
    return result
