"""Lyapunov spectrum from the variational equations with the impact's saltation matrix.

heyoka's variational equations of :func:`~precise_impact.core.flow.acceleration`; at every
impact the event callback maps the tangents by the saltation matrix and re-orthonormalises them
(QR), so near-grazing impacts neither overflow nor hide later events.  References: Müller,
Chaos Solitons Fractals 5 (1995) 1671; Benettin et al., Meccanica 15 (1980) 21-30.  The hard
cases (grazing contacts, the local clock, missed-impact guard) are in ``docs/numerics.rst``.
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
from precise_impact.analysis.lyapunov.result import LyapunovResult, block_stderr, means_stderr
from precise_impact.core.clock import local_grid, period_float
from precise_impact.core.flow import acceleration
from precise_impact.core.impact import GrazingDepth as _Depth
from precise_impact.core.impact import (
    grazing_depth_coefficient,
    impact_at_start,
    is_contact,
    oscillator_saltation,
    reset_velocity,
    steady_amplitude,
)
from precise_impact.core.linalg import gram_schmidt2
from precise_impact.core.params import (
    I_A,
    I_ETA,
    I_R,
    I_XW,
    I_ZETA,
    RUNTIME_PARAMS,
    Params,
    check_count,
    exact,
)
from precise_impact.core.precision import Precision
from precise_impact.errors import (
    BudgetExceededError,
    IntegrationError,
    MissedImpactError,
    ParameterError,
)
from precise_impact.io.progress import Progress
from precise_impact.solvers.heyoka.cache import IntegratorCache
from precise_impact.solvers.heyoka.events import ImpactRecorder

__all__ = [
    "variational_spectrum",
    "build_variational_integrator",
    "MissedImpactError",
    "grazing_depth_coefficient",
    "steady_amplitude",
]

# heyoka's var_ode_sys state layout: [x, v, dx/dx0, dx/dv0, dv/dx0, dv/dv0]
_PHI = (2, 3, 4, 5)
#: A maximum beyond the wall by more than this many grazing depths is a missed impact.
GUARD_FACTOR = 4


class _SaltationRecorder(ImpactRecorder):
    """Terminal-event callback: impact map on the state, saltation matrix on the tangents.

    Counts impacts against the budget with :class:`~precise_impact.solvers.heyoka.events.ImpactRecorder`
    (no log: ``keep=False``).

    Deep-copied into the integrator by heyoka: read it back from
    ``ta.t_events[0].callback``.  Counters (since the last :meth:`reset`):
    ``count`` impacts applied, ``grazing`` contacts (not impacts), ``min_speed``
    smallest ``v-`` of an impact, ``max_contact_speed`` largest ``v-`` of a contact,
    ``max_saltation`` largest ``|S[1][0]|``.  The logs of the in-callback QR are
    appended to ``qr_t``/``qr_log1``/``qr_log2`` (impact time, ``ln r11``, ``ln r22``)
    until :meth:`take_logs` hands them over (module docstring, *Per-period logs*).

    In float64 the callback works on Python floats: the parameters are converted
    once (:meth:`reset`), the state is read with one ``tolist`` and written with one
    slice assignment (numpy scalars cost several times more per operation).  Every
    other precision works on the integrator's own numbers.
    """

    def __init__(self) -> None:
        super().__init__(keep=False)
        self.reset(10**7, _Depth(), math.sqrt, math.log, math.cos)

    def reset(self, max_impacts: int, depth: _Depth, sqrt, log, cos, pars: Any = None) -> None:
        self.reset_log(max_impacts, keep=False)
        self.grazing = 0
        self.min_speed = math.inf
        self.max_contact_speed = 0.0
        self.max_saltation = 0.0
        self.depth = depth
        self.t_depth = 0.0  # the clock value the grazing depth is taken at (set per orbit)
        self.sqrt, self.ln, self.cos = sqrt, log, cos
        # float64: the parameters as Python floats, read once
        self.f64 = (
            None
            if pars is None or sqrt is not math.sqrt
            else [float(pars[i]) for i in range(len(pars))]
        )
        self.qr_t: list = []
        self.qr_log1: list = []
        self.qr_log2: list = []

    def take_logs(self) -> tuple[list, list, list]:
        """The in-callback QR logs ``(t, ln r11, ln r22)`` since the last call, and forget them."""
        out = self.qr_t, self.qr_log1, self.qr_log2
        self.qr_t, self.qr_log1, self.qr_log2 = [], [], []
        return out

    def __call__(self, ta, d_sgn) -> bool:
        st = ta.state
        t = ta.time
        f = self.f64
        if f is not None:
            pr = f
            x, vb, p00, p01, p10, p11 = st.tolist()
        else:
            pr = ta.pars
            vb, p00, p01, p10, p11 = st[1], st[2], st[3], st[4], st[5]
        R, x_w, eta, zeta, a = pr[I_R], pr[I_XW], pr[I_ETA], pr[I_ZETA], pr[I_A]
        acc = acceleration(t, x_w, vb, eta, zeta, a, self.cos)
        if is_contact(vb, acc, self.depth(self.t_depth, pr)):
            # Tangential contact within rounding of the wall: not an impact.
            self.grazing += 1
            sp = abs(float(vb))
            if sp > self.max_contact_speed:
                self.max_contact_speed = sp
            return True
        S = oscillator_saltation(t, vb, eta, zeta, a, x_w, R, self.cos)
        (s00, s01), (s10, s11) = S
        # Renormalise at once (module docstring, 1. and 2.): the logs carry the growth.
        q0, q1, u0, u1, r11, r22 = gram_schmidt2(
            s00 * p00 + s01 * p10,
            s10 * p00 + s11 * p10,
            s00 * p01 + s01 * p11,
            s10 * p01 + s11 * p11,
            self.sqrt,
        )
        va = reset_velocity(vb, R)
        if f is not None:
            st[:] = (x_w, va, q0, u0, q1, u1)
        else:
            st[0], st[1], st[2], st[3], st[4], st[5] = x_w, va, q0, u0, q1, u1
        self.qr_t.append(t)
        self.qr_log1.append(float(self.ln(r11)))
        # plastic impact (R = 0): the second exponent is -inf
        self.qr_log2.append(float(self.ln(r22)) if r22 != 0 else -math.inf)
        self.log(t)
        sp = abs(float(vb))
        if sp < self.min_speed:
            self.min_speed = sp
        s = abs(float(s10))
        if s > self.max_saltation:
            self.max_saltation = s
        return self.within_budget()


class _MaximumGuard:
    """Non-terminal-event callback on ``v`` (negative direction): ``x`` at every maximum.

    Counters since :meth:`reset`: ``maxima`` checked, ``missed`` maxima beyond the
    wall by more than ``GUARD_FACTOR * delta(t)``, ``max_overshoot`` the largest
    ``x - x_w`` at a maximum, ``first_miss`` ``(t, x - x_w)`` of the first miss.
    Read it back from ``ta.nt_events[0].callback``.
    """

    def __init__(self) -> None:
        self.reset(_Depth())

    def reset(self, depth: _Depth, pars: Any = None) -> None:
        self.depth = depth
        self.t_depth = 0.0  # as the recorder's
        self.pars = pars  # float64: the parameters as Python floats (else the integrator's)
        self.maxima = 0
        self.missed = 0
        self.max_overshoot = -math.inf
        self.first_miss: tuple[float, float] | None = None

    def __call__(self, ta, time, d_sgn) -> None:
        # The integrator's state is at the end of the step: evaluate the dense output.
        ta.update_d_output(time)
        pr = self.pars if self.pars is not None else ta.pars
        over = ta.d_output[0] - pr[I_XW]
        self.maxima += 1
        o = float(over)
        if o > self.max_overshoot:
            self.max_overshoot = o
        if over > GUARD_FACTOR * self.depth(self.t_depth, pr):
            self.missed += 1
            if self.first_miss is None:
                self.first_miss = (float(time), o)


_INTEGRATORS = IntegratorCache("variational")  # compiled once; every caller gets its own copy


def build_variational_integrator(precision: Precision, tol: Any = None):
    """The oscillator + first-order variational equations integrator.

    State ``[x, v, dx/dx0, dx/dv0, dv/dx0, dv/dv0]``; runtime parameters
    ``RUNTIME_PARAMS``; one terminal event (``x - x_w``, positive direction,
    :class:`_SaltationRecorder`) and one non-terminal event (``v``, negative
    direction: maxima of ``x``, :class:`_MaximumGuard`).  ``tol`` as in
    :class:`~precise_impact.HeyokaSolver` (``None``: the precision's epsilon).
    """
    import heyoka as hy

    key = (precision.name, None if tol is None else precision.to_str(tol))

    def compile_():
        x, v = hy.make_vars("x", "v")
        p = {name: hy.par[i] for i, name in enumerate(RUNTIME_PARAMS)}
        rhs = acceleration(hy.time, x, v, p["eta"], p["zeta"], p["a"], hy.cos)
        vsys = hy.var_ode_sys([(x, v), (v, rhs)], hy.var_args.vars, order=1)
        kw = precision.heyoka_kwargs
        ev = hy.t_event(
            x - p["x_w"],
            callback=_SaltationRecorder(),
            direction=hy.event_direction.positive,
            fp_type=kw["fp_type"],
        )
        guard = hy.nt_event(
            v,
            callback=_MaximumGuard(),
            direction=hy.event_direction.negative,
            fp_type=kw["fp_type"],
        )
        zero = precision.from_fraction(Fraction(0))
        extra = {"tol": tol} if tol is not None else {}
        ta = hy.taylor_adaptive(
            vsys,
            [zero, zero],
            pars=[zero] * len(RUNTIME_PARAMS),
            t_events=[ev],
            nt_events=[guard],
            compact_mode=precision.kind == "mp",
            **extra,
            **kw,
        )
        return ta

    return _INTEGRATORS.get(key, compile_)


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
    st[2], st[4], st[3], st[5], r11, r22 = gram_schmidt2(a0, a1, b0, b1, sqrt)
    if r22 == 0:
        return log(r11), -math.inf  # plastic impact (R = 0): the second exponent is -inf
    return log(r11), log(r22)


def _state_logs(rows, sqrt, log) -> tuple[list, list]:
    """``ln r11``, ``ln r22`` of the QR of each row's tangent matrix (rows of the grid output)."""
    l1, l2 = [], []
    for row in rows:
        *_, r11, r22 = gram_schmidt2(row[2], row[4], row[3], row[5], sqrt)
        l1.append(float(log(r11)))
        l2.append(float(log(r22)) if r22 != 0 else -math.inf)
    return l1, l2


#: Forcing periods per ``propagate_grid`` call of the variational integration
#: (module docstring, *Per-period logs*): the clock is set back after each call.
CHUNK = 8


def _one_orbit(
    ta,
    rec,
    guard,
    P,
    params: Params,
    transient: int,
    periods: int,
    progress,
    label: str,
    check_guard: bool,
):
    """Transient, then ``periods`` measured periods; returns per-period logs and samples.

    Integrated ``CHUNK`` periods per ``propagate_grid`` call on the local clock
    (module docstring, *Time* and *Per-period logs*).
    """
    import heyoka as hy

    conv = P.from_fraction
    one, zero = conv(Fraction(1)), conv(Fraction(0))
    x0, v0 = conv(params.x0), conv(params.v0)
    if impact_at_start(params.x0, params.v0, params.x_w, params.R):
        v0 = reset_velocity(v0, conv(params.R))
    grid = local_grid(P, params.t0, params.eta, CHUNK)
    L0 = grid[0]
    # the grazing depth at the chunk's last clock value (module docstring, *Time*)
    rec.t_depth = guard.t_depth = grid[-1]
    ta.time = L0
    ta.state[:] = P.array([x0, v0, one, zero, zero, one])
    ta.reset_cooldowns()
    sqrt, log = (math.sqrt, math.log) if P.kind == "float64" else (np.sqrt, np.log)
    period = period_float(params.eta)
    grids = {}

    def advance(k):
        """``k <= CHUNK`` periods from ``L0``; the grid states (rows ``1..k``)."""
        g = grids.get(k)
        if g is None:
            g = grids[k] = P.array(grid[: k + 1])
        ta.time = L0  # the forcing is T-periodic: the clock starts every chunk at L0
        res = ta.propagate_grid(g)
        oc = res[0]
        if rec.exceeded:
            raise BudgetExceededError(
                f"impact budget max_impacts={rec.max_impacts} exhausted at t={P.to_str(ta.time)}"
            )
        if oc != hy.taylor_outcome.time_limit:
            raise IntegrationError(f"heyoka stopped with outcome {oc} at t={P.to_str(ta.time)}")
        if check_guard and guard.missed:
            t_m, over = guard.first_miss
            raise MissedImpactError(
                f"a maximum of x lies {over:.3g} beyond the wall x_w = {float(params.x_w)!r} at local time "
                f"{t_m:.17g} with no impact event (more than {GUARD_FACTOR} grazing depths): heyoka's event "
                "detection missed an impact; the result cannot be trusted"
            )
        return res[-1]

    done = 0
    while done < transient:
        k = min(CHUNK, transient - done)
        advance(k)
        _gram_schmidt(ta.state, sqrt, log)  # keep the tangents bounded during the transient too
        done += k
    # the transient's logs are discarded, not its basis: the tangents keep the orientation
    # they converged to (a restart at the identity costs a 1/t bias the error bar cannot see)
    rec.take_logs()
    impacts0 = rec.count
    l1, l2, dt = np.empty(periods), np.empty(periods), np.full(periods, period)
    sx, sv = np.empty(periods), np.empty(periods)
    ni = np.zeros(periods)  # impacts in each measured period (the attractors' impact-rate test)
    bar = Progress(periods, f"variational LLE{label}", progress)
    done = 0
    while done < periods:
        k = min(CHUNK, periods - done)
        rows = advance(k)[1:]
        # a period's logs: those of the in-callback QRs of its impacts, plus the change
        # of the tangent state's own QR logs (the state restarted orthonormal at L0)
        a1, a2 = _state_logs(rows.tolist() if P.kind == "float64" else rows, sqrt, log)
        ct, c1, c2 = rec.take_logs()
        s1 = s2 = 0.0
        j = 0
        for i in range(k):
            g = grid[i + 1]
            p1 = p2 = 0.0
            while j < len(ct) and ct[j] <= g:
                p1 += c1[j]
                p2 += c2[j]  # -inf after a plastic impact (R = 0); the state logs stay finite
                j += 1
                ni[done + i] += 1
            l1[done + i], l2[done + i] = p1 + (a1[i] - s1), p2 + (a2[i] - s2)
            s1, s2 = a1[i], a2[i]
        sx[done : done + k], sv[done : done + k] = rows[:, 0], rows[:, 1]
        _gram_schmidt(ta.state, sqrt, log)  # its logs are a1[-1], a2[-1], already counted
        done += k
        bar.update(done)
    return l1, l2, dt, sx, sv, rec.count - impacts0, ni


def initial_condition(params: Params, j: int) -> Params:
    """The ``j``-th initial condition of an ensemble: ``v0 + j/4`` (j = 0 is ``params`` itself)."""
    return params if j == 0 else params.replace(v0=params.v0 + Fraction(j, 4))


def _depth_for(P: Precision, grazing_depth: Any, params: Params) -> _Depth:
    """The recorder's/guard's :class:`_Depth` in precision ``P`` (validated)."""
    if grazing_depth is None:
        coef = grazing_depth_coefficient(P)
        amp = Fraction(steady_amplitude(params))  # a float is plenty for a safety margin
        if P.kind == "float64":
            return _Depth(float(coef), float(amp))
        return _Depth(P.from_fraction(coef), P.from_fraction(amp))
    q = exact("grazing_depth", grazing_depth)
    if q < 0:
        raise ParameterError("grazing_depth", str(grazing_depth), "None or a depth >= 0")
    return _Depth(fixed=float(q) if P.kind == "float64" else P.from_fraction(q))


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
    q = P.check_tol(tol)
    tol = None if q is None else P.from_fraction(q)
    depth = _depth_for(P, grazing_depth, params)
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
    diag = {
        "impacts": 0,
        "grazing": 0,
        "min_impact_speed": math.inf,
        "max_contact_speed": 0.0,
        "max_saltation": 0.0,
        "maxima": 0,
        "max_overshoot": -math.inf,
        "missed": 0,
    }
    for j, (ic, n) in enumerate(zip(ics, per_orbit)):
        rec.reset(max_impacts, depth, *fns, pars=ta.pars)
        grd.reset(depth, rec.f64)
        label = f" (orbit {j + 1}/{n_ic})" if n_ic > 1 else ""
        l1, l2, dt, sx, sv, imp, ni = _one_orbit(
            ta, rec, grd, P, ic, transient, n, progress, label, guard
        )
        if strobe is None:
            strobe = (sx, sv)
        tails.append((sx[-3 * MAX_PERIOD :], sv[-3 * MAX_PERIOD :]))
        L1.append(l1)
        L2.append(l2)
        DT.append(dt)
        impacts += imp
        blocks.append(block_stderr(l1, dt, min(blocks_per_orbit, n))[0])
        # the attractors' per-start tests: finer blocks (TEST_BLOCKS of >= TEST_BLOCK_PERIODS
        # periods) and the impacts per period in the same blocks (block_stderr's split)
        nt = min(n, max(blocks_per_orbit, min(TEST_BLOCKS, n // TEST_BLOCK_PERIODS)))
        test_blocks.append(block_stderr(l1, dt, nt)[0])
        rates.append(np.array([ni[i].mean() for i in np.array_split(np.arange(n), nt) if len(i)]))
        diag["impacts"] += rec.count
        diag["grazing"] += rec.grazing
        diag["min_impact_speed"] = min(diag["min_impact_speed"], rec.min_speed)
        diag["max_contact_speed"] = max(diag["max_contact_speed"], rec.max_contact_speed)
        diag["max_saltation"] = max(diag["max_saltation"], rec.max_saltation)
        diag["maxima"] += grd.maxima
        diag["max_overshoot"] = max(diag["max_overshoot"], grd.max_overshoot)
        diag["missed"] += grd.missed
    elapsed = _time.perf_counter() - start
    l1, l2, dt = np.concatenate(L1), np.concatenate(L2), np.concatenate(DT)
    diag["max_period_log"] = float(np.max(l1)) if len(l1) else -math.inf
    diag["finite_logs"] = bool(np.all(np.isfinite(l1)))
    all_blocks = np.concatenate(blocks)
    se = means_stderr(all_blocks)
    total = float(np.sum(dt))
    lam1, lam2 = float(np.sum(l1) / total), float(np.sum(l2) / total)
    result = LyapunovResult(
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
        stats=diag,
    )
    if attractors:
        per_start = [
            (float(np.sum(a) / np.sum(d)), float(np.sum(b) / np.sum(d)), blk)
            for a, b, d, blk in zip(L1, L2, DT, test_blocks)
        ]
        attribute(
            result,
            tails,
            per_start,
            P.name if P.kind in ("float64", "mp") else "float64",
            impact_blocks=rates,
            periods=per_orbit,
        )
    return result
