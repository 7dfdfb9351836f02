"""The coupled circuit of Fig. 3: two networks, difference amplifiers U15/U16, R31 and R32.

With the paper's eq. (15) resistors it realises the printed eq. (14a) (the ``'paper'`` form),
not the reduction of eqs. (12); ``docs/circuit.rst``.
"""

from __future__ import annotations

import dataclasses
import time as _time
from fractions import Fraction
from typing import Any

import numpy as np

from precise_impact.core.digits import Digits, max_digits
from precise_impact.core.impact import reset_velocity
from precise_impact.core.params import Params, check_count
from precise_impact.core.precision import Precision
from precise_impact.core.result import ResultMixin, columns
from precise_impact.errors import BudgetExceededError, ParameterError
from precise_impact.io.figures import CoupledPlotMixin
from precise_impact.models.circuit.components import Components, dimensionless, nominal_components
from precise_impact.models.circuit.network import NETWORK_PARS
from precise_impact.models.circuit.opamp import design_omega
from precise_impact.solvers.base import PRECISION_KINDS, Capabilities, register_coupled_model
from precise_impact.solvers.heyoka.cache import IntegratorCache
from precise_impact.solvers.heyoka.coupled import check_k
from precise_impact.solvers.heyoka.events import ImpactRecorder

__all__ = [
    "coupling_resistors",
    "simulate_coupled_circuit",
    "CoupledCircuitTrajectory",
    "CIRCUIT_COUPLED_FORM",
]

#: The coupled form the Fig. 3 circuit realises.
CIRCUIT_COUPLED_FORM = "paper"
PARS = NETWORK_PARS + ("R31", "R32")
_I = {n: i for i, n in enumerate(PARS)}
#: Impact budget per oscillator (the integration stops there: ``BudgetExceededError``).
_MAX_IMPACTS = 10**7


def coupling_resistors(
    design: Components, k: Fraction, zeta: Fraction
) -> tuple[Fraction, Fraction]:
    """Eq. (15): ``R31 = R3 / (2k)``, ``R32 = R3 / (k (1 + 2 zeta))`` (k > 0)."""
    return design.R3 / (2 * k), design.R3 / (k * (1 + 2 * zeta))


class _Impact(ImpactRecorder):
    """Comparator event callback of one oscillator (state indices ``s``, ``q``): the
    impact law on ``V_q`` (R = 1), recorded with a budget of 10**7 impacts."""

    def __init__(self, s: int, q: int) -> None:
        super().__init__(max_impacts=_MAX_IMPACTS)
        self.s, self.q = s, q

    def reset(self) -> None:
        self.reset_log(_MAX_IMPACTS)

    def __call__(self, ta, d_sgn) -> bool:
        st = ta.state
        vb = st[self.q]
        va = reset_velocity(vb, 1 + 0 * vb)
        st[self.q] = va
        st[self.s] = ta.pars[_I["V_wall"]]
        return self.record(ta.time, vb, va)


_INTEGRATORS = IntegratorCache("coupled-circuit")  # compiled once; every caller gets its own copy


def _build(P: Precision):
    import heyoka as hy  # noqa: PLC0415 -- optional: heyoka loaded on first use (the module imports without it)

    def compile_():
        p = {n: hy.par[i] for i, n in enumerate(PARS)}
        Vs1, Vq1, Vs2, Vq2 = hy.make_vars("V_s1", "V_q1", "V_s2", "V_q2")
        V3 = p["V_A"] * hy.cos(p["Omega"] * hy.time)
        rho = p["R5"] / p["R4"]

        def vp(Vs, Vq, extra):
            return -p["R2"] * (V3 / p["R1"] - rho * Vq / p["R6"] + Vs / p["R7"] + extra)

        Vd = Vs2 - Vs1  # U15
        Ve = Vq1 - Vq2  # U16
        rhs = [
            (Vs1, -Vq1 / (p["R8"] * p["C1"])),
            (Vq1, -vp(Vs1, Vq1, 0.0) / (p["R3"] * p["C2"])),
            (Vs2, -Vq2 / (p["R8"] * p["C1"])),
            (Vq2, -vp(Vs2, Vq2, Vd / p["R31"] + Ve / p["R32"]) / (p["R3"] * p["C2"])),
        ]
        kw = P.heyoka_kwargs
        evs = [
            hy.t_event(
                Vs1 - p["V_wall"],
                callback=_Impact(0, 1),
                direction=hy.event_direction.negative,
                fp_type=kw["fp_type"],
            ),
            hy.t_event(
                Vs2 - p["V_wall"],
                callback=_Impact(2, 3),
                direction=hy.event_direction.negative,
                fp_type=kw["fp_type"],
            ),
        ]
        zero = P.from_fraction(Fraction(0))
        ta = hy.taylor_adaptive(
            rhs,
            [zero] * 4,
            pars=[zero] * len(PARS),
            t_events=evs,
            compact_mode=P.kind == "mp",
            **kw,
        )
        return ta

    return _INTEGRATORS.get(P.name, compile_)


