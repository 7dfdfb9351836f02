"""Continuation of periodic orbits and their bifurcations, each against an independent reference:
the closed-form grazing frequencies and 1:1 orbits, the stroboscopic Newton of find_orbit (a
different formulation: the fast engine with the wall), and simulations on both sides of every
located point."""

import json
import math
import subprocess
import sys
from fractions import Fraction

import numpy as np
import pytest

import precise_impact as pi
from precise_impact.analysis.orbits.shooting import ShootingSystem, from_orbit

EPS = 2.0**-52


@pytest.fixture(scope="session")
def nonimpacting():
    """The non-impacting orbit from eta = 0.6 to 1.3, through its virtual stretch."""
    ss = pi.steady_state(pi.Params.make(eta="0.6"))
    return pi.continue_orbit(
        pi.Params.make(eta="0.6"),
        "eta",
        "0.6",
        "1.3",
        1,
        guess=(ss.P, ss.eta * ss.Q),
        impacts=0,
        virtual=1,
    )


@pytest.fixture(scope="session")
def one_to_one():
    """The 1:1 orbit at R = 0.8 from eta = 1 down to 0.93: a period-doubling point and its doubled
    branch."""
    return pi.continue_orbit(pi.Params.make(R="0.8", eta="1"), "eta", "1", "0.93", 1)


@pytest.fixture(scope="session")
def period3():
    return pi.continue_orbit(pi.Params.make(eta="0.74"), "eta", "0.74", "0.80", 3)


def _only(res, kind, branch=0):
    found = [b for b in res.bifurcations if b.type == kind and b.branch == branch and b.admissible]
    assert len(found) == 1, [(b.type, b.branch, b.value) for b in res.bifurcations]
    return found[0]


def test_jacobian_of_the_shooting_system_is_exact():
    p = pi.Params.make(eta="0.74")
    o = pi.find_orbit(p, 3)
    S = ShootingSystem(
        {k: float(getattr(p, k)) for k in ("eta", "zeta", "a", "x_w", "R", "t0")},
        "eta",
        3,
        o.impacts,
    )
    u = from_orbit(S, p, o.x, o.v, 0.74)
    G, J = S.residual(u, 0.74, jacobian=True)
    assert np.abs(G).max() < 1e-13  # the simulated orbit solves the impact-sequence system
    h = 1e-6
    fd = np.column_stack(
        [
            (S.residual(u + h * e, 0.74) - S.residual(u - h * e, 0.74)) / (2 * h)
            for e in np.eye(len(u))
        ]
    )
    # central differences: truncation h^2 |G'''| ~ 1e-11, rounding eps |G| / h ~ 1e-9
    assert np.abs(J - fd).max() < 1e-8 * (1 + np.abs(J).max())
    # its monodromy equals find_orbit's (the fast engine's orbit_map with the wall)
    mu = sorted(np.linalg.eigvals(S.monodromy(u, 0.74)), key=abs)
    assert np.allclose(mu, sorted(o.multipliers, key=abs), atol=1e-12)


def test_grazing_of_the_nonimpacting_orbit_is_the_closed_form(nonimpacting):
    exact = [float(g) for g in pi.grazing_frequencies(pi.Params.make())]
    got = sorted(b.value for b in nonimpacting.bifurcations if b.type == "grazing")
    assert len(got) == 2 and all(b.type == "grazing" for b in nonimpacting.bifurcations)
    # x_w - amplitude is evaluated to ~4 eps x_w; |d amplitude / d eta| > 1 at both points
    for g, e in zip(got, exact, strict=True):
        assert abs(g - e) <= 64 * EPS * e
    b = nonimpacting.branches[0]
    assert b.stable.all() and b.values.min() == 0.6 and b.values.max() == 1.3
    # between the grazing frequencies the orbit crosses the wall: virtual, and nowhere else
    inside = (b.values > exact[0]) & (b.values < exact[1])
    assert np.array_equal(~b.admissible, inside)
    # multipliers exp((-zeta +- i w) T): the LLE is -zeta to rounding
    assert np.abs(b.lle + 0.05).max() < 1e-13


