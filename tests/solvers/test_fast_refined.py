"""The fast engine through near-tangential contacts: double-double refinement inside the kernel.

* the double-double arithmetic (``solvers/fast/dd.py``) against mpmath at 300 bits, and its gap
  (``gap_dd``) against the core closed form (``core.flight.Flight``) in mpmath: one formula,
  pinned in every arithmetic;
* grazing orbits (the non-impacting steady state with the wall ``1e-15`` beyond or inside its
  amplitude: every maximum within float64's evaluation error of the wall): the compiled engine
  refines the flight instead of handing the whole run to heyoka, and each refined flight,
  replayed from its anchor with heyoka at 128 bits, ends in the state the engine computed;
* the LLE kernel, sweeps and domain-of-attraction maps take the same path (no whole-run
  fallback, an exact LLE ``-zeta`` where the wall is just missed).
"""

from __future__ import annotations

import math
import random
from decimal import Decimal
from fractions import Fraction

import mpmath
import numpy as np
import pytest

numba = pytest.importorskip(
    "numba", reason="the fast engine needs numba (pip install numba); CI installs it"
)

from precise_impact import Params, simulate  # noqa: E402
from precise_impact.analysis.impact_surface.basins import basins  # noqa: E402
from precise_impact.analysis.lyapunov.fast import fast_batch_rows, point_rows  # noqa: E402
from precise_impact.core.flight import Flight, MpmathOps, steady_coefficients  # noqa: E402
from precise_impact.core.flow import steady_state  # noqa: E402
from precise_impact.solvers.fast import dd  # noqa: E402
from precise_impact.solvers.fast.lle import fast_lle, lle_batch_serial  # noqa: E402
from precise_impact.solvers.fast.single import (  # noqa: E402
    DD_ERR,
    STATUS_SLOW_IMPACT,
    FastSolver,
    strobe,
)

EPS = float(np.finfo(float).eps)
MP = mpmath.MPContext()
MP.prec = 300


def _mp(h: float, lo: float = 0.0):
    return MP.mpf(h) + MP.mpf(lo)


def _exact(x: float) -> str:
    """A float64 as the decimal string of its exact value (a parameter the engine reads back
    bit for bit)."""
    return str(Decimal(x))


def _grazing(offset: float, eta: str = "0.712") -> Params:
    """The paper's system with the wall ``offset`` beyond the steady amplitude (negative: inside),
    started on the steady state at ``t0 = 0`` (no transient): every maximum of the motion is
    within ``|offset|`` of the wall."""
    p0 = Params.make(eta=eta)
    ss = steady_state(p0)
    amp = MP.sqrt(MP.mpf(ss.P) ** 2 + MP.mpf(ss.Q) ** 2)
    xw = _exact(float(amp + offset))
    return Params.make(eta=eta, x_w=xw, x0=_exact(float(ss.P)), v0=_exact(float(ss.eta * ss.Q)))


# ----------------------------------------------------------------- the arithmetic, pinned
def test_double_double_functions_against_mpmath():
    """cos/sin of |a| <= 300 to 2 units of 2^-104 absolute (Cody-Waite with pi/2 in three
    parts, 14 Taylor terms), exp relative to 4 units, division and root to 1 unit (measured:
    0.4, 2.1, 0.12, 0.4 units)."""
    rng = random.Random(7)
    worst = {"cs": 0.0, "exp": 0.0, "div": 0.0, "sqrt": 0.0}
    for _ in range(500):
        x = rng.uniform(-300, 300)
        xl = x * rng.uniform(-1e-17, 1e-17)
        ch, cl, sh, sl = dd.dd_cos_sin(x, xl)
        X = _mp(x, xl)
        worst["cs"] = max(worst["cs"], abs(_mp(ch, cl) - MP.cos(X)), abs(_mp(sh, sl) - MP.sin(X)))
        y = rng.uniform(-40, 5)
        eh, el = dd.dd_exp(y, y * 1e-17)
        worst["exp"] = max(worst["exp"], abs(_mp(eh, el) / MP.exp(_mp(y, y * 1e-17)) - 1))
        a, b = rng.uniform(0.1, 10), rng.uniform(0.1, 10)
        qh, ql = dd.dd_div(a, a * 1e-17, b, 0.0)
        worst["div"] = max(worst["div"], abs(_mp(qh, ql) / (_mp(a, a * 1e-17) / b) - 1))
        rh, rl = dd.dd_sqrt(a, a * 1e-17)
        worst["sqrt"] = max(worst["sqrt"], abs(_mp(rh, rl) / MP.sqrt(_mp(a, a * 1e-17)) - 1))
    units = {k: float(v) / dd.DD_EPS for k, v in worst.items()}
    assert units["cs"] <= 2 and units["exp"] <= 4, units
    assert units["div"] <= 1 and units["sqrt"] <= 1, units


