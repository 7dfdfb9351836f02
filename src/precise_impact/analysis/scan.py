"""One parameter-scan runner: a grid, a per-point job, an executor, tiles with resume, progress.

Tiles of consecutive grid points run in this process, in worker processes or on Dask; with a
store (:class:`NpzTileStore`) an interrupted scan keeps its finished tiles and a rerun computes
only the others, bit for bit the same.  Sweeps, bifurcation diagrams, brute-force branches and
sync scans all run through :func:`run_scan`; design: ``docs/design.rst``.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import os
import signal
import socket
import time
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

import numpy as np

from precise_impact.core.compat import warn_renamed
from precise_impact.core.params import check_count
from precise_impact.core.precision import Precision
from precise_impact.errors import OptionalDependencyError, ParameterError
from precise_impact.io.atomic import atomic_write
from precise_impact.io.progress import Progress, ProgressArg, check_progress
from precise_impact.io.progress import say as _say
from precise_impact.signals import recheck_later
from precise_impact.solvers.base import ENGINES

__all__ = [
    "EXECUTORS",
    "Grid",
    "NpzTileStore",
    "PointJob",
    "ScanRun",
    "check_axis",
    "check_workers",
    "dask_batches",
    "deprecated_keyword",
    "resolve_model",
    "TASKS_PER_WORKER",
    "run_scan",
    "tile_bounds",
]

#: How the tiles run: in this process, in local worker processes, or on Dask.
EXECUTORS = ("serial", "processes", "dask")


# ------------------------------------------------------------------ vocabulary
def deprecated_keyword(old: str, new: str, where: str, stacklevel: int = 3) -> None:
    """Warn that keyword (or form) ``old`` of ``where`` is deprecated in favour of ``new`` (the
    one message, :func:`precise_impact.core.compat.warn_renamed`)."""
    warn_renamed(old, new, where, stacklevel=stacklevel + 1)


def resolve_model(
    model: Any,
    engine: Any,
    where: str,
    default: str | None = "fast",
    precision: Precision | None = None,
) -> str | None:
    """The engine a scan uses: ``model`` (``'fast'`` / ``'heyoka'``), or the deprecated
    ``engine`` with a :class:`DeprecationWarning` naming ``model=``.

    ``None`` for both gives ``default``.  A bad value raises a :class:`ParameterError`
    naming the keyword it came in; with ``precision``, ``'fast'`` needs float64.
    """
    name = "model"
    if engine is not None:
        deprecated_keyword("engine=", "model=", where, stacklevel=4)
        if model is not None and model != engine:
            raise ParameterError("engine", engine, f"not given with model = {model!r}")
        model, name = engine, "engine"
    if model is None:
        if default is None:
            return None
        model = default
    if not isinstance(model, str) or model not in ENGINES:
        raise ParameterError(name, model, "'fast' or 'heyoka'")
    if model == "fast" and precision is not None and precision.kind != "float64":
        raise ParameterError(
            "precision",
            precision.name,
            f"'float64' for {name}='fast' ({name}='heyoka' for other precisions)",
        )
    return model


def check_axis(axis: Any, name: str | None = None, what: str = "axis") -> tuple:
    """``axis`` as a tuple ``(name, start, stop, n)``; ``name`` (if given) must match.

    The values are validated where the grid is built (exact decimals, ranges).
    """
    if isinstance(axis, (str, bytes)) or not isinstance(axis, Sequence) or len(axis) != 4:
        raise ParameterError(what, axis, "an axis tuple (name, start, stop, n)")
    if not isinstance(axis[0], str) or (name is not None and axis[0] != name):
        raise ParameterError(what, axis[0], f"the parameter {name!r}" if name else "a name")
    return tuple(axis)


# ------------------------------------------------------------------ the grid
@dataclasses.dataclass(frozen=True)
class Grid:
    """A row-major grid: ``axes`` is a tuple of ``(name, values)``.

    Attributes
    ----------
    axes : tuple of (str, tuple)
        Each axis' name and its values (any type; exact Fractions for parameters).
    """

    axes: tuple

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(v) for _, v in self.axes)

    @property
    def size(self) -> int:
        return math.prod(self.shape)

    def index(self, k: int) -> tuple[int, ...]:
        """The multi-index of flat point ``k``."""
        return tuple(int(i) for i in np.unravel_index(k, self.shape))

    def point(self, k: int) -> dict[str, Any]:
        """``{name: value}`` of flat point ``k``."""
        return {name: vals[i] for (name, vals), i in zip(self.axes, self.index(k), strict=True)}

    def tiles(self, tile_size: int) -> list[tuple[int, int]]:
        """``[(lo, hi), ...]``: the flat points of each tile of ``tile_size``."""
        return tile_bounds(self.size, tile_size)


@dataclasses.dataclass(frozen=True)
class PointJob:
    """A tile job from a per-point function: ``PointJob(fn, points)(lo, hi)`` is
    ``[fn(p) for p in points[lo:hi]]`` (picklable when ``fn`` and the points are).

    Attributes
    ----------
    fn : callable
        The per-point computation (a module-level function).
    points : sequence
        Its argument at each flat point of the grid.
    """

    fn: Callable[[Any], Any]
    points: Sequence

    def __call__(self, lo: int, hi: int) -> list:
        return [self.fn(p) for p in self.points[lo:hi]]


def tile_bounds(n_points: int, tile_size: int) -> list[tuple[int, int]]:
    """``[(lo, hi), ...]``: consecutive tiles of ``tile_size`` points (the last one shorter)."""
    return [(lo, min(n_points, lo + tile_size)) for lo in range(0, n_points, tile_size)]


# ------------------------------------------------------------------ the on-disk tiles
class NpzTileStore:
    """Finished tiles as ``DIRECTORY/tiles/tile_NNNNN.npz`` (the sweep's format).

    Each file holds the tile's ``fields`` (one value per point), ``index`` (its flat
    points), the scan's ``digest``, the tile number and a SHA-256 ``checksum`` over
    them: a missing, damaged, foreign or misplaced file is never taken.

    Parameters
    ----------
    directory : pathlib.Path
        The scan's directory.
    digest : str
        The scan's identity (a hash of everything that determines its numbers).
    fields : tuple of str
        The arrays of a tile.
    n_points, tile_size : int
        The grid's size and the points per tile.
    """

    def __init__(
        self, directory: Path, digest: str, fields: tuple, n_points: int, tile_size: int
    ) -> None:
        self.directory, self.digest, self.fields = Path(directory), digest, tuple(fields)
        self.n_points, self.tile_size = n_points, tile_size
        self.keys = self.fields + ("index",)

    @property
    def n_tiles(self) -> int:
        return -(-self.n_points // self.tile_size)

    def path(self, tile: int) -> Path:
        return self.directory / "tiles" / f"tile_{tile:05d}.npz"

    def checksum(self, tile: int, arrays: dict[str, np.ndarray]) -> str:
        """SHA-256 over the tile's identity (digest, tile number) and every array's dtype,
        shape and bytes: a tile copied onto another's path, or a flipped bit, fails it."""
        h = hashlib.sha256(f"{self.digest}:{tile}".encode())
        for key in self.keys:
            a = np.ascontiguousarray(arrays[key])
            h.update(f"{key}:{a.dtype.str}:{a.shape}".encode())
            h.update(a.tobytes())
        return h.hexdigest()

    def write(self, tile: int, arrays: dict[str, np.ndarray]) -> None:
        """Write one finished tile atomically."""
        data = {k: np.asarray(arrays[k]) for k in self.keys}
        data.update(
            digest=np.asarray(self.digest),
            tile=np.asarray(tile),
            checksum=np.asarray(self.checksum(tile, data)),
        )
        atomic_write(self.path(tile), lambda fh: np.savez(fh, **data), binary=True)

    def read(self, tile: int) -> tuple[dict | None, str | None]:
        """``(arrays, None)`` for a verified tile; ``(None, why)`` for a missing, damaged
        or foreign one (``why`` is ``None`` when the file is simply absent)."""
        path = self.path(tile)
        if not path.exists():
            return None, None
        try:
            with np.load(path, allow_pickle=False) as d:
                data = {k: d[k] for k in self.keys + ("digest", "tile", "checksum")}
        except Exception as e:  # truncated, empty, not a zip, missing keys, bad header ...
            return None, f"unreadable ({type(e).__name__})"
        if str(data["digest"]) != self.digest:
            return None, "belongs to another sweep"
        lo = tile * self.tile_size
        hi = min(self.n_points, lo + self.tile_size)
        if (
            data["tile"].shape != ()
            or int(data["tile"]) != tile
            or not np.array_equal(data["index"], np.arange(lo, hi))
        ):
            return None, "holds another tile's points"
        if any(data[f].shape != (hi - lo,) for f in self.fields):
            return None, "has arrays of the wrong length"
        if str(data["checksum"]) != self.checksum(tile, data):
            return None, "fails its checksum"
        return {k: data[k] for k in self.keys}, None

    def finished(self, say: Callable[[str], None]) -> set[int]:
        """The tiles that verify; every damaged or foreign tile is named (it is recomputed)."""
        done = set()
        for t in range(self.n_tiles):
            arrays, why = self.read(t)
            if arrays is not None:
                done.add(t)
            elif why is not None:
                say(f"sweep: {self.path(t)} {why}: recomputing it")
        return done


