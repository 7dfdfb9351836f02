"""The scan runner: every executor gives the same tiles, resume after a partial or interrupted
run, tiles, progress, the shared vocabulary (model=, axis tuples), the brute-force diagram."""

from __future__ import annotations

import dataclasses
import importlib.util
import math
import sys
import warnings
from fractions import Fraction

import numpy as np
import pytest

from precise_impact import ParameterError, Params
from precise_impact.analysis.orbits.branch import brute_force_diagram
from precise_impact.analysis.scan import (
    Grid,
    NpzTileStore,
    PointJob,
    check_axis,
    resolve_model,
    run_scan,
    tile_bounds,
)
from precise_impact.io.progress import Progress, check_progress


@dataclasses.dataclass(frozen=True)
class Job:
    """A picklable tile job: per point k, ``sin(k) * scale`` and ``k`` as the npz fields;
    ``fail_at``: the tile that raises KeyboardInterrupt (a Ctrl-C inside the work)."""

    scale: float = 1.0
    tile_size: int = 3
    fail_at: int | None = None

    def __call__(self, lo: int, hi: int) -> dict:
        if self.fail_at is not None and lo // self.tile_size == self.fail_at:
            raise KeyboardInterrupt
        k = np.arange(lo, hi)
        return {"y": np.sin(k) * self.scale, "k2": (k * k).astype(float), "index": k}


def _store(path, digest="d1", n=10, tile=3):
    return NpzTileStore(path, digest, ("y", "k2"), n, tile)


def _flat(run) -> np.ndarray:
    return np.concatenate([v["y"] for v in run.values])


def _from_store(store) -> np.ndarray:
    out = np.full(store.n_points, np.nan)
    for t in range(store.n_tiles):
        arrays, why = store.read(t)
        assert arrays is not None, why
        out[arrays["index"]] = arrays["y"]
    return out


def test_tiles_and_grid():
    assert tile_bounds(10, 4) == [(0, 4), (4, 8), (8, 10)]
    assert tile_bounds(3, 5) == [(0, 3)]
    g = Grid((("eta", (Fraction(1), Fraction(2))), ("x_w", ("a", "b", "c"))))
    assert g.shape == (2, 3) and g.size == 6
    assert g.point(4) == {"eta": Fraction(2), "x_w": "b"} and g.index(5) == (1, 2)
    calls = []
    run = run_scan(lambda lo, hi: calls.append((lo, hi)) or hi - lo, 10, 4)
    assert calls == [(0, 4), (4, 8), (8, 10)] and run.values == [4, 4, 2]
    assert (run.tiles_total, run.tiles_computed, run.backend) == (3, 3, "serial")


@pytest.mark.parametrize(
    "executor, workers",
    [
        ("serial", 1),
        ("processes", 2),
        pytest.param(
            "dask",
            2,
            marks=pytest.mark.skipif(
                importlib.util.find_spec("distributed") is None,
                reason="Dask is an optional extra (pip install 'precise_impact[dask]')",
            ),
        ),
    ],
)
def test_every_executor_gives_the_same_tiles(executor, workers, tmp_path, request):
    kw = {}
    if executor == "dask":  # Dask's worker processes cannot import this test module by name
        import cloudpickle

        cloudpickle.register_pickle_by_value(sys.modules[__name__])
        # the session's LocalCluster of 2 worker processes: the one executor="dask" would
        # start per run (twice here, 6-10 s)
        kw["dask"] = request.getfixturevalue("dask_scheduler")
    job = Job()
    run = run_scan(job, 10, 3, executor=executor, workers=workers, **kw)
    assert run.backend == executor and run.workers == workers
    assert np.array_equal(_flat(run), np.sin(np.arange(10)))
    store = _store(tmp_path)  # the same through the store: every tile on disk, nothing kept
    run = run_scan(job, 10, 3, executor=executor, workers=workers, store=store, **kw)
    assert run.values == [None] * 4 and run.tiles_computed == 4
    assert np.array_equal(_from_store(store), np.sin(np.arange(10)))


def test_resume_after_a_partial_run(tmp_path):
    store = _store(tmp_path)
    part = run_scan(Job(), 10, 3, store=store, max_tiles=2)
    assert (part.tiles_computed, part.tiles_reused) == (2, 0)
    assert [store.read(t)[0] is not None for t in range(4)] == [True, True, False, False]
    seen = []  # the rest only, and the progress counts on from the finished tiles
    rest = run_scan(Job(), 10, 3, store=store, workers=2, progress=lambda d, n: seen.append((d, n)))
    assert (rest.tiles_computed, rest.tiles_reused) == (2, 2)
    assert seen in ([(9, 10), (10, 10)], [(7, 10), (10, 10)])  # 6 points were done
    assert np.array_equal(_from_store(store), np.sin(np.arange(10)))
    # another scan's store (another digest) takes none of these tiles and says why
    lines = []
    other = run_scan(Job(scale=2.0), 10, 3, store=_store(tmp_path, "d2"), say=lines.append)
    assert other.tiles_reused == 0 and len(lines) == 4 and "another sweep" in lines[0]