def test_period_doubling_located_and_confirmed(one_to_one):
    pd = _only(one_to_one, "period-doubling")
    eta = pd.value
    re, im = pd.multipliers[0] if abs(pd.multipliers[0][0] + 1) < 0.5 else pd.multipliers[1]
    assert abs(re + 1) < 1e-12 and im == 0  # mu = -1 located to rounding
    # the closed-form 1:1 orbit at the located eta is the branch's orbit, and has the multiplier -1
    p = pi.Params.make(R="0.8", eta=Fraction(eta))
    cf = [o for o in pi.one_impact_orbits(p, dps=30) if abs(float(o.x) - pd.x[0]) < 1e-6]
    assert len(cf) == 1
    assert abs(float(cf[0].x) - pd.x[0]) < 1e-12 and abs(float(cf[0].v) - pd.v[0]) < 1e-12
    assert min(abs(complex(m) + 1) for m in cf[0].multipliers) < 1e-10
    # simulations: on the stable side a perturbed orbit returns, past the point it leaves
    for d, stays in ((+2e-3, True), (-2e-3, False)):
        q = pi.Params.make(R="0.8", eta=Fraction(eta + d))
        o = pi.find_orbit(q, 1, guess=(pd.x[0], pd.v[0]))
        tr = pi.simulate(
            q.replace(x0=Fraction(o.x) - Fraction(1, 10**6), v0=Fraction(o.v)), 3000, model="fast"
        )
        dist = math.hypot(float(tr.x[-1]) - o.x, float(tr.v[-1]) - o.v)
        assert (dist < 1e-9) == stays, (d, dist)


def test_doubled_branch_is_a_true_period_2_orbit(one_to_one):
    assert len(one_to_one.branches) >= 2
    b = one_to_one.branches[1]
    assert (b.period, b.impacts) == (2, 2) and b.origin.startswith("period-doubling of branch 0")
    k = int(np.argmax(b.admissible & (np.arange(len(b.values)) > 2)))
    eta = b.values[k]
    # an independent Newton (stroboscopic, the fast engine with the wall) from the branch's point
    o = pi.find_orbit(
        pi.Params.make(R="0.8", eta=Fraction(eta)), 2, guess=(b.x[k, 0], b.v[k, 0]), impacts=2
    )
    assert abs(o.x - b.x[k, 0]) < 1e-11 and abs(o.v - b.v[k, 0]) < 1e-11
    assert abs(b.x[k, 0] - b.x[k, 1]) > 1e-4  # not the period-1 orbit counted twice
    mu = sorted(math.hypot(*m) for m in b.multipliers[k])
    assert np.allclose(mu, sorted(abs(m) for m in o.multipliers), rtol=1e-9)


def test_grazing_of_period_3_located_by_tangency_and_confirmed(period3):
    g = _only(period3, "grazing")
    assert "interior maximum" in g.detail and abs(g.test) < 1e-13
    eta = g.value
    # confirmation: just before, the orbit (Newton with the real wall) keeps 2 impacts; just
    # after, the continued orbit's point, simulated with the wall, meets a third impact
    d = 1e-5
    before = pi.continue_orbit(
        pi.Params.make(eta="0.74"), "eta", "0.74", repr(eta - d), 3
    ).branches[0]
    after = pi.continue_orbit(
        pi.Params.make(eta="0.74"), "eta", "0.74", repr(eta + d), 3, virtual=1
    ).branches[0]
    assert before.admissible[-1] and not after.admissible[-1]
    qb = pi.Params.make(eta=repr(eta - d))
    o = pi.find_orbit(qb, 3, guess=(before.x[-1, 0], before.v[-1, 0]))
    assert o.impacts == 2 and abs(o.x - before.x[-1, 0]) < 1e-11
    qa = pi.Params.make(
        eta=repr(eta + d), x0=repr(float(after.x[-1, 0])), v0=repr(float(after.v[-1, 0]))
    )
    tr = pi.simulate(qa, 3, model="fast")
    assert len(tr.impacts_t) == 3


def test_fold_of_the_one_to_one_orbits_against_the_closed_form():
    res = pi.continue_orbit(pi.Params.make(eta="0.6"), "eta", "0.6", "0.65", 1, impacts=1)
    f = _only(res, "fold")
    assert min(abs(complex(*m) - 1) for m in f.multipliers) < 1e-10
    b = res.branches[0]
    assert (
        abs(b.values.max() - f.value) < 1e-3 and b.values[-1] == 0.6
    )  # it turned back to the start
    # the closed-form 1:1 orbits: a pair just below the fold, none just above
    below = pi.one_impact_orbits(pi.Params.make(eta=Fraction(f.value - 1e-4)), dps=30)
    above = pi.one_impact_orbits(pi.Params.make(eta=Fraction(f.value + 1e-4)), dps=30)
    near = lambda os_: [o for o in os_ if abs(float(o.x) - f.x[0]) < 0.2]  # noqa: E731
    assert len(near(below)) == 2 and len(near(above)) == 0


def test_no_neimark_sacker_because_det_m_is_fixed(one_to_one):
    """det M = R^(2n) exp(-2 zeta p T) along every branch (saltation det R^2, flow det
    e^(-2 zeta t)),
    so |mu1 mu2| < 1 and a complex pair can never reach the unit circle when zeta > 0."""
    for b in one_to_one.branches:
        T = 2 * math.pi / b.values
        mu = b.multipliers[..., 0] + 1j * b.multipliers[..., 1]
        det = np.abs(mu[:, 0] * mu[:, 1])
        ok = b.admissible
        assert np.allclose(
            det[ok], 0.8 ** (2 * b.impacts) * np.exp(-2 * 0.05 * b.period * T[ok]), rtol=1e-9
        )
    assert not any(x.type == "neimark-sacker" for x in one_to_one.bifurcations)


