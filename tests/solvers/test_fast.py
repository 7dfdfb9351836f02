"""The fast engine (compiled closed forms, float64) against independent references.

* heyoka (the reference, another method): the period-3 orbit at eta = 0.74 over 300
  periods, the chaotic orbit at eta = 0.712 up to period 40 (the two float64 results
  separate by ~0.2 decimal digits per period there: bound 1e-6), equal impact sequences;
* exact checks: the exponents sum to -2 zeta + (impact rate) ln R^2 (to rounding: each
  saltation determinant is exactly R^2 in exact arithmetic), a non-impacting orbit has
  LLE = -zeta, the chaotic LLE at eta = 0.712 is 0.0302;
* the compiled saltation matrix equals core.impact.oscillator_saltation (one home);
* a missed-impact audit: identical impact sequences with heyoka on random parameter sets
  and on grazing orbits.
"""

from __future__ import annotations

import math
import random

import numpy as np
import pytest

numba = pytest.importorskip(
    "numba", reason="the fast engine needs numba (pip install numba); CI installs it"
)

from precise_impact import Params, simulate  # noqa: E402
from precise_impact.core.impact import oscillator_saltation  # noqa: E402
from precise_impact.solvers.fast.lle import fast_lle  # noqa: E402
from precise_impact.solvers.fast.single import FastSolver, compiled_saltation  # noqa: E402

EPS = np.finfo(float).eps


def test_period_three_orbit_agrees_with_heyoka_over_300_periods():
    """A stable orbit against heyoka mp:113 (the truth to ~1e-30 here): perturbations decay,
    so the error stays at the level of the float64 clock, the rounding of the sample and
    impact times ``t ~ eps t_end`` times the speed (bound ``4 eps t_end max|v|`` = 5.7e-12;
    measured 1.6e-12, heyoka float64 1.1e-12).  Impact counts and times agree."""
    p = Params.make(eta="0.74")
    f, ref, h = FastSolver().solve(p, 300), simulate(p, 300, precision="mp:113"), simulate(p, 300)
    t_end, v_max = float(ref.t[-1]), max(abs(float(v)) for v in ref.v)
    bound = 4 * EPS * t_end * v_max
    err = np.max(np.abs(np.asarray(f.x) - np.array([float(x) for x in ref.x])))
    assert err <= bound, (err, bound)
    assert len(f.impacts_t) == len(ref.impacts_t) == len(h.impacts_t)
    assert (
        np.max(np.abs(np.asarray(f.impacts_t) - np.array([float(t) for t in ref.impacts_t])))
        <= 4 * EPS * t_end
    )


def test_chaotic_orbit_agrees_with_heyoka_until_chaos_separates_them():
    """Two float64 methods differ by rounding (~1e-15 after the first impacts); on this orbit
    the difference grows ~0.2 decimal digits per period over the first 50 (the finite-time
    rate near grazing exceeds the 0.13 average): 1e-15 x 10^(0.2 x 40) = 1e-7 at period 40,
    bound 1e-6.  The impact counts agree."""
    p = Params.make(eta="0.712")
    f, h = FastSolver().solve(p, 40), simulate(p, 40)
    err = np.abs(np.asarray(f.x) - np.asarray(h.x, float))
    assert err.max() <= 1e-6, err.max()
    assert len(f.impacts_t) == len(h.impacts_t)


def test_compiled_saltation_is_the_core_one():
    rng = random.Random(1)
    for _ in range(50):
        t, vm = rng.uniform(0, 100), rng.uniform(1e-3, 2)
        eta, zeta, a, xw, R = (
            rng.uniform(0.2, 2),
            rng.uniform(0, 0.5),
            rng.uniform(-2, 2),
            rng.uniform(-2, 2),
            rng.uniform(0, 1),
        )
        core = oscillator_saltation(t, vm, eta, zeta, a, xw, R, math.cos)
        fast = compiled_saltation(t, vm, eta, zeta, a, xw, R)
        ref = [core[0][0], core[0][1], core[1][0], core[1][1]]
        assert all(
            abs(x - y) <= 8 * EPS * max(1.0, abs(y)) for x, y in zip(fast, ref, strict=True)
        ), (fast, ref)


@pytest.mark.parametrize("R", ["1", "0.8"])
def test_exponents_sum_exactly(R):
    """Liouville with saltation: lambda1 + lambda2 = -2 zeta + (impacts per unit time) ln R^2.
    Each QR step's logs sum to log|det| to rounding: 4 eps per period over 7000 periods,
    divided by the measured time: bound 1e-12."""
    p = Params.make(eta="0.712", R=R)
    r = fast_lle(p, periods=3000, transient=500)
    T = 2 * math.pi / 0.712
    rate = r["impacts"] / (len(r["per_start"]) * 3000 * T)
    for s in r["per_start"]:
        expected = -0.1 + (s["impacts"] / (3000 * T)) * math.log(float(Params.make(R=R).R) ** 2)
        assert abs(s["lle"] + s["lambda2"] - expected) <= 1e-12, (s, expected)
    assert rate > 0