@pytest.mark.parametrize("workers", [1, 2])
def test_an_interrupt_keeps_the_finished_tiles(tmp_path, workers):
    store = _store(tmp_path, n=30)
    with pytest.raises(KeyboardInterrupt):
        run_scan(Job(fail_at=3), 30, 3, store=store, workers=workers)
    kept = {t for t in range(10) if store.read(t)[0] is not None}
    assert 3 not in kept
    if workers == 1:
        assert kept == {0, 1, 2}  # in order, up to the interrupted tile
    rest = run_scan(Job(), 30, 3, store=store, workers=workers)
    assert rest.tiles_reused == len(kept) and rest.tiles_computed == 10 - len(kept)
    assert np.array_equal(_from_store(store), np.sin(np.arange(30)))


def test_point_job_and_progress():
    job = PointJob(math.sqrt, [float(k) for k in range(7)])
    seen = []
    run = run_scan(job, 7, 3, progress=lambda d, n: seen.append((d, n)))
    assert [x for v in run.values for x in v] == [math.sqrt(k) for k in range(7)]
    assert seen == [(3, 7), (6, 7), (7, 7)]
    seen.clear()
    run_scan(job, 7, 3, progress=lambda d, n: seen.append((d, n)), unit="tiles")
    assert seen == [(1, 3), (2, 3), (3, 3)]
    assert check_progress(np.bool_(True)) is True and check_progress(None) is None
    for bad in ("yes", 1, 0.5):
        with pytest.raises(ParameterError) as e:
            check_progress(bad)
        assert e.value.name == "progress"


def test_a_callable_progress_prints_nothing(capsys):
    got = []
    bar = Progress(4, "items", lambda d, n: got.append((d, n)))
    for i in range(1, 5):
        bar.update(i, "extra")
    bar.close()
    assert got == [(1, 4), (2, 4), (3, 4), (4, 4)] and capsys.readouterr().err == ""


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"executor": "threads"}, "executor"),
        ({"workers": 0}, "workers"),
        ({"dask": "udp://x"}, "dask"),
        ({"executor": "serial", "dask": "local"}, "dask"),
        ({"progress": "yes"}, "progress"),
        ({"unit": "rows"}, "unit"),
    ],
)
def test_runner_validation(kwargs, name):
    with pytest.raises(ParameterError) as e:
        run_scan(Job(), 10, 3, **kwargs)
    assert e.value.name == name


def test_model_and_axis_vocabulary():
    assert resolve_model(None, None, "f") == "fast"
    assert resolve_model("heyoka", None, "f") == "heyoka"
    with pytest.warns(DeprecationWarning, match="use model="):
        assert resolve_model(None, "heyoka", "f") == "heyoka"
    for model, engine, name in [("gpu", None, "model"), (None, "gpu", "engine")]:
        with pytest.raises(ParameterError) as e, warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            resolve_model(model, engine, "f")
        assert e.value.name == name
    assert check_axis(["eta", "0.7", "0.8", 3], "eta") == ("eta", "0.7", "0.8", 3)
    for bad in (("eta", "0.7", "0.8"), "eta", ("x_w", "1", "2", 3)):
        with pytest.raises(ParameterError):
            check_axis(bad, "eta")


def test_brute_force_diagram_axis_processes_and_old_form():
    """The axis tuple gives the old (parameter, start, stop, n) numbers (which warn),
    serial and 2 processes agree bit for bit, a periodic window repeats itself."""
    p = Params.make()
    kw = dict(periods=6, transient=300)
    vals, x = brute_force_diagram(p, ("eta", "0.73", "0.75", 3), **kw)
    assert np.array_equal(vals, np.linspace(0.73, 0.75, 3)) and x.shape == (3, 6)
    with pytest.warns(DeprecationWarning, match="axis tuple"):
        v_old, x_old = brute_force_diagram(p, "eta", 0.73, 0.75, 3, **kw)
    assert np.array_equal(vals, v_old) and np.array_equal(x, x_old, equal_nan=True)
    _, x2 = brute_force_diagram(p, ("eta", "0.73", "0.75", 3), workers=2, **kw)
    assert np.array_equal(x, x2, equal_nan=True)
    assert np.allclose(x[2, :3], x[2, 3:], atol=1e-9)  # eta = 0.75: the period-3 window
    with pytest.raises(ParameterError) as e:
        brute_force_diagram(p, ("eta", "0.73", "0.75", 3), n=4)
    assert e.value.name == "n"
