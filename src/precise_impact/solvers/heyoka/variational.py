"""The heyoka variational integrator: tangent flow with the impact's saltation matrix.

Used by :func:`~precise_impact.analysis.lyapunov.variational.variational_spectrum` (the
algorithm: ensemble, statistics, attractors); this module builds and drives the integrator.

The tangent dynamics between impacts are heyoka's first-order variational
equations (``var_ode_sys``) of the same flow :func:`precise_impact.core.flow.acceleration`.
heyoka does not know about the discontinuity: at every impact the terminal-event
callback maps the tangent matrix through the saltation matrix
(:func:`precise_impact.core.impact.oscillator_saltation`), ``Phi+ = S Phi-``.  The
tangent matrix is re-orthonormalised (Gram-Schmidt = QR; Benettin et al.,
Meccanica 15 (1980) 21-30; Shimada & Nagashima, Prog. Theor. Phys. 61 (1979)
1605) *right after every impact* and at the end of every ``CHUNK`` (8) periods; the
logs of the diagonal of R accumulate the two exponents, per period (*Per-period
logs* below).  A chunk never spans more than ``8 / (zeta + sqrt(max(zeta^2 - 1, 0)))``
time units (:func:`~precise_impact.solvers.heyoka.variational.chunk_layout`: fewer periods
per chunk, or a long period cut into steps with a QR after each), since heyoka's error
control is relative to the whole state and tangents shrunk far below ``(x, v)`` would be
integrated as noise (measured at eta = 0.001, non-impacting: LLE -0.0045 for -zeta = -0.05).
Müller, Chaos Solitons Fractals 5 (1995) 1671 introduced the saltation-matrix treatment
for impacting systems.

Hard cases
----------
*Near-grazing impacts: the 1/v- of the saltation matrix.*  For the oscillator
``S = [[-R, 0], [s, -R]]`` with ``s = (1 + R)(a cos(eta t) - x_w) / v-``
(:mod:`precise_impact.core.impact`), so ``|s|`` grows without bound as the impact
velocity ``v- -> 0``.  Three things could go wrong and are prevented:

1. *Overflow.*  ``S Phi`` has entries ``~|s| |Phi|``.  Applying ``S`` and then
   re-orthonormalising immediately (in the impact callback) leaves entries of
   size ``<= 1`` after every impact, whose logs ``ln r11``, ``ln r22`` are added
   to the current period's logs (QR of a product = product of the R factors, so
   the per-period logs are, in exact arithmetic, the same as with one QR at the
   period end).  The largest value ever formed is ``|s|`` times an entry ``<= 1``
   (times the growth of the smooth flow within one period, < 2 here): overflow
   needs ``v- < ~1e-308`` in float64 and never happens in practice (float64
   cannot resolve an impact with ``v- < ~1e-8``, see 3.), and the MPFR exponent
   range of ``mp:BITS`` is astronomically wide.  Every log is finite unless
   ``R = 0`` (``det S = 0``: ``lambda2 = -inf``, see :func:`_gram_schmidt`).
2. *heyoka's event machinery sees the tangents.*  heyoka measures errors against
   the infinity norm of the *whole* state, tangent entries included
   (``g_eps = eps * max|state|``, ``taylor_adaptive.cpp``), and after a terminal
   event it ignores the same event for a cooldown of ``10 g_eps / |g'|``
   (``taylor_deduce_cooldown``, ``src/detail/event_detection.cpp``), here
   ``10 g_eps / v-``.  Large tangent entries therefore lengthen the cooldown and
   hide the next impacts: measured with identity tangents scaled by ``1e17`` at
   eta = 0.712, R = 0.8, the cooldown after the first impact became 5.3 time
   units (8 of 13 impacts in 20 periods found, the mass went through the wall to
   x = 2.76) and with ``1e18`` 682 time units (1 of 13).  Renormalising right
   after each impact keeps ``max|state|`` at the size of ``(x, v)``, so the
   cooldown is the plain integrator's.
3. *Contacts at rounding level are not impacts.*  An orbit whose maximum lies
   within rounding of the wall (exact grazing) may or may not produce an event,
   at random, with ``v-`` at the rounding level (measured on the grazing steady
   orbit, x_w = amplitude to 1 ulp: ``v- ~ 1e-8`` in about half of the periods).
   Applying the impact there kicks ``v`` by ``(1 + R) v-`` and multiplies the
   tangents by ``|s| ~ 1e8`` on the strength of a rounding error: measured
   (eta = 0.70, x_w = amplitude rounded down), the grazing steady orbit then
   leaves for the impacting chaotic attractor within 4 periods (impact speeds
   1.7e-8, 1.5e-4, 1.3e-2: Nordmark's square-root map amplifies the rounding-level
   kick) and the LLE comes out as +0.034 instead of -zeta.  As for the robust
   analytical finder (:class:`~precise_impact.solvers.closed_form.AnalyticalSolver`,
   ``stats["grazing"]``), an event whose excursion beyond the wall,
   ``depth = v-^2 / (2 |x''|)`` (``x'' < 0``: a maximum), is below the grazing
   depth ``delta(t)`` is a tangential *contact*: no reset, no saltation, counted
   in ``stats["grazing"]``.  Default ``delta(t) = 16 u (|x_w| + |a| + A_p
   (1 + eta |t|))`` with ``u = 2^-bits`` the unit roundoff and ``A_p`` the
   steady-state amplitude (:func:`~precise_impact.core.flow.steady_state`): a few
   roundings of the terms of the Taylor evaluation, plus the rounding of the
   forcing phase (heyoka evaluates ``cos(eta t)`` with ``t`` rounded, an absolute
   phase error ``u eta |t|`` that jitters the orbit's amplitude by ``~u eta |t|
   A_p``), times 16 for safety.  Measured apparent depths of the events on grazing
   steady orbits (eta = 0.6, 0.70, 0.712, 0.74, 2e4 periods on an absolute clock):
   ``<= 2.1 u eta |t| A_p`` and ``~5e-16`` in the first periods.  An event with
   ``v- <= 0`` (rounding) is a contact as well; ``x'' >= 0`` at small ``v-``
   (pushed into the wall) is always an impact.

*Time.*  The forcing is ``T``-periodic, so every chunk of ``CHUNK`` periods is
integrated on the same local grid ``L0 .. L0 + CHUNK T`` with the clock set back to
``L0`` afterwards (:func:`precise_impact.core.clock.local_grid`; the two-trajectory
method does the same every period): ``|t|`` stays below ``(CHUNK + 1) T``, so the
forcing-phase rounding ``u eta |t|`` and the grazing depth ``delta(t)`` stay at the
level of the first chunk for any run length.  The rounding of a whole chunk stays
in the state when the clock is set back, so the grazing depth is taken at the
chunk's last clock value, ``delta(L0 + CHUNK T)``, for every event of the run
(measured on the grazing steady orbit at eta = 0.70: with ``delta(t)`` at the event's
own clock, a touch early in a chunk had an apparent depth of 1.2e-14 against
``delta(0.19) = 9e-15`` and was taken for an impact)
(with absolute time the apparent depth on the grazing orbit grew to 4e-11 after
2e4 periods).

*Per-period logs.*  A chunk of ``CHUNK`` periods is one ``propagate_grid`` call
with an output at every period boundary (no Python work per period).  The tangent
state ``Phi_s`` starts the chunk orthonormal and is only touched by the in-callback
QR, so the true tangent matrix is ``Phi_s(t) U(t)`` with ``U`` the product of the
upper-triangular factors taken so far; the diagonal of a product of upper-triangular
matrices is the product of the diagonals, hence the cumulative logs at a period
boundary ``g`` are ``ln r_ii(QR(Phi_s(g)))`` plus the in-callback logs of the
impacts at times ``<= g``, and a period's logs are the differences.  Between impacts
``Phi_s`` grows at most like the smooth flow over one chunk (its norm stays ~1: the
flow of the damped oscillator does not amplify, it rotates and shrinks), so
overflow, and heyoka's cooldown seeing large tangents (2. above), cannot arise.
The columns align at most by ``exp((lambda1 - lambda2) t)`` between impacts within a
chunk (``~e^11`` at eta = 0.712 for 8 impact-free periods), which costs ``ln r22``
at most ~5 of float64's 16 digits relative to a per-period QR, far below the
statistical error.

*Missed impacts: the guard.*  heyoka's event detection isolates the roots of the
event polynomial of each step (Descartes' rule of signs with bisection) and
refines them with TOMS 748; its documentation warns that roots of multiplicity
> 1 (a tangency) can be missed (heyoka.py tutorial "Event detection",
"Limitations and caveats: badly-conditioned event equations"), and a root
whose refinement fails (TOMS 748 reporting an ``errno``, or too many iterations)
is dropped with a logged warning (``event_detection.cpp``).  Measured: on the
grazing steady orbit (eta = 0.74, x_w = amplitude rounded to nearest) heyoka
logged "returned a nonzero errno with message 'Numerical argument out of domain'"
once in 2000 periods; the dropped root was a maximum at exactly ``x - x_w = 0.0``
(a rounding-level tangency, a contact).  As a check independent of that machinery, a
non-terminal event on ``v`` (direction negative: every maximum of ``x``)
evaluates ``x`` at the maximum (dense output): a maximum beyond the wall by more
than ``4 delta(t)`` can only be a missed impact (contacts stay within
``delta(t)``); it raises :class:`MissedImpactError` (``guard=True``) or is counted
(``guard=False``).  Measured: no float64 or mp miss above rounding level; the
guard fires on the deliberately inflated-cooldown case of 2. above.
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
#: (module docstring, *Per-period logs*): the clock is set back after each call.
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
        self.sqrt, self.log = (math.sqrt, math.log) if P.kind == "float64" else (np.sqrt, np.log)
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
        # the grazing depth at the chunk's last clock value (module docstring, *Time*)
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
    (module docstring, *Time* and *Per-period logs*).
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
