"""The ngspice backend (precise_impact.models.circuit.spice) against the heyoka reference.

Tests that run ngspice are skipped when it is not installed; netlist generation,
validation, the E-series/tolerance draws and the missing-ngspice error run
everywhere.  Error figures and timings against TMAX:
benchmarks/results/spice_tmax.md (benchmarks/bench_spice.py).
"""

from __future__ import annotations

import math
import re
import shutil
from fractions import Fraction

import numpy as np
import pytest

from precise_impact import HeyokaSolver, ParameterError, Params, steady_state
from precise_impact.models.circuit.components import nominal_components
from precise_impact.models.circuit.effects.catalogue import DATASHEET_SWITCH
from precise_impact.models.circuit.spice import (
    E24,
    E96,
    NgspiceNotFoundError,
    SpiceError,
    draw_components,
    e_series_round,
    run_spice,
    spice_netlist,
)

needs_ngspice = pytest.mark.skipif(
    shutil.which("ngspice") is None,
    reason="ngspice not installed: apt-get install ngspice; CI installs it",
)

P074 = Params.make(eta="0.74")
COMP074 = nominal_components(P074)


# ------------------------------------------------------------------ accuracy
@needs_ngspice
def test_period3_steady_state_matches_heyoka():
    """eta = 0.74, ideal parts, TMAX = 10 us: last 30 of 150 samples within 0.01.

    Measured max error 2.0e-3 (gear/BDF2 truncation error dominates, see
    spice_tmax.md); the impact sequence is the reference's, impact by impact.
    """
    n = 150
    res = run_spice(COMP074, None, n, tmax=10e-6)
    ref = HeyokaSolver("float64").solve(P074, n)
    assert res.t.shape == (n + 1,)
    np.testing.assert_allclose(res.t, np.asarray(ref.t, dtype=float), rtol=1e-14, atol=1e-12)
    ex = np.abs(res.x - np.asarray(ref.x, dtype=float))[-30:]
    ev = np.abs(res.v - np.asarray(ref.v, dtype=float))[-30:]
    assert ex.max() < 0.01 and ev.max() < 0.01, (ex.max(), ev.max())
    assert res.n_impacts == ref.n_impacts
    ref_imp = np.asarray(ref.impacts_t, dtype=float)
    assert np.abs(res.impacts_t - ref_imp).max() < 1e-3
    # the circuit reverses within ~1 ns of the wall crossing: tiny overshoot, R = 1
    assert np.all(np.abs(res.impacts_x - 2) < 1e-5)
    r_eff = -res.impacts_v_after / res.impacts_v_before
    np.testing.assert_allclose(r_eff, 1.0, atol=1e-4)
    # samples land on breakpoints: no interpolation
    assert res.stats["sample_interpolated"] == 0
    assert res.stats["sample_max_offset_s"] < 1e-12 * 2 * math.pi / 740
    tr = res.to_trajectory()
    assert tr.model == "spice" and tr.params == P074


