"""Starts on the wall, starts at a sample time, impacts exactly on a sample or the end time.

Convention under test (HeyokaSolver and AnalyticalSolver): samples are
right-continuous, i.e. an output time equal to an impact time holds the
post-impact state ``(x_w, v_after)`` exactly, and sample 0 is the state at
``t0`` after an impact at ``t0``.  A start on the wall:

* ``v0 > 0``: an impact at ``t0``;
* ``v0 = 0``: sticks while ``a cos(eta t) - x_w > 0`` (HeyokaSolver; the analytical
  solver does not model sticking and raises BudgetExceededError), else flies;
* ``v0 < 0``: flies away, no impact.

Independent references: the closed-form analytical solver (a different method),
the closed-form release time, and exact rational arithmetic for the sample times.
"""

from __future__ import annotations

from fractions import Fraction

import mpmath
import pytest

from precise_impact import AnalyticalSolver, BudgetExceededError, HeyokaSolver, Params, Precision
from precise_impact.verification.metrics import sample_errors

PRECISIONS = ["float64", "longdouble", "float128", "mp:128"]


def mpq(q) -> mpmath.mpf:
    q = Fraction(q)
    with mpmath.workprec(600):
        return mpmath.mpf(q.numerator) / q.denominator


def analytical(precision: str) -> AnalyticalSolver:
    return AnalyticalSolver() if precision == "float64" else AnalyticalSolver(precision="mp:136")


# --------------------------------------------------------------------------- on the wall
@pytest.mark.parametrize("R", ["1", "4/5", "0"])
@pytest.mark.parametrize("precision", PRECISIONS)
def test_start_on_wall_moving_in(precision, R):
    """v0 > 0 on the wall at t0 = 1/3: an impact at t0 (sample 0 is the post-impact
    state), then the same motion as the analytical solver.  The wall force
    cos(0.74 t) - 2 < 0, so for R = 0 the mass leaves the wall at rest.
    Tolerance against the analytical solver at 40 digits: float64 1e-12 (10
    periods of a stable orbit), else 1e-15."""
    p = Params.make(eta="0.74", x0="2", v0="0.5", t0="1/3", R=R)
    tr = HeyokaSolver(precision).solve(p, 10)
    P = tr.precision
    t0 = P.from_fraction(p.t0)
    assert tr.t[0] == t0 and tr.impacts_t[0] == t0
    assert tr.impacts_v_before[0] == P.from_fraction(Fraction(1, 2))
    va = -P.from_fraction(p.R) * P.from_fraction(Fraction(1, 2))
    assert tr.impacts_v_after[0] == va
    assert (tr.x[0], tr.v[0]) == (P.from_fraction(p.x_w), va)
    assert tr.stats["sticking"] == []
    an = analytical("mp:133").solve(p, 10)
    assert an.n_impacts == tr.n_impacts
    assert float(an.impacts_t[0]) == float(t0)
    # (the mpmath analytical solver works at 136 bits but reports at 133: its
    # sample 0 is evaluated a rounding away from its start, hence not exactly va)
    assert abs(float(an.v[0]) - float(va)) <= 1e-35
    assert max(sample_errors(tr, an)) <= (1e-12 if precision == "float64" else 1e-15)


@pytest.mark.parametrize("precision", PRECISIONS)
def test_start_on_wall_at_rest_force_pulling_away(precision):
    """x0 = x_w = 2, v0 = 0: the force cos(0.74 t0) - 2 < 0 pulls the mass off the
    wall; no impact at t0 (and no spurious one), sample 0 = (2, 0), and the
    analytical solver (mpmath, 40 digits) agrees: float64 1e-12, others 1e-15."""
    p = Params.make(eta="0.74", x0="2", v0="0", t0="-5/2")
    tr = HeyokaSolver(precision).solve(p, 10)
    P = tr.precision
    assert (tr.x[0], tr.v[0]) == (P.from_fraction(p.x_w), 0)
    assert tr.stats["sticking"] == [] and tr.stats["spurious_contacts"] == 0
    assert all(t > P.from_fraction(p.t0) for t in tr.impacts_t)
    an = analytical("mp:133").solve(p, 10)
    assert an.n_impacts == tr.n_impacts
    assert max(sample_errors(tr, an)) <= (1e-12 if precision == "float64" else 1e-15)