def test_the_double_double_gap_is_the_core_flight():
    """gap_dd is core.flight.Flight (mpmath, 300 bits) from the same float64 inputs: x - x_w,
    x' and x'' within DD_ERR times the flight's scale, over 20 periods of local time."""
    rng = random.Random(3)
    ops = MpmathOps(bits=300)
    for _ in range(40):
        eta, zeta, a = rng.uniform(0.5, 1.5), rng.uniform(0.0, 0.3), rng.uniform(0.5, 2)
        xw, t0 = rng.uniform(0.3, 2.5), rng.uniform(0, 60)
        x0, v0 = rng.uniform(-2, xw), rng.uniform(-2, 2)
        dds = dd.dd_setup(t0, x0, v0, eta, zeta, a)
        P, Q = steady_coefficients(*(ops.mpf(u) for u in (eta, zeta, a)))
        wd = ops.sqrt(1 - ops.mpf(zeta) ** 2)
        f = Flight(
            P, Q, ops.mpf(eta), ops.mpf(zeta), wd, ops, ops.mpf(t0), ops.mpf(x0), ops.mpf(v0)
        )
        scale = abs(xw) + float(ops.sqrt(P * P + Q * Q)) + float(f.amplitude()) + 1
        for t in (t0 + rng.uniform(0, 20 * 2 * math.pi / eta) for _ in range(5)):
            gh, gl, gph, gpl, ah, al = dd.gap_dd(t, t0, eta, zeta, xw, *dds)
            x, v = f.at(ops.mpf(t))
            acc = a * ops.cos(ops.mpf(eta) * t) - 2 * zeta * v - x
            assert abs(_mp(gh, gl) - (x - xw)) <= DD_ERR * scale
            assert abs(_mp(gph, gpl) - v) <= DD_ERR * scale
            assert abs(_mp(ah, al) - acc) <= DD_ERR * scale


# ----------------------------------------------------------------------- refined flights
@pytest.mark.parametrize("offset", [1e-15, -1e-15])
def test_grazing_orbit_runs_on_the_compiled_engine(offset):
    """The wall 1e-15 beyond (inside) the steady amplitude: every maximum is within float64's
    evaluation error (~1e-13) of the wall.  Before: STATUS_CONTACT, the whole run to heyoka.
    Now every flight is refined in double-double and the run stays compiled."""
    p = _grazing(offset)
    tr = FastSolver(fallback=False).solve(p, 160)
    assert tr.stats["engine"] == "fast"
    if offset > 0:  # the wall is just missed: no impact at all, every flight (at most
        # FLIGHT_SAMPLES = 16 periods long) refined
        assert len(tr.impacts_t) == 0 and tr.stats["refined_flights"] >= 9
    else:  # just reached: an impact at ~sqrt(2 |x''| 1e-15) ~ 4.5e-8, which the grazing
        # bifurcation's square-root map then drives away from the wall (2.6e-4, 2e-2, ...)
        v = np.asarray(tr.impacts_v_before)
        assert tr.stats["refined_flights"] >= 1 and len(v) >= 2
        assert 1e-8 < v[0] < 1e-7 and v[1] > 1e2 * v[0], v[:3]


def _refined(q: Params, n: int) -> bool:
    return FastSolver(fallback=False).solve(q, n).stats["refined_flights"] >= 1


