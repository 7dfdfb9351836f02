"""The ``switched-capacitor`` model: the impact made by the circuit itself.

Comparator U5, flip-flop A1 and switches U6/U7 reverse C2; with every effect off this is the
ideal impact (R = 1) exactly (``docs/circuit.rst``).
"""

from __future__ import annotations

import time as _time
from collections.abc import Mapping
from fractions import Fraction
from typing import Any

import numpy as np

from precise_impact.core.mpcontext import mp_context
from precise_impact.core.params import Params, check_count
from precise_impact.core.precision import Precision
from precise_impact.core.trajectory import Trajectory
from precise_impact.errors import BudgetExceededError, IntegrationError, ParameterError
from precise_impact.models.circuit.components import Components, design_and_start, dimensionless
from precise_impact.models.circuit.effects import comparator, flipflop, switch
from precise_impact.models.circuit.effects.catalogue import validate_effects
from precise_impact.models.circuit.effects.tolerance import actual_components
from precise_impact.models.circuit.network import NETWORK_PARS
from precise_impact.models.circuit.opamp import design_omega
from precise_impact.solvers.heyoka.cache import IntegratorCache
from precise_impact.solvers.heyoka.events import ImpactRecorder

__all__ = ["SwitchedCapacitorSolver", "effective_system"]

PARS = NETWORK_PARS + ("pol", "ron", "v_trip", "v_rearm")
_I = {n: i for i, n in enumerate(PARS)}


def _system():
    import heyoka as hy  # noqa: PLC0415 -- optional: heyoka loaded on first use (the module imports without it)

    p = {n: hy.par[i] for i, n in enumerate(PARS)}
    V_s, V_C = hy.make_vars("V_s", "V_C")
    V3 = p["V_A"] * hy.cos(p["Omega"] * hy.time)
    rho = p["R5"] / p["R4"]
    k = switch.coupling(p["ron"], p["R2"], p["R3"])
    V_q = switch.vq(p["pol"], V_C, V3, V_s, k, p["R1"], p["R6"], p["R7"], rho)
    V_p = -p["R2"] * (V3 / p["R1"] - rho * V_q / p["R6"] + V_s / p["R7"])
    return (
        (V_s, V_C),
        [(V_s, -V_q / (p["R8"] * p["C1"])), (V_C, p["pol"] * V_p / (p["R3"] * p["C2"]))],
        V_q,
        V_p,
    )


def effective_system(design: Components, effects: Mapping[str, Any] | None = None) -> dict:
    """The mechanical system the switched-capacitor circuit realises between switchings.

    Between two switchings the circuit is linear in ``(V_s, V_C)``: its matrix ``A`` and its
    forcing column ``b`` follow from the same KCL as the model (:func:`switch.vq`, with the
    drawn parts of a ``tolerance`` effect and the switches' ``R_on``), exactly in rationals.
    ``omega^2 = det A`` and ``2 zeta omega = -tr A`` give the effective natural frequency and
    damping (``R_on`` adds about ``2 R_on / R3`` to ``2 zeta``); ``eta = Omega / omega``; the
    effective forcing ``a`` is the one whose mechanical response has the circuit's amplitude
    at ``Omega``; the wall stays ``-V_wall / V_unit``.  The same for either switch polarity.

    Parameters
    ----------
    design : Components
        The design values (the scene's).
    effects : mapping or None
        Effects of the model (``switch.ron`` and ``tolerance`` matter).

    Returns
    -------
    dict
        ``{"zeta", "eta", "a", "x_w", "omega", "ron_damping"}`` (floats; ``ron_damping`` is
        ``2 R_on / R3`` of the drawn R3, in ``2 zeta`` units).  Nominal parts without ``R_on``
        give the design's own parameters.
    """
    effects = validate_effects(effects, "switched-capacitor")
    comp = actual_components(design, effects)
    ron = effects.get("switch", {}).get("ron", Fraction(0))
    rho = comp.R5 / comp.R4
    k = switch.coupling(ron, comp.R2, comp.R3)

    def rhs(V_s: Fraction, V_C: Fraction, V3: Fraction) -> tuple[Fraction, Fraction]:
        V_q = switch.vq(1, V_C, V3, V_s, k, comp.R1, comp.R6, comp.R7, rho)
        V_p = -comp.R2 * (V3 / comp.R1 - rho * V_q / comp.R6 + V_s / comp.R7)
        return -V_q / (comp.R8 * comp.C1), V_p / (comp.R3 * comp.C2)

    (a11, a21), (a12, a22) = (
        rhs(Fraction(1), Fraction(0), Fraction(0)),
        rhs(Fraction(0), Fraction(1), Fraction(0)),
    )
    b = rhs(Fraction(0), Fraction(0), Fraction(1))
    A = np.array([[a11, a12], [a21, a22]], dtype=float)
    omega = float(a11 * a22 - a12 * a21) ** 0.5
    zeta = -float(a11 + a22) / (2 * omega)
    W = float(comp.Omega)
    eta = W / omega
    h = np.linalg.solve(1j * W * np.eye(2) - A, np.array([float(b[0]), float(b[1])]))
    amp_x = abs(h[0]) * float(comp.V_A) / float(design.V_unit)
    a = float(amp_x) * ((1 - eta**2) ** 2 + (2 * zeta * eta) ** 2) ** 0.5
    return {
        "zeta": zeta,
        "eta": eta,
        "a": a,
        "x_w": float(-comp.V_wall / design.V_unit),
        "omega": omega,
        "ron_damping": float(2 * ron / comp.R3),
    }


