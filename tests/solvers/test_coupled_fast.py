"""The master-slave pair on the compiled engine (``engine='fast'``) against heyoka.

The engine's premise, checked first: between impacts the position difference
``e = y - x`` obeys ``e'' + c1 e' + c0 e = 0`` in every form (``error_coefficients``),
so without impacts the fast and heyoka runs agree to round-off.  With impacts, before
chaos separates them, the two agree sample by sample and impact by impact; on the
diagonal the slave is the master bit for bit; sync statistics far from the threshold
agree; no dense sample lies beyond the wall (no missed impact of either oscillator).
"""

from __future__ import annotations

import math
import random
from fractions import Fraction as F

import numpy as np
import pytest

from precise_impact import ParameterError, Params
from precise_impact.analysis.sync import sync_scan
from precise_impact.solvers.heyoka.coupled import COUPLED_FORMS, simulate_coupled

EPS = 2.0**-52


@pytest.mark.parametrize("form", COUPLED_FORMS)
@pytest.mark.parametrize("k", ["0.05", "0.5"])
def test_smooth_flow_equals_heyoka(form, k):
    """No impacts (x_w = 1000): both integrate a damped linear system whose flow does not
    amplify errors (transient growth O(1)); heyoka commits <= eps |state| per step, the
    closed form a few eps per evaluation: the difference stays below 1e3 eps max|y|
    (measured <= 30 eps) over 50 periods, for every form: the coefficients c1, c0 of the
    difference equation are right."""
    p = Params.make(x_w="1000")
    a = simulate_coupled(p, k, form, 50, y0=("0.5", "0.3"), per_period=8, model="fast")
    b = simulate_coupled(p, k, form, 50, y0=("0.5", "0.3"), per_period=8)
    assert a.stats["engine"] == "fast" and len(a.master_impacts_t) == len(a.slave_impacts_t) == 0
    scale = max(1.0, float(np.abs(b.dense_y).max()))
    for u, v in ((a.dense_x, b.dense_x), (a.dense_y, b.dense_y), (a.dense_w, b.dense_w)):
        assert np.abs(u - np.asarray(v, float)).max() <= 1e3 * EPS * scale


@pytest.mark.parametrize("form", COUPLED_FORMS)
@pytest.mark.parametrize(
    "k, y0", [("0.031", ("-1", "0.5")), ("0.05", ("1.5", "0.3")), ("0.2", ("0.7", "-1"))]
)
def test_impacting_pair_equals_heyoka_until_chaos_separates_them(form, k, y0):
    """eta = 0.712 (chaotic master): two float64 methods differ by round-off that grows
    ~0.2 decimal digits per period (as for the single oscillator): <= 1e-15 x 10^(0.2 x 30)
    = 1e-9 at period 30, bound 1e-7 (measured <= 3e-9).  Impact sequences (master, slave,
    their times) are the same up to there.  (Which near-coincident pairs count as
    simultaneous may differ: heyoka's window is 64 eps (1 + |x_w|), the engine's also
    covers the evaluation error of the gap, ~1e-13 at t ~ 500.)"""
    p = Params.make(eta="0.712")
    a = simulate_coupled(p, k, form, 30, y0=y0, per_period=4, model="fast")
    b = simulate_coupled(p, k, form, 30, y0=y0, per_period=4)
    assert a.stats["engine"] == "fast"
    for u, v in ((a.dense_x, b.dense_x), (a.dense_y, b.dense_y)):
        assert np.abs(u - np.asarray(v, float)).max() <= 1e-7
    assert len(a.master_impacts_t) == len(b.master_impacts_t)
    assert len(a.slave_impacts_t) == len(b.slave_impacts_t)
    assert np.abs(a.slave_impacts_t - np.asarray(b.slave_impacts_t, float)).max() <= 1e-7


@pytest.mark.parametrize("form", COUPLED_FORMS)
def test_diagonal_start_stays_on_the_diagonal_bit_for_bit(form):
    """y0 = (x0, v0) and every coupling term exactly 0: e = 0 stays exactly 0, every impact
    is simultaneous, and the slave's samples are the master's."""
    tr = simulate_coupled(Params.make(eta="0.712"), "0.1", form, 200, model="fast")
    assert np.array_equal(tr.x, tr.y) and np.array_equal(
        tr.v if form != "first-order" else tr.v, tr.w
    )
    assert len(tr.master_impacts_t) == len(tr.slave_impacts_t) == tr.stats["simultaneous"] > 0


def test_no_dense_sample_lies_beyond_the_wall():
    """Missed-impact audit on random systems: 40 samples per period never put either
    oscillator beyond the wall by more than rounding (a missed impact would leave it
    there for a good part of a period)."""
    rng = random.Random(3)
    for _ in range(10):
        eta = F(rng.randint(600, 900), 1000)
        xw = F(rng.randint(100, 250), 100)
        form = rng.choice(COUPLED_FORMS)
        k = F(rng.randint(0, 300), 1000)
        p = Params.make(eta=eta, x_w=xw, R=F(rng.randint(70, 100), 100))
        tr = simulate_coupled(
            p,
            k,
            form,
            60,
            y0=(F(rng.randint(-150, 100), 100), F(rng.randint(-100, 100), 100)),
            per_period=40,
            model="fast",
        )
        assert tr.stats["engine"] == "fast"
        tol = 1e-12 * max(1.0, float(xw))
        assert tr.dense_x.max() <= float(xw) + tol and tr.dense_y.max() <= float(xw) + tol, (
            eta,
            xw,
            form,
            k,
        )


def test_sync_fractions_agree_with_heyoka_far_from_the_threshold():
    """Below the threshold (k = 0.005 < LLE 0.03) no run synchronises, above it (k = 0.1)
    every run does, with either engine; the fast LLE of the scan is the master's."""
    p = Params.make(eta="0.712")
    kw = dict(periods=300, ensemble=4, lle_periods=4000)
    f = sync_scan(p, "first-order", ["0.005", "0.1"], **kw)
    h = sync_scan(p, "first-order", ["0.005", "0.1"], model="heyoka", **kw)
    assert list(f.fraction_synchronised) == list(h.fraction_synchronised) == [0.0, 1.0]
    assert abs(f.lle - 0.0302) < 6 * f.lle_stderr + 2e-3


def test_overdamped_difference_equation_falls_back_to_heyoka():
    """The printed (14a) with k = 10: e'' + 11.1 e' + 21 e = 0 is overdamped (c1^2/4 > c0):
    the closed form is the underdamped one, so heyoka integrates the run and says so."""
    tr = simulate_coupled(Params.make(eta="0.712"), "10", "paper", 5, y0=("1", "0"), model="fast")
    assert (
        tr.stats["engine"].startswith("heyoka (fallback: ") and "underdamped" in tr.stats["engine"]
    )


def test_bad_engine_and_precision_are_named():
    p = Params.make()
    with pytest.raises(ParameterError, match="engine"):
        simulate_coupled(p, "0.1", engine="spice")  # the old spelling: still checked
    with pytest.raises(ParameterError, match="precision"):
        simulate_coupled(p, "0.1", model="fast", precision="mp:128")
    with pytest.raises(ParameterError, match="engine"):
        sync_scan(p, "first-order", ["0.1"], engine="gpu", lle_periods=0)
    assert math.isfinite(simulate_coupled(p, "0.1", periods=2, model="fast").x[-1])
