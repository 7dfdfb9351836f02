"""Parameter sweeps at scale: LLE, period and impact rate on a 1-D or 2-D grid.

The grid is cut into *tiles* of consecutive points (row-major order).  Each tile is
computed by :func:`compute_tile` (SIMD batch variational integration,
:mod:`precise_impact.analysis.lyapunov.batch`) in a worker process, or on a Dask cluster, and written
atomically to ``OUT/tiles/tile_NNNNN.npz`` as soon as it is done.  A rerun with the
same specification skips finished tiles, so an interrupted sweep resumes where it
stopped and yields the same numbers bit for bit.  The assembled table is written as
``sweep.npz`` and ``sweep.csv`` with heat maps (2-D) or curves (1-D).
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import json
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from fractions import Fraction
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from precise_impact.core.result import ResultMixin
from precise_impact.io.figures import figure
from precise_impact.errors import OptionalDependencyError, ParameterError
from precise_impact.core.params import Params, check_count, decimal_str, exact_grid
from precise_impact.io.atomic import atomic_write

__all__ = ["SWEEP_PARAMS", "SweepSpec", "compute_tile", "run_sweep", "load_sweep"]

#: Runtime parameters a sweep may vary (no recompilation between points).
SWEEP_PARAMS = ("eta", "x_w", "zeta", "a", "R")
_FIELDS = ("lle", "stderr", "lambda2", "period", "impacts_per_period")
_MINIMUM = {"eta": (Fraction(0), True), "zeta": (Fraction(0), False), "R": (Fraction(0), False)}


#: Default work budget of a sweep in point-periods (grid points x (periods + transient)):
#: 10^10 is a 1000 x 1000 map at 2000 + 1000 periods three times over (~15 h at today's
#: 60 points/s on 2 cores); larger sweeps ask for --max-work explicitly.
MAX_WORK = 10**10


@dataclasses.dataclass(frozen=True)
class SweepSpec:
    """What a sweep computes.  Everything here enters the tiles' identity hash.

    Attributes
    ----------
    base : Params
        Fixed parameters and the initial condition of every point.
    axes : tuple of (name, tuple of Fraction)
        One or two axes over :data:`SWEEP_PARAMS`.
    periods, transient : int
        Measured and discarded periods per point.
    tile_size : int
        Points per tile (the unit of work, checkpoint and resume).
    batch_size : int
        SIMD lanes per batch integrator (part of the identity: results are computed
        group by group).
    """

    base: Params
    axes: tuple
    periods: int = 2000
    transient: int = 1000
    tile_size: int = 64
    batch_size: int = 8

    @classmethod
    def make(cls, base: Params, axes: Sequence[tuple[str, Any, Any, Any]], periods=2000, transient=1000,
             tile_size=64, batch_size=None, max_work: int = MAX_WORK) -> "SweepSpec":
        """Validate and build: ``axes`` = [(name, min, max, n), ...] (1 or 2 axes).

        The work, grid points x (periods + transient), is checked against ``max_work``
        (default :data:`MAX_WORK`) before any grid is built, so a 10^6 x 10^6 request is
        refused at once with the figure and the way to raise the budget.
        """
        from precise_impact.analysis.lyapunov.batch import default_batch_size

        if not 1 <= len(axes) <= 2:
            raise ParameterError("axes", len(axes), "a sweep has 1 or 2 axes")
        periods = check_count(periods, "periods", minimum=1)
        transient = check_count(transient, "transient")
        max_work = check_count(max_work, "max_work", 10**15, minimum=1)
        points = 1
        for ax in axes:
            if len(ax) != 4:
                raise ParameterError("axis", ax, "(name, min, max, n)")
            points *= check_count(ax[3], "n", 1_000_000, minimum=1)
        work = points * (periods + transient)
        if work > max_work:
            raise ParameterError("max_work", max_work, f"this sweep needs {points} points x {periods + transient} periods "
                                 f"= {work:.3g} point-periods (~{work / 3000 / 60 / 3600:.3g} h at 60 points/s of "
                                 f"3000 periods); raise the budget (--max-work) to at least {work}")
        built = []
        for name, lo, hi, n in axes:
            if name not in SWEEP_PARAMS:
                raise ParameterError("axis", name, "one of " + ", ".join(SWEEP_PARAMS))
            minimum, strict = _MINIMUM.get(name, (None, False))
            if minimum is None:
                vals = exact_grid(lo, hi, n, name, minimum=Fraction(-(10**30)))
            else:
                vals = exact_grid(lo, hi, n, name, minimum=minimum, strict=strict)
            if name == "R" and vals[-1] > 1:
                raise ParameterError("R_max", decimal_str(vals[-1]), "restitution must satisfy R <= 1")
            built.append((name, tuple(vals)))
        if len(built) == 2 and built[0][0] == built[1][0]:
            raise ParameterError("axis", built[1][0], "the two axes must be different parameters")
        tile_size = check_count(tile_size, "tile_size", 100_000)
        if tile_size < 1:
            raise ParameterError("tile_size", tile_size, "an integer >= 1")
        batch_size = default_batch_size() if batch_size is None else check_count(batch_size, "batch_size", 64)
        spec = cls(base, tuple(built), periods, transient, tile_size, batch_size)
        for k in (0, spec.n_points - 1):  # every point valid (ranges are monotone): check the corners
            spec.point(k)
        return spec

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(v) for _, v in self.axes)

    @property
    def n_points(self) -> int:
        return math.prod(self.shape)

    @property
    def n_tiles(self) -> int:
        return -(-self.n_points // self.tile_size)

    def point(self, k: int) -> Params:
        """The parameters of flat point ``k`` (row-major)."""
        idx = np.unravel_index(k, self.shape)
        return self.base.replace(**{name: vals[i] for (name, vals), i in zip(self.axes, idx)})

    def to_json_dict(self) -> dict:
        return {
            "base": self.base.decimal(),
            "axes": [[name, [decimal_str(v) for v in vals]] for name, vals in self.axes],
            "periods": self.periods,
            "transient": self.transient,
            "tile_size": self.tile_size,
            "batch_size": self.batch_size,
        }

    @property
    def digest(self) -> str:
        import heyoka

        ident = dict(self.to_json_dict(), heyoka=heyoka.__version__)
        return hashlib.sha256(json.dumps(ident, sort_keys=True).encode()).hexdigest()[:16]


def compute_tile(spec: SweepSpec, tile: int) -> dict[str, np.ndarray]:
    """Compute one tile (a pure function of ``spec`` and ``tile``)."""
    from precise_impact.analysis.lyapunov.batch import batch_lle

    lo = tile * spec.tile_size
    hi = min(spec.n_points, lo + spec.tile_size)
    pts = [spec.point(k) for k in range(lo, hi)]
    res = batch_lle(pts, periods=spec.periods, transient=spec.transient, batch_size=spec.batch_size)
    out = {f: np.array([r[f] for r in res]) for f in _FIELDS}
    out["index"] = np.arange(lo, hi)
    return out


def _tile_path(out: Path, tile: int) -> Path:
    return out / "tiles" / f"tile_{tile:05d}.npz"


def _write_tile(out: Path, spec: SweepSpec, tile: int, arrays: dict[str, np.ndarray]) -> None:
    data = dict(arrays, digest=np.asarray(spec.digest))
    atomic_write(_tile_path(out, tile), lambda fh: np.savez(fh, **data), binary=True)


def _finished(out: Path, spec: SweepSpec) -> set[int]:
    done = set()
    for t in range(spec.n_tiles):
        p = _tile_path(out, t)
        if p.exists():
            try:
                with np.load(p) as d:
                    if str(d["digest"]) == spec.digest:
                        done.add(t)
            except (OSError, ValueError, KeyError):
                pass  # unreadable (should not happen with atomic writes): recompute
    return done


def _tiles_task(spec: SweepSpec, tiles: list[int]) -> list[tuple[int, dict]]:
    return [(t, compute_tile(spec, t)) for t in tiles]


def run_sweep(
    spec: SweepSpec,
    out: str | os.PathLike,
    workers: int | None = None,
    dask: str | None = None,
    progress: bool = True,
    max_tiles: int | None = None,
) -> SweepSummary:
    """Compute every unfinished tile, then assemble the table and the plots.

    Parameters
    ----------
    spec : SweepSpec
    out : directory
        Holds ``sweep_spec.json``, ``tiles/`` and the assembled outputs.  An ``out``
        that holds a *different* sweep is refused (:class:`ParameterError`).
    workers : int or None, default ``None`` (``os.cpu_count()``)
        Local worker processes (ignored with ``dask``).
    dask : None, ``'local'`` or a scheduler address ``'tcp://HOST:PORT'``
        Run the tiles on a Dask ``LocalCluster`` (one single-threaded worker process
        per core) or on the cluster behind the address (``pip install
        precise_impact[dask]``).
    progress : bool, default ``True``
        A progress bar on stderr.
    max_tiles : int or None
        Stop after this many newly computed tiles (for tests of resuming).

    Returns a summary dict (tiles computed / reused, points per second, paths).
    """
    out = Path(out)
    spec_file = out / "sweep_spec.json"
    ident = dict(spec.to_json_dict(), digest=spec.digest)
    if spec_file.exists():
        old = json.loads(spec_file.read_text())
        if old.get("digest") != spec.digest:
            raise ParameterError("out", str(out), "holds a different sweep (sweep_spec.json); use another --out or delete it")
    else:
        text = json.dumps(ident, indent=1)
        atomic_write(spec_file, lambda fh: fh.write(text), binary=False)
    done = _finished(out, spec)
    todo = [t for t in range(spec.n_tiles) if t not in done]
    if max_tiles is not None:
        todo = todo[:max_tiles]
    start = time.perf_counter()
    count = {"n": 0}

    def finished(t: int, arrays: dict) -> None:
        _write_tile(out, spec, t, arrays)
        count["n"] += 1
        if progress:
            n_done = len(done) + count["n"]
            w = 40
            f = int(w * n_done / spec.n_tiles)
            el = time.perf_counter() - start
            rate = count["n"] * spec.tile_size / max(el, 1e-9)
            print(
                f"\r  sweep [{'#' * f}{'.' * (w - f)}] {n_done}/{spec.n_tiles} tiles  {el:7.1f} s  ~{rate:6.1f} points/s",
                end="\n" if n_done == spec.n_tiles or count["n"] == len(todo) else "",
                file=sys.stderr,
                flush=True,
            )

    if dask is not None:
        n_workers = _run_dask(spec, todo, dask, finished, workers)
    else:
        n_workers = workers if workers is not None else (os.cpu_count() or 1)
        n_workers = check_count(n_workers, "workers", 1024)
        if n_workers < 1:
            raise ParameterError("workers", n_workers, "an integer >= 1")
        if n_workers == 1 or len(todo) <= 1:
            for t in todo:
                finished(t, compute_tile(spec, t))
        else:
            with ProcessPoolExecutor(max_workers=n_workers) as ex:
                futs = {ex.submit(compute_tile, spec, t): t for t in todo}
                for f in as_completed(futs):
                    finished(futs[f], f.result())
    elapsed = time.perf_counter() - start
    summary = {
        "tiles_total": spec.n_tiles,
        "tiles_reused": len(done),
        "tiles_computed": count["n"],
        "elapsed_s": elapsed,
        "points_per_s": count["n"] * spec.tile_size / elapsed if count["n"] and elapsed > 0 else None,
        "workers": n_workers,
        "backend": "dask" if dask is not None else "processes",
        "complete": len(done) + count["n"] == spec.n_tiles,
    }
    if summary["complete"]:
        summary.update(assemble(spec, out))
    return SweepSummary(**summary)


@dataclasses.dataclass
class SweepSummary(ResultMixin):
    """What :func:`run_sweep` did.

    Attributes
    ----------
    tiles_total, tiles_reused, tiles_computed : int
        Tiles of the grid; found finished in ``out`` (resume); computed by this call.
    elapsed_s : float
        Wall time of this call.
    points_per_s : float or None
        Grid points computed per second (``None`` if nothing was computed).
    workers : int
        Processes (or Dask workers) used.
    backend : str
        ``'processes'`` or ``'dask'``.
    complete : bool
        Every tile is finished (then the assembled files exist).
    npz, csv, png : str or None
        The assembled ``sweep.npz``, ``sweep.csv``, ``sweep.png`` (when complete).
    """

    tiles_total: int
    tiles_reused: int
    tiles_computed: int
    elapsed_s: float
    points_per_s: float | None
    workers: int
    backend: str
    complete: bool
    npz: str | None = None
    csv: str | None = None
    png: str | None = None


def _run_dask(spec: SweepSpec, todo: list[int], dask: str, finished: Callable, workers: int | None) -> int:
    try:
        from dask.distributed import Client, LocalCluster, as_completed as dask_as_completed
    except ImportError:
        raise OptionalDependencyError("dask", "pip install 'precise_impact[dask]'", "--dask") from None
    if dask == "local":
        n = check_count(workers, "workers", 1024, minimum=1) if workers is not None else (os.cpu_count() or 1)
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(cluster)
    elif dask.startswith("tcp://"):
        cluster = None
        try:
            client = Client(dask, timeout=10)
        except (OSError, TimeoutError) as e:
            raise ParameterError("scheduler", dask, f"a reachable Dask scheduler (none answered within 10 s: {type(e).__name__})") from None
    else:
        raise ParameterError("dask", dask, "'local' or a scheduler address tcp://HOST:PORT")
    try:
        n_workers = len(client.scheduler_info()["workers"])
        futs = client.map(compute_tile, [spec] * len(todo), todo, pure=False)
        tile_of = {f.key: t for f, t in zip(futs, todo)}
        for f in dask_as_completed(futs):
            finished(tile_of[f.key], f.result())
            f.release()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    return n_workers


def load_sweep(out: str | os.PathLike, spec: SweepSpec) -> dict[str, np.ndarray]:
    """Read every tile of a finished sweep into arrays of the grid's shape."""
    out = Path(out)
    arrays = {f: np.full(spec.n_points, np.nan) for f in _FIELDS}
    for t in range(spec.n_tiles):
        with np.load(_tile_path(out, t)) as d:
            if str(d["digest"]) != spec.digest:
                raise ParameterError("out", str(out), f"tile {t} belongs to another sweep")
            for f in _FIELDS:
                arrays[f][d["index"]] = d[f]
    return {f: a.reshape(spec.shape) for f, a in arrays.items()}