def test_non_impacting_orbit_has_lle_minus_zeta():
    """eta = 0.5: the steady state stays clear of the wall; both exponents are -zeta
    (complex pair of the linear flow).  The finite-time estimate differs from -zeta only
    by log(||Phi|| ||Phi^-1||) / t <= log((1 + zeta / w)^2) / t ~ 0.1 / t (the flow matrix
    is not normal; the basis is never restarted): bound 0.2 / t."""
    periods = 2000
    r = fast_lle(Params.make(eta="0.5"), periods=periods, transient=200)
    t = periods * 2 * math.pi / 0.5
    assert r["impacts"] == 0
    assert abs(r["lle"] + 0.05) <= 0.2 / t and abs(r["lambda2"] + 0.05) <= 0.2 / t, r


def test_chaotic_lle_matches_the_variational_reference():
    """eta = 0.712: LLE 0.0302 (heyoka variational over 10^6 periods: 0.03012 +- 0.00005);
    4 x 6000 periods give a standard error ~0.0005: bound 4 standard errors + 0.0005."""
    r = fast_lle(Params.make(eta="0.712"), periods=6000, transient=1000)
    assert all(s == "ok" for s in r["status"])
    assert abs(r["lle"] - 0.03012) <= 4 * r["stderr"] + 5e-4, r


def _impacts(tr):
    return np.asarray(tr.impacts_t, float)


def _same_impacts(ta, tb, xa, xb, t_samples, T):
    """Identical impact sequences up to where chaos separates the two orbits (samples
    apart by > 1e-6): every impact time before that agrees to 1e-6."""
    k = min(len(ta), len(tb))
    close = np.abs(ta[:k] - tb[:k]) <= 1e-6 * np.maximum(1, np.abs(tb[:k]))
    first_far = int(np.argmin(close)) if not close.all() else k
    far = np.abs(xa - xb) > 1e-6
    t_sep = float(t_samples[int(np.argmax(far))]) if far.any() else math.inf
    if first_far == k:
        return len(ta) == len(tb) or t_sep < math.inf
    return tb[first_far] >= t_sep - T


@pytest.mark.parametrize("seed", range(12))
def test_missed_impact_audit_random_parameters(seed):
    """Random systems around the paper's (eta 0.5-1.2, zeta 0.01-0.3, a 0.5-2, x_w 0.3-2.5,
    R 0.6-1): the fast engine, the robust analytical finder and heyoka see the same
    impacts until chaos separates the orbits."""
    rng = random.Random(seed)
    p = Params.make(
        eta=f"{rng.uniform(0.5, 1.2):.4f}",
        zeta=f"{rng.uniform(0.01, 0.3):.3f}",
        a=f"{rng.uniform(0.5, 2):.3f}",
        x_w=f"{rng.uniform(0.3, 2.5):.3f}",
        R=f"{rng.uniform(0.6, 1):.3f}",
    )
    f = FastSolver(fallback=False).solve(p, 30)
    h = simulate(p, 30)
    an = simulate(p, 30, model="analytical")
    T = 2 * math.pi / float(p.eta)
    ts = np.asarray(h.t, float)
    xf, xh, xa = np.asarray(f.x), np.asarray(h.x, float), np.asarray(an.x, float)
    assert _same_impacts(_impacts(f), _impacts(h), xf, xh, ts, T), seed
    assert _same_impacts(_impacts(f), _impacts(an), xf, xa, ts, T), seed


@pytest.mark.parametrize("depth", [1e-4, 1e-8, 1e-12])
def test_missed_impact_audit_grazing(depth):
    """Excursions 1e-4 .. 1e-12 beyond the wall: the non-impacting steady state with the wall
    moved in by ``depth`` below its amplitude.  Both engines see the same first impact (a
    1e-12-deep one lasts ~2e-6 time units: a scan with step 1e-3 T misses it)."""
    from precise_impact.core.flow import steady_state

    p0 = Params.make(eta="0.5")
    amp = math.sqrt(float(steady_state(p0).amplitude_squared))
    xw = f"{amp - depth:.17g}"
    # start on the steady state (no transient): x = P, v = eta Q at t = 0
    ss = steady_state(p0)
    p = Params.make(eta="0.5", x_w=xw, x0=f"{float(ss.P):.17g}", v0=f"{float(ss.Q) * 0.5:.17g}")
    f = FastSolver(fallback=False).solve(p, 3)
    h = simulate(p, 3)
    an = simulate(p, 3, model="analytical")
    tf, th, ta = _impacts(f), _impacts(h), _impacts(an)
    assert len(tf) >= 1 and len(th) >= 1 and len(ta) >= 1
    assert abs(tf[0] - th[0]) <= 1e-6 and abs(tf[0] - ta[0]) <= 1e-6