@pytest.mark.parametrize("precision", PRECISIONS)
def test_start_on_wall_moving_away(precision):
    """x0 = x_w, v0 < 0: plain free flight, no impact at t0; agrees with the analytical solver."""
    p = Params.make(eta="0.74", x0="2", v0="-0.5", t0="7")
    tr = HeyokaSolver(precision).solve(p, 10)
    P = tr.precision
    assert (tr.x[0], tr.v[0]) == (P.from_fraction(p.x_w), P.from_fraction(p.v0))
    assert all(t > P.from_fraction(p.t0) for t in tr.impacts_t)
    an = analytical("mp:133").solve(p, 10)
    assert an.n_impacts == tr.n_impacts
    assert max(sample_errors(tr, an)) <= (1e-12 if precision == "float64" else 1e-15)


@pytest.mark.parametrize(
    "eta, a, x_w, t0, release",
    [
        # G = cos(0.3 t) - 1/2 > 0 at t0 = 1; turns negative at 0.3 t = pi/3
        ("0.3", "1", "0.5", "1", lambda: mpmath.pi / 3 / mpq("0.3")),
        # a < 0: G = -cos(0.5 t) - 1/2 > 0 at t0 = 6 (0.5 t0 = 3 in (2pi/3, 4pi/3)),
        # turns negative at 0.5 t = 4 pi / 3
        ("0.5", "-1", "0.5", "6", lambda: 4 * mpmath.pi / 3 / mpq("0.5")),
        # x_w < 0, start in a later forcing period: 0.25 t0 = 37.5 = 5 * 2pi + 6.08,
        # G = cos(0.25 t) + 1/2 > 0 there (cos 6.08 = 0.98); it turns negative at
        # acos(-1/2) = 2 pi / 3 of the next period: 0.25 t = 2 pi / 3 + 6 * 2 pi
        ("0.25", "1", "-0.5", "150", lambda: (2 * mpmath.pi / 3 + 6 * 2 * mpmath.pi) / mpq("0.25")),
    ],
)
@pytest.mark.parametrize("precision", PRECISIONS)
def test_start_on_wall_at_rest_pushed_in_sticks(precision, eta, a, x_w, t0, release):
    """x0 = x_w, v0 = 0 with the wall force pushing in: (x_w, 0) exactly until the
    closed-form release time (rounded up: 0 <= t_rel - exact <= 1 ulp), then free
    flight inside the allowed region.  The analytical solver raises instead."""
    p = Params.make(eta=eta, a=a, x_w=x_w, x0=x_w, v0="0", t0=t0, zeta="0.05")
    with mpmath.workprec(600):
        G = lambda s: mpq(a) * mpmath.cos(mpq(eta) * s) - mpq(x_w)  # noqa: E731
        assert G(mpq(t0)) > 0
    tr = HeyokaSolver(precision).solve(p, 2, per_period=64)
    P = tr.precision
    x_w_p = P.from_fraction(p.x_w)
    (t_s, t_r), *later = tr.stats["sticking"]
    assert t_s == P.from_fraction(p.t0)
    with mpmath.workprec(600):
        ex = release()
        assert abs(G(ex)) < mpmath.mpf(10) ** -100
        d = P.to_mpf(t_r) - ex
        assert 0 <= d <= P.eps_float * ex
    assert tr.impacts_t.size == 0 or tr.impacts_t[0] > t_r
    n_stuck = 0
    for t, x, v in zip(tr.dense_t, tr.dense_x, tr.dense_v, strict=True):
        assert x <= x_w_p
        if t <= t_r:
            assert (x, v) == (x_w_p, 0)
            n_stuck += 1
        elif not later or t < later[0][0]:
            assert x < x_w_p  # released: off the wall (until a later contact)
    assert n_stuck >= 2
    with pytest.raises(BudgetExceededError):
        AnalyticalSolver().solve(p, 2)


def test_start_on_wall_chatters_from_the_first_impact():
    """x0 = x_w, small v0 > 0 with the force pushing in, R = 1/2: the impact at t0
    starts a chattering sequence, which ends in sticking at its accumulation time."""
    p = Params.make(eta="0.2", a="1", x_w="0.5", x0="0.5", v0="1/10", R="1/2", t0="1")
    tr = HeyokaSolver("float64").solve(p, 1)
    assert float(tr.impacts_t[0]) == 1.0 and tr.v[0] == -0.05
    (ep, *_) = tr.stats["chattering"]
    assert ep["t_accumulation"] == tr.stats["sticking"][0][0]
    assert (
        1.3 < ep["t_accumulation"] < 1.55
    )  # ~ 1 + 2 R v0 / (g (1 - R)) = 1.42, g = cos(0.2) - 0.5
    assert ep["episode_impacts"] < 30