def assemble(spec: SweepSpec, out: Path) -> dict[str, str]:
    """Write ``sweep.npz``, ``sweep.csv`` and ``sweep.png`` from the tiles."""
    data = load_sweep(out, spec)
    axes = {f"axis{i}_{name}": np.array([float(v) for v in vals]) for i, (name, vals) in enumerate(spec.axes)}
    npz = dict(data, **axes, spec_json=np.asarray(json.dumps(spec.to_json_dict())))
    atomic_write(out / "sweep.npz", lambda fh: np.savez_compressed(fh, **npz), binary=True)
    names = [name for name, _ in spec.axes]
    lines = [",".join(names + list(_FIELDS))]
    for k in range(spec.n_points):
        idx = np.unravel_index(k, spec.shape)
        coords = [decimal_str(vals[i]) for (_, vals), i in zip(spec.axes, idx)]
        vals = [repr(float(data[f][idx])) if f != "period" else str(int(data[f][idx])) for f in _FIELDS]
        lines.append(",".join(coords + vals))
    text = "\n".join(lines) + "\n"
    atomic_write(out / "sweep.csv", lambda fh: fh.write(text), binary=False)
    _plot(spec, data, out / "sweep.png")
    return {"npz": str(out / "sweep.npz"), "csv": str(out / "sweep.csv"), "png": str(out / "sweep.png")}


