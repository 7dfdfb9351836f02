"""Lyapunov spectrum from the variational equations with the impact's saltation matrix.

The tangent dynamics between impacts are heyoka's first-order variational
equations (``var_ode_sys``) of the same flow :func:`precise_impact._system.acceleration`.
heyoka does not know about the discontinuity: at every impact the terminal-event
callback maps the tangent matrix through the saltation matrix
(:func:`precise_impact._impact.oscillator_saltation`), ``Phi+ = S Phi-``.  Every
period the tangent matrix is re-orthonormalised (Gram-Schmidt = QR; Benettin et
al., Meccanica 15 (1980) 21-30; Shimada & Nagashima, Prog. Theor. Phys. 61 (1979)
1605), so it never overflows nor underflows; the logs of the diagonal of R
accumulate the two exponents.  Müller, Chaos Solitons Fractals 5 (1995) 1671
introduced the saltation-matrix treatment for impacting systems.
"""

from __future__ import annotations

import math
import sys
import threading
import time as _time
from fractions import Fraction
from typing import Any

import numpy as np

from .._errors import BudgetExceededError, ParameterError
from .._impact import impact_at_start, oscillator_saltation, reset_velocity
from .._params import RUNTIME_PARAMS, Params, check_count
from .._precision import Precision
from .._system import acceleration
from ._result import LyapunovResult, block_stderr

__all__ = ["variational_spectrum", "build_variational_integrator"]

_IDX = {name: i for i, name in enumerate(RUNTIME_PARAMS)}
# heyoka's var_ode_sys state layout: [x, v, dx/dx0, dx/dv0, dv/dx0, dv/dv0]
_PHI = (2, 3, 4, 5)


class _SaltationRecorder:
    """Terminal-event callback: impact map on the state, saltation matrix on the tangents.

    Deep-copied into the integrator by heyoka: read it back from
    ``ta.t_events[0].callback``.
    """

    def __init__(self) -> None:
        self.reset(10**7)

    def reset(self, max_impacts: int) -> None:
        self.count = 0
        self.max_impacts = max_impacts
        self.exceeded = False
        self.min_speed = math.inf

    def __call__(self, ta, d_sgn) -> bool:
        st, pr = ta.state, ta.pars
        R, x_w = pr[_IDX["R"]], pr[_IDX["x_w"]]
        vb = st[1]
        S = oscillator_saltation(ta.time, vb, pr[_IDX["eta"]], pr[_IDX["zeta"]], pr[_IDX["a"]], x_w, R, np.cos)
        p00, p01, p10, p11 = st[2], st[3], st[4], st[5]
        st[2] = S[0][0] * p00 + S[0][1] * p10
        st[3] = S[0][0] * p01 + S[0][1] * p11
        st[4] = S[1][0] * p00 + S[1][1] * p10
        st[5] = S[1][0] * p01 + S[1][1] * p11
        st[1] = reset_velocity(vb, R)
        st[0] = x_w
        self.count += 1
        sp = abs(float(vb))
        if sp < self.min_speed:
            self.min_speed = sp
        if self.count >= self.max_impacts:
            self.exceeded = True
            return False
        return True


_CACHE: dict[tuple, Any] = {}
_LOCK = threading.Lock()


def build_variational_integrator(precision: Precision, tol: Any = None):
    """Compile (or fetch) the oscillator + first-order variational equations integrator."""
    import heyoka as hy

    key = (precision.name, None if tol is None else precision.to_str(tol))
    with _LOCK:
        if key in _CACHE:
            return _CACHE[key]
        x, v = hy.make_vars("x", "v")
        p = {name: hy.par[i] for i, name in enumerate(RUNTIME_PARAMS)}
        rhs = acceleration(hy.time, x, v, p["eta"], p["zeta"], p["a"], hy.cos)
        vsys = hy.var_ode_sys([(x, v), (v, rhs)], hy.var_args.vars, order=1)
        kw = precision.heyoka_kwargs
        ev = hy.t_event(x - p["x_w"], callback=_SaltationRecorder(), direction=hy.event_direction.positive, fp_type=kw["fp_type"])
        zero = precision.from_fraction(Fraction(0))
        extra = {"tol": tol} if tol is not None else {}
        ta = hy.taylor_adaptive(
            vsys,
            [zero, zero],
            pars=[zero] * len(RUNTIME_PARAMS),
            t_events=[ev],
            compact_mode=precision.kind == "mp",
            **extra,
            **kw,
        )
        _CACHE[key] = ta
        return ta


