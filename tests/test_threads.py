"""Thread safety: solves from several threads give the serial results bit for bit.

A compiled heyoka integrator is mutable state (time, state, parameters, event
callbacks).  Before the one integrator cache (``precise_impact.solvers.heyoka.cache``)
handed out private copies, 4 threads sharing one cached integrator raised in 13 of
20 runs and silently returned different numbers in 2 of 20.  Here every run in a
thread must equal its serial twin exactly (``np.array_equal``, no tolerance:
the same arithmetic in the same order gives the same bits).
"""

from __future__ import annotations

import importlib.util
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from precise_impact import HeyokaSolver, Params
from precise_impact.analysis.lyapunov import lyapunov
from precise_impact.analysis.lyapunov.batch import batch_lle
from precise_impact.analysis.sweep import SweepSpec, load_sweep, run_sweep

THREADS, RUNS = 4, 20

# Different parameters per run, so that a run reading another run's integrator
# state (time, parameters, recorder) shows up as a wrong number.
ETAS = [f"0.{700 + 3 * i}" for i in range(RUNS)]


def _in_threads(fn, args):
    """``fn(arg)`` for every arg, THREADS at a time, started together."""
    with ThreadPoolExecutor(max_workers=THREADS) as pool:
        return list(pool.map(fn, args))


def _trajectory_key(tr):
    arrays = (tr.t, tr.x, tr.v, tr.impacts_t, tr.impacts_v_before, tr.impacts_v_after)
    return tuple(np.asarray(a, dtype=float) for a in arrays)


def _same(a, b) -> bool:
    return len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))


def test_heyoka_solve_from_threads_is_bit_identical():
    def run(eta):
        return _trajectory_key(HeyokaSolver("float64").solve(Params.make(eta=eta), 30))

    serial = [run(eta) for eta in ETAS]
    threaded = _in_threads(run, ETAS)
    bad = [eta for eta, s, t in zip(ETAS, serial, threaded, strict=True) if not _same(s, t)]
    assert not bad, f"threaded solves differ from serial ones at eta = {bad}"


def test_one_solver_object_shared_by_threads_is_bit_identical():
    """One HeyokaSolver used by every thread: its solves take turns on its own integrator."""
    solver = HeyokaSolver("float64")

    def run(eta):
        return _trajectory_key(solver.solve(Params.make(eta=eta), 30))

    serial = [run(eta) for eta in ETAS]
    threaded = _in_threads(run, ETAS)
    assert all(_same(s, t) for s, t in zip(serial, threaded, strict=True))


def test_simulate_reuses_a_solver_per_thread_bit_identically():
    """``simulate`` keeps one heyoka solver per thread and setting: every call, in any order
    and from any thread, equals a solve by a brand-new solver (a fresh copy of the compiled
    integrator), so the reuse leaves no state behind."""
    from precise_impact import simulate

    fresh = {
        eta: _trajectory_key(HeyokaSolver("float64").solve(Params.make(eta=eta), 30))
        for eta in ETAS
    }

    def run(eta):
        return _trajectory_key(simulate(Params.make(eta=eta), 30))

    order = ETAS + ETAS[::-1]
    assert all(_same(run(eta), fresh[eta]) for eta in order)
    threaded = _in_threads(run, order)
    assert all(_same(t, fresh[eta]) for t, eta in zip(threaded, order, strict=True))


def test_variational_lle_from_threads_is_bit_identical():
    def run(eta):
        r = lyapunov(
            Params.make(eta=eta), periods=60, transient=20, initial_conditions=1, segments=2
        )
        return (np.array([r.lle, r.spectrum[0], r.spectrum[1], r.n_impacts]), r.running)

    serial = [run(eta) for eta in ETAS]
    threaded = _in_threads(run, ETAS)
    assert all(_same(s, t) for s, t in zip(serial, threaded, strict=True))


def test_batch_lle_from_threads_is_bit_identical():
    groups = [[Params.make(eta=eta)] for eta in ETAS]

    def run(points):
        rows = batch_lle(points, periods=60, transient=20, segments=2, batch_size=4)
        return tuple(
            np.array(
                [
                    row["lle"],
                    row["stderr"],
                    row["lambda2"],
                    row["period"],
                    row["impacts_per_period"],
                ]
            )
            for row in rows
        )

    serial = [run(g) for g in groups]
    threaded = _in_threads(run, groups)
    assert all(_same(s, t) for s, t in zip(serial, threaded, strict=True))