class _Comparator(ImpactRecorder):
    """Trip event (``V_s`` falls through ``v_trip``): toggles at once, or stops for a delayed
    toggle.

    The trip times are its :class:`~precise_impact.solvers.heyoka.events.ImpactRecorder` log
    (``t``), under the impact budget.  An immediate toggle also keeps the state at the trip
    (``V_s, V_C`` and the polarity before the flip) in :attr:`states`, from which the solver
    computes ``V_q`` just before and just after the reversal (the impact velocities).
    """

    def __init__(self) -> None:
        super().__init__()
        self.reset(True, 10**6)

    def reset(self, immediate: bool, max_impacts: int, rearm_at_flip: bool = True) -> None:
        self.immediate = immediate
        # Without hysteresis the comparator output drops as soon as V_s is back above
        # V_wall, which is right at the flip: an event root at the very start of the
        # next step would not be seen, so re-arm at the flip (no downward crossing can
        # follow before V_s has risen again, so nothing is tripped early).
        self.rearm_at_flip = rearm_at_flip
        self.armed = True
        self.reset_log(max_impacts)
        self.pending = False
        self.states: list = []

    def __call__(self, ta, d_sgn) -> bool:
        if not self.armed:
            return True
        self.armed = False
        if not self.record(ta.time):
            return False
        if self.immediate:
            # heyoka stopped at the trip: the state there, before the flip (copies)
            self.states.append((ta.state[0], ta.state[1], ta.pars[_I["pol"]]))
            ta.pars[_I["pol"]] = -ta.pars[_I["pol"]]
            self.armed = self.rearm_at_flip
            return True
        self.pending = True
        return False


class _Rearm:
    def __init__(self, comparator_index: int = 0) -> None:
        self.i = comparator_index

    def __call__(self, ta, d_sgn) -> bool:
        ta.t_events[self.i].callback.armed = True
        return True


_INTEGRATORS = IntegratorCache(
    "switched-capacitor"
)  # compiled once; every caller gets its own copy


def _build(P: Precision, tol):
    import heyoka as hy  # noqa: PLC0415 -- optional: heyoka loaded on first use (the module imports without it)

    key = (P.name, None if tol is None else P.to_str(tol))

    def compile_():
        (V_s, V_C), rhs, _, _ = _system()
        kw = P.heyoka_kwargs
        trip = hy.t_event(
            V_s - hy.par[_I["v_trip"]],
            callback=_Comparator(),
            direction=hy.event_direction.negative,
            fp_type=kw["fp_type"],
        )
        rearm = hy.t_event(
            V_s - hy.par[_I["v_rearm"]],
            callback=_Rearm(0),
            direction=hy.event_direction.positive,
            fp_type=kw["fp_type"],
        )
        zero = P.from_fraction(Fraction(0))
        extra = {"tol": tol} if tol is not None else {}
        ta = hy.taylor_adaptive(
            rhs,
            [zero, zero],
            pars=[zero] * len(PARS),
            t_events=[trip, rearm],
            compact_mode=P.kind == "mp",
            **extra,
            **kw,
        )
        return ta

    return _INTEGRATORS.get(key, compile_)


