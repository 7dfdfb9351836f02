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
    # the fast engine priced as itself (2/30 of a heyoka float64 period), not as heyoka
    bif_fast = estimate_cost("bifurcation", periods=2000, transient=1000, runs=50, model="fast")
    assert bif_fast.seconds == pytest.approx(50 * (2 / 30 * 3000 * 1e-5 + 3001 * 1e-6))
    sweep = estimate_cost("sweep", periods=2000, transient=1000, runs=10**4)
    assert sweep.seconds == pytest.approx(10**4 * (2 / 30 * 3000 * 1e-5 + 3001 * 1e-6))
    sweep_heyoka = estimate_cost("sweep", periods=2000, transient=1000, runs=10**4, model="heyoka")
    assert sweep_heyoka.seconds == pytest.approx(10**4 * (4 * 3000 * 1e-5 + 3001 * 1e-6))
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
    assert set(JOBS) == {"simulate", "scene", "lle", "bifurcation", "sync", "certify", "sweep"}


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


def test_the_fast_engine_is_priced_as_itself():
    """A fast bifurcation was priced as heyoka variational runs (30x over) and refused at a
    budget it fits in: 100 x 11000 periods ~1.8 s fast, ~23 s as heyoka."""
    enforce_max_time(10, "bifurcation", periods=10**4, transient=1000, runs=100, model="fast")
    with pytest.raises(OverBudgetError):
        enforce_max_time(10, "bifurcation", periods=10**4, transient=1000, runs=100)
    # a sweep: the fast kernel, or heyoka's SIMD batch; checked per worker
    enforce_max_time(60, "sweep", periods=2000, transient=1000, runs=10**4)  # ~50 s
    with pytest.raises(OverBudgetError):
        enforce_max_time(60, "sweep", periods=2000, transient=1000, runs=10**4, model="heyoka")
    spec = pi.SweepSpec.make(pi.Params.make(), [("eta", "0.6", "0.9", 1000)])
    with pytest.raises(OverBudgetError, match="max_time"):
        pi.run_sweep(spec, "/nonexistent/never-written", workers=1, max_time=1)


def test_a_fast_lle_falls_back_to_heyoka_only_within_what_is_left_of_its_budget(capsys):
    """Issue 28: an orbit the fast engine does not resolve reran the whole estimate on heyoka,
    whatever the budget (1e7 periods with max_time=70: no result after 90 s).  Now heyoka's
    estimate (~14 min here) is checked against the time left: refused at once (exit 3 in
    the CLI); a fallback that fits runs and says so."""
    over = pi.Params.make(eta="0.712", zeta="1.2")  # outside the closed form: falls back
    t = time.perf_counter()
    with pytest.raises(BudgetExceededError, match="heyoka would take") as e:
        pi.lyapunov(over, "variational", model="fast", periods=10**7, max_time=70)
    assert time.perf_counter() - t < 2.0 and "left of max_time = 70 s" in str(e.value)
    assert not isinstance(e.value, ParameterError)  # a budget met mid-run, not bad input
    r = pi.lyapunov(
        over, "variational", model="fast", periods=40, transient=10, max_time=70, progress=True
    )
    assert r.stats["engine"] == "heyoka variational (fallback: zeta >= 1)"
    err = capsys.readouterr().err
    assert "computed by heyoka instead" in err and "zeta >= 1" in err


def test_the_cli_refuses_a_fallback_over_budget_with_exit_3(capsys, monkeypatch):
    import signal

    from precise_impact.cli.main import main

    monkeypatch.setattr(signal, "signal", lambda *a: None)  # main() leaves SIGTERM alone here
    t = time.perf_counter()
    code = main(
        ["lle", "--model", "fast", "--zeta", "1.2", "--periods", "10000000", "--max-time", "70"]
    )
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 3 and len(lines) == 1 and "heyoka would take" in lines[0], lines
    assert time.perf_counter() - t < 2.0
    code = main(["lle", "--model", "fast", "--periods", "100000000", "--max-time", "60"])
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 3 and len(lines) == 1 and "over budget: max_time" in lines[0], lines