# --------------------------------------------------------------------------- exactly on a sample
def _eta_for(P: Precision, target, t0: Fraction, k: int) -> Fraction:
    """A rational eta whose k-th sample time t0 + 2 pi k / eta rounds exactly to ``target``."""
    with mpmath.workprec(3 * P.bits + 64):
        man, exp = mpmath.mpf(2 * mpmath.pi * k / (target - mpq(t0))).man_exp
    return Fraction(man) * Fraction(2) ** exp


def _ulp(P: Precision, m):
    return mpmath.ldexp(1, int(mpmath.floor(mpmath.log(abs(m), 2))) + 1 - P.bits)


def coincide(solver, base: Params, k: int, periods: int):
    """A run in which sample ``k`` lies exactly on the run's own first impact.

    With a = 0 the motion does not depend on eta, which only places the samples.
    Take the first impact time t_c of a longer run; choose eta so that sample k
    rounds exactly to t_c (or to a neighbour a few ulps away, since the computed
    impact time can move by an ulp when the step sequence near it changes) and
    re-run until the run's recorded impact and its sample k are the same number.
    """
    P = solver.precision
    tc = P.to_mpf(solver.solve(base, periods + 2).impacts_t[0])
    tried = []
    for j in (0, 1, -1, 2, -2, 3, -3):
        with mpmath.workprec(P.bits + 64):
            target = tc + j * _ulp(P, tc)
        for _ in range(3):
            if target in tried:
                break
            tried.append(target)
            tr = solver.solve(base.replace(eta=_eta_for(P, target, base.t0, k)), periods)
            assert P.to_mpf(tr.t[k]) == target
            if tr.n_impacts == 0:
                break
            if tr.impacts_t[0] == tr.t[k]:
                return tr
            target = P.to_mpf(tr.impacts_t[0])
    raise AssertionError("no run with an impact exactly on a sample found")


SOLVERS = [(HeyokaSolver, p) for p in PRECISIONS + ["mp:256"]] + [
    (lambda _: AnalyticalSolver(), "float64")
]


@pytest.mark.parametrize(
    "k, periods", [(1, 2), (3, 5), (1, 1), (2, 2)], ids=["sample-1", "sample-3", "end-1", "end-2"]
)
@pytest.mark.parametrize(
    "make, precision",
    SOLVERS,
    ids=[f"{'analytical' if m is not HeyokaSolver else 'heyoka'}-{p}" for m, p in SOLVERS],
)
def test_impact_exactly_on_a_sample_is_right_continuous(make, precision, k, periods):
    """An impact at exactly a sample time (k < periods) or the end time (k = periods):
    the sample holds the post-impact state (x_w, v_after) bit for bit and the
    impact is recorded (also at the end time).  Unforced (a = 0), damped, R = 1/2,
    t0 = 3/7.  (heyoka alone gave the pre-impact state at such a sample in
    longdouble and mp, and missed an impact exactly at the end time; the solver
    now integrates one output spacing past the end and sets the state.)"""
    base = Params.make(a="0", zeta="0.05", x_w="1", x0="-2", v0="0", R="1/2", eta="1/2", t0="3/7")
    solver = make(precision)
    tr = coincide(solver, base, k, periods)
    P = tr.precision
    assert tr.x[k] == P.from_fraction(base.x_w)
    assert tr.v[k] == tr.impacts_v_after[0] < 0
    assert tr.impacts_v_before[0] > 0
    # one sample earlier the mass is still on its way to the wall
    assert tr.x[k - 1] < P.from_fraction(base.x_w)


@pytest.mark.parametrize("precision", PRECISIONS)
def test_sample_zero_is_t0_exactly(precision):
    """t0 is sample 0 (rounded once from the exact rational), with the initial state."""
    p = Params.make(eta="0.74", x0="-1/3", v0="2/7", t0="22/7")
    tr = HeyokaSolver(precision).solve(p, 3, per_period=5)
    P = tr.precision
    assert tr.t[0] == tr.dense_t[0] == P.from_fraction(p.t0)
    assert (tr.x[0], tr.v[0]) == (P.from_fraction(p.x0), P.from_fraction(p.v0))
    with mpmath.workprec(P.bits + 64):
        T = 2 * mpmath.pi / mpq(p.eta)
        for j, t in enumerate(tr.t):
            assert abs(P.to_mpf(t) - (mpq(p.t0) + j * T)) <= P.eps_float * abs(P.to_mpf(t))
