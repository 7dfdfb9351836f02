"""run_scan on a real Dask cluster (LocalCluster, worker processes): the tiles equal the serial
ones bit for bit, and each worker compiles (or loads from numba's cache) a kernel once, not per
task."""

from __future__ import annotations

import dataclasses
import functools
import importlib.util
import os
import sys

import pytest

from precise_impact.analysis.impact_surface import basins as B
from precise_impact.analysis.scan import run_scan

pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("distributed") is None, reason="Dask is optional"
)

SPEC = B._Spec(
    pars=(4.85, 0.0, 1.0, -0.3, 0.5), t0=0.0, section="impact",
    axes=(("phase", 0.0, 1.0, 10), ("v", 0.0, 0.6, 8)), transient=30, max_period=8,
    chaos_periods=50,
)  # fmt: skip


@dataclasses.dataclass(frozen=True)
class Watched:
    """A tile of the basins job, with the worker's pid and its strobe kernel's compile count."""

    job: object

    def __call__(self, lo: int, hi: int):
        from precise_impact.solvers.fast.single import strobe

        tile = self.job(lo, hi)
        loads = sum(strobe.stats.cache_hits.values()) + sum(strobe.stats.cache_misses.values())
        return tile, (os.getpid(), loads, len(strobe.overloads))


def test_dask_tiles_equal_serial_and_compile_once():
    import cloudpickle

    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # workers cannot import tests
    job = functools.partial(B._points_job, SPEC, None, 30)
    serial = run_scan(job, 80, 5, executor="serial")
    run = run_scan(Watched(job), 80, 5, dask="local", workers=2)
    assert run.backend == "dask" and run.workers == 2 and run.tiles_computed == 16
    for a, (b, _) in zip(serial.values, run.values, strict=True):
        assert a.keys() == b.keys()
        for k in a:
            assert a[k].dtype == b[k].dtype and a[k].tobytes() == b[k].tobytes(), k
    per_worker: dict[int, set] = {}
    for _, (pid, loads, overloads) in run.values:
        per_worker.setdefault(pid, set()).add((loads, overloads))
    for seen in per_worker.values():  # the count stays what the first task left: no recompiling
        assert len(seen) == 1
        ((loads, overloads),) = seen
        assert loads == overloads == 1


def _tile(lo: int, hi: int) -> list:
    return list(range(lo, hi))


def test_dask_address_beside_a_default_client():
    """A user's own Client (the default one) stays the default, and run_scan does not wait on
    its event loop (``as_completed`` without ``loop`` did: each scan lost ~2 s)."""
    import time

    from dask.distributed import Client, LocalCluster, default_client

    with LocalCluster(n_workers=1, threads_per_worker=1, dashboard_address=None) as cluster:
        with Client(cluster.scheduler_address) as mine:
            t = time.perf_counter()
            runs = [run_scan(_tile, 6, 2, dask=cluster.scheduler_address) for _ in range(2)]
            wall = time.perf_counter() - t
            assert default_client() is mine
    assert [r.values for r in runs] == [[[0, 1], [2, 3], [4, 5]]] * 2
    assert wall < 3.0, wall  # ~0.1 s each; ~2 s each before
