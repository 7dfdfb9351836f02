"""The ``circuit`` model: the op-amp network with the mechanical impact law applied to ``V_q``.

Results are read out through the design components, as an experimenter reads the circuit.
"""

from __future__ import annotations

import time as _time
from collections.abc import Mapping
from fractions import Fraction
from typing import Any

import numpy as np

from precise_impact.core.impact import reset_velocity
from precise_impact.core.mpcontext import mp_context
from precise_impact.core.params import Params, check_count
from precise_impact.core.precision import Precision
from precise_impact.core.trajectory import Trajectory
from precise_impact.errors import BudgetExceededError, IntegrationError
from precise_impact.models.circuit.components import (
    Components,
    design_and_start,
    dimensionless,
)
from precise_impact.models.circuit.components import (
    exact_omega as dimensionless_omega,
)
from precise_impact.models.circuit.effects.catalogue import validate_effects
from precise_impact.models.circuit.effects.tolerance import actual_components
from precise_impact.models.circuit.network import (
    NETWORK_PARS,
    OpAmp,
    dynamic_network,
    network_rhs,
    opamp_from_effects,
    saturation_events,
)
from precise_impact.solvers.heyoka.cache import IntegratorCache
from precise_impact.solvers.heyoka.events import ImpactRecorder

__all__ = ["CircuitSolver", "circuit_system", "design_omega"]


def design_omega(design: Components) -> Fraction:
    """The design's natural angular frequency, exact (the mapping needs it rational)."""
    return dimensionless_omega(design)


_IDX = {n: i for i, n in enumerate(NETWORK_PARS)}


def circuit_system(op: OpAmp):
    """heyoka variables and right-hand sides of the network for ``op`` (runtime component
    parameters)."""
    import heyoka as hy  # noqa: PLC0415 -- optional: heyoka loaded on first use (the module imports without it)

    p = {n: hy.par[i] for i, n in enumerate(NETWORK_PARS)}
    if op.dynamic:
        return dynamic_network(hy, p, op)
    V_s, V_q = hy.make_vars("V_s", "V_q")
    dVs, dVq, _ = network_rhs(hy, p, V_s, V_q, op)
    return [V_s, V_q], [(V_s, dVs), (V_q, dVq)]


class _Impact(ImpactRecorder):
    """Comparator event callback: the mechanical impact law applied to ``V_q``
    (recorded by :class:`~precise_impact.solvers.heyoka.events.ImpactRecorder`)."""

    def __init__(self, dynamic: bool) -> None:
        super().__init__()
        self.dynamic = dynamic
        self.reset(10**6)

    def reset(self, max_impacts: int) -> None:
        self.reset_log(max_impacts)

    def __call__(self, ta, d_sgn) -> bool:
        st = ta.state
        vb = st[1]
        va = reset_velocity(vb, 1 + 0 * vb)  # the circuit realises R = 1
        if self.dynamic:  # keep U2's inverting node where it was: Vc2 = v- - V_q
            st[5] = (vb + st[5]) - va
        st[1] = va
        st[0] = ta.pars[_IDX["V_wall"]]
        return self.record(ta.time, vb, va)


_INTEGRATORS = IntegratorCache("circuit")  # compiled once; every caller gets its own copy


def _build(precision: Precision, tol, op: OpAmp):
    import heyoka as hy  # noqa: PLC0415 -- optional: heyoka loaded on first use (the module imports without it)

    key = (precision.name, None if tol is None else precision.to_str(tol), op)

    def compile_():
        vars_, rhs = circuit_system(op)
        kw = precision.heyoka_kwargs
        ev = hy.t_event(
            vars_[0] - hy.par[_IDX["V_wall"]],
            callback=_Impact(op.dynamic),
            direction=hy.event_direction.negative,
            fp_type=kw["fp_type"],
        )
        sat = []
        if not op.dynamic and op.v_sat is not None:
            _, _, alg = network_rhs(
                hy, {n: hy.par[i] for i, n in enumerate(NETWORK_PARS)}, vars_[0], vars_[1], op
            )
            sat = saturation_events(
                hy,
                op,
                alg["unclamped"],
                kw["fp_type"],
                precision.from_fraction(Fraction(1, 10**12)),
            )
        zero = precision.from_fraction(Fraction(0))
        extra = {"tol": tol} if tol is not None else {}
        ta = hy.taylor_adaptive(
            rhs,
            [zero] * len(vars_),
            pars=[zero] * len(NETWORK_PARS),
            t_events=[ev] + sat,
            compact_mode=precision.kind == "mp" or op.dynamic,
            **extra,
            **kw,
        )
        return ta

    return _INTEGRATORS.get(key, compile_)