@needs_ngspice
def test_initial_state_and_phase_are_the_requested_ones():
    """x0, v0, t0 map to V_s = -x0 V_unit, V_q = v0 omega R8 C1 V_unit and a cosine from t0.

    ngspice writes no t = 0 point under 'uic', so sample 0 is the initial
    condition; the first accepted time point and 5 periods (TMAX = 3 us) are
    checked against heyoka started from the same state (eta = 0.70).
    """
    p = Params.make(eta="0.70", x0="0.5", v0="-0.3", t0="1.3")
    comp = nominal_components(p)
    res = run_spice(comp, None, 5, tmax=3e-6, x0="0.5", v0="-0.3", t0="1.3", dense=True)
    assert res.x[0] == 0.5 and res.v[0] == pytest.approx(-0.3, abs=1e-15)
    assert res.t[0] == pytest.approx(1.3, abs=1e-15)

    def value(pattern):
        return float(re.search(pattern, res.netlist).group(1))

    assert value(r"C1 n4 s 1e-07 IC=(\S+)") == 0.5 and value(r"V\(s\)=(\S+)") == -0.5
    assert value(r"V\(q\)=(\S+)") == pytest.approx(-0.3, rel=1e-15)  # omega R8 C1 V_unit = 1
    assert value(r"C2 ca cb 1e-07 IC=(\S+)") == pytest.approx(0.3, rel=1e-15)
    assert value(r"cos\(700\.0\*time \+ (\S+)\)") == pytest.approx(0.91, rel=1e-15)  # eta t0
    # first accepted point (t ~ 1e-7 s) against heyoka
    ref = HeyokaSolver("float64").solve(p, 5, per_period=2000)
    t_first = res.dense_t[0]
    x_ref = np.interp(t_first, np.asarray(ref.dense_t, float), np.asarray(ref.dense_x, float))
    assert 0 < t_first - 1.3 < 1e-3
    assert abs(res.dense_x[0] - x_ref) < 1e-6
    ref5 = HeyokaSolver("float64").solve(p, 5)
    # BDF2 phase error ~2/9 (omega h)^3 per step accumulates before damping: 3e-4 measured
    assert np.abs(res.x - np.asarray(ref5.x, float)).max() < 1e-3
    assert np.abs(res.v - np.asarray(ref5.v, float)).max() < 1e-3


@needs_ngspice
def test_switch_on_resistance_damps_by_2ron_over_r3():
    """switch.ron in series with C2 adds damping 2 zeta += eps = 2 Ron / R3.

    Non-impacting steady state at eta = 0.70 (started on the ideal steady state):
    amplitude ``a |1 + i eta eps| / |1 - eta^2 - eta^2 eps 2 zeta + i eta (2 zeta + eps)|``
    (the U2 integrator becomes -(1 + s 2 Ron C2)/(s R3 C2)).  Ron = 160 Ohm:
    eps = 0.032, amplitude 1.93562 instead of 1.94257 (-0.0069).  Measured to 6e-5.
    """
    p = Params.make(eta="0.70")
    comp = nominal_components(p)
    ss = steady_state(p)
    x0, v0 = ss.P, p.eta * ss.Q
    eta, k = 0.7, 0.1

    def amplitude(eps):
        den = complex(1 - eta**2 - eta**2 * eps * k, eta * (k + eps))
        return abs(complex(1, eta * eps)) / abs(den)

    amps = {}
    for ron in (None, "160"):
        eff = None if ron is None else {"switch": {"ron": ron}}
        res = run_spice(comp, eff, 30, tmax=10e-6, x0=x0, v0=v0)
        assert res.n_impacts == 0
        a = np.sqrt(res.x[-5:] ** 2 + (res.v[-5:] / eta) ** 2)
        assert np.ptp(a) < 1e-6  # settled
        amps[ron] = a[-1]
    assert amps[None] == pytest.approx(amplitude(0.0), abs=3e-4)
    assert amps["160"] == pytest.approx(amplitude(2 * 160 / 1e4), abs=3e-4)
    assert amps["160"] - amps[None] == pytest.approx(amplitude(0.032) - amplitude(0.0), abs=2e-4)
    assert amps["160"] < amps[None] - 0.006


@needs_ngspice
def test_charge_injection_shifts_velocity_by_q_over_c2():
    """Q into U2's virtual ground per toggle: v_after = -v_before - Q/(C2 omega R8 C1 V_unit)."""
    q = 1e-9  # 0.01 V on 100 nF: v shifts by -0.01 at every impact
    res = run_spice(COMP074, {"switch": {"ron": "0", "charge_injection": str(q)}}, 20, tmax=10e-6)
    assert res.n_impacts >= 10
    shift = res.impacts_v_after + res.impacts_v_before
    np.testing.assert_allclose(shift, -0.01, atol=1e-3)  # measured -0.0099 .. -0.0106
    assert abs(np.mean(shift) + 0.01) < 5e-4


