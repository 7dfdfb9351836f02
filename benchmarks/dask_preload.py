"""``dask worker --preload`` module of bench_basins.py: a worker imports the package and loads
the compiled kernels (numba's cache) as it starts, as a long-running cluster's workers are warm,
so a scan's first task on it does not pay ~1.7 s of imports and kernel loading (the local
process pool gets the same from the warm driver it forks from)."""

from __future__ import annotations

import time


def dask_setup(worker) -> None:
    """Import the basins map and run one point (loads the kernels); the seconds it took are
    kept as ``worker.precise_impact_warmup_s``."""
    t = time.perf_counter()
    from precise_impact import Params  # noqa: PLC0415 -- timed: the worker's warm-up
    from precise_impact.analysis.impact_surface.basins import basins  # noqa: PLC0415 -- timed

    p = Params.make(eta="4.85", zeta=0, R="0.5", x_w="-0.3", x0="-0.5")
    basins(p, ((0, 1, 1), (0, 0.6, 1)), transient=2, progress=False)
    worker.precise_impact_warmup_s = time.perf_counter() - t