class CircuitSolver:
    """The op-amp network with component values, integrated by heyoka in volts and seconds.

    Parameters
    ----------
    precision : str, default ``'float64'``
    tol : decimal or None, default ``None`` (the precision's epsilon)
    effects : mapping or None, default ``None``
        ``{name: {setting: value}}`` from
        :data:`~precise_impact.models.circuit.effects.catalogue.EFFECTS` that fit model
        ``'circuit'`` (op-amp gain, GBW, saturation, offset; component tolerance).
    max_impacts : int, default ``10**6``

    See Also
    --------
    precise_impact.models.circuit.components.Components : its component values.
    precise_impact.models.circuit.switched.SwitchedCapacitorSolver : the switched-capacitor circuit.
    precise_impact.models.circuit.spice.SpiceSolver : the same circuit in ngspice.
    """

    model_name = "circuit"

    def __init__(
        self,
        precision: str | Precision = "float64",
        tol: Any = None,
        effects: Mapping[str, Mapping[str, Any]] | None = None,
        max_impacts: int = 10**6,
    ) -> None:
        self.precision = Precision.parse(precision)
        self.effects = validate_effects(effects, "circuit")
        self.op = opamp_from_effects(self.effects)
        q = self.precision.check_tol(tol)
        self.tol = None if q is None else self.precision.from_fraction(q)
        self.max_impacts = check_count(max_impacts, "max_impacts", 10**9)

    def actual_components(self, design: Components) -> Components:
        """The components simulated: ``design``, or its tolerance draw if that effect is on."""
        return actual_components(design, self.effects)

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
        """Simulate ``periods`` forcing periods; samples at ``t0 + k 2 pi / Omega`` (seconds).

        ``x0, v0, t0`` are dimensionless (mapped through the design components).
        ``stats`` of the result holds the circuit-level arrays.

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
        comp = self.actual_components(design)
        ta = _build(P, self.tol, self.op)
        ta.pars[:] = P.array([P.from_fraction(getattr(comp, n)) for n in NETWORK_PARS])
        omega = design_omega(design)
        rc, vu = design.R8 * design.C1, design.V_unit
        Vs0 = -params.x0 * vu
        Vq0 = params.v0 * omega * rc * vu
        t0s = params.t0 / omega
        state = [Vs0, Vq0]
        if self.op.dynamic:
            # consistent op-amp states: ideal stage outputs, virtual grounds at 0
            mp = mp_context(P.bits + 32)  # this thread's own: the global precision is shared
            om_t0 = mp.mpf(comp.Omega.numerator) / comp.Omega.denominator * t0s.numerator
            om_t0 = om_t0 / t0s.denominator
            V3 = Fraction(
                mp.nstr(comp.V_A.numerator * mp.cos(om_t0) / comp.V_A.denominator, P.digits + 5)
            )
            Vmq0 = -(comp.R5 / comp.R4) * Vq0
            Vp0 = -comp.R2 * (V3 / comp.R1 + Vmq0 / comp.R6 + Vs0 / comp.R7)
            state += [Vp0, Vmq0, -Vs0, -Vq0]
        ta.time = P.from_fraction(t0s)
        ta.state[:] = P.array([P.from_fraction(s) for s in state])
        ta.reset_cooldowns()
        rec = ta.t_events[0].callback
        rec.reset(self.max_impacts)
        step = max(per_period, 1)
        grid = P.array(P.sample_times(t0s, comp.Omega, periods, step))
        start = _time.perf_counter()
        res = ta.propagate_grid(grid)
        elapsed = _time.perf_counter() - start
        import heyoka as hy  # noqa: PLC0415 -- optional: heyoka loaded on first use (the module imports without it)

        if rec.exceeded:
            raise BudgetExceededError(f"impact budget max_impacts={self.max_impacts} exhausted")
        if res[0] != hy.taylor_outcome.time_limit:
            raise IntegrationError(f"heyoka stopped early: {res[0]}")
        states = np.asarray(res[-1])
        conv = P.from_fraction
        om, rcv, vuv = conv(omega), conv(rc), conv(vu)

        # readout (numpy arrays elementwise; object arrays for float128 / mp)
        scale = om * rcv * vuv
        tau, x, v = om * grid, -states[:, 0] / vuv, states[:, 1] / scale
        imp_t = P.array([om * t for t in rec.t])
        imp_vb = P.array([vb / (om * rcv * vuv) for vb in rec.v_before])
        imp_va = P.array([va / (om * rcv * vuv) for va in rec.v_after])
        traj = Trajectory(
            params=params,
            model=self.model_name,
            precision=P,
            tol=self.tol if self.tol is not None else P.eps,
            t=tau[::step],
            x=x[::step],
            v=v[::step],
            impacts_t=imp_t,
            impacts_v_before=imp_vb,
            impacts_v_after=imp_va,
            elapsed_s=elapsed,
            stats={
                "steps": int(res[3]),
                "effects": sorted(self.effects),
                "components": comp.decimal(),
            },
        )
        if per_period > 0:
            traj.dense_t, traj.dense_x, traj.dense_v = tau, x, v
        return traj