@pytest.mark.skipif(
    importlib.util.find_spec("distributed") is None,
    reason="Dask is an optional extra (pip install 'precise_impact[dask]'); CI installs it",
)
def test_sweep_on_a_threaded_dask_worker_is_bit_identical(tmp_path):
    """Dask workers run several threads by default: tiles computed concurrently in
    one process must equal the serial sweep bit for bit."""
    from dask.distributed import LocalCluster

    spec = SweepSpec.make(
        Params.make(),
        [("eta", "0.70", "0.75", 4), ("x_w", "1.9", "2.1", 3)],
        periods=120,
        transient=60,
        tile_size=2,
    )
    run_sweep(spec, tmp_path / "serial", workers=1, progress=False)
    # processes=False: the worker's THREADS threads share this process (and the one
    # integrator cache) with each other and with the serial run above.
    with LocalCluster(
        n_workers=1,
        threads_per_worker=THREADS,
        processes=False,
        protocol="tcp://",
        dashboard_address=None,
    ) as cluster:
        s = run_sweep(spec, tmp_path / "threads", dask=cluster.scheduler_address, progress=False)
    assert s.complete
    a, b = load_sweep(tmp_path / "serial", spec), load_sweep(tmp_path / "threads", spec)
    for f in ("lle", "stderr", "lambda2", "period", "impacts_per_period"):
        assert np.array_equal(a[f], b[f], equal_nan=True), f


# ---------------------------------------------------------------------------- mpmath
# mpmath's working precision is process-global (``mpmath.mp``, set by ``workprec``/``workdps``):
# before every mpmath computation had a context of its own, a thread working at another
# precision changed the results of one_impact_orbits (6 of 8 threaded calls), find_orbit
# mp (8 of 8) and the mpmath analytical solver (2 of 8 differed, 4 of 8 raised a spurious
# BudgetExceededError "no progress").


def _mp_key(obj):
    """Bits of a result: mpmath numbers by their raw tuples (``repr`` depends on mp.dps)."""
    if hasattr(obj, "_mpf_"):
        return ("f", obj._mpf_)
    if hasattr(obj, "_mpc_"):
        return ("c", obj._mpc_)
    if isinstance(obj, (list, tuple, np.ndarray)):
        return tuple(_mp_key(x) for x in obj)
    if isinstance(obj, float):
        return obj.hex()
    return str(obj)  # heyoka reals print round-trip digits


def _one_impact():
    from precise_impact.analysis.orbits.one_impact import one_impact_orbits

    orbits = one_impact_orbits(Params.make(R="0.8", eta="1"), dps=40, grid=100)
    return _mp_key([(o.x, o.v, o.multipliers, o.lle, o.precision) for o in orbits])


def _find_orbit_mp():
    from precise_impact.analysis.orbits.newton import find_orbit

    o = find_orbit(Params.make(R="0.8", eta="1"), period=1, precision="mp:200")
    return _mp_key((o.x, o.v, o.multipliers, o.lle, o.residual))


def _analytical_mp():
    from precise_impact import AnalyticalSolver

    tr = AnalyticalSolver(precision="mp:200").solve(Params.make(R="0.8", eta="1.3", x0="0.5"), 8)
    return _mp_key((tr.x, tr.v, tr.impacts_t, tr.impacts_v_after))


_SHARED: dict = {}


def _analytical_mp_shared():
    """One mpmath solver object (one MpmathOps context) used by every thread at once."""
    from precise_impact import AnalyticalSolver

    solver = _SHARED.setdefault("analytical", AnalyticalSolver(precision="mp:200"))
    tr = solver.solve(Params.make(R="0.8", eta="1.3", x0="0.5"), 8)
    return _mp_key((tr.x, tr.v, tr.impacts_t, tr.impacts_v_after))


def _heyoka_mp():
    tr = HeyokaSolver("mp:160").solve(Params.make(R="0.8", eta="1.3", x0="0.5"), 4)
    return _mp_key((tr.x, tr.v, tr.impacts_t, tr.impacts_v_after))