# ------------------------------------------------------------------ the runner
@dataclasses.dataclass
class ScanRun:
    """What :func:`run_scan` did.

    Attributes
    ----------
    values : list
        Per tile: the job's result computed by this call (``None`` for a tile reused
        from the store, not run, or written to a store: read those from the store).
    tiles_total, tiles_reused, tiles_computed : int
        Tiles of the grid; found finished in the store; computed by this call.
    elapsed_s : float
        Wall time of the computation.
    workers : int
        Worker processes (Dask: the cluster's workers; serial: the workers asked for).
    backend : str
        The executor that ran: one of :data:`EXECUTORS`.
    """

    values: list
    tiles_total: int
    tiles_reused: int
    tiles_computed: int
    elapsed_s: float
    workers: int
    backend: str


def check_workers(workers: Any) -> int:
    """``workers`` worker processes (``None``: ``os.cpu_count()``), checked in 1 .. 1024."""
    n = workers if workers is not None else (os.cpu_count() or 1)
    n = check_count(n, "workers", 1024)
    if n < 1:
        raise ParameterError("workers", n, "an integer >= 1")
    return n


def _refused(address: str) -> str | None:
    """Why a TCP connection to a ``tcp://HOST:PORT`` scheduler address is refused at once, or
    ``None`` (it connects, or answers too slowly to tell: :class:`Client`'s timeout decides)."""
    host, _, port = address.removeprefix("tcp://").rpartition(":")
    if not port.isdigit():
        return None
    try:
        socket.create_connection((host.strip("[]") or "127.0.0.1", int(port)), timeout=2).close()
    except ConnectionRefusedError as e:
        return e.strerror or "refused"
    except OSError:
        return None
    return None