@needs_ngspice
def test_every_effect_runs_and_keeps_impacting():
    """Datasheet parts (every effect but tolerance) for 20 periods: ngspice succeeds,
    impacts happen, the wall overshoot grows with the delays but stays small."""
    eff = {
        "opamp_gain": {},
        "opamp_gbw": {},
        "opamp_saturation": {},
        "opamp_offset": {},
        "comparator": {},
        "flipflop": {},
        "switch": DATASHEET_SWITCH,
    }
    res = run_spice(COMP074, eff, 20, tmax=10e-6)
    assert res.n_impacts >= 10
    # the reversal comes 10-50 ns after the crossing; with op-amp poles ngspice sometimes
    # takes one ~100 ns step across the toggle, so x at the reversal is known to ~1e-4
    assert np.all(np.abs(res.impacts_x - 2) < 1e-3)
    assert np.all(np.abs(res.x) < 2.01)
    assert res.effects["switch"]["bbm"] == Fraction(25, 10**9)


@needs_ngspice
def test_timeout_is_a_clear_error():
    with pytest.raises(SpiceError, match="timeout"):
        run_spice(COMP074, None, 150, tmax=1e-6, timeout=0.05)


# ------------------------------------------------------------------ no ngspice needed
def test_missing_ngspice_names_it_and_how_to_install():
    with pytest.raises(NgspiceNotFoundError, match=r"ngspice.*apt-get install ngspice"):
        run_spice(COMP074, None, 2, executable="/nonexistent/ngspice")


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"effects": {"nope": {}}}, "effects.nope"),
        ({"effects": {"switch": {"ron": "-1"}}}, "effects.switch.ron"),
        ({"effects": {"switch": {"bogus": 1}}}, "effects.switch.bogus"),
        ({"effects": {"comparator": {"delay": "2e-3"}}}, "effects.comparator.delay"),
        ({"periods": 0}, "periods"),
        ({"periods": -3}, "periods"),
        ({"periods": 2.5}, "periods"),
        ({"tmax": 0}, "tmax"),
        ({"tmax": "nan"}, "tmax"),
        ({"tmax": "1"}, "tmax"),  # longer than a forcing period
        ({"x0": "2.5"}, "x0"),  # inside the wall
        ({"v0": "inf"}, "v0"),
        ({"components": "10k"}, "components"),
        ({"options": {"reltol": "1e-3\n.end"}}, "options.reltol"),
        ({"options": {"bad name": 1}}, "options"),
    ],
)
def test_bad_input_is_refused_before_any_work(kwargs, name):
    """Both entry points validate first: a missing ngspice is never reached."""
    args = {"components": COMP074, "effects": None, "periods": 3, "tmax": 10e-6}
    args.update(kwargs)
    for fn in (spice_netlist, lambda **a: run_spice(**a, executable="/nonexistent/ngspice")):
        with pytest.raises(ParameterError) as exc:
            fn(**args)
        assert exc.value.name == name


def test_run_spice_refuses_bad_timeout():
    with pytest.raises(ParameterError, match="timeout"):
        run_spice(COMP074, None, 3, timeout=0, executable="/nonexistent/ngspice")


def test_netlist_is_fig2_with_one_drive_node():
    net = spice_netlist(COMP074, None, 7, 10e-6)
    for el in (
        "R1 v3 n1",
        "R6 mq n1",
        "R7 s n1",
        "R2 n1 p",
        "R3 p n2",
        "R4 q n3",
        "R5 n3 mq",
        "R8 q n4",
        "C1 n4 s",
        "C2 ca cb",
        "EU1 p 0 0 n1 1000000000.0",
        "EU2 q 0 0 n2",
        "EU3 mq 0 0 n3",
        "EU4 s 0 0 n4",
    ):
        assert el in net, el
    sw = [ln for ln in net.splitlines() if re.match(r"BU[67][AB] ", ln)]
    assert len(sw) == 4
    assert all(set(re.findall(r"V\((\w+)\)", ln)) - {"n2", "ca", "cb", "q"} == {"pol"} for ln in sw)
    assert ".options method=gear" in net
    assert re.search(r"^\.tran \S+ \S+ 0 1e-05 uic$", net, re.M)
    assert "wrdata spice_out.txt V(s) V(q) V(pol) V(cmp)" in net
    pwl = re.search(r"PWL\(([^)]*)\)", net.replace("\n+ ", " ")).group(1).split()
    assert len(pwl) == 2 * 8  # samples k = 0..7
    assert float(pwl[-2]) == pytest.approx(7 * 2 * math.pi / 740, rel=1e-15)
    assert "digital" not in net.lower() and "adc_bridge" not in net