def _heyoka_mp_chattering():
    """Sticking and chattering: the wall's mpmath (release time, accumulation time)."""
    p = Params.make(R="4/5", eta="0.2", a="1", x_w="0.5", zeta="0.05")
    tr = HeyokaSolver("mp:192").solve(p, 3)
    return _mp_key((tr.x, tr.v, tr.impacts_t, tr.impacts_v_after))


def _grazing_frequencies():
    from precise_impact import grazing_frequencies

    return _mp_key(grazing_frequencies(Params.make(), dps=200))


_PAIR: list = []


def _sample_errors_mp():
    """A verification metric: errors of a float64 run against an mp:200 one, in mpmath."""
    from precise_impact import AnalyticalSolver
    from precise_impact.verification.metrics import sample_errors

    if not _PAIR:  # computed once, serially (the first, serial call)
        p = Params.make(eta="0.74")
        _PAIR.extend(
            [AnalyticalSolver().solve(p, 20), AnalyticalSolver(precision="mp:200").solve(p, 20)]
        )
    return _mp_key(sample_errors(*_PAIR))


def _prove_orbit():
    """python-flint, not mpmath (its process-wide precision is set under the engine's lock)."""
    from precise_impact import prove_orbit

    r = prove_orbit(Params.make(R="0.8", eta="1"), 1, bits=128, transient=200)
    return (str(r.x), str(r.v), [str(m) for m in r.multipliers], r.proven, r.stable)


MP_ENTRY_POINTS = {
    "one_impact_orbits": _one_impact,
    "find_orbit mp": _find_orbit_mp,
    "AnalyticalSolver mp": _analytical_mp,
    "AnalyticalSolver mp, one object": _analytical_mp_shared,
    "HeyokaSolver mp": _heyoka_mp,
    "HeyokaSolver mp chattering": _heyoka_mp_chattering,
    "grazing_frequencies": _grazing_frequencies,
    "sample_errors mp": _sample_errors_mp,
    "prove_orbit": _prove_orbit,
}
#: ~10 s each on 2 busy cores (heyoka's mp compile with the wall's events): marked slow
_SLOW_MP = {"HeyokaSolver mp chattering", "prove_orbit"}
MP_NAMES = [
    pytest.param(n, marks=pytest.mark.slow) if n in _SLOW_MP else n for n in MP_ENTRY_POINTS
]


@pytest.mark.parametrize("name", MP_NAMES)
def test_mp_results_do_not_depend_on_mpmaths_global_precision(name):
    """The same call under another module-level mpmath precision gives the same bits (the
    deterministic form of the race below: each computation works in a context of its own)."""
    import mpmath

    fn = MP_ENTRY_POINTS[name]
    default = fn()
    with mpmath.workprec(70):
        low = fn()
    with mpmath.workdps(300):
        high = fn()
    assert low == default and high == default


@pytest.mark.parametrize("name", MP_NAMES)
def test_mp_results_from_threads_are_bit_identical(name):
    """4 threads, while another thread keeps switching mpmath's global precision, give the
    serial result bit for bit."""
    import threading
    import time

    import mpmath

    fn = MP_ENTRY_POINTS[name]
    t0 = time.perf_counter()
    serial = fn()
    # cheap calls repeated (~0.3 s a thread) so that the threads and the noise interleave
    reps = max(1, min(50, int(0.3 / (time.perf_counter() - t0))))
    stop = threading.Event()

    def noise():  # mostly at 24 bits: a computation that catches it loses digits
        while not stop.is_set():
            with mpmath.workprec(24):
                for _ in range(100):
                    mpmath.exp(mpmath.mpf(1) / 3)
            with mpmath.workdps(500):
                mpmath.cos(mpmath.mpf(2) / 7)

    import sys

    switch = sys.getswitchinterval()
    sys.setswitchinterval(1e-5)  # switch threads often: short computations interleave too
    other = threading.Thread(target=noise)
    other.start()
    try:
        threaded = _in_threads(lambda _: [fn() for _ in range(reps)], range(THREADS))
    finally:
        stop.set()
        other.join()
        sys.setswitchinterval(switch)
    assert all(t == serial for run in threaded for t in run)