def run_scan(
    job: Callable[[int, int], Any],
    n_points: int,
    tile_size: int = 1,
    *,
    executor: str | None = None,
    workers: int | None = 1,
    dask: str | None = None,
    store: NpzTileStore | None = None,
    max_tiles: int | None = None,
    progress: ProgressArg = None,
    label: str = "scan",
    unit: str = "points",
    say: Callable[[str], None] | None = None,
    on_tile: Callable[[int, Any], None] | None = None,
) -> ScanRun:
    """Run ``job(lo, hi)`` on every unfinished tile of a grid of ``n_points``.

    Parameters
    ----------
    job : callable ``(lo, hi) -> value``
        Computes the flat points ``lo .. hi - 1`` (picklable for processes and Dask:
        a module-level function, a ``functools.partial`` of one, or a dataclass).
    n_points : int
        Points of the grid (row-major, :class:`Grid`).
    tile_size : int, default 1
        Points per tile: the unit of work, of checkpoint (with ``store``) and of resume.
    executor : None or one of :data:`EXECUTORS`, default ``None``
        ``None`` picks: Dask with ``dask``, else processes when ``workers > 1`` and more
        than one tile is left, else serial.  ``'processes'`` uses a pool even for one
        worker; ``'dask'`` without ``dask`` is a local cluster.
    workers : int or None, default 1
        Local worker processes (``None``: ``os.cpu_count()``); 1, or at most one tile
        to run, runs in this process.  With ``dask='local'``: the cluster's workers.
    dask : None, ``'local'`` or ``'tcp://HOST:PORT'``
        Run the tiles on a Dask ``LocalCluster`` (single-threaded worker processes) or
        on the scheduler at that address (``pip install 'precise_impact[dask]'``).
    store : NpzTileStore or None, default ``None``
        Write each finished tile there at once and skip the tiles it already holds
        (``values`` then stays ``None``: read the tiles from the store).
    max_tiles : int or None, default ``None``
        Compute at most this many unfinished tiles (a partial run).
    progress : bool, None or callable, default ``None``
        :data:`~precise_impact.io.progress.ProgressArg`: a throttled line on stderr
        (``None``: only on a terminal) or ``progress(done, total)`` per finished tile.
    label : str, default ``'scan'``
        What the progress line names.
    unit : ``'points'`` or ``'tiles'``, default ``'points'``
        What the progress counts (tiles also show the rate in points per second).
    say : callable or None
        Where a damaged tile of the store is named (default: a line on stderr).
    on_tile : callable or None
        Called as ``on_tile(tile, value)`` in this process as each tile finishes (in
        completion order; e.g. a per-tile report).

    Returns
    -------
    ScanRun
        The values of the computed tiles and the run's figures.

    Raises
    ------
    ParameterError
        Bad ``workers``, ``dask``, ``tile_size`` or ``progress``, before any work.
    OptionalDependencyError
        ``dask`` is asked for and Dask is not installed.
    KeyboardInterrupt
        Ctrl-C (or SIGTERM through the CLI): the pending tiles are cancelled, every tile
        finished before is kept (written to ``store``), then the interrupt propagates.
    """
    progress = check_progress(progress)
    tile_size = check_count(tile_size, "tile_size", 10**9, minimum=1)
    dask = _check_executor(executor, dask, unit)
    bounds = tile_bounds(n_points, tile_size)
    done, todo = _todo(len(bounds), store, say, max_tiles)
    start = time.perf_counter()
    tally = _Tally(bounds, done, store, on_tile, unit, tile_size, start)
    tally.bar = Progress(len(bounds) if unit == "tiles" else n_points, label, progress)
    n_workers, backend = _dispatch(job, bounds, todo, executor, dask, workers, tally.finished)
    tally.bar.close()
    return ScanRun(
        values=tally.values,
        tiles_total=len(bounds),
        tiles_reused=len(done),
        tiles_computed=tally.tiles,
        elapsed_s=time.perf_counter() - start,
        workers=n_workers,
        backend=backend,
    )