def _replay_tolerance(t: float, scale: float) -> float:
    """What one refined flight claims: the float64 clock's rounding (ulp(t) / 2 at an impact
    time, times the jump of x'' across it, <= 2 (|a| + |x_w| + |v|) ~ 2 scale), and float64
    evaluation of the flights that follow (64 eps scale, the engine's own err_scale), with a
    factor 4 to spare."""
    return 4 * (2 * scale * EPS * max(1.0, abs(t) + 2 * math.pi) + 64 * EPS * scale)


@pytest.mark.parametrize("seed", range(3))
def test_each_refined_flight_replayed_with_heyoka_at_128_bits(seed):
    """A seeded run near the grazing orbit (start perturbed by ~1e-13, so early maxima fall on
    either side of the wall); every refined flight it logged (up to 6 per seed) is replayed
    from its anchor ``(t, x, v)`` (the engine's local clock, floats taken as exact) by the
    compiled engine and by heyoka at 128 bits to the first sample after its contact: the
    states agree to what the run claims (:func:`_replay_tolerance`, ~1e-13)."""
    rng = random.Random(seed)
    p = _grazing(rng.choice([1e-15, -1e-15]))
    p = p.replace(
        x0=p.x0 + Fraction(rng.uniform(-1e-13, 1e-13)),
        v0=p.v0 + Fraction(rng.uniform(-1e-13, 1e-13)),
    )
    run = FastSolver(fallback=False).solve(p, 80)
    anchors = run.stats["refined_anchors"]
    assert run.stats["refined_flights"] >= 1 and anchors
    for _base, t, x, v in anchors[:6]:
        # the float64 system the engine ran (0.712 as a float is another system: near the wall
        # a 1e-17 change of eta moved this impact's speed by 4e-3 relative), from the anchor
        q = p.replace(
            **{k: Fraction(float(getattr(p, k))) for k in ("eta", "zeta", "a", "R")},
            t0=Fraction(t), x0=Fraction(x), v0=Fraction(v),
        )  # fmt: skip
        # the refined flight lasts up to FLIGHT_SAMPLES = 16 periods: the shortest replay of
        # 1, 2, 4, 8, 16 periods that reaches its contact (the engine refines it again)
        n = next(n for n in (1, 2, 4, 8, 16) if _refined(q, n))
        fast = FastSolver(fallback=False).solve(q, n)
        ref = simulate(q, n, precision="mp:128")
        scale = float(abs(p.x_w)) + 3.0
        tol = _replay_tolerance(t, scale)
        assert abs(fast.x[-1] - float(ref.x[-1])) <= tol, (t, fast.x[-1], ref.x[-1])
        assert abs(fast.v[-1] - float(ref.v[-1])) <= tol, (t, fast.v[-1], ref.v[-1])
        assert len(fast.impacts_t) == len(ref.impacts_t)


def test_lle_kernel_on_the_grazing_orbit_is_exactly_minus_zeta():
    """The wall just missed every period: the orbit is the non-impacting steady state, whose
    LLE is -zeta exactly (both exponents: the flow is linear with det exp(-2 zeta t)).  Every
    start's run is compiled (no fallback), refines every flight (16 periods each), and the LLE is
    -zeta up to the finite-time term log(||Phi|| ||Phi^-1||) / t <= log((1 + zeta / w)^2) / t
    (as test_fast.test_non_impacting_orbit_has_lle_minus_zeta; bound 0.2 / t)."""
    p = _grazing(1e-15)
    periods = 400
    r = fast_lle(p, periods=periods, transient=100, initial_conditions=1)
    assert r["status"] == ["ok"] and r["impacts"] == 0
    assert r["refined_flights"] >= 25, r["refined_flights"]
    t = periods * 2 * math.pi / 0.712
    assert abs(r["lle"] + 0.05) <= 0.2 / t and abs(r["lambda2"] + 0.05) <= 0.2 / t, r