def test_netlist_maps_each_effect():
    eff = {
        "opamp_gain": {"A0": "2e5"},
        "opamp_gbw": {"gbw": "3e6"},
        "opamp_saturation": {},
        "opamp_offset": {},
        "comparator": {"delay": "7e-9", "hysteresis": "0.01"},
        "flipflop": {"delay": "14e-9"},
        "switch": DATASHEET_SWITCH,
    }
    net = spice_netlist(COMP074, eff, 3, 10e-6)
    assert f"CU1P U1_o 0 {1 / (2 * math.pi * 3e6)!r}" in net  # pole: C = 1/(2 pi GBW)
    assert "/200000.0" in net  # DC gain A0
    assert "softplus(V(U2_o)-13.5)" in net  # saturation clamp
    assert "VU3OS U3_np 0 DC 0.003" in net  # offset in series with the + input
    assert f"CU5 cmp 0 {7e-9 / math.log(2)!r}" in net  # delay -> lag with equal 50 % delay
    assert "-2.005-V(s)" in net and "V(s)--1.995" in net  # hysteresis thresholds
    assert f"CA1D pol 0 {14e-9 / math.log(2)!r}" in net
    assert "pold" in net and "CPN2 n2 0" in net  # break-before-make
    assert "BINJ 0 n2 I = 1e-12*abs(V(pol)-V(pinj))" in net
    assert f"{math.log(1e4) - math.log(160)!r}*tanh(u)" in net  # R_on = 160 -> R_mid = R3 = 10k


def test_e_series_tables_and_rounding():
    assert len(E96) == 96 and len(E24) == 24
    assert list(E96) == [round(10 ** (i / 96) * 100) for i in range(96)]  # E96 has no exceptions
    assert e_series_round("10300", "E96") == 10200
    assert e_series_round("10400", "E96") == 10500
    assert e_series_round("4.6e-9", "E24") == Fraction(47, 10**10)
    assert e_series_round("2.8", "E24") == Fraction(27, 10)
    assert e_series_round("99e3", "E96") == 100_000  # across the decade
    with pytest.raises(ParameterError):
        e_series_round("0", "E96")


def test_draw_components_is_seeded_and_within_tolerance():
    c = COMP074.replace(R6="99e3", C1="98e-9")
    zero = draw_components(c, {"resistor_pct": 0, "capacitor_pct": 0})
    assert zero.R6 == 100_000 and zero.C1 == Fraction(1, 10**7) and zero.R1 == 10_000
    assert draw_components(COMP074, {"resistor_pct": 0, "capacitor_pct": 0}) == COMP074
    a = draw_components(c, {"seed": 7})
    assert a == draw_components(c, {"seed": 7})
    assert a != draw_components(c, {"seed": 8})
    for name in ("R1", "R2", "R3", "R4", "R5", "R6", "R7", "R8"):
        assert abs(getattr(a, name) / getattr(zero, name) - 1) <= Fraction(1, 100) + Fraction(
            1, 10**5
        )
    for name in ("C1", "C2"):
        assert abs(getattr(a, name) / getattr(zero, name) - 1) <= Fraction(5, 100) + Fraction(
            1, 10**5
        )
    assert (a.V_A, a.Omega, a.V_wall, a.V_unit) == (c.V_A, c.Omega, c.V_wall, c.V_unit)
    with pytest.raises(ParameterError, match="effects.tolerance.seed"):
        draw_components(c, {"seed": -1})
    # the netlist uses the drawn values, the header keeps the design
    net = spice_netlist(COMP074, {"tolerance": {"seed": 3}}, 2, 10e-6)
    d = draw_components(COMP074, {"seed": 3})
    assert f"R1 v3 n1 {float(d.R1)!r}" in net and "* drawn:" in net