def _check_executor(executor: str | None, dask: str | None, unit: str) -> str | None:
    """Check ``unit``, ``executor`` and ``dask``; the Dask target (``'local'`` for
    ``executor='dask'`` without one) or ``None``."""
    if unit not in ("points", "tiles"):
        raise ParameterError("unit", unit, "'points' or 'tiles'")
    if executor is not None and executor not in EXECUTORS:
        raise ParameterError("executor", executor, "one of " + ", ".join(EXECUTORS))
    if executor == "dask" and dask is None:
        dask = "local"
    if executor in ("serial", "processes") and dask is not None:
        raise ParameterError("dask", dask, f"not given with executor = {executor!r}")
    if dask is not None and not (
        isinstance(dask, str) and (dask == "local" or dask.startswith("tcp://"))
    ):
        raise ParameterError("dask", dask, "'local' or a scheduler address tcp://HOST:PORT")
    return dask


def _todo(n_tiles: int, store, say, max_tiles) -> tuple[set[int], list[int]]:
    """The tiles the store holds finished, and the ones to compute (at most ``max_tiles``)."""
    done = store.finished(say or _say) if store is not None else set()
    todo = [t for t in range(n_tiles) if t not in done]
    if max_tiles is not None:
        todo = todo[: check_count(max_tiles, "max_tiles", 10**9)]
    return done, todo