class SwitchedCapacitorSolver:
    """Comparator, flip-flop and analog switches reversing C2, at component level.

    Parameters
    ----------
    precision : str, default ``'float64'``
    tol : decimal or None, default ``None`` (the precision's epsilon)
    effects : mapping or None, default ``None``
        Effects fitting ``'switched-capacitor'``: ``comparator``, ``flipflop``,
        ``switch``, ``tolerance``
        (:data:`~precise_impact.models.circuit.effects.catalogue.EFFECTS`).
    max_impacts : int, default ``10**6``

    See Also
    --------
    precise_impact.models.circuit.opamp.CircuitSolver : the continuous op-amp circuit.
    precise_impact.solvers.base.Solver : the protocol it follows.
    """

    model_name = "switched-capacitor"

    def __init__(
        self,
        precision: str | Precision = "float64",
        tol: Any = None,
        effects: Mapping[str, Mapping[str, Any]] | None = None,
        max_impacts: int = 10**6,
    ) -> None:
        self.precision = Precision.parse(precision)
        self.effects = validate_effects(effects, "switched-capacitor")
        q = self.precision.check_tol(tol)
        self.tol = None if q is None else self.precision.from_fraction(q)
        self.max_impacts = check_count(max_impacts, "max_impacts", 10**9)
        sw = self.effects.get("switch", {})
        self.ron = sw.get("ron", Fraction(0))
        self.bbm = sw.get("bbm", Fraction(0))
        self.q_inj = sw.get("charge_injection", Fraction(0))
        self.slew = sw.get("slew_rate", Fraction(13 * 10**6))
        self.delay = comparator.delay(self.effects.get("comparator")) + flipflop.delay(
            self.effects.get("flipflop")
        )
        self.hyst = self.effects.get("comparator", {}).get("hysteresis", Fraction(0))

    def solve(
        self,
        params: Params | Components,
        periods: int,
        *,
        per_period: int = 0,
        x0: Any = None,
        v0: Any = None,
        t0: Any = None,
    ) -> Trajectory:
        """Simulate; samples at ``t0 + k 2 pi / Omega``, mapped to the dimensionless system.

        Impacts are recorded when the switches reconnect C2 (the velocity jump):
        ``impacts_t`` is that instant (dimensionless), ``v_before``/``v_after`` the
        mapped ``V_q`` just before the switches opened and just after they closed (with
        immediate switching, no delay, break-before-make or charge injection: just before
        and after the polarity flip at the comparator trip, so ``v_after = -v_before``
        when ``R_on = 0``: the ideal impact, R = 1).

        Parameters
        ----------
        params : Params or Components
            The system (the nominal design realising ``Params``) or a design of your own.
        periods : int
            Forcing periods.
        per_period : int, default 0
            Dense output points per period (``0``: none).
        x0, v0, t0 : decimal or None, default ``None``
            Dimensionless initial condition replacing the one of ``params``.

        Returns
        -------
        Trajectory
            In the dimensionless variables of ``dimensionless(design)``.

        Raises
        ------
        ParameterError
            Bad input, before any work.
        """
        design, x0, v0, t0 = design_and_start(params, x0, v0, t0)
        P = self.precision
        periods = check_count(periods, "periods")
        per_period = check_count(per_period, "per_period", 100_000)
        params = dimensionless(design, x0=x0, v0=v0, t0=t0)
        comp = actual_components(design, self.effects)
        omega = design_omega(design)
        rc, vu = design.R8 * design.C1, design.V_unit
        ta = _build(P, self.tol)
        pars = [getattr(comp, n) for n in NETWORK_PARS] + [
            Fraction(1),
            self.ron,
            *comparator.thresholds(comp.V_wall, self.effects.get("comparator")),
        ]
        ta.pars[:] = P.array([P.from_fraction(q) for q in pars])
        t0s, Vs0 = self._set_initial_state(ta, P, comp, params, omega, rc, vu)
        immediate = self.delay == 0 and self.bbm == 0 and self.q_inj == 0
        cmp_ = ta.t_events[0].callback
        cmp_.reset(immediate, self.max_impacts, rearm_at_flip=self.hyst == 0)
        if Vs0 <= pars[_I["v_trip"]]:
            raise ParameterError(
                "x0",
                str(params.x0),
                "the start must be outside the comparator threshold (x0 < x_w)",
            )
        step = max(per_period, 1)
        grid = P.sample_times(t0s, comp.Omega, periods, step)
        vq_fn = self._vq_function(P, comp)
        sw = self._switch_constants(P, comp)  # converted once per solve, not per switching
        start = _time.perf_counter()
        samples, switches = self._propagate(ta, grid, cmp_, immediate, sw, vq_fn)
        elapsed = _time.perf_counter() - start
        scales = (omega, rc, vu)
        return self._trajectory(
            P, params, comp, samples, switches, scales, step, per_period, elapsed, cmp_.count
        )

    def _set_initial_state(self, ta, P, comp, params, omega, rc, vu):
        """Time and state of ``ta`` at the start: ``V_s`` and ``V_C`` such that ``V_q`` (with
        ``pol = +1``) equals the mapped ``v0``; returns the start time and ``V_s``."""
        conv = P.from_fraction
        Vs0 = -params.x0 * vu
        Vq0 = params.v0 * omega * rc * vu
        t0s = params.t0 / omega
        k = switch.coupling(self.ron, comp.R2, comp.R3)
        rho = comp.R5 / comp.R4
        # V3(t0) enters only through R_on; exact cosine at t0 via mpmath (in a context of this
        # thread's own: mpmath's global precision is shared by every thread)
        mp = mp_context(P.bits + 32)
        c = mp.cos(
            mp.mpf(comp.Omega.numerator) / comp.Omega.denominator * t0s.numerator / t0s.denominator
        )
        V3 = (
            Fraction(mp.nstr(c * comp.V_A.numerator / comp.V_A.denominator, P.digits + 5))
            if k
            else Fraction(0)
        )
        VC0 = -(Vq0 * (1 + k * rho / comp.R6) - k * (V3 / comp.R1 + Vs0 / comp.R7))
        ta.time = conv(t0s)
        ta.state[:] = P.array([conv(Vs0), conv(VC0)])
        ta.reset_cooldowns()
        return t0s, Vs0

    def _propagate(self, ta, grid, cmp_, immediate: bool, sw: dict, vq_fn):
        """Integrate through the sample times, switching where the comparator trips: the samples
        ``(t, V_s, V_q)`` and the recorded reconnections of C2."""
        import heyoka as hy  # noqa: PLC0415 -- optional: heyoka loaded on first use (the module imports without it)

        samples = []
        switches = ImpactRecorder(max_impacts=self.max_impacts)  # the reconnections of C2
        pending_at = None
        for target in grid:
            while True:
                stop = target if pending_at is None or pending_at > target else pending_at
                if ta.time < stop:
                    oc = ta.propagate_until(stop)[0]
                else:
                    oc = hy.taylor_outcome.time_limit
                if cmp_.exceeded:
                    raise BudgetExceededError(
                        f"impact budget max_impacts={self.max_impacts} exhausted"
                    )
                if cmp_.pending:
                    cmp_.pending = False
                    pending_at = ta.time + sw["delay"]
                    continue
                if immediate and cmp_.count > switches.count:
                    # fast path: the callback flipped pol at the trip instant; V_q before and
                    # after from the state it kept there
                    new = zip(cmp_.t[switches.count :], cmp_.states[switches.count :], strict=True)
                    for tt, (Vs, VC, pol) in new:
                        switches.log(tt, vq_fn(tt, Vs, VC, pol), vq_fn(tt, Vs, VC, -pol))
                if pending_at is not None and ta.time == pending_at:
                    vb, va = self._switch(ta, sw, vq_fn)
                    switches.log(ta.time, vb, va)
                    pending_at = None
                    continue
                if oc != hy.taylor_outcome.time_limit and not (int(oc) < 0):
                    raise IntegrationError(f"heyoka stopped early: {oc}")
                break
            samples.append(
                (ta.time, ta.state[0], vq_fn(ta.time, ta.state[0], ta.state[1], ta.pars[_I["pol"]]))
            )
        return samples, switches

    def _trajectory(
        self, P, params, comp, samples, switches, scales, step, per_period, elapsed, trips
    ) -> Trajectory:
        """The samples and reconnections mapped to the dimensionless system, as a trajectory."""
        omega, rc, vu = scales
        conv = P.from_fraction
        om, rcv, vuv = conv(omega), conv(rc), conv(vu)
        tau = P.array([om * s[0] for s in samples])
        x = P.array([-s[1] / vuv for s in samples])
        v = P.array([s[2] / (om * rcv * vuv) for s in samples])
        # impact velocities: V_q just before the switches open and just after they close
        # (immediate switching: both at the trip, around the polarity flip)
        imp_t, imp_vb, imp_va = [], [], []
        for tt, vb, va in switches.rows():
            imp_t.append(om * tt)
            imp_vb.append(vb / (om * rcv * vuv))
            imp_va.append(va / (om * rcv * vuv))
        traj = Trajectory(
            params=params,
            model=self.model_name,
            precision=P,
            tol=self.tol if self.tol is not None else P.eps,
            t=tau[::step],
            x=x[::step],
            v=v[::step],
            impacts_t=P.array(imp_t),
            impacts_v_before=P.array(imp_vb),
            impacts_v_after=P.array(imp_va),
            elapsed_s=elapsed,
            stats={
                "effects": sorted(self.effects),
                "components": comp.decimal(),
                "comparator_trips": trips,
            },
        )
        if per_period > 0:
            traj.dense_t, traj.dense_x, traj.dense_v = tau, x, v
        return traj

    def _vq_function(self, P, comp):
        conv = P.from_fraction
        R1, R2, R3, R6, R7 = (conv(getattr(comp, n)) for n in ("R1", "R2", "R3", "R6", "R7"))
        rho = conv(comp.R5 / comp.R4)
        VA, Om = conv(comp.V_A), conv(comp.Omega)
        k = conv(switch.coupling(self.ron, comp.R2, comp.R3))
        ideal = self.ron == 0

        def vq(t, Vs, VC, pol):
            if ideal:
                return -pol * VC
            return switch.vq(pol, VC, VA * np.cos(Om * t), Vs, k, R1, R6, R7, rho)

        return vq

    def _switch_constants(self, P, comp) -> dict:
        """The constants of :meth:`_switch` in the working precision (each rounded once)."""
        conv = P.from_fraction
        c = {n: conv(getattr(comp, n)) for n in ("R1", "R2", "R6", "R7", "V_A", "Omega")}
        c.update(
            delay=conv(self.delay),
            bbm=conv(self.bbm),
            rho=conv(comp.R5 / comp.R4),
            slew=conv(self.slew),
            rc=conv(comp.R8 * comp.C1),
            dq=conv(switch.injected_voltage(self.q_inj, comp.C2)) if self.q_inj != 0 else None,
        )
        return c

    def _switch(self, ta, c: dict, vq_fn):
        """Break-before-make interval (closed form), polarity reversal, charge injection.

        ``c``: :meth:`_switch_constants`.
        """
        st = ta.state
        t_open = ta.time
        pol = ta.pars[_I["pol"]]
        vb = vq_fn(t_open, st[0], st[1], pol)
        if self.bbm > 0:
            tb = c["bbm"]
            V3 = c["V_A"] * np.cos(c["Omega"] * t_open)
            Vp = -c["R2"] * (V3 / c["R1"] - c["rho"] * vb / c["R6"] + st[0] / c["R7"])
            st[0] = switch.break_before_make(st[0], vb, Vp, tb, c["slew"], c["rc"])
            ta.time = t_open + tb
        ta.pars[_I["pol"]] = -pol
        cb = ta.t_events[0].callback
        if cb.rearm_at_flip:
            cb.armed = True
        if self.q_inj != 0:
            st[1] = st[1] + c["dq"]
        ta.reset_cooldowns()
        va = vq_fn(ta.time, st[0], st[1], -pol)
        return vb, va
