"""Circuit model, switched-capacitor model and coupled circuit against the mechanical reference."""

from __future__ import annotations

from fractions import Fraction

import mpmath
import numpy as np
import pytest

from precise_impact import ParameterError, Params, acceleration, simulate
from precise_impact.models.circuit.components import dimensionless, nominal_components
from precise_impact.models.circuit.coupled import (
    CIRCUIT_COUPLED_FORM,
    coupling_resistors,
    simulate_coupled_circuit,
)
from precise_impact.models.circuit.effects.tolerance import draw_components, e_series_round
from precise_impact.models.circuit.network import NETWORK_PARS, OpAmp
from precise_impact.models.circuit.opamp import CircuitSolver, circuit_system
from precise_impact.models.circuit.switched import SwitchedCapacitorSolver
from precise_impact.solvers.heyoka.coupled import simulate_coupled
from precise_impact.verification.metrics import sample_errors


def test_nominal_components_and_mapping_are_exact():
    p = Params.make(eta="0.712")
    c = nominal_components(p)
    assert (c.R1, c.R6, c.C1, c.Omega, c.V_wall) == (10000, 100000, Fraction(1, 10**7), 712, -2)
    assert dimensionless(c) == p


def _rhs_at(ops, values, pars, t):
    """Evaluate heyoka expressions in 300-bit MPFR (heyoka cfunc), returned as mpmath numbers."""
    import heyoka as hy

    from precise_impact import Precision

    P = Precision.parse("mp:300")
    f = hy.cfunc([e for _, e in ops], vars=[v for v, _ in ops], fp_type=hy.real, prec=300)
    conv = lambda z: P.from_mpf(z) if isinstance(z, mpmath.mpf) else P.from_fraction(Fraction(z))  # noqa: E731
    arr = lambda zs: np.array([conv(z) for z in zs], dtype=hy.real)  # noqa: E731
    out = f(arr(values), pars=arr(pars), time=conv(t))
    return [P.to_mpf(o) for o in out]


def test_ideal_network_is_the_mechanical_equation_and_the_printed_5b_is_not():
    """With ideal parts the network's flow, rescaled, is eq. (2a) exactly; the printed
    eq. (5b) sign (-R2/(R3 C2)) gives negative damping and stiffness instead.

    Independent check: evaluate the heyoka circuit rhs at random states in 300-bit
    arithmetic and compare with precise_impact.acceleration in mpmath (1e-60)."""
    p = Params.make(eta="0.712")
    c = nominal_components(p)
    vars_, rhs = circuit_system(OpAmp())
    assert len(vars_) == 2  # no effect: no extra state
    pars = [getattr(c, n) for n in NETWORK_PARS]
    rng = np.random.default_rng(1)
    with mpmath.workdps(80):
        w = mpmath.mpf(1000)
        for _ in range(5):
            x, v, tau = (mpmath.mpf(float(z)) for z in rng.uniform(-2, 2, 3))
            Vs, Vq, t = -x, v, tau / w  # x = -V_s, x' = V_q (omega R8 C1 = 1, V_unit = 1)
            dVs, dVq = _rhs_at(
                list(zip(vars_, [e for _, e in rhs], strict=True)), [Vs, Vq], pars[:-1], t
            )  # V_wall: event only
            # dx/dtau = -dV_s/dt / omega ; dv/dtau = dV_q/dt / omega
            assert abs(-dVs / w - v) < 1e-60
            acc = acceleration(tau, x, v, mpmath.mpf("0.712"), mpmath.mpf("0.05"), 1, mpmath.cos)
            assert abs(dVq / w - acc) < 1e-60
            # the printed (5b): dV_q/dt = -R2/(R3 C2)(V3/R1 - V_q/R6 + V_s/R7) = -(our dV_q/dt)
            printed = -dVq / w
            assert abs(printed - acc) > 1e-3 or abs(acc) < 1e-3


@pytest.mark.parametrize("precision, bound", [("float64", None), ("mp:256", 1e-60)])
def test_ideal_circuit_reproduces_the_mechanical_reference(precision, bound):
    """eta = 0.74 (period 3) over 100 periods: float64 within 10 eps t (the phase
    round-off bound of test_reference), mp:256 within 1e-60; same impacts."""
    p = Params.make(eta="0.74")
    tr = CircuitSolver(precision).solve(nominal_components(p), 100)
    ref = simulate(p, 100, precision=precision)
    b = bound if bound is not None else 10 * 2.2e-16 * float(ref.t[-1])
    assert max(sample_errors(tr, ref)) <= b
    assert tr.n_impacts == ref.n_impacts