def simulate_coupled_circuit(
    design: Components,
    k: Any,
    periods: int,
    x0=0,
    v0=0,
    y0=(0, 0),
    t0=0,
    per_period: int = 0,
    precision: str = "float64",
    zeta: Fraction | None = None,
    actual: Components | None = None,
) -> CoupledCircuitTrajectory:
    """Simulate the paper's Fig. 3 circuit: two coupled op-amp oscillators.

    Parameters
    ----------
    design : Components
        The design (read-out: dimensionless ``x``, ``v`` from the node voltages).
    k : decimal
        Coupling ``k >= 0`` (realised by the coupling resistors of eq. 15).
    periods : int
        Forcing periods, ``>= 1``.
    x0, v0 : decimal, default 0
        Master's dimensionless initial state.
    y0 : pair of decimal, default ``(0, 0)``
        Slave's ``(y, y')``.
    t0 : decimal, default 0
        Initial time.
    per_period : int, default 0
        Dense samples per period (``<= 100000``).
    precision : str, default ``'float64'``
        ``'float64'``, ``'longdouble'``, ``'float128'`` or ``'mp:BITS'``.
    zeta : Fraction or None, default ``None``
        Damping used in eq. 15; ``None`` is the design's own damping.
    actual : Components or None, default ``None``
        Simulated component values (e.g. a tolerance draw; both oscillators share
        it), read out through ``design``; ``None`` simulates ``design`` itself.

    Returns
    -------
    CoupledCircuitTrajectory
        Dimensionless samples ``t, x, v, y, w`` and the impacts of both oscillators.

    Raises
    ------
    ParameterError
        Bad input, before any work.

    See Also
    --------
    precise_impact.solvers.heyoka.coupled.simulate_coupled : the mechanical master-slave pair.

    References
    ----------
    .. [1] V. Denysenko, M. Balcerzak, A. Dabrowski, "Electronic equivalent of a
           mechanical impact oscillator", Fig. 3 and eq. (15).

    Examples
    --------
    >>> import precise_impact as pi
    >>> c = pi.nominal_components(pi.Params.make(eta="0.74"))
    >>> tr = pi.simulate_coupled_circuit(c, "0.1", 3)
    >>> tr.x.shape, tr.y.shape
    ((4,), (4,))
    """

    P = Precision.parse(precision)
    k = check_k(k)
    periods = check_count(periods, "periods")
    per_period = check_count(per_period, "per_period", 100_000)
    params = dimensionless(design, x0=x0, v0=v0, t0=t0)
    Params.make(
        **{**params.decimal(), "x0": y0[0], "v0": y0[1]}
    )  # slave start validated like the master's
    zeta = params.zeta if zeta is None else zeta
    R31, R32 = (
        coupling_resistors(design, k, zeta) if k > 0 else (Fraction(10) ** 30, Fraction(10) ** 30)
    )
    omega = design_omega(design)
    rc, vu = design.R8 * design.C1, design.V_unit
    conv = P.from_fraction
    ta = _build(P)
    sim = design if actual is None else actual
    ta.pars[:] = P.array([conv(getattr(sim, n)) for n in NETWORK_PARS] + [conv(R31), conv(R32)])
    y, w = Fraction(y0[0]), Fraction(y0[1])
    state = [-params.x0 * vu, params.v0 * omega * rc * vu, -y * vu, w * omega * rc * vu]
    ta.time = conv(params.t0 / omega)
    ta.state[:] = P.array([conv(s) for s in state])
    ta.reset_cooldowns()
    for ev in ta.t_events:
        ev.callback.reset()
    step = max(per_period, 1)
    grid = P.array(P.sample_times(params.t0 / omega, design.Omega, periods, step))
    t_start = _time.perf_counter()
    res = ta.propagate_grid(grid)
    elapsed = _time.perf_counter() - t_start
    import heyoka as hy  # noqa: PLC0415 -- optional: heyoka loaded on first use (the module imports without it)

    if res[0] != hy.taylor_outcome.time_limit:
        raise BudgetExceededError(f"coupled circuit stopped early: {res[0]}")
    st = np.asarray(res[-1])
    om, rcv, vuv = conv(omega), conv(rc), conv(vu)
    scale = om * rcv * vuv
    return CoupledCircuitTrajectory(
        **{
            "t": P.array([om * t for t in grid])[::step],
            "x": P.array([-s / vuv for s in st[:, 0]])[::step],
            "v": P.array([q / scale for q in st[:, 1]])[::step],
            "y": P.array([-s / vuv for s in st[:, 2]])[::step],
            "w": P.array([q / scale for q in st[:, 3]])[::step],
            "master_impacts_t": P.array([om * t for t in ta.t_events[0].callback.t]),
            "slave_impacts_t": P.array([om * t for t in ta.t_events[1].callback.t]),
            "elapsed_s": elapsed,
            "precision": P,
            "params": params,
            "R31": R31,
            "R32": R32,
        }
    )