def _gram_schmidt(st, sqrt, log):
    """Orthonormalise the tangent columns in place (modified Gram-Schmidt = QR).

    Returns ``(ln r11, ln r22)``.  ``sqrt``/``log`` are math's for float64 (Python
    floats are several times faster than numpy scalars) and numpy's otherwise.
    """
    if sqrt is math.sqrt:
        a0, b0, a1, b1 = st[2:6].tolist()  # [dx/dx0, dx/dv0, dv/dx0, dv/dv0]
    else:
        a0, b0, a1, b1 = st[2], st[3], st[4], st[5]
    # columns: c1 = (a0, a1) (d/dx0), c2 = (b0, b1) (d/dv0)
    r11 = sqrt(a0 * a0 + a1 * a1)
    q0, q1 = a0 / r11, a1 / r11
    proj = q0 * b0 + q1 * b1
    b0, b1 = b0 - proj * q0, b1 - proj * q1
    r22 = sqrt(b0 * b0 + b1 * b1)
    st[2], st[4] = q0, q1
    if r22 == 0:
        # A plastic impact (R = 0, det S = 0) collapses the tangent space onto one
        # direction: the second exponent is -inf.  Re-seed the second vector
        # orthogonal to the first so the first exponent stays well defined.
        st[3], st[5] = -q1, q0
        return log(r11), -math.inf
    st[3], st[5] = b0 / r22, b1 / r22
    return log(r11), log(r22)


