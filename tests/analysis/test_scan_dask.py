"""run_scan on a real Dask cluster (LocalCluster, worker processes): the tiles equal the serial
ones bit for bit, and each worker compiles (or loads from numba's cache) a kernel once, not per
task."""

from __future__ import annotations

import dataclasses
import os
import sys
import time

import numpy as np
import pytest

from precise_impact import Params
from precise_impact.analysis.impact_surface.basins import point_attractor
from precise_impact.analysis.scan import run_scan

distributed = pytest.importorskip("distributed", reason="Dask is optional")
cloudpickle = pytest.importorskip("cloudpickle", reason="Dask is optional")

PARAMS = Params.make(eta="4.85", zeta=0, R="0.5", x_w="-0.3", x0="-0.5")


def _tile(lo: int, hi: int) -> dict:
    """Points ``lo .. hi - 1`` of a 10 x 8 impact-surface grid, through the compiled engine."""
    rows = [
        point_attractor(PARAMS, "impact", (k % 10 + 0.5) / 10, 0.6 * (k // 10 + 0.5) / 8,
                        transient=30, max_period=8, chaos_periods=50)
        for k in range(lo, hi)
    ]  # fmt: skip
    return {
        f: np.asarray([r[f] for r in rows], dtype=float) for f in ("capture", "lle", "rep_phase")
    }


@dataclasses.dataclass(frozen=True)
class Watched:
    """A tile of the basins job, with the worker's pid and its strobe kernel's compile count."""

    job: object

    def __call__(self, lo: int, hi: int):
        from precise_impact.solvers.fast.single import strobe  # noqa: PLC0415 -- on the worker

        tile = self.job(lo, hi)
        loads = sum(strobe.stats.cache_hits.values()) + sum(strobe.stats.cache_misses.values())
        return tile, (os.getpid(), loads, len(strobe.overloads))


def test_dask_tiles_equal_serial_and_compile_once():
    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # workers cannot import tests
    job = _tile
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


def _range(lo: int, hi: int) -> list:
    return list(range(lo, hi))


def test_dask_address_beside_a_default_client(dask_scheduler):
    """A user's own Client (the default one) stays the default, and run_scan does not wait on
    its event loop (``as_completed`` without ``loop`` did: each scan lost ~2 s).  The cluster:
    the session's (its own 1-worker LocalCluster before: 3 s to start)."""
    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # workers cannot import tests
    with distributed.Client(dask_scheduler) as mine:
        t = time.perf_counter()
        runs = [run_scan(_range, 6, 2, dask=dask_scheduler) for _ in range(2)]
        wall = time.perf_counter() - t
        assert distributed.default_client() is mine
    assert [r.values for r in runs] == [[[0, 1], [2, 3], [4, 5]]] * 2
    assert wall < 3.0, wall  # ~0.1 s each; ~2 s each before


@pytest.mark.parametrize(
    "n_tiles,workers", [(0, 2), (1, 2), (5, 2), (32, 2), (33, 2), (500, 2), (500, 7)]
)
def test_dask_batches_cover_every_tile_once_in_order(n_tiles, workers):
    """Tiles go to Dask in consecutive groups: every tile once, in order, at most
    ``TASKS_PER_WORKER`` tasks per worker, and one tile per task while that many suffice (a
    Dask task costs ~10 ms of CPU: 500 tiles of the chatter map as 500 tasks lost 4-26 %)."""
    from precise_impact.analysis.scan import TASKS_PER_WORKER, dask_batches

    todo = list(range(3, 3 + n_tiles))
    batches = dask_batches(todo, workers)
    assert [t for b in batches for t in b] == todo
    assert len(batches) <= workers * TASKS_PER_WORKER and all(batches)
    if n_tiles <= workers * TASKS_PER_WORKER:
        assert len(batches) == n_tiles
    sizes = {len(b) for b in batches[:-1]}
    assert len(sizes) <= 1 and (not batches or len(batches[-1]) <= max(sizes | {1}))