@pytest.mark.parametrize("precision", ["float64", "mp:256"])
def test_switched_capacitor_without_effects_is_the_ideal_impact(precision):
    """Every effect off: reversing C2 flips V_q exactly (R = 1); chaotic eta = 0.712 over
    30 periods agrees with heyoka to the float64 chaos-amplified level (measured 1e-9)
    / 1e-60 in mp."""
    p = Params.make(eta="0.712")
    tr = SwitchedCapacitorSolver(precision).solve(nominal_components(p), 30)
    ref = simulate(p, 30, precision=precision)
    assert max(sample_errors(tr, ref)) <= (1e-7 if precision == "float64" else 1e-60)
    assert tr.n_impacts == ref.n_impacts


@pytest.mark.parametrize("precision", ["float64", "mp:128"])
def test_switched_capacitor_records_the_impact_velocities(precision):
    """Issue 27: every ``impacts_v_before`` was NaN (immediate switching logged only the trip
    instant).  Now V_q just before and after the flip: on the period-3 orbit (eta = 0.74,
    100 periods, 67 impacts) the same velocities as the mechanics within the phase round-off
    bound of the ideal-circuit test (10 eps t_end: each sample's time carries ~eps t of
    rounding, and |dv/dt| <= 1 + |x| + a = O(1) near the wall), and ``v_after = -v_before``
    exactly (R_on = 0: reversing C2 flips V_q, the ideal impact R = 1)."""
    p = Params.make(eta="0.74")
    tr = SwitchedCapacitorSolver(precision).solve(nominal_components(p), 100)
    ref = simulate(p, 100, precision=precision)
    P = tr.precision
    assert tr.n_impacts == ref.n_impacts == 67
    # exact values (P.to_mpf), not parsed at mpmath's global 53 bits: at mp:128 that rounding
    # would hide every difference below ~1e-16 and the bound below could never be seen
    vb = [P.to_mpf(v) for v in tr.impacts_v_before]
    vr = [P.to_mpf(v) for v in ref.impacts_v_before]
    va = [P.to_mpf(v) for v in tr.impacts_v_after]
    assert all(mpmath.isfinite(v) and v > 0 for v in vb)  # towards the wall at x_w = 2
    # a + b: the exact sum is 0 only for an exact negation, and a nonzero sum stays nonzero
    # when rounded (-b itself would be rounded to mpmath's global precision)
    assert all(a + b == 0 for a, b in zip(va, vb, strict=True))
    bound = 10 * mpmath.mpf(2) ** (-P.bits + 1) * mpmath.mpf(P.to_str(ref.t[-1]))
    assert max(abs(a - b) for a, b in zip(vb, vr, strict=True)) <= bound
    assert "null" not in tr.to_dict()


def test_switch_on_resistance_steady_state_closed_form():
    """R_on in series with C2: the non-impacting steady state (eta = 0.70, wall far away)
    equals the closed form of the linear switched-capacitor equations.

    Independent reference: with k = 2 R_on / R (all R equal, R2/R6 = 2 zeta) and tau =
    omega t, V_q = (-V_C + k (V_s + V3)) / (1 + 2 zeta k), dV_s/dtau = -V_q,
    dV_C/dtau = -V3 + 2 zeta V_q - V_s: u = Re[(i eta - A)^-1 b a] at tau = kT (mpmath).
    Tolerance 1e-9: transient exp(-zeta' t) ~ e^-300 gone, float64 phase round-off ~1e-12.
    About 2 R_on / R3 = 0.032 of extra damping in 2 zeta units (0.1 -> ~0.132)."""
    p = Params.make(eta="0.70", x_w="10")
    c = nominal_components(p)
    tr = SwitchedCapacitorSolver(effects={"switch": {"ron": "160"}}).solve(c, 600)
    with mpmath.workdps(30):
        z, eta, k = mpmath.mpf("0.05"), mpmath.mpf("0.7"), mpmath.mpf(2 * 160) / 10000
        c1, c2 = -1 / (1 + 2 * z * k), k / (1 + 2 * z * k)
        A = mpmath.matrix([[-c2, -c1], [2 * z * c2 - 1, 2 * z * c1]])
        b = mpmath.matrix([-c2, -1 + 2 * z * c2])
        U = mpmath.lu_solve(1j * eta * mpmath.eye(2) - A, b)
        Vs, VC = mpmath.re(U[0]), mpmath.re(U[1])
        x_ss, v_ss = -Vs, c1 * VC + c2 * Vs + c2
        # trace of A: the damping the switch adds, 2 zeta' = -trace
        assert abs(-(A[0, 0] + A[1, 1]) - (0.1 + 0.032)) < 0.004
    assert abs(float(tr.x[-1]) - float(x_ss)) < 1e-9 and abs(float(tr.v[-1]) - float(v_ss)) < 1e-9
    ideal = SwitchedCapacitorSolver().solve(c, 600)
    assert abs(float(ideal.x[-1]) - 102 / 53) < 1e-9  # the zeta = 0.05 steady state


