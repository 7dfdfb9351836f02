"""Per-job cost estimates live in the API (estimate_cost) and the API enforces max_time itself."""

from __future__ import annotations

import time

import pytest

import precise_impact as pi
from precise_impact.analysis.bifurcation import bifurcation
from precise_impact.analysis.sync import sync_scan
from precise_impact.core.budget import JOBS, enforce_max_time, estimate_cost, run_cost
from precise_impact.core.precision import Precision
from precise_impact.errors import BudgetExceededError, OverBudgetError, ParameterError

F64 = Precision.parse("float64")


def test_job_estimates():
    # float64: 1e-5 s per period, 1e-6 s per sample (core/budget.py)
    lle = estimate_cost("lle", periods=20000, transient=1000)
    assert lle.seconds == pytest.approx(4 * (2 * 21000 * 1e-5 + 21001 * 1e-6))
    assert lle.bytes == 0 and lle.what == "4 x 21000 periods in float64"
    fast = estimate_cost("lle", periods=20000, transient=1000, model="fast")
    assert fast.seconds == pytest.approx(4 * (2 / 30 * 21000 * 1e-5 + 21001 * 1e-6))
    sim = estimate_cost("simulate", periods=100, per_period=10, precision="float128")
    assert sim.seconds == pytest.approx(100 * 6e-4 + 1001 * 2e-5) and sim.bytes == 1001 * 200
    bif = estimate_cost("bifurcation", periods=2000, transient=1000, runs=50)
    assert bif.seconds == pytest.approx(50 * (2 * 3000 * 1e-5 + 3001 * 1e-6))
    sync = estimate_cost("sync", periods=500, per_period=20, runs=48, model="heyoka")
    assert sync.seconds == pytest.approx(48 * (4 * 500 * 1e-5 + 10001 * 1e-6))
    sync_fast = estimate_cost("sync", periods=500, per_period=20, runs=48, model="fast")
    assert sync_fast.seconds < sync.seconds
    single = estimate_cost("scene", periods=100, model="heyoka")
    circuit = estimate_cost("scene", periods=100, model="circuit")
    pair = estimate_cost("scene", periods=100, model="heyoka", coupled=True)
    assert circuit.seconds == pair.seconds == pytest.approx(4 * 100 * 1e-5 + 101 * 1e-6)
    assert single.seconds == pytest.approx(100 * 1e-5 + 101 * 1e-6)


def test_unknown_job_and_old_signature():
    with pytest.raises(ParameterError, match="job"):
        estimate_cost("orbit", periods=10)
    with pytest.warns(DeprecationWarning, match="run_cost"):
        old = estimate_cost(F64, 100, 10, factor=2)
    assert old == run_cost(F64, 100, 10, factor=2)
    assert set(JOBS) == {"simulate", "scene", "lle", "bifurcation", "sync", "certify"}


def test_enforce_max_time():
    enforce_max_time(None, "lle", periods=10**8)  # no budget: nothing checked
    enforce_max_time(60, "lle", periods=100)
    with pytest.raises(OverBudgetError, match="max_time") as e:
        enforce_max_time(60, "lle", periods=10**7)
    assert isinstance(e.value, BudgetExceededError) and e.value.name == "max_time"
    enforce_max_time(60, "bifurcation", scale=100, periods=10**5, runs=100)
    with pytest.raises(OverBudgetError):
        enforce_max_time(60, "bifurcation", scale=1, periods=10**5, runs=100)
    with pytest.raises(ParameterError, match="1 <= max_time"):
        enforce_max_time(0, "lle", periods=10)


def _refused_quickly(call):
    t = time.perf_counter()
    with pytest.raises(OverBudgetError) as e:
        call()
    assert time.perf_counter() - t < 2.0  # before any work
    return e.value


def test_the_api_enforces_max_time():
    p = pi.Params.make(eta="0.712")
    e = _refused_quickly(lambda: pi.simulate(p, 10**6, precision="mp:2048", max_time=60))
    assert e.name == "max_time" and "10^6" not in str(e) and "1000000 periods" in str(e)
    _refused_quickly(lambda: pi.lyapunov(p, periods=10**7, max_time=60))
    _refused_quickly(
        lambda: pi.lyapunov(p, "variational", model="fast", periods=10**8, max_time=10)
    )
    _refused_quickly(
        lambda: bifurcation(p, ("eta", "0.7", "0.8", 1000), periods=10**5, workers=1, max_time=10)
    )
    _refused_quickly(
        lambda: sync_scan(
            p, "first-order", ["0.02", "0.03"], periods=10**5, ensemble=100, max_time=10
        )
    )
    # within the budget the run is the one without it (same numbers)
    a = pi.simulate(p, 5, max_time=60)
    b = pi.simulate(p, 5)
    assert list(a.x) == list(b.x)
    r = pi.lyapunov(p, "variational", model="fast", periods=200, transient=10, max_time=60)
    assert r.periods == 200