class _Tally:
    """Takes each finished tile: to the store or ``values``, to ``on_tile``, to the progress."""

    def __init__(self, bounds, done, store, on_tile, unit, tile_size, start) -> None:
        self.bounds, self.done, self.store, self.on_tile = bounds, done, store, on_tile
        self.unit, self.tile_size, self.start = unit, tile_size, start
        self.values: list[Any] = [None] * len(bounds)
        self.tiles = 0
        self.points = sum(hi - lo for t, (lo, hi) in enumerate(bounds) if t in done)
        self.bar: Progress | None = None

    def finished(self, t: int, value: Any) -> None:
        """Tile ``t`` finished with ``value``."""
        if self.store is not None:
            self.store.write(t, value)
        else:
            self.values[t] = value
        if self.on_tile is not None:
            self.on_tile(t, value)
        self.tiles += 1
        self.points += self.bounds[t][1] - self.bounds[t][0]
        assert self.bar is not None
        if self.unit == "tiles":
            rate = self.tiles * self.tile_size / max(time.perf_counter() - self.start, 1e-9)
            self.bar.update(len(self.done) + self.tiles, f"~{rate:.1f} points/s")
        else:
            self.bar.update(self.points)


def _dispatch(job, bounds, todo, executor, dask, workers, finished) -> tuple[int, str]:
    """Run the ``todo`` tiles on the chosen executor; ``(workers, backend)``."""
    if dask is not None:
        return _run_dask(job, bounds, todo, dask, finished, workers), "dask"
    n_workers = check_workers(workers)
    if executor == "serial" or (executor is None and (n_workers == 1 or len(todo) <= 1)):
        for t in todo:
            finished(t, job(*bounds[t]))
        return n_workers, "serial"
    _run_processes(job, bounds, todo, n_workers, finished)
    return n_workers, "processes"


def _run_processes(job, bounds, todo, n_workers, finished) -> None:
    """Tiles on a local process pool; on an interrupt the pending ones are cancelled and
    every one finished by then is handed to ``finished`` before the interrupt goes on."""
    ex = ProcessPoolExecutor(
        max_workers=min(n_workers, len(todo)), initializer=_worker_init
    )  # no idle processes
    futs: dict[Future, int] = {}
    handled: set[int] = set()
    try:
        futs = {ex.submit(_in_worker, job, *bounds[t]): t for t in todo}
        for f in as_completed(futs):
            finished(futs[f], f.result())
            handled.add(futs[f])
    except BaseException as e:
        if isinstance(e, KeyboardInterrupt):
            _interrupt_workers(ex)
        ex.shutdown(wait=True, cancel_futures=True)
        for f, t in futs.items():  # keep what finished while the pool wound down
            if t not in handled and f.done() and not f.cancelled() and f.exception() is None:
                finished(t, f.result())
        raise
    ex.shutdown(wait=True)


#: In a worker process: a tile is being computed (an interrupt stops it; an idle worker
#: ignores one, and the pool's shutdown ends it without a traceback).
_BUSY = False
#: In a worker process: interrupted; the tiles still queued to it are refused, not computed.
_STOPPED = False


def _worker_sigint(signum, frame) -> None:
    """SIGINT (and its re-check, SIGALRM) in a worker: raised while a tile runs, unless the
    worker is inside an import or a finalizer (:func:`~precise_impact.signals.recheck_later`),
    where it waits for the import to end."""
    global _STOPPED
    if signum == signal.SIGINT:
        _STOPPED = True
    if _BUSY and _STOPPED and not recheck_later(frame, below=_in_worker.__code__):
        raise KeyboardInterrupt


def _worker_init() -> None:
    """A pool worker: SIGINT stops the tile it computes, and is ignored between tiles."""
    signal.signal(signal.SIGINT, _worker_sigint)
    if hasattr(signal, "SIGALRM"):
        signal.signal(signal.SIGALRM, _worker_sigint)


def _in_worker(job: Callable[[int, int], Any], lo: int, hi: int) -> Any:
    """``job(lo, hi)`` in a pool worker, interruptible while it runs."""
    global _BUSY
    if _STOPPED:  # queued before the interrupt (a pool cannot cancel those): not computed
        raise KeyboardInterrupt
    _BUSY = True
    try:
        return job(lo, hi)
    finally:
        _BUSY = False


def _interrupt_workers(ex: ProcessPoolExecutor) -> None:
    """Pass an interrupt on to the pool's workers (a SIGTERM reaches this process alone; Ctrl-C
    in a terminal reaches them too): their compiled loops stop within milliseconds
    (:func:`~precise_impact.solvers.fast.control.run_kernel`) instead of finishing tiles that
    would not be kept, so the run ends in about a second, not after its longest tile."""
    workers = getattr(ex, "_processes", None) or {}  # pid -> process (CPython's pool)
    for pid in list(workers):
        try:
            os.kill(pid, signal.SIGINT)
        except OSError:  # already gone
            pass