def test_delays_shift_the_impact_and_hysteresis_moves_the_wall():
    """A comparator + flip-flop delay d lets x go past the wall by ~ v d omega before
    the reversal; hysteresis h moves the effective wall to x_w + h/2 (V_unit = 1 V)."""
    p = Params.make(eta="0.74")
    c = nominal_components(p)
    d = SwitchedCapacitorSolver(effects={"comparator": {"delay": "1e-6"}}).solve(
        c, 60, per_period=400
    )
    assert d.dense_x.max() > 2.0  # beyond the wall during the delay
    vmax = max(abs(float(v)) for v in d.dense_v)
    assert float(d.dense_x.max()) - 2.0 < vmax * 1e-6 * 1000 * 1.01  # v * delay * omega
    h = SwitchedCapacitorSolver(effects={"comparator": {"hysteresis": "0.02"}}).solve(
        c, 60, per_period=400
    )
    assert abs(float(h.dense_x.max()) - 2.01) < 2e-3


def test_effect_off_costs_nothing():
    """No effects: the same number of states, events and Taylor steps as the mechanical model."""
    p = Params.make(eta="0.712")
    tr = CircuitSolver().solve(nominal_components(p), 200)
    ref = simulate(p, 200)
    assert abs(tr.stats["steps"] - ref.stats["steps"]) <= 0.02 * ref.stats["steps"]


@pytest.mark.parametrize(
    "effect", ["opamp_gain", "opamp_offset", "opamp_gbw", "opamp_saturation", "tolerance"]
)
def test_each_op_amp_effect_changes_the_result_boundedly(effect):
    p = Params.make(eta="0.74")
    c = nominal_components(p)
    ref = simulate(p, 60)
    tr = CircuitSolver(
        effects={effect: {"v_sat": "1.9"} if effect == "opamp_saturation" else {}}
    ).solve(c, 60)
    err = max(sample_errors(tr, ref))
    assert 1e-9 < err < 3, err


def test_dynamic_gbw_is_stiff_but_consistent_with_quasi_static():
    """Dynamic single-pole op-amps: ~1e4 Taylor steps per period (the cost of the stiff
    closed-loop poles at ~GBW/N) and, after one period, within 1e-3 of the
    quasi-static reduction (which is first order in tau = N / (2 pi GBW) ~ 1e-7 s)."""
    p = Params.make(eta="0.74")
    c = nominal_components(p)
    dyn = CircuitSolver(effects={"opamp_gbw": {"mode": "dynamic"}}).solve(c, 1)
    qs = CircuitSolver(effects={"opamp_gbw": {}}).solve(c, 1)
    assert dyn.stats["steps"] > 5000
    assert (
        abs(float(dyn.x[-1]) - float(qs.x[-1])) < 1e-3
        and abs(float(dyn.v[-1]) - float(qs.v[-1])) < 1e-3
    )


def test_tolerance_draws_are_seeded_and_within_tolerance():
    """Seeded (same seed, same parts), each part within its band around the E-series value."""
    c = nominal_components(Params.make())
    a = draw_components(c, {"resistor_pct": "1", "capacitor_pct": "5", "seed": 3})
    assert a == draw_components(c, {"resistor_pct": "1", "capacitor_pct": "5", "seed": 3})
    assert a != draw_components(c, {"resistor_pct": "1", "capacitor_pct": "5", "seed": 4})
    for n in ("R1", "R6", "C1"):
        series, tol = ("E96", Fraction(1, 100)) if n.startswith("R") else ("E24", Fraction(5, 100))
        nominal = e_series_round(getattr(c, n), series)
        assert abs(getattr(a, n) / nominal - 1) <= tol * (
            1 + Fraction(1, 10**5)
        )  # 6-digit rounding
    assert e_series_round(Fraction(100000), "E96") == 100000


