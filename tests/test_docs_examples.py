"""The checks behind the user guide's examples (docs/guide/*.rst).

The guide's examples are plain code with printed output (``sphinx-build -b doctest`` runs
them and compares the output); the assertions that used to sit in them live here, one test
per example, running the same code.  Tolerances are the ones the pages state, with the
measured values in the comments.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

import precise_impact as pi
from precise_impact.verification.metrics import sample_errors

GUIDE = Path(__file__).resolve().parents[1] / "docs" / "guide"
docs_checkout = pytest.mark.skipif(not GUIDE.is_dir(), reason="needs the checkout's docs/")


# ---------------------------------------------------------------- the pages themselves


def _directive_blocks(text: str, name: str) -> list[str]:
    """The bodies of every ``.. name::`` directive of an rst page."""
    blocks = []
    lines = text.split("\n")
    for i, line in enumerate(lines):
        if re.match(rf"^\s*\.\. {name}::", line):
            indent = len(line) - len(line.lstrip())
            body = []
            for nxt in lines[i + 1 :]:
                if nxt.strip() and len(nxt) - len(nxt.lstrip()) <= indent:
                    break
                body.append(nxt)
            blocks.append("\n".join(body))
    return blocks


def _pages() -> list[Path]:
    return sorted(GUIDE.glob("*.rst"))


@docs_checkout
def test_guide_examples_hold_no_asserts():
    # the examples read as tutorials: the checks are the tests in this file
    found = [
        (page.name, line.strip())
        for page in _pages()
        for name in ("testcode", "runfigure")
        for block in _directive_blocks(page.read_text(encoding="utf-8"), name)
        for line in block.split("\n")
        if re.match(r"\s*assert\b", line)
    ]
    assert found == []


@docs_checkout
def test_every_guide_page_has_a_figure():
    pages = _pages()
    assert len(pages) >= 13
    without = [p.name for p in pages if not _directive_blocks(p.read_text("utf-8"), "runfigure")]
    assert without == []


# ---------------------------------------------------------------- simulate.rst


def test_simulate_steady_state_at_070():
    tr = pi.simulate(pi.Params.make(eta="0.70"), 600)
    ss = pi.steady_state(pi.Params.make(eta="0.70"))
    assert (str(ss.P), str(ss.eta * ss.Q)) == ("102/53", "49/265")
    # float64 after 600 periods: round-off of the transient decays like exp(-zeta t), so the
    # error is a few eps times the state (measured 5e-13)
    assert abs(float(tr.x[-1]) - 102 / 53) < 1e-11
    assert abs(float(tr.v[-1]) - 49 / 265) < 1e-11


def test_simulate_two_precisions_agree():
    c = pi.Params.make(eta="0.712")
    a = pi.simulate(c, 50, precision="mp:128")
    b = pi.simulate(c, 50, precision="mp:192")
    # 0.13 digits lost per period: 50 periods cost ~7 of 128 bits' 38 digits (measured 5e-29)
    assert max(sample_errors(a, b)) < 1e-25
    assert a.n_impacts == b.n_impacts


def test_simulate_three_methods_agree_on_period3():
    s = pi.make_solver("analytical")
    assert isinstance(s, pi.Solver)
    p = pi.Params.make(eta="0.74")
    closed, taylor = s.solve(p, 30), pi.simulate(p, 30)
    fast = pi.simulate(p, 30, model="fast")
    ref = np.asarray(taylor.x, float)
    # independent methods on a stable orbit: round-off growth only (measured ~1e-13)
    assert np.max(np.abs(np.asarray(closed.x, float) - ref)) < 1e-9
    assert np.max(np.abs(fast.x - ref)) < 1e-9


def test_simulate_saltation_determinant():
    S = pi.oscillator_saltation(1.0, 0.7, 0.712, 0.05, 1.0, 2.0, 0.8, math.cos)
    det = S[0][0] * S[1][1] - S[0][1] * S[1][0]
    assert abs(det - 0.64) < 1e-15  # R^2, a few roundings of O(1) products


# ---------------------------------------------------------------- lyapunov.rst


def test_lyapunov_chaotic_estimate_and_exact_sum():
    r = pi.lyapunov(pi.Params.make(eta="0.712"), periods=4000, transient=500)
    assert (r.method, r.initial_conditions) == ("variational", 4)
    # the paper's estimate ~0.0302; a 4000-period run has stderr ~1e-3
    assert abs(r.lle - 0.0302) < 4 * r.lle_stderr + 1e-3
    # lambda1 + lambda2 = -2 zeta + (impacts / time) ln R^2 = -0.1 for R = 1, exactly
    assert abs(sum(r.spectrum) + 0.1) < 1e-12


def test_lyapunov_non_impacting_is_minus_zeta():
    r = pi.lyapunov(pi.Params.make(eta="0.70"), periods=300, transient=3000, initial_conditions=1)
    assert r.n_impacts == 0
    # finite-time bias below ln(1 + 2 zeta / omega_d) / t
    assert abs(r.stats["finite_time"]["lle"] + 0.05) < 1e-3
    assert (r.lle_source, r.attractors[0].kind, r.attractors[0].period) == (
        "floquet",
        "periodic",
        1,
    )
    assert abs(r.lle + 0.05) < 1e-12


def test_lyapunov_two_attractors_without_damping():
    r = pi.lyapunov(pi.Params.make(zeta="0", eta="1.2"), model="fast")
    assert sorted(len(a.starts) for a in r.attractors) == [1, 3]
    head = r.headline_attractor
    assert r.lle == head.lle > 0.01 and len(head.starts) == 3


def test_lyapunov_floquet_on_one_impact_orbit():
    r = pi.lyapunov(pi.Params.make(R="0.8", eta="1"), model="fast", periods=4000)
    assert abs(r.lle - (math.log(0.8) / (2 * math.pi) - 0.05)) < 1e-12


# ---------------------------------------------------------------- orbits.rst


def test_orbits_period3():
    o = pi.find_orbit(pi.Params.make(eta="0.74"), 3)
    assert (o.period, o.impacts, o.stable) == (3, 2, True)
    assert o.residual < 1e-13 and abs(o.lle + 0.017669) < 1e-6


def test_orbits_newton_matches_closed_form():
    p = pi.Params.make(R="0.8", eta="1")
    (cf,) = pi.one_impact_orbits(p)
    nw = pi.find_orbit(p, 1)
    assert abs(nw.x - float(cf.x)) < 1e-12
    assert abs(nw.lle - (math.log(0.8) / (2 * math.pi) - 0.05)) < 1e-12


def test_orbits_multiprecision_newton():
    import mpmath

    p = pi.Params.make(R="0.8", eta="1")
    (cf,) = pi.one_impact_orbits(p, dps=70)
    o = pi.find_orbit(p, 1, precision="mp:192")
    assert abs(o.x - cf.x) < mpmath.mpf(10) ** -50  # 192 bits: 57 digits


def test_orbits_period2_from_closed_form():
    p = pi.Params.make(R="0.8", eta="0.9")
    (cf,) = pi.one_impact_orbits(p, period=2)
    o = pi.find_orbit(p, 2, guess_from="closed-form")
    assert (o.period, o.impacts, o.stability) == (2, 1, "stable")
    assert abs(o.x - float(cf.x)) < 1e-12


def test_orbits_continuation_grazing_and_period_doubling():
    ss = pi.steady_state(pi.Params.make(eta="0.6"))
    res = pi.continue_orbit(
        pi.Params.make(eta="0.6"), "eta", "0.6", "0.75", 1, guess=(ss.P, ss.eta * ss.Q), impacts=0
    )
    (g,) = [b for b in res.bifurcations if b.type == "grazing"]
    exact = float(pi.grazing_frequencies(pi.Params.make())[0])
    assert abs(g.value - exact) < 1e-14
    res = pi.continue_orbit(pi.Params.make(R="0.8", eta="1"), "eta", "1", "0.95", 1)
    pd = res.bifurcations[0]
    assert (pd.type, round(pd.value, 10), res.branches[1].period) == (
        "period-doubling",
        0.9605568621,
        2,
    )


# ---------------------------------------------------------------- certified.rst


def test_certified_radius_target():
    r = pi.certify(pi.Params.make(eta="0.712"), 300)
    assert len(r.impacts) == 215 and r.max_radius() < 1e-30
    s = r.to_dict()["samples"][300]
    assert float(s["x_rad"]) < 1e-30


# ---------------------------------------------------------------- coupled.rst


def test_coupled_strong_coupling_synchronises():
    p = pi.Params.make(eta="0.712")
    # k = 0.2 far above the threshold (~ the LLE, 0.03): |x - y| decays like exp(-(k - LLE) t)
    a = pi.simulate_coupled(p, "0.2", "first-order", 60, y0=("0.5", "0"))
    assert abs(float(a.x[-1]) - float(a.y[-1])) < 1e-8
    s = pi.sync_scan(p, "first-order", ["0.2"], periods=60, ensemble=2, lle_periods=0)
    assert list(s.fraction_synchronised) == [1.0]


def test_coupled_fast_matches_heyoka():
    p = pi.Params.make(eta="0.712")
    f = pi.simulate_coupled(p, "0.2", "first-order", 20, y0=("0.5", "0"), model="fast")
    h = pi.simulate_coupled(p, "0.2", "first-order", 20, y0=("0.5", "0"))
    assert f.stats["engine"] == "fast" and len(f.slave_impacts_t) == len(h.slave_impacts_t)
    assert np.max(np.abs(f.y - np.asarray(h.y, float))) < 1e-8


# ---------------------------------------------------------------- bifurcation.rst


def test_bifurcation_period3_points():
    d = pi.bifurcation(
        pi.Params.make(),
        ("eta", "0.74", "0.75", 2),
        periods=100,
        transient=300,
        workers=1,
        progress=False,
    )
    assert d.x.shape[0] == 2 and all(np.isfinite(d.lle))
    # eta = 0.74 is the paper's period-3 orbit: three distinct stroboscopic points
    assert len(set(np.round(d.x[0], 6))) == 3


# ---------------------------------------------------------------- circuits.rst


def test_circuits_ideal_models_reproduce_mechanics():
    p = pi.Params.make(eta="0.74")
    ref = np.asarray(pi.simulate(p, 20).x, float)
    for model in ("circuit", "switched-capacitor"):
        tr = pi.simulate(p, 20, model=model)
        err = np.max(np.abs(np.asarray(tr.x, float) - ref))
        assert err < 1e-9, (model, err)  # round-off growth, measured ~1e-13


def test_circuits_switch_effect_and_scene():
    s = pi.SwitchedCapacitorSolver(effects={"switch": {}})
    assert s.solve(pi.Params.make(eta="0.74"), 20).n_impacts > 0
    scenes = pi.builtin_scenes()
    assert len(scenes) == 10 and "fig6-period3-ideal" in scenes
    assert isinstance(pi.run_scene(pi.load_scene("fig6-period3-ideal")), pi.Trajectory)


# ---------------------------------------------------------------- compare.rst


def test_compare_periodic_score():
    p = pi.Params.make(eta="0.74")
    ref = pi.simulate(p, 200, precision="mp:128")
    sc = pi.score(pi.simulate(p, 200, model="analytical-paper"), ref, regime="periodic")
    assert (sc["regime"], sc["period_model"], sc["period_reference"]) == ("periodic", 3, 3)
    assert sc["max_state_error"] < 1e-9  # measured 1.5e-12


# ---------------------------------------------------------------- reference.rst


def test_reference_testing_api():
    from precise_impact.testing import assert_stroboscopic_close

    def my_solver(params, periods):
        traj = pi.simulate(pi.Params.make(**params), periods, precision="float64")
        return traj.x, traj.v

    result = assert_stroboscopic_close(my_solver, "single-0.74", periods=30, atol=1e-6, rtol=1e-6)
    assert result["passed"]
    assert pi.verify_reference(cases=["single-0.74"]) == []


# ---------------------------------------------------------------- workprecision.rst


def test_workprecision_tighter_tolerance_is_never_worse():
    p = pi.Params.make(eta="0.74")
    ref = pi.simulate(p, 30, precision="mp:128")
    errors = {
        tol: max(sample_errors(pi.HeyokaSolver("float64", tol=tol).solve(p, 30), ref))
        for tol in ("1e-6", "1e-10", None)
    }
    assert errors["1e-6"] >= errors["1e-10"] >= 0 and errors[None] < 1e-11  # measured 4e-14


# ---------------------------------------------------------------- circuit_builders.rst


def test_circuit_builders_mapping():
    from precise_impact.models.circuit.components import to_circuit, to_mechanical

    comp = pi.nominal_components(pi.Params.make(eta="0.712"))
    omega = float(comp.omega())
    assert omega == 1000.0 and float(comp.Omega) == 712.0 and float(comp.V_wall) == -2.0
    t, V_s, V_q = to_circuit(comp, 2 * math.pi / 0.712, 1.5, 0.8, omega)
    assert abs(t / (2 * math.pi / 712) - 1) < 4e-16 and V_s == -1.5 and V_q == 0.8  # 2 roundings
    assert to_mechanical(comp, t, V_s, V_q, omega)[1:] == (1.5, 0.8)


def test_circuit_builders_scene_components(tmp_path):
    from fractions import Fraction

    from precise_impact.models.circuit.components import dimensionless

    path = tmp_path / "my-circuit.toml"
    path.write_text(
        '[model]\nname = "switched-capacitor"\n[parameters]\neta = "0.74"\n'
        '[components]\nR = "47 kohm"\nC = "22 nF"\nR6 = "235 kohm"\n'
    )
    design = pi.load_scene(path).design()
    q = dimensionless(design)
    # R6 = R / (2 zeta) with zeta = 0.1: half the nominal 470 kOhm doubles the damping
    assert design.R6 == 235000 and q.zeta == Fraction(1, 10)
    assert (q.eta, q.a, q.x_w) == (Fraction(37, 50), 1, 2)


@pytest.mark.parametrize("ron", ["0", "160", "1000"])
def test_switch_on_resistance_damping(ron):
    """The decay rate of the unforced switched-capacitor circuit is (2 zeta + 2 R_on/R3) / D,
    D = 1 + 4 zeta R_on / R3 (nominal design), and the frequency omega / sqrt(D): the
    linearisation of models/circuit/effects/switch.vq, stated in circuit_builders.rst."""
    p = pi.Params.make(a="0", x_w="10", eta="0.712")  # no forcing, the wall out of reach
    T = 2 * math.pi / 0.712
    solver = pi.SwitchedCapacitorSolver(effects={"switch": {"ron": ron}})
    cols = []
    for x0, v0 in (("1", "0"), ("0", "1")):
        tr = solver.solve(p, 1, x0=x0, v0=v0)
        assert tr.n_impacts == 0
        cols.append([float(tr.x[1]), float(tr.v[1])])
    M = np.array(cols).T  # the one-period map
    r = float(ron) / 10e3
    D = 1 + 4 * 0.05 * r
    sigma = (0.1 + 2 * r) / D / 2
    omega_d = math.sqrt(1 / D - sigma**2)
    # float64 integration at epsilon tolerance over one period of an O(1) state:
    # measured differences ~1e-15; 1e-12 leaves room for the Taylor steps' round-off
    assert abs(-math.log(np.linalg.det(M)) / T - 2 * sigma) < 1e-12
    assert abs(np.trace(M) - 2 * math.exp(-sigma * T) * math.cos(omega_d * T)) < 1e-12