def test_lyapunov_method_fast_is_the_variational_spectrum():
    """Same quantity, two engines (heyoka's variational ODE and the compiled closed form):
    periodic eta = 0.74 has a negative LLE whose two estimates agree to their error bars
    (both measure the same orbit; the basis restart after the transient differs: a
    finite-time offset ~ 1/(periods T)), and the spectra sum to -2 zeta (R = 1) to 1e-12."""
    from precise_impact import lyapunov

    p = Params.make(eta="0.74")
    f = lyapunov(p, "variational", model="fast", periods=4000, transient=500)
    v = lyapunov(p, "variational", periods=4000, transient=500)
    assert f.method == "fast" and f.stats["engine"] == "fast"
    assert abs(sum(f.spectrum) + 0.1) <= 1e-12 and abs(sum(v.spectrum) + 0.1) <= 1e-12
    offset = 2.0 / (1000 * 2 * math.pi / 0.74)  # log(cond) / (periods per start x T)
    assert abs(f.lle - v.lle) <= 4 * math.hypot(f.lle_stderr, v.stderr) + offset, (f.lle, v.lle)


def test_sweep_engines_agree_on_periods_and_impact_rates(tmp_path):
    """A small map with both engines: identical detected periods and impact rates on the
    periodic points, LLEs within the error bars plus the finite-time offset."""
    from precise_impact import SweepSpec, run_sweep

    axes = [("eta", "0.73", "0.75", 3)]
    res = {}
    for eng in ("fast", "heyoka"):
        spec = SweepSpec.make(
            Params.make(), axes, periods=600, transient=400, tile_size=3, model=eng
        )
        res[eng] = run_sweep(spec, tmp_path / eng, workers=1, progress=False)
    f, h = res["fast"], res["heyoka"]
    assert (
        np.array_equal(f.period, h.period) and np.sum(f.period > 0) >= 2
    )  # eta = 0.73: no period <= 32
    per = f.period > 0
    assert np.allclose(f.impacts_per_period[per], h.impacts_per_period[per], atol=2 / 600)
    offset = 2.0 / (600 * 2 * math.pi / 0.75)
    assert np.all(np.abs(f.lle - h.lle)[per] <= 4 * np.hypot(f.stderr, h.stderr)[per] + offset)


def test_fast_model_through_the_public_api_and_its_fallback():
    tr = simulate(Params.make(eta="0.74"), 20, model="fast")
    assert tr.model == "fast" and tr.stats["engine"] == "fast"
    # a start at rest on the wall (a sticking decision): heyoka does it, and says so
    p = Params.make(eta="0.74", x_w="0.5", x0="0.5", v0="0", R="0.5")
    tr = simulate(p, 5, model="fast")
    assert tr.stats["engine"].startswith("heyoka (fallback")
    with pytest.raises(Exception) as e:
        simulate(p, 5, model="fast", precision="mp:128")
    assert getattr(e.value, "name", None) == "precision"


@pytest.mark.parametrize("seed", range(8))
def test_no_dense_sample_lies_beyond_the_wall(seed):
    """An independent no-miss check: a missed impact lets the mass through the wall for a
    stretch of ~ its speed / |x''| (>= 1e-6 time units for the impacts of these systems), so
    1000 dense samples per period would catch it.  Every sample stays within rounding
    (64 eps x scale) of the wall on the inside."""
    rng = random.Random(100 + seed)
    p = Params.make(
        eta=f"{rng.uniform(0.5, 1.2):.4f}",
        zeta=f"{rng.uniform(0.01, 0.3):.3f}",
        a=f"{rng.uniform(0.5, 2):.3f}",
        x_w=f"{rng.uniform(0.3, 2.5):.3f}",
        R=f"{rng.uniform(0.6, 1):.3f}",
    )
    tr = FastSolver(fallback=False).solve(p, 40, per_period=1000)
    scale = 1 + abs(float(p.x_w)) + abs(float(p.a))
    assert np.max(np.asarray(tr.dense_x) - float(p.x_w)) <= 64 * EPS * scale


def _fast_lle_in_child(_):
    import precise_impact as pi

    r = pi.lyapunov(pi.Params.make(eta="0.712"), model="fast", periods=600, transient=100)
    return r.lle, r.n_impacts


def test_a_child_forked_after_a_fast_run_gets_the_same_exponent():
    """GNU OpenMP's threads do not survive fork(): a child forked after the parent's parallel
    kernel ran printed "Terminating: fork() called ..." and returned LLE 0.0 with no impacts.
    The child now runs the serial kernel: the same numbers as the parent's, bit for bit."""
    import multiprocessing

    parent = _fast_lle_in_child(0)
    with multiprocessing.get_context("fork").Pool(1) as pool:
        child = pool.map(_fast_lle_in_child, [0])[0]
    assert parent[1] > 0 and child == parent