def test_coupled_circuit_realises_the_printed_14a():
    """Fig. 3 with eq. (15) resistors = the printed (14a) ('paper' form) to round-off:
    mp:200 within 1e-50 over 40 chaotic periods; not the reduction of (12)."""
    p = Params.make(eta="0.712")
    c = nominal_components(p)
    assert CIRCUIT_COUPLED_FORM == "paper"
    R31, R32 = coupling_resistors(c, Fraction(1, 20), p.zeta)
    assert (c.R3 / R31, c.R3 / R32) == (Fraction(1, 10), Fraction(1, 20) * Fraction(11, 10))
    r = simulate_coupled_circuit(c, "0.05", 40, y0=("0.5", "0"), precision="mp:200")
    m = simulate_coupled(p, "0.05", "paper", 40, y0=("0.5", "0"), precision="mp:200")
    P = m.precision
    with mpmath.workprec(250):
        assert max(abs(P.to_mpf(a) - P.to_mpf(b)) for a, b in zip(r["y"], m.y, strict=True)) < 1e-50
        red = simulate_coupled(p, "0.05", "reduced", 40, y0=("0.5", "0"), precision="mp:200")
        assert (
            max(abs(P.to_mpf(a) - P.to_mpf(b)) for a, b in zip(r["y"], red.y, strict=True)) > 1e-3
        )


def test_component_validation():
    with pytest.raises(ParameterError) as e:
        nominal_components(Params.make()).replace(R3="-5")
    assert e.value.name == "R3"
    with pytest.raises(ParameterError) as e:
        dimensionless(nominal_components(Params.make()).replace(R2="10001"))
    assert "omega^2" in str(e.value)
    with pytest.raises(ParameterError) as e:
        CircuitSolver(effects={"switch": {}})
    assert e.value.name == "effects.switch"
    with pytest.raises(ParameterError) as e:
        SwitchedCapacitorSolver(effects={"comparator": {"delay": "-1"}})
    assert e.value.name == "effects.comparator.delay"


@pytest.mark.parametrize(
    "R, zeta, names",
    [("1e-11", "0.05", "R"), ("10e3", "2.6245623987117068e-98", "zeta"), ("1e14", "0.05", "R")],
)
def test_designs_outside_the_integrable_range_are_refused_naming_the_input(R, zeta, names):
    """Found by the scene fuzzer: R = 1e-11 ohm (omega = 1e18 rad/s: Taylor coefficients ~omega^20
    overflow float64, heyoka stopped with a NaN step) and zeta = 2.6e-98 (R6 = R/(2 zeta) out of
    range, refused without naming zeta) are refused before work, naming what the caller gave."""
    from precise_impact import Params, nominal_components
    from precise_impact.errors import ParameterError

    with pytest.raises(ParameterError) as e:
        nominal_components(Params.make(eta="0.712", zeta=zeta), R=R)
    assert names in e.value.name.split(", ") or names in str(e.value)


@pytest.mark.parametrize("model", ["circuit", "switched-capacitor", "spice"])
def test_circuits_refuse_a_restitution_they_do_not_realise(model):
    """Every circuit reverses V_q with unit gain at the wall: R = 1. Asked for R = 0.8, the
    circuit and the switched-capacitor model ran R = 1 silently (10 periods at eta = 0.74:
    0.44 from the R = 0.8 mechanics in x, 1.3e-14 from R = 1); now R is refused by name
    before any work, in the one place Params become a design (nominal_components)."""
    with pytest.raises(ParameterError, match=r"R = '0\.8' is not allowed: R = 1 for the circuits"):
        simulate(Params.make(eta="0.74", R="0.8"), model=model, periods=2)


def test_the_cli_refuses_a_circuit_at_r_below_one(capsys):
    from precise_impact.cli.main import main

    assert main(["simulate", "--model", "circuit", "--R", "0.8", "--periods", "2"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "R = '0.8'" in err[0], err