def test_sweep_tile_across_the_grazing_set_stays_compiled():
    """A sweep's tile (fast_batch_rows) whose x_w axis crosses the grazing set: the walls 1e-15
    inside, on, and 1e-15 beyond the steady amplitude; no point goes to heyoka and each refines
    its flights."""
    pts = [_grazing(o) for o in (-1e-15, 0.0, 1e-15)]
    res = fast_batch_rows(point_rows(pts), lambda idx: [pts[i] for i in idx], 300, 100)
    assert [r["engine"] for r in res] == ["fast"] * 3
    # reached (offset <= 0): the first refined flight's impact launches the orbit off the wall
    # (see test_grazing_orbit_runs_on_the_compiled_engine); missed: every flight refined
    assert [r["refined_flights"] >= 1 for r in res] == [True] * 3, res
    assert res[2]["refined_flights"] >= 20 and res[2]["impacts_per_period"] == 0
    # the wall missed: non-impacting, -zeta up to the finite-time term (bound 0.2 / t as above)
    assert abs(res[2]["lle"] + 0.05) <= 0.2 / (300 * 2 * math.pi / 0.712)


def test_basins_grid_on_the_grazing_orbit_has_no_grazing_cells():
    """A domain-of-attraction map on the stroboscopic section around the grazing orbit (wall
    1e-15 beyond its amplitude), the starts within 3e-16 of it: their maxima stay within
    float64's error of the wall without reaching it (a start 1e-3 away reaches it and goes to
    the chaotic attractor).  Before: cells labelled 'grazing contact' (the float64 engine does
    not decide); now every cell is the non-impacting orbit."""
    p = _grazing(1e-15)
    x0, v0 = float(p.x0), float(p.v0)
    res = basins(
        p, ((x0 - 3e-16, x0 + 3e-16, 3), (v0 - 3e-16, v0 + 3e-16, 3)), section="stroboscopic",
        transient=60, max_period=4, chaos_periods=100, refine=False, workers=1,
    )  # fmt: skip
    kinds = {res.attractors[i]["kind"] for i in np.asarray(res.labels).ravel().tolist()}
    assert kinds == {"non-impacting"}, kinds


def test_chatter_grid_stops_before_refining_the_chatter_tail():
    """A chatter map (eta 4.85, zeta 0, R 0.5, x_w -0.3: every start chatters into sticking):
    the late hops of a chatter start at the wall with post-impact speed ~1e-9..1e-6, inside
    float64's error band, and each would be refined in double-double (~200 us) down to the
    speed floor (measured: 1415 refined flights of 144 starts, ~10 per start).  The kernel
    stops at the chatter's tail (``chatter_tail``: STATUS_SLOW_IMPACT, heyoka's chattering
    rule) with at most a few refined flights per episode, and the recorded impacts end in a
    falling sequence under a wall force pushing into the wall (basins' ``_sticks`` rule); the
    LLE kernel too (measured before: 9-10 refined flights per start)."""
    eta, zeta, a, xw, R = 4.85, 0.0, 1.0, -0.3, 0.5
    n, refined = 60, []
    for ph in np.linspace(0, 1, 6, endpoint=False):
        for v in np.linspace(0.01, 0.6, 6):
            it, iv = np.empty(100000), np.empty(100000)
            xs, vs, ts = np.empty(n + 1), np.empty(n + 1), np.empty(n + 1)
            st, ni, _, ref = strobe(
                eta, zeta, a, xw, R, ph * 2 * math.pi / eta, xw, -v, n, 1, 1000 * n,
                it, iv, xs, vs, ts, np.empty((0, 4)),
            )  # fmt: skip
            assert st == STATUS_SLOW_IMPACT, (ph, v, st)
            last = iv[:ni][-3:]
            assert ni >= 3 and last[2] < last[1] < last[0] < 1e-4, (ph, v, last)
            assert a * math.cos(eta * it[ni - 1]) - xw > 0.0, (ph, v)
            refined.append(int(ref))
    assert max(refined) <= 2, refined
    # the LLE kernel (sweeps, basins' chaos test) stops the same way
    pars = np.array([[eta, zeta, a, xw, R]] * 8)
    starts = np.array([[0.1 * j, xw, -0.05 - 0.07 * j] for j in range(8)])
    status, *_, refined_lle = lle_batch_serial(pars, starts, 60, 0, 3, 10**6, 1)
    assert status.tolist() == [STATUS_SLOW_IMPACT] * 8 and max(refined_lle) <= 2, refined_lle
