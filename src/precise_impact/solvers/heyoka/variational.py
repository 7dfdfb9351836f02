"""The heyoka variational integrator: tangent flow with the impact's saltation matrix.

Builds and drives the integrator behind
:func:`~precise_impact.analysis.lyapunov.variational.variational_spectrum`: heyoka's variational
equations between impacts, ``Phi+ = S Phi-`` and a QR at every impact.  Hard cases, local clock,
per-period logs, guard: ``docs/numerics.rst``, "Variational equations with the saltation
matrix".  References: Benettin et al., Meccanica 15 (1980) 21-30; Müller, Chaos Solitons
Fractals 5 (1995) 1671.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Any

import numpy as np

from precise_impact.core.clock import local_grid, period_float
from precise_impact.core.flow import acceleration, tangent_qr_interval
from precise_impact.core.impact import (
    BOUNCES_ENDLESS,
    BOUNCES_REST,
    elastic_bounce_count,
    elastic_bounce_refusal,
    grazing_depth_coefficient,
    impact_at_start,
    is_contact,
    oscillator_saltation,
    reset_velocity,
    short_elastic_flight,
    steady_amplitude,
)
from precise_impact.core.impact import GrazingDepth as _Depth
from precise_impact.core.linalg import gram_schmidt2
from precise_impact.core.params import (
    I_A,
    I_ETA,
    I_R,
    I_XW,
    I_ZETA,
    RUNTIME_PARAMS,
    Params,
    exact,
)
from precise_impact.core.precision import Precision
from precise_impact.errors import (
    BudgetExceededError,
    EndlessBouncesError,
    IntegrationError,
    MissedImpactError,
    ParameterError,
)
from precise_impact.io.progress import Progress
from precise_impact.solvers.heyoka.cache import IntegratorCache
from precise_impact.solvers.heyoka.events import ImpactRecorder
from precise_impact.solvers.heyoka.single import _below_wall, _Wall

__all__ = [
    "build_variational_integrator",
    "integrate_orbit",
    "depth_for",
    "CHUNK",
    "chunk_layout",
    "GUARD_FACTOR",
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

    Counts impacts against the budget with
    :class:`~precise_impact.solvers.heyoka.events.ImpactRecorder` (no log: ``keep=False``).

    Deep-copied into the integrator by heyoka: read it back from
    ``ta.t_events[0].callback``.  Counters (since the last :meth:`reset`):
    ``count`` impacts applied, ``grazing`` contacts (not impacts), ``min_speed``
    smallest ``v-`` of an impact, ``max_contact_speed`` largest ``v-`` of a contact,
    ``max_saltation`` largest ``|S[1][0]|``.  The logs of the in-callback QR are
    appended to ``qr_t``/``qr_log1``/``qr_log2`` (impact time, ``ln r11``, ``ln r22``)
    until :meth:`take_logs` hands them over (docs/numerics.rst, *Per-period logs*).

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
        #: R = 1 bounce sequences (core.impact.elastic_bounce_count): the run's end on the
        #: local clock (set per chunk), the precision's eps, and the refusal once predicted
        self.t_end = math.inf
        self.eps = 2.0**-52
        self.predicted = False
        self.refusal: str | None = None

    def _bounces(self, t: Any, vb: Any, pr: Any) -> bool:
        """At an ``R = 1`` impact: predict a bounce sequence at its first short flight; True
        (stop, ``refusal`` set) when it comes to rest or outruns the impact budget."""
        tf, vf = float(t), float(vb)
        eta, zeta, a, x_w = (float(pr[i]) for i in (I_ETA, I_ZETA, I_A, I_XW))
        g = a * math.cos(eta * tf) - x_w
        if not short_elastic_flight(vf, g, eta):
            self.predicted = False
            return False
        if self.predicted:
            return False
        self.predicted = True
        n, end, s = elastic_bounce_count(tf, vf, self.t_end, eta, zeta, a, x_w, self.eps)
        left = self.max_impacts - self.count
        if end not in (BOUNCES_REST, BOUNCES_ENDLESS) and n <= left:
            return False
        self.refusal = elastic_bounce_refusal(tf, n, end, s, self.max_impacts)
        return True

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
        # Renormalise at once (docs/numerics.rst, hard cases 1. and 2.): the logs carry the growth.
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
        if R >= 1 and self._bounces(t, vb, pr):
            return False
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
    import heyoka as hy  # noqa: PLC0415 -- optional: heyoka loaded on first use (the module imports without it)

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
#: (docs/numerics.rst, *Per-period logs*): the clock is set back after each call.
CHUNK = 8


def chunk_layout(period: float, zeta: Any) -> tuple[int, int]:
    """Periods per chunk and QR steps per period: ``(CHUNK, 1)`` unless that spans more than
    :func:`~precise_impact.core.flow.tangent_qr_interval` (long periods, strong damping):
    then as many whole periods as fit (at least one), and a long period cut into equal steps.

    Between two QRs the tangents must not shrink far below ``(x, v)``: heyoka's error control
    is relative to the whole state, and tangent entries near ``eps |x|`` are noise
    (measured: eta = 0.001, non-impacting, 8 periods per QR: LLE -0.0045 for -zeta = -0.05;
    zeta = 1.5: lambda2 -1.02 for -2.618).
    """
    h = tangent_qr_interval(zeta)
    if CHUNK * period <= h:
        return CHUNK, 1
    if period <= h:
        return max(1, int(h // period)), 1
    return 1, math.ceil(period / h)


class _Orbit:
    """One orbit of :func:`integrate_orbit`: the integrator, its clock grid and the steps."""

    def __init__(self, ta, rec, guard, P, params: Params, left: int, check_guard: bool) -> None:
        self.ta, self.rec, self.guard, self.P, self.params = ta, rec, guard, P, params
        import heyoka as hy  # noqa: PLC0415 -- optional: heyoka loaded on first use (the module imports without it)

        self.time_limit = hy.taylor_outcome.time_limit
        self.check_guard = check_guard
        self.period = period_float(params.eta)
        self.chunk, self.sub = chunk_layout(self.period, params.zeta)
        self.grid = local_grid(P, params.t0, params.eta, self.chunk, self.sub)
        self.L0 = self.grid[0]
        fns: tuple[Any, Any] = (math.sqrt, math.log) if P.kind == "float64" else (np.sqrt, np.log)
        self.sqrt, self.log = fns
        self.grids: dict[int, Any] = {}
        self.left = left  # periods still to run (the bounce prediction's horizon)
        self.subgrids = (
            [P.array(self.grid[j : j + 2]) for j in range(self.sub)] if self.sub > 1 else []
        )

    def start(self) -> None:
        """The initial state with the tangents at the identity (an impact at the start applied)."""
        P, params, ta = self.P, self.params, self.ta
        conv = P.from_fraction
        one, zero = conv(Fraction(1)), conv(Fraction(0))
        x0, v0 = conv(params.x0), conv(params.v0)
        if impact_at_start(params.x0, params.v0, params.x_w, params.R):
            v0 = reset_velocity(v0, conv(params.R))
            # leave a rounding-level distance below the wall: a propagation that starts on it
            # can miss the next impact (measured: x0 = x_w = 0, v0 = 1/4, the force into the
            # wall: the impact at t ~ 0.5 was missed, MissedImpactError 0.976 beyond the wall)
            x0 = _below_wall(P, params.x_w)
        # the grazing depth at the chunk's last clock value (docs/numerics.rst, *Time*)
        self.rec.t_depth = self.guard.t_depth = self.grid[-1]
        ta.time = self.L0
        ta.state[:] = P.array([x0, v0, one, zero, zero, one])
        ta.reset_cooldowns()

    def run(self, g):
        """Propagate over the grid ``g`` (starting at the clock's value); the grid states."""
        ta, rec, P = self.ta, self.rec, self.P
        res = ta.propagate_grid(g)
        oc = res[0]
        if rec.refusal is not None:
            raise EndlessBouncesError(rec.refusal)
        if rec.exceeded:
            raise BudgetExceededError(
                f"impact budget max_impacts={rec.max_impacts} exhausted at t={P.to_str(ta.time)}"
            )
        if oc != self.time_limit:
            raise IntegrationError(f"heyoka stopped with outcome {oc} at t={P.to_str(ta.time)}")
        if self.check_guard and self.guard.missed:
            t_m, over = self.guard.first_miss
            raise MissedImpactError(
                f"a maximum of x lies {over:.3g} beyond the wall x_w = {float(self.params.x_w)!r} "
                f"at local time {t_m:.17g} with no impact event (more than {GUARD_FACTOR} "
                "grazing depths): heyoka's event detection missed an impact; the result cannot "
                "be trusted"
            )
        return res[-1]

    def advance(self, k):
        """``k <= chunk`` periods from ``L0``; the grid states (rows ``1..k``)."""
        g = self.grids.get(k)
        if g is None:
            g = self.grids[k] = self.P.array(self.grid[: k + 1])
        self.ta.time = self.L0  # the forcing is T-periodic: the clock starts every chunk at L0
        self.rec.t_end = float(self.L0) + self.left * self.period
        self.left -= k
        return self.run(g)

    def one_period(self):
        """One period in ``sub`` steps, the tangents re-orthonormalised after each (a long
        period: :func:`chunk_layout`); the state QRs' summed logs and the period-end state."""
        self.ta.time = self.L0
        self.rec.t_end = float(self.L0) + self.left * self.period
        self.left -= 1
        s1 = s2 = 0.0
        row = None
        for g in self.subgrids:
            row = self.run(g)[-1]
            a, b = _gram_schmidt(self.ta.state, self.sqrt, self.log)
            s1, s2 = s1 + float(a), s2 + float(b)
        return s1, s2, row

    def transient(self, done: int, transient: int) -> None:
        """Periods ``done..transient``, the tangents kept bounded (their logs discarded later)."""
        while done < transient:
            if self.sub > 1:
                self.one_period()
                done += 1
                continue
            k = min(self.chunk, transient - done)
            self.advance(k)
            _gram_schmidt(self.ta.state, self.sqrt, self.log)  # keep the tangents bounded too
            done += k

    def measure_long(self, out, done: int, periods: int, bar) -> int:
        """Measured periods one at a time in ``sub`` QR steps (a long period); periods done."""
        l1, l2, sx, sv, ni = out
        while done < periods and self.sub > 1:
            s1, s2, row = self.one_period()
            _, c1, c2 = self.rec.take_logs()
            p1 = p2 = 0.0
            for u, w in zip(c1, c2, strict=True):
                p1, p2 = p1 + u, p2 + w
            l1[done], l2[done] = p1 + s1, p2 + s2
            ni[done] = len(c1)
            sx[done], sv[done] = row[0], row[1]
            done += 1
            bar.update(done)
        return done

    def measure_chunks(self, out, done: int, periods: int, bar) -> None:
        """Measured periods ``CHUNK`` at a time, each period's logs attributed by its end."""
        l1, l2, sx, sv, ni = out
        P, grid = self.P, self.grid
        while done < periods:
            k = min(self.chunk, periods - done)
            rows = self.advance(k)[1:]
            # a period's logs: those of the in-callback QRs of its impacts, plus the change
            # of the tangent state's own QR logs (the state restarted orthonormal at L0)
            a1, a2 = _state_logs(
                rows.tolist() if P.kind == "float64" else rows, self.sqrt, self.log
            )
            ct, c1, c2 = self.rec.take_logs()
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
            _gram_schmidt(self.ta.state, self.sqrt, self.log)  # its logs: a1[-1], a2[-1], counted
            done += k
            bar.update(done)


def integrate_orbit(
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
    (docs/numerics.rst, *Time* and *Per-period logs*).
    """
    orb = _Orbit(ta, rec, guard, P, params, transient + periods, check_guard)
    orb.start()
    pre = _released_start(ta, rec, P, params, orb.grid, orb.sub, orb.run, orb.sqrt, orb.log)
    done = 0
    if pre is not None:  # the first period went to the sticking start and its release
        orb.left -= 1
        if transient:
            done = 1
    orb.transient(done, transient)
    # the transient's logs are discarded, not its basis: the tangents keep the orientation
    # they converged to (a restart at the identity costs a 1/t bias the error bar cannot see)
    rec.take_logs()
    impacts0 = rec.count
    l1, l2, dt = np.empty(periods), np.empty(periods), np.full(periods, orb.period)
    sx, sv = np.empty(periods), np.empty(periods)
    ni = np.zeros(periods)  # impacts in each measured period (the attractors' impact-rate test)
    bar = Progress(periods, f"variational LLE{label}", progress)
    done = 0
    if pre is not None and not transient:  # the release's period is the first measured one
        _, c1, c2 = rec.take_logs()
        l1[0], l2[0] = sum(c1) + pre[0], sum(c2) + pre[1]
        ni[0] = len(c1)
        sx[0], sv[0] = pre[2][0], pre[2][1]
        done = 1
    out = (l1, l2, sx, sv, ni)
    done = orb.measure_long(out, done, periods, bar)
    orb.measure_chunks(out, done, periods, bar)
    return l1, l2, dt, sx, sv, rec.count - impacts0, ni


def released_at(P: Precision, params: Params, L0: Any) -> Any:
    """The release time (local clock, precision ``P``) of a start at rest on the wall at the
    local time ``L0`` with the force into it (the heyoka solver's sticking decision), or
    ``None`` for a start that does not stick; :class:`ParameterError` if the force never
    turns (the mass stays on the wall for good: no Lyapunov exponents)."""
    wall = _Wall(P, params)
    if not wall.sticks(L0):
        return None
    t_r = wall.release(L0)
    if t_r is None:
        raise ParameterError(
            "x0",
            f"{params.x0} (= x_w, v0 = 0)",
            "a start off the wall or moving: at rest on the wall with the force always into it "
            "the mass stays there for good, which has no Lyapunov exponents",
        )
    return t_r


def _released_start(ta, rec, P, params: Params, grid: list, sub: int, run, sqrt, log):
    """A start at rest on the wall with the force into it sticks until the force turns
    (core.impact.pushes_into_wall, release_time: the heyoka solver's sticking decision):
    integrate its first period from the release, a rounding-level distance below the wall
    (a propagation starting on the wall can miss the next impact), with the tangents at the
    identity there.  Returns ``None`` for any other start, else the logs of that period's
    QRs and its end state ``(s1, s2, row)``; raises :class:`ParameterError` if the force never
    turns.  (Measured before: x_w = 0, x0 = v0 = 0 went through the wall, MissedImpactError.)
    """
    if not (params.x0 == params.x_w and params.v0 == 0):
        return None
    t_r = released_at(P, params, grid[0])
    if t_r is None:
        return None
    one, zero = P.from_fraction(Fraction(1)), P.from_fraction(Fraction(0))
    ta.time = t_r
    ta.state[:] = P.array([_below_wall(P, params.x_w), zero, one, zero, zero, one])
    ta.reset_cooldowns()
    s1 = s2 = 0.0
    row = ta.state
    for g in grid[1 : sub + 1]:
        if g <= t_r:
            continue
        row = run(P.array([ta.time, g]))[-1]
        a, b = _gram_schmidt(ta.state, sqrt, log)
        s1, s2 = s1 + float(a), s2 + float(b)
    return s1, s2, row


def depth_for(P: Precision, grazing_depth: Any, params: Params) -> _Depth:
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