def _plot(spec: SweepSpec, data: dict, path: Path) -> None:
    from matplotlib.colors import TwoSlopeNorm

    fig = figure(figsize=(12, 4.8))
    if len(spec.axes) == 1:
        name, vals = spec.axes[0]
        x = [float(v) for v in vals]
        ax1, ax2 = fig.subplots(1, 2)
        ax1.errorbar(x, data["lle"], yerr=data["stderr"], lw=0.8)
        ax1.axhline(0, color="k", lw=0.5)
        ax1.set_xlabel(name)
        ax1.set_ylabel("LLE per unit time")
        ax2.step(x, data["period"], where="mid")
        ax2.set_xlabel(name)
        ax2.set_ylabel("period (0 = none <= 32)")
    else:
        (n0, v0), (n1, v1) = spec.axes
        ext = [float(v1[0]), float(v1[-1]), float(v0[0]), float(v0[-1])]
        ax1, ax2 = fig.subplots(1, 2)
        lle = data["lle"]
        vmax = max(1e-6, float(np.nanmax(lle)))
        vmin = min(-1e-6, float(np.nanmin(lle)))
        im = ax1.imshow(lle, origin="lower", aspect="auto", extent=ext, cmap="RdBu_r",
                        norm=TwoSlopeNorm(vcenter=0.0, vmin=vmin, vmax=vmax))
        fig.colorbar(im, ax=ax1, label="LLE per unit time")
        ax1.set_xlabel(n1)
        ax1.set_ylabel(n0)
        ax1.set_title("largest Lyapunov exponent")
        import matplotlib

        cmap = matplotlib.colormaps["tab20"].with_extremes(bad="white")
        per = np.ma.masked_equal(data["period"], 0)  # no period <= 32 (chaotic / transient): white
        im2 = ax2.imshow(per, origin="lower", aspect="auto", extent=ext, cmap=cmap, vmin=0.5, vmax=20.5)
        fig.colorbar(im2, ax=ax2, label="period (white: none <= 32)")
        ax2.set_xlabel(n1)
        ax2.set_title("detected period")
    fig.suptitle(f"{spec.n_points} points, {spec.transient} transient + {spec.periods} periods each")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    atomic_write(path, lambda fh: fh.write(buf.getvalue()), binary=True)