@dataclasses.dataclass
class CoupledCircuitTrajectory(CoupledPlotMixin, ResultMixin):
    """What :func:`simulate_coupled_circuit` returns (dimensionless, read out through the design).

    Attributes
    ----------
    t, x, v, y, w : numpy.ndarray
        Samples at the forcing period: time, master (x, x'), slave (y, y').
    master_impacts_t, slave_impacts_t : numpy.ndarray
        Impact times (dimensionless).
    elapsed_s : float
        Integration wall time.
    precision : Precision
    params : Params
        The dimensionless parameters of the design.
    R31, R32 : Fraction
        The coupling resistors of eq. (15).

    See Also
    --------
    precise_impact.models.circuit.coupled.simulate_coupled_circuit : returns it.
    precise_impact.solvers.heyoka.coupled.CoupledTrajectory : the mechanical pair's result.
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    y: np.ndarray
    w: np.ndarray
    master_impacts_t: np.ndarray
    slave_impacts_t: np.ndarray
    elapsed_s: float
    precision: Precision
    params: Params
    R31: Fraction
    R32: Fraction
    claim: Digits | None = dataclasses.field(default=None, repr=False, compare=False)

    def claimed_digits(self) -> Digits:
        """Significant digits per sample: ``'demonstrated'`` after
        ``simulate_coupled(..., demonstrate=...)``; otherwise none (the circuit pair records
        no impact velocities, so its error amplification cannot be estimated)."""
        if self.claim is None:
            z = np.zeros(len(self.t), dtype=int)
            self.claim = Digits(
                "estimated",
                z,
                z.copy(),
                max_digits(self.precision),
                "the circuit pair records no impact velocities: no digit can be estimated "
                "(demonstrate=True claims the digits a second precision agrees on)",
                y=z.copy(),
                w=z.copy(),
            )
        return self.claim

    def _tables(self) -> dict:
        """``to_dataframe()`` tables: ``samples`` (default), ``impacts`` (``who``: master or
        slave), mapped to the dimensionless system."""
        P = self.precision

        def impacts() -> dict:
            who = ["master"] * len(self.master_impacts_t) + ["slave"] * len(self.slave_impacts_t)
            t = list(self.master_impacts_t) + list(self.slave_impacts_t)
            return columns(("who", None, who), ("t", "1", t), precision=P)

        return {
            "samples": lambda: columns(
                ("period", None, np.arange(len(self.t))),
                *((n, "1", getattr(self, n)) for n in ("t", "x", "v", "y", "w")),
                precision=P,
            ),
            "impacts": impacts,
        }


class CircuitCoupledSolver:
    """The Fig. 3 op-amp pair as a coupled model (``model='circuit'``, ``form='paper'``).

    The nominal design realising ``params``
    (:func:`~precise_impact.models.circuit.components.nominal_components`) simulated by
    :func:`simulate_coupled_circuit`; the slave starts at ``y0`` (``None``: the master's start).

    Parameters
    ----------
    precision : Precision
        Working precision.
    """

    model_name = "circuit"

    def __init__(self, precision: Precision) -> None:
        self.precision = precision

    def solve(
        self,
        params: Params,
        k: Any,
        periods: int,
        *,
        form: str = CIRCUIT_COUPLED_FORM,
        y0: Any = None,
        per_period: int = 0,
    ) -> CoupledCircuitTrajectory:
        """Simulate the circuit pair (:func:`~precise_impact.simulate_coupled`)."""
        if form != CIRCUIT_COUPLED_FORM:
            raise ParameterError("form", form, f"{CIRCUIT_COUPLED_FORM!r} for the circuit model")
        return simulate_coupled_circuit(
            nominal_components(params),
            k,
            periods,
            x0=params.x0,
            v0=params.v0,
            y0=(params.x0, params.v0) if y0 is None else y0,
            t0=params.t0,
            per_period=per_period,
            precision=self.precision.name,
        )


def _coupled_circuit(prec: Precision, tol: Any, **options: Any) -> CircuitCoupledSolver:
    return CircuitCoupledSolver(prec, **options)


register_coupled_model(
    "circuit",
    "the Fig. 3 op-amp pair of the nominal design ('paper' form, R = 1)",
    _coupled_circuit,
    Capabilities(
        PRECISION_KINDS,
        tolerance=False,
        forms=(CIRCUIT_COUPLED_FORM,),
        note="the circuit integrates at the precision's epsilon",
    ),
)