def _run_dask(job, bounds, todo, dask: str, finished, workers) -> int:
    """Tiles on a Dask cluster (``'local'``: a ``LocalCluster`` of ``workers``
    single-threaded processes); returns the cluster's worker count."""
    client, cluster = _dask_client(dask, workers)
    try:
        n_workers = len(client.scheduler_info()["workers"])
        _dask_tiles(client, job, bounds, dask_batches(todo, n_workers), finished)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    return n_workers


def _dask_client(dask: str, workers):
    """``(client, cluster)``: a client of a new ``LocalCluster`` (``'local'``) or of the
    scheduler at ``dask`` (``cluster`` is then ``None``)."""
    try:
        from dask.distributed import Client, LocalCluster  # noqa: PLC0415 -- optional: loaded on first use
    except ImportError:
        raise OptionalDependencyError(
            "dask", "pip install 'precise_impact[dask]'", "--dask"
        ) from None
    if dask == "local":
        cluster = LocalCluster(
            n_workers=check_workers(workers), threads_per_worker=1, processes=True,
            dashboard_address=None,
        )  # fmt: skip
        return Client(cluster, set_as_default=False), cluster
    refused = _refused(dask)
    if refused is not None:  # nothing listens there: say so now, not after the 10 s timeout
        raise ParameterError(
            "scheduler", dask, f"a reachable Dask scheduler (connection refused: {refused})"
        )
    try:
        return Client(dask, timeout=10, set_as_default=False), None
    except (OSError, TimeoutError) as e:
        raise ParameterError(
            "scheduler",
            dask,
            f"a reachable Dask scheduler (none answered within 10 s: {type(e).__name__})",
        ) from None


#: Tasks per Dask worker that a scan's tiles are grouped into.  A Dask task costs the client,
#: the scheduler and the worker ~10 ms of CPU in all (500 empty tasks on a 2-worker
#: ``LocalCluster``: 5.3 s of wall, 1.7 s of it the client's CPU and 3-4 s the scheduler's), so
#: one task per 0.07 s tile of the 1000 x 1000 chatter map left Dask at 0.74-0.96 of local
#: processes; 16 tasks per worker keep that cost near 1 % and the last task's wait short.
TASKS_PER_WORKER = 16


def dask_batches(todo: list[int], n_workers: int) -> list[list[int]]:
    """The ``todo`` tiles in consecutive groups, one Dask task each: about
    :data:`TASKS_PER_WORKER` per worker, at least one tile per task."""
    size = max(1, -(-len(todo) // (max(1, n_workers) * TASKS_PER_WORKER)))
    return [todo[i : i + size] for i in range(0, len(todo), size)]


def _call_tiles(job: Callable[[int, int], Any], spans: list[tuple[int, int]]) -> list:
    """``job(lo, hi)`` for each span, on a Dask worker (``job`` arrives there once, scattered)."""
    return [job(lo, hi) for lo, hi in spans]


def _dask_tiles(client, job, bounds, batches, finished) -> None:
    """Submit the tiles (one task per batch), hand each tile to ``finished`` as its batch
    completes.

    The job is scattered to the workers once and each task names it, so a job holding large
    arrays (a refinement's index, a sub-grid's points) is not pickled into every task.  The
    results are gathered in the background (``with_results``), not one round trip per task on
    this thread.  The client is not made the default one and the completions are awaited on its
    own event loop: on a user's default client's loop each scan lost ~2 s.
    """
    from dask.distributed import as_completed  # noqa: PLC0415 -- optional: loaded on first use

    job_f = client.scatter(job, broadcast=True, hash=False)
    spans = [[bounds[t] for t in batch] for batch in batches]
    futs = client.map(_call_tiles, [job_f] * len(batches), spans, pure=False)
    tiles_of = {f.key: batch for f, batch in zip(futs, batches, strict=True)}
    for f, values in as_completed(futs, with_results=True, loop=client.loop):
        for t, value in zip(tiles_of[f.key], values, strict=True):
            finished(t, value)
        f.release()
    job_f.release()