def test_continue_cli_contract(tmp_path):
    out = tmp_path / "c"
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "precise_impact",
            "continue",
            "--param",
            "eta",
            "1",
            "0.95",
            "--R",
            "0.8",
            "--json",
            "--out",
            str(out),
            "--diagram",
            "20",
            "--doublings",
            "0",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["parameter"] == "eta" and d["branches"][0]["period"] == 1
    (pd,) = [b for b in d["bifurcations"] if b["type"] == "period-doubling"]
    assert abs(pd["eta"] - 0.96055686213853) < 1e-9
    assert (out / "continuation.png").stat().st_size > 10_000 and json.loads(
        (out / "continuation.json").read_text()
    )
    for argv, word in (
        (["--param", "x_w2", "1", "2"], "parameter"),
        (["--param", "R", "0.9", "1.2"], "R"),
        (["--param", "eta", "0.7", "0.8", "--eta", "0.7"], "eta"),
        (["--param", "eta", "0.7", "0.7"], "stop"),
        (["--param", "eta", "0.7", "0.8", "--period", "0"], "period"),
    ):
        r = subprocess.run(
            [sys.executable, "-m", "precise_impact", "continue", *argv],
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert r.returncode == 2 and r.stderr.count("\n") == 1 and word in r.stderr, (
            argv,
            r.stderr,
        )


def test_continuation_in_a_and_x_w_agree_by_scaling():
    """x -> x / a maps the system with (a, x_w) onto (1, x_w / a): the period-3 orbit grazes where
    x_w / a takes one value, whether a or x_w is continued -- two branches, one number."""
    ra = pi.continue_orbit(pi.Params.make(eta="0.74"), "a", "1", "1.2", 3)
    rx = pi.continue_orbit(pi.Params.make(eta="0.74"), "x_w", "2", "1.5", 3)
    ga, gx = _only(ra, "grazing"), _only(rx, "grazing")
    assert abs(2 / ga.value - gx.value) < 1e-12
    assert np.allclose(
        sorted(m[0] for m in ga.multipliers), sorted(m[0] for m in gx.multipliers), atol=1e-10
    )


def test_continuation_in_R_lands_on_the_end_of_its_range():
    res = pi.continue_orbit(pi.Params.make(eta="1", R="0.8"), "R", "0.8", "1", 1)
    b = res.branches[0]
    assert b.values[-1] == 1.0 and b.stop_reason == "reached R = 1"
    o = pi.find_orbit(pi.Params.make(eta="1", R="1"), 1, guess=(b.x[-1, 0], b.v[-1, 0]))
    assert abs(o.x - b.x[-1, 0]) < 1e-12 and abs(o.v - b.v[-1, 0]) < 1e-12


def test_continuation_in_zeta_follows_the_closed_form():
    """The 1:1 orbit at R = 0.8, eta = 1 continued in zeta from 0.05 to 0.15: every point of the
    branch is the closed-form 1:1 orbit at its zeta (one_impact_orbits, mpmath).  The corrector
    stops at steps <= 64 eps (1 + |y|) after quadratic convergence, so a point is the exact
    solution perturbed by the rounding of G (~100 eps over a flight of length T) times
    |G_u^-1| (~10 here): ~1e-13; 1e-10 is the bound asked, with room."""
    res = pi.continue_orbit(
        pi.Params.make(R="0.8", eta="1"), "zeta", "0.05", "0.15", 1, doublings=0
    )
    b = res.branches[0]
    assert (
        b.parameter == "zeta"
        and b.impacts == 1
        and b.values.max() == 0.15
        and b.values.min() == 0.05
    )
    assert len(b.values) >= 10 and b.admissible.all()
    worst = 0.0
    for k, z in enumerate(b.values):
        cf = pi.one_impact_orbits(
            pi.Params.make(R="0.8", eta="1", zeta=Fraction(float(z))), dps=30, grid=200
        )
        best = min(max(abs(float(o.x) - b.x[k, 0]), abs(float(o.v) - b.v[k, 0])) for o in cf)
        worst = max(worst, best)
        # the closed-form multipliers are the branch's (|mu| the same to the same level)
        o = min(cf, key=lambda o: abs(float(o.x) - b.x[k, 0]))
        assert np.allclose(
            sorted(abs(complex(m)) for m in o.multipliers),
            sorted(math.hypot(*m) for m in b.multipliers[k]),
            rtol=0,
            atol=1e-10,
        )
    assert worst <= 1e-10, worst