def _one_orbit(ta, rec, P, params: Params, transient: int, periods: int, progress, label: str):
    """Transient, then ``periods`` renormalised periods; returns per-period logs and samples."""
    import heyoka as hy

    conv = P.from_fraction
    one, zero = conv(Fraction(1)), conv(Fraction(0))
    x0, v0 = conv(params.x0), conv(params.v0)
    if impact_at_start(params.x0, params.v0, params.x_w, params.R):
        v0 = reset_velocity(v0, conv(params.R))
    ta.time = conv(params.t0)
    ta.state[:] = P.array([x0, v0, one, zero, zero, one])
    ta.reset_cooldowns()
    times = P.sample_times(params.t0, params.eta, transient + periods)
    sqrt, log = (math.sqrt, math.log) if P.kind == "float64" else (np.sqrt, np.log)
    import mpmath

    with mpmath.workdps(30):
        period = float(2 * mpmath.pi / (mpmath.mpf(params.eta.numerator) / params.eta.denominator))

    def advance(t_end):
        oc = ta.propagate_until(t_end)[0]
        if rec.exceeded:
            raise BudgetExceededError(f"impact budget max_impacts={rec.max_impacts} exhausted at t={P.to_str(ta.time)}")
        if oc != hy.taylor_outcome.time_limit:
            raise RuntimeError(f"heyoka stopped with outcome {oc} at t={P.to_str(ta.time)}")

    for k in range(1, transient + 1):
        advance(times[k])
        _gram_schmidt(ta.state, sqrt, log)  # keep the tangents bounded during the transient too
    st = ta.state
    st[2], st[3], st[4], st[5] = one, zero, zero, one
    impacts0 = rec.count
    l1, l2, dt = np.empty(periods), np.empty(periods), np.empty(periods)
    sx, sv = np.empty(periods), np.empty(periods)
    step = max(1, periods // 10)
    for j in range(periods):
        k = transient + j + 1
        advance(times[k])
        g1, g2 = _gram_schmidt(ta.state, sqrt, log)
        l1[j], l2[j] = float(g1), float(g2)
        sx[j], sv[j] = ta.state[0], ta.state[1]
        dt[j] = period
        if progress and (j + 1) % step == 0:
            print(f"  variational LLE{label}: {j + 1}/{periods} periods", file=sys.stderr, flush=True)
    return l1, l2, dt, sx, sv, rec.count - impacts0


def initial_condition(params: Params, j: int) -> Params:
    """The ``j``-th initial condition of an ensemble: ``v0 + j/4`` (j = 0 is ``params`` itself)."""
    return params if j == 0 else params.replace(v0=params.v0 + Fraction(j, 4))


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
) -> LyapunovResult:
    """Both Lyapunov exponents from the variational equations with saltation matrices.

    Keywords
    --------
    params : Params
        System and initial condition (the paper's defaults: eta = 0.712 chaotic).
    periods : int, default 20000
        Measured forcing periods in all (each ``T = 2 pi / eta`` long), spread evenly
        over the initial conditions; ``>= initial_conditions``.
    transient : int, default 1000
        Periods integrated first from each initial condition and discarded (the
        tangents are renormalised during it and restart as the identity after it).
    precision : str, default ``'float64'``
        Any precision of :class:`~precise_impact.Precision`.
    tol : decimal or None, default ``None`` (the precision's epsilon)
    segments : int, default 20
        Independent blocks for the standard error (batch means, :func:`block_stderr`),
        spread over the initial conditions; ``>= 2``.
    initial_conditions : int, default 4
        Orbits started from ``(x0, v0 + j/4)``, ``j = 0..n-1`` (:func:`initial_condition`);
        their blocks enter one error bar, so an attractor that depends on the initial
        condition shows up as a large error bar rather than a confident wrong value.
    max_impacts : int, default 10**7
        Impact budget per orbit (raises :class:`BudgetExceededError`).
    progress : bool, default ``False``
        A progress line on stderr every 10 %.

    Returns a :class:`LyapunovResult` with ``spectrum = (lambda1, lambda2)`` per unit
    time and the first orbit's stroboscopic samples.  Exact properties:
    ``lambda1 + lambda2 = -2 zeta + (impacts / time) ln R^2`` (``det Phi`` of the
    smooth flow is ``exp(-2 zeta t)``, ``det S = R^2``); without impacts both
    exponents equal ``-zeta`` (underdamped linear flow).  For a periodic orbit the
    estimate converges as O(1/t) (a bias, which the batch-means error bar does not see).

    References: Benettin et al., Meccanica 15 (1980) 9-30 (QR re-orthonormalisation);
    Müller, Chaos Solitons Fractals 5 (1995) 1671-1681 (saltation matrices for
    impacting systems); di Bernardo et al., Piecewise-smooth Dynamical Systems (2008),
    sec. 2.5; Flyvbjerg & Petersen, J. Chem. Phys. 91 (1989) 461 (batch means).
    """
    P = Precision.parse(precision)
    periods = check_count(periods, "periods")
    n_ic = check_count(initial_conditions, "initial_conditions", 1000)
    if n_ic < 1:
        raise ParameterError("initial_conditions", initial_conditions, "an integer with 1 <= initial_conditions <= 1000")
    if periods < n_ic:
        raise ParameterError("periods", periods, f"an integer >= initial_conditions = {n_ic} (>= 1 period per orbit)")
    transient = check_count(transient, "transient")
    segments = check_count(segments, "segments", 10**6)
    if segments < 2:
        raise ParameterError("segments", segments, "an integer >= 2 (the error bar needs independent blocks)")
    if tol is not None:
        from .._params import exact

        q = exact("tol", tol)
        if not 0 < q < 1:
            raise ParameterError("tol", str(tol), "tolerance must satisfy 0 < tol < 1")
        tol = P.from_fraction(q)
    ics = [initial_condition(params, j) for j in range(n_ic)]  # validated before any work

    ta = build_variational_integrator(P, tol)
    ta.pars[:] = P.array([P.from_fraction(getattr(params, n)) for n in RUNTIME_PARAMS])
    rec = ta.t_events[0].callback
    start = _time.perf_counter()
    per_orbit = [periods // n_ic + (1 if j < periods % n_ic else 0) for j in range(n_ic)]
    blocks_per_orbit = max(2, -(-segments // n_ic))
    L1, L2, DT, blocks = [], [], [], []
    impacts = 0
    strobe = None
    for j, (ic, n) in enumerate(zip(ics, per_orbit)):
        rec.reset(max_impacts)
        label = f" (orbit {j + 1}/{n_ic})" if n_ic > 1 else ""
        l1, l2, dt, sx, sv, imp = _one_orbit(ta, rec, P, ic, transient, n, progress, label)
        if strobe is None:
            strobe = (sx, sv)
        L1.append(l1)
        L2.append(l2)
        DT.append(dt)
        impacts += imp
        blocks.append(block_stderr(l1, dt, min(blocks_per_orbit, n))[0])
    elapsed = _time.perf_counter() - start
    l1, l2, dt = np.concatenate(L1), np.concatenate(L2), np.concatenate(DT)
    all_blocks = np.concatenate(blocks)
    se = float(np.std(all_blocks, ddof=1) / math.sqrt(len(all_blocks))) if len(all_blocks) > 1 else math.nan
    total = float(np.sum(dt))
    lam1, lam2 = float(np.sum(l1) / total), float(np.sum(l2) / total)
    return LyapunovResult(
        params=params,
        method="variational",
        precision=P.name,
        lle=lam1,
        spectrum=(lam1, lam2),
        stderr=se,
        periods=periods,
        transient=transient,
        impacts=impacts,
        running=np.cumsum(l1) / np.cumsum(dt),
        segments=all_blocks,
        elapsed_s=elapsed,
        initial_conditions=n_ic,
        strobe_x=strobe[0],
        strobe_v=strobe[1],
    )
