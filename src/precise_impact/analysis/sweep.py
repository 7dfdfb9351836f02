"""Parameter sweeps at scale: LLE, period and impact rate on a 1-D or 2-D grid.

The grid is cut into tiles computed through the scan runner
(:func:`~precise_impact.analysis.scan.run_scan`: processes or Dask) and written atomically, so
an interrupted sweep resumes and gives the same numbers bit for bit.
"""

from __future__ import annotations

import csv
import dataclasses
import functools
import hashlib
import io
import json
import math
import os
from collections.abc import Sequence
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from precise_impact.analysis.lyapunov.batch import batch_lle, default_batch_size
from precise_impact.analysis.lyapunov.fast import ROW_FIELDS, fast_batch_rows
from precise_impact.analysis.scan import (
    Grid,
    NpzTileStore,
    check_workers,
    resolve_model,
    run_scan,
)
from precise_impact.core.budget import enforce_max_time, estimate_cost, format_duration
from precise_impact.core.params import Params, as_params, check_count, decimal_str, exact_grid
from precise_impact.core.result import ResultMixin, columns
from precise_impact.errors import OverBudgetError, ParameterError
from precise_impact.io.atomic import atomic_write, check_output_dir
from precise_impact.io.figures import figure, finish, period_colormap, wrap_title
from precise_impact.io.jsonout import dumps, write_json
from precise_impact.io.lock import DirectoryLock
from precise_impact.io.progress import say

__all__ = ["SWEEP_PARAMS", "SweepSpec", "SweepResult", "compute_tile", "run_sweep", "load_sweep"]

#: Runtime parameters a sweep may vary (no recompilation between points).
SWEEP_PARAMS = ("eta", "x_w", "zeta", "a", "R")
_FIELDS = ("lle", "stderr", "lambda2", "period", "impacts_per_period")
#: A point's ``status`` code and its word in ``sweep.csv``: computed, or refused (an ``R = 1``
#: bounce sequence predicted to come to rest on the wall or to outrun the impact budget,
#: :class:`~precise_impact.errors.EndlessBouncesError`; its values are NaN).  The tiles keep
#: their documented fields: a refused point has ``period = REFUSED_PERIOD``.
STATUS_WORDS = {
    0: "ok",
    1: "refused: R = 1 bounces on the wall without end",
    2: "failed: the integration stopped (e.g. a missed impact while chattering into the wall)",
}
REFUSED_PERIOD = -1  # status 1; status 2 is period = -2
#: The longest period the sweep's detection looks for (fast_batch_rows' default): the period
#: map's category "none <= 32".
_MAX_PERIOD = 32
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
        group by group; used by the heyoka engine).
    engine : str
        The model (also :attr:`model`): ``'fast'`` (the compiled closed form,
        :func:`~precise_impact.analysis.lyapunov.fast.fast_batch`; a point it does not
        resolve is computed by heyoka) or ``'heyoka'`` (SIMD batch variational
        integration, :func:`~precise_impact.analysis.lyapunov.batch.batch_lle`).

    See Also
    --------
    precise_impact.analysis.sweep.run_sweep : compute a sweep.
    precise_impact.analysis.sweep.load_sweep : read one back.
    precise_impact.analysis.sweep.SweepResult : the result.
    """

    base: Params
    axes: tuple
    periods: int = 2000
    transient: int = 1000
    tile_size: int = 64
    batch_size: int = 8
    engine: str = "fast"

    @classmethod
    def make(
        cls,
        base: Params,
        axes: Sequence[tuple[str, Any, Any, Any]],
        periods=2000,
        transient=1000,
        tile_size=64,
        batch_size=None,
        max_work: int = MAX_WORK,
        model: str | None = None,
        *,
        engine: str | None = None,
    ) -> SweepSpec:
        """Validate and build a sweep specification.

        Parameters
        ----------
        base : Params
            Every parameter not swept (and the initial condition of each run).
        axes : sequence of (name, min, max, n)
            One or two axes; ``name`` one of ``eta``, ``x_w``, ``zeta``, ``a``, ``R``;
            ``min`` and ``max`` exact decimals (both included), ``n >= 1`` values.
        periods : int, default 2000
            Measured periods per grid point (LLE, period detection, impacts).
        transient : int, default 1000
            Discarded periods per grid point.
        tile_size : int, default 64
            Grid points per tile (the unit of work written atomically and resumed).
        batch_size : int or None, default ``None``
            SIMD lanes per batch integrator (``<= 64``); ``None`` is heyoka's recommended
            width on this CPU (8 with AVX-512, 4 with AVX2).
        max_work : int, default :data:`MAX_WORK`
            Budget on grid points x (periods + transient), checked before any grid is
            built, so a 10^6 x 10^6 request is refused at once with the figure and the
            way to raise the budget.
        model : str or None, default ``None`` (``'fast'``)
            ``'fast'`` (compiled closed form, ~30x heyoka's points per second) or
            ``'heyoka'``.
        engine : str or None, default ``None``
            Deprecated spelling of ``model`` (a :class:`DeprecationWarning`).

        Returns
        -------
        SweepSpec
            The validated, immutable specification.

        Raises
        ------
        ParameterError
            Bad axis name, range, count or a budget exceeded.
        """
        base = as_params(base, "base")
        if isinstance(axes, (str, bytes)) or not isinstance(axes, Sequence):
            raise ParameterError(
                "axes", type(axes).__name__, "a list of 1 or 2 axes (name, min, max, n)"
            )
        if not 1 <= len(axes) <= 2:
            raise ParameterError("axes", len(axes), "a sweep has 1 or 2 axes")
        periods = check_count(periods, "periods", minimum=1)
        transient = check_count(transient, "transient")
        max_work = check_count(max_work, "max_work", 10**15, minimum=1)
        points = 1
        for ax in axes:
            if isinstance(ax, (str, bytes)) or not isinstance(ax, Sequence) or len(ax) != 4:
                raise ParameterError("axes", ax, "a list of 1 or 2 axes (name, min, max, n)")
            points *= check_count(ax[3], "n", 1_000_000, minimum=1)
        work = points * (periods + transient)
        if work > max_work:
            model_name = resolve_model(model, engine, "SweepSpec.make")
            cost = estimate_cost(
                "sweep", periods=periods, transient=transient, runs=points, model=model_name
            )
            raise OverBudgetError(
                "max_work",
                max_work,
                f"this sweep needs {points} points x {periods + transient} periods "
                f"= {work:.3g} point-periods (~{format_duration(cost.seconds)} on one core, "
                f"{model_name} model); raise the budget (--max-work) to at least {work}",
            )
        built = []
        for name, lo, hi, n in axes:
            if name not in SWEEP_PARAMS:
                raise ParameterError("axis", name, "one of " + ", ".join(SWEEP_PARAMS))
            minimum, strict = _MINIMUM.get(name, (None, False))
            if minimum is None:
                vals = exact_grid(lo, hi, n, name, minimum=Fraction(-(10**30)))
            else:
                vals = exact_grid(lo, hi, n, name, minimum=minimum, strict=strict)
            if name == "R" and max(vals) > 1:
                end = "R_max" if vals[-1] > 1 else "R_min"
                raise ParameterError(end, decimal_str(max(vals)), "restitution must satisfy R <= 1")
            built.append((name, tuple(vals)))
        if len(built) == 2 and built[0][0] == built[1][0]:
            raise ParameterError("axis", built[1][0], "the two axes must be different parameters")
        tile_size = check_count(tile_size, "tile_size", 100_000)
        if tile_size < 1:
            raise ParameterError("tile_size", tile_size, "an integer >= 1")
        batch_size = (
            default_batch_size()
            if batch_size is None
            else check_count(batch_size, "batch_size", 64)
        )
        model = resolve_model(model, engine, "SweepSpec.make")
        spec = cls(base, tuple(built), periods, transient, tile_size, batch_size, model)
        for k in (
            0,
            spec.n_points - 1,
        ):  # every point valid (ranges are monotone): check the corners
            spec.point(k)
        return spec

    @property
    def model(self) -> str:
        """The engine (``'fast'`` or ``'heyoka'``); stored as ``engine`` in the tiles' identity."""
        return self.engine

    @property
    def grid(self) -> Grid:
        """The sweep's grid (:class:`~precise_impact.analysis.scan.Grid`)."""
        return Grid(self.axes)

    @property
    def shape(self) -> tuple[int, ...]:
        return self.grid.shape

    @property
    def n_points(self) -> int:
        return self.grid.size

    @property
    def n_tiles(self) -> int:
        return -(-self.n_points // self.tile_size)

    def point(self, k: int) -> Params:
        """The parameters of flat point ``k`` (row-major)."""
        return self.base.replace(**self.grid.point(k))

    def rows(self, lo: int, hi: int) -> np.ndarray:
        """Flat points ``lo .. hi - 1`` as float rows (columns
        :data:`~precise_impact.analysis.lyapunov.fast.ROW_FIELDS`), each value rounded once
        from its exact decimal, as ``float(self.point(k).name)`` (no Params per point:
        the corners were validated by :meth:`make` and the axes are monotone)."""
        row = {n: float(getattr(self.base, n)) for n in ROW_FIELDS}
        out = np.empty((hi - lo, len(ROW_FIELDS)))
        out[:] = [row[n] for n in ROW_FIELDS]
        idx = np.unravel_index(np.arange(lo, hi), self.shape)
        for (name, vals), ix in zip(self.axes, idx, strict=True):
            out[:, ROW_FIELDS.index(name)] = np.array([float(v) for v in vals])[ix]
        return out

    def to_json_dict(self) -> dict:
        return {
            "base": self.base.decimal(),
            "axes": [[name, [decimal_str(v) for v in vals]] for name, vals in self.axes],
            "periods": self.periods,
            "transient": self.transient,
            "tile_size": self.tile_size,
            "batch_size": self.batch_size,
            "engine": self.engine,
        }

    @functools.cached_property
    def digest(self) -> str:
        """The sweep's identity: a hash of :meth:`to_json_dict` and the engine versions
        (computed once per object: every tile written and read checks it)."""
        import heyoka  # noqa: PLC0415 -- optional: loaded on first use

        ident = dict(self.to_json_dict(), heyoka=heyoka.__version__)
        if self.engine == "fast":
            import numba  # noqa: PLC0415 -- heavy: numba, loaded on first use

            ident["numba"] = numba.__version__
        return hashlib.sha256(dumps(ident, sort_keys=True).encode()).hexdigest()[:16]


def compute_tile(spec: SweepSpec, tile: int) -> dict[str, np.ndarray]:
    """Compute one tile (a pure function of ``spec`` and ``tile``)."""
    lo = tile * spec.tile_size
    hi = min(spec.n_points, lo + spec.tile_size)
    if spec.engine == "fast":
        res = fast_batch_rows(
            spec.rows(lo, hi),
            lambda idx: [spec.point(lo + i) for i in idx],
            periods=spec.periods,
            transient=spec.transient,
        )
    else:
        pts = [spec.point(k) for k in range(lo, hi)]
        res = batch_lle(
            pts, periods=spec.periods, transient=spec.transient, batch_size=spec.batch_size
        )
    out = {f: np.array([r[f] for r in res]) for f in _FIELDS}
    code = np.array([r.get("status_code", 0) for r in res])
    out["period"] = np.where(code > 0, -code, out["period"])
    out["index"] = np.arange(lo, hi)
    return out


def _store(out: Path, spec: SweepSpec) -> NpzTileStore:
    """The sweep's tiles on disk (``OUT/tiles/tile_NNNNN.npz``, checked against ``spec``)."""
    return NpzTileStore(out, spec.digest, _FIELDS, spec.n_points, spec.tile_size)


def _tile_job(spec: SweepSpec, lo: int, hi: int) -> dict[str, np.ndarray]:
    """The runner's job: the tile that starts at flat point ``lo``."""
    return compute_tile(spec, lo // spec.tile_size)


def run_sweep(
    spec: SweepSpec,
    out: str | os.PathLike,
    workers: int | None = None,
    dask: str | None = None,
    progress: bool | None = None,
    max_tiles: int | None = None,
    max_time: Any = None,
) -> SweepResult:
    """Compute every unfinished tile, then assemble the table and the plots.

    Parameters
    ----------
    spec : SweepSpec
        What to compute (:meth:`SweepSpec.make`).
    out : str or os.PathLike
        Directory; holds ``sweep_spec.json``, ``tiles/`` and the assembled outputs.  An ``out``
        that holds a *different* sweep is refused (:class:`ParameterError`).
    workers : int or None, default ``None`` (``os.cpu_count()``)
        Local worker processes (ignored with ``dask``).
    dask : None, ``'local'`` or a scheduler address ``'tcp://HOST:PORT'``
        Run the tiles on a Dask ``LocalCluster`` (one single-threaded worker process
        per core) or on the cluster behind the address (``pip install
        precise_impact[dask]``).
    progress : bool or None, default ``None``
        A progress bar on stderr (:class:`~precise_impact.io.progress.Progress`):
        ``None`` shows it only when stderr is a terminal.
    max_tiles : int or None, default ``None`` (no limit)
        Stop after this many newly computed tiles (for tests of resuming).
    max_time : decimal or None, default ``None``
        Time budget in seconds per worker (``1 <= max_time <= 604800``): the estimated
        cost of every point of the grid (:func:`~precise_impact.core.budget.estimate_cost`,
        job ``'sweep'``) is checked against ``max_time x workers`` before any work
        (:class:`~precise_impact.errors.OverBudgetError`); ``None``: no time budget (the
        work budget of :meth:`SweepSpec.make` still holds).

    Notes
    -----
    Each tile file carries the sweep's digest, its tile number, its points' indices and
    a SHA-256 over all of them and its arrays.  On resume a tile that is unreadable,
    belongs to another sweep, holds another tile's points or fails its checksum is
    named on stderr and recomputed; ``sweep.npz`` / ``sweep.csv`` are written only when
    every tile verifies.  A damaged ``sweep_spec.json`` is rewritten (with a line)
    unless a tile shows that the directory holds another sweep.

    Returns
    -------
    SweepResult
        The grid (NaN at the points of tiles not finished yet), ``complete``, the
        assembled ``files`` (when complete) and the run's ``stats``: tiles total /
        reused / computed, wall time, points per second, workers, backend.

    Raises
    ------
    ParameterError
        Bad input, ``out`` holds a different sweep, or another run is writing to ``out``
        (a lock file, :class:`~precise_impact.io.lock.DirectoryLock`), before any work.
    OptionalDependencyError
        ``dask`` is asked for and Dask is not installed.

    See Also
    --------
    precise_impact.analysis.sweep.SweepSpec : the grid, periods and tiling of a sweep.
    precise_impact.analysis.sweep.load_sweep : read a finished sweep back.
    precise_impact.analysis.bifurcation.bifurcation : a one-axis diagram in memory.

    Examples
    --------
    >>> import precise_impact as pi
    >>> import tempfile
    >>> spec = pi.SweepSpec.make(pi.Params.make(), [("eta", "0.70", "0.74", 3)], periods=60,
    ...                          transient=20, tile_size=2)
    >>> with tempfile.TemporaryDirectory() as out:
    ...     res = pi.run_sweep(spec, out, workers=1, progress=False)
    ...
    >>> type(res).__name__, len(spec.axes[0][1])
    ('SweepResult', 3)
    """
    if not isinstance(spec, SweepSpec):
        raise ParameterError("spec", spec, "a SweepSpec (from SweepSpec.make)")
    out = check_output_dir(out, "out", force=True)  # a directory path; resumed in, not replaced
    if max_time is not None:
        n_workers = 1 if dask is not None and dask != "local" else check_workers(workers)
        enforce_max_time(
            max_time,
            "sweep",
            scale=n_workers,
            periods=spec.periods,
            transient=spec.transient,
            runs=spec.n_points,
            model=spec.engine,
        )
    with DirectoryLock(out, "out"):  # one writer per directory, before anything is read or written
        return _run_locked(spec, out, workers, dask, progress, max_tiles)


def _check_spec_file(spec: SweepSpec, out: Path) -> None:
    """Refuse a directory that holds another sweep; write (or repair) ``sweep_spec.json``."""
    spec_file = out / "sweep_spec.json"
    ident = dict(spec.to_json_dict(), digest=spec.digest)
    if spec_file.exists():
        try:
            old = json.loads(spec_file.read_text(encoding="utf-8"))
            old_digest = old.get("digest") if isinstance(old, dict) else None
        except (OSError, ValueError):
            old = old_digest = None
        if old_digest == spec.digest:
            return
        if old is not None and old_digest is not None:
            raise ParameterError(
                "out",
                str(out),
                "a directory of this sweep or an empty one (it holds a different "
                "sweep: sweep_spec.json); use another --out or delete it",
            )
        # Damaged: the tiles carry their own identity; if any belongs to another sweep, refuse.
        for t in sorted(out.glob("tiles/tile_*.npz")):
            try:
                with np.load(t, allow_pickle=False) as d:
                    foreign = str(d["digest"]) != spec.digest
            except Exception:
                continue
            if foreign:
                raise ParameterError(
                    "out",
                    str(out),
                    "a directory of this sweep or an empty one (sweep_spec.json is "
                    f"damaged and {t.name} belongs to another sweep); use another --out",
                )
        say(f"sweep: {spec_file} is damaged: rewriting it (the tiles carry their own identity)")
    write_json(spec_file, ident)


def _run_locked(spec, out, workers, dask, progress, max_tiles) -> SweepResult:
    _check_spec_file(spec, out)
    run = run_scan(
        functools.partial(_tile_job, spec),
        spec.n_points,
        spec.tile_size,
        workers=workers,
        dask=dask,
        store=_store(out, spec),
        max_tiles=max_tiles,
        progress=progress,
        label="sweep tiles",
        unit="tiles",
        say=say,
    )
    n, elapsed = run.tiles_computed, run.elapsed_s
    stats = {
        "tiles_total": spec.n_tiles,
        "tiles_reused": run.tiles_reused,
        "tiles_computed": n,
        "elapsed_s": elapsed,
        "points_per_s": n * spec.tile_size / elapsed if n and elapsed > 0 else None,
        "workers": run.workers,
        "backend": "dask" if run.backend == "dask" else "processes",
    }
    result = _gather(out, spec, stats, strict=False)
    if result.complete:  # every tile verified just now: only then the assembled files
        result.files = assemble(result, out)
    return result


@dataclasses.dataclass
class SweepResult(ResultMixin):
    """A sweep's table on its grid, returned by :func:`run_sweep` and :func:`load_sweep`.

    Attributes
    ----------
    spec : SweepSpec
        What was swept (the grid is ``spec.axes``, row-major).
    lle, stderr, lambda2 : numpy.ndarray of float, shape ``spec.shape``
        Largest Lyapunov exponent per unit time, its standard error, the second exponent.
    period : numpy.ndarray of float, shape ``spec.shape``
        Detected period of the stroboscopic samples
        (:func:`~precise_impact.analysis.periodicity.detect_period`; 0: none <= 32; -1, -2: the
        point was refused or failed, see :attr:`status`).
    impacts_per_period : numpy.ndarray of float, shape ``spec.shape``
        Mean impacts per forcing period.
    complete : bool
        Every tile is finished.  The arrays are NaN at the points of unfinished tiles.
    files : dict of str to str
        ``{'npz', 'csv', 'png'}``: the assembled outputs :func:`run_sweep` wrote (empty
        before the sweep is complete, and from :func:`load_sweep`).
    stats : dict
        Diagnostics.  From :func:`run_sweep`: ``tiles_total``, ``tiles_reused`` (found
        finished: resume), ``tiles_computed`` (by this call), ``elapsed_s``,
        ``points_per_s`` (``None`` if nothing was computed), ``workers``, ``backend``
        (``'processes'`` or ``'dask'``).  From :func:`load_sweep`: ``tiles_total``.

    See Also
    --------
    precise_impact.analysis.sweep.run_sweep : returns it.
    precise_impact.analysis.sweep.load_sweep : also returns it.
    precise_impact.analysis.sweep.SweepSpec : the grid.

    Notes
    -----
    ``save(path)`` writes ``.json`` (:meth:`to_dict`), ``.npz`` (the arrays, one
    ``axisI_NAME`` array of coordinates per axis and the specification as
    ``spec_json``) or ``.csv`` (one row per point: the coordinates as decimal numbers
    (float64), the fields, ``status``, then each coordinate exactly in ``NAME_exact``: a
    decimal, or a ratio such as ``89/58``).
    """

    spec: SweepSpec
    lle: np.ndarray
    stderr: np.ndarray
    lambda2: np.ndarray
    period: np.ndarray
    impacts_per_period: np.ndarray
    complete: bool
    files: dict = dataclasses.field(default_factory=dict)
    stats: dict = dataclasses.field(default_factory=dict)

    def _tables(self) -> dict:
        """``to_dataframe()`` table ``points``: one row per grid point, as ``sweep.csv``."""

        def points() -> dict:
            grids = np.meshgrid(*self.coordinates().values(), indexing="ij")
            cols = [(n, "1", g.ravel()) for n, g in zip(self.coordinates(), grids, strict=True)]
            cols += [
                ("lle", "1/tau", self.lle.ravel()),
                ("stderr", "1/tau", self.stderr.ravel()),
                ("lambda2", "1/tau", self.lambda2.ravel()),
                ("period", None, self.period.ravel()),
                ("impacts_per_period", None, self.impacts_per_period.ravel()),
                ("status", None, [_status_word(c) for c in self.status.ravel()]),
            ]
            return columns(*cols)

        return {"points": points}

    @property
    def status(self) -> np.ndarray:
        """Per point: 0 computed, 1 refused (an ``R = 1`` bounce sequence on the wall
        predicted to come to rest or to outrun the impact budget), 2 failed (the integrator
        stopped: a missed impact while chattering into the wall ...); a refused or failed
        point has NaN values and ``period = -status``; ``sweep.csv`` says it in words
        (:data:`STATUS_WORDS`).  NaN where a tile is missing."""
        return np.where(np.isnan(self.period), np.nan, np.maximum(-self.period, 0.0))

    def plot(self, path: str | os.PathLike | None = None):
        """The LLE map and the period map (one discrete colour per whole period, with
        "none <= 32" and "refused" as categories of their own).

        Parameters
        ----------
        path : str, os.PathLike or None, default ``None``
            Also write the figure there (``.png``, ``.pdf``, ``.svg``, atomically).

        Returns
        -------
        matplotlib.figure.Figure
        """
        return _plot(self.spec, {f: getattr(self, f) for f in _FIELDS}, path)

    def coordinates(self) -> dict[str, np.ndarray]:
        """Each axis' values as float64, ``{name: array}`` in axis order."""
        return {name: np.array([float(v) for v in vals]) for name, vals in self.spec.axes}

    def save(self, path: str | os.PathLike) -> Path:
        """Write the result atomically as ``.json``, ``.npz`` or ``.csv`` (see Notes of the class).

        Parameters
        ----------
        path : str or os.PathLike
            The file; its suffix picks the format.

        Returns
        -------
        pathlib.Path
            The file written.

        Raises
        ------
        ParameterError
            ``path`` ends in none of ``.json``, ``.npz``, ``.csv``.
        """
        path = Path(path)
        spec = self.spec
        if path.suffix == ".npz":
            axes = {f"axis{i}_{name}": v for i, (name, v) in enumerate(self.coordinates().items())}
            npz = dict(
                {f: getattr(self, f) for f in _FIELDS},
                **axes,
                spec_json=np.asarray(dumps(spec.to_json_dict())),
            )
            atomic_write(path, lambda fh: np.savez_compressed(fh, **npz), binary=True)
            return path
        if path.suffix == ".csv":
            # each coordinate as a decimal number (float64, repr round-trips) that spreadsheets
            # and pandas read as a number, and exactly (``89/58``) in its own NAME_exact column
            names = [name for name, _ in spec.axes]
            buf = io.StringIO()
            w = csv.writer(buf, lineterminator="\n")
            w.writerow(names + list(_FIELDS) + ["status"] + [f"{n}_exact" for n in names])
            for k in range(spec.n_points):
                idx = np.unravel_index(k, spec.shape)
                exact = [vals[i] for (_, vals), i in zip(spec.axes, idx, strict=True)]
                row = [
                    repr(float(getattr(self, f)[idx]))
                    if f != "period"
                    else _int_or_nan(self.period[idx] if self.period[idx] >= 0 else np.nan)
                    for f in _FIELDS
                ]
                w.writerow(
                    [repr(float(v)) for v in exact]
                    + row
                    + [_status_word(self.status[idx])]
                    + [decimal_str(v) for v in exact]
                )
            text = buf.getvalue()
            atomic_write(path, lambda fh: fh.write(text), binary=False)
            return path
        if path.suffix != ".json":
            raise ParameterError("path", str(path), "a file ending in .json, .npz or .csv")
        return super().save(path)


def _status_word(code: float) -> str:
    return STATUS_WORDS.get(int(code), "nan") if math.isfinite(code) else "nan"


def _int_or_nan(x: float) -> str:
    return str(int(x)) if math.isfinite(x) else "nan"


def _gather(out: Path, spec: SweepSpec, stats: dict, strict: bool) -> SweepResult:
    """The verified tiles in ``out`` as a :class:`SweepResult` (NaN where a tile is missing)."""
    arrays = {f: np.full(spec.n_points, np.nan) for f in _FIELDS}
    found = 0
    store = _store(out, spec)
    for t in range(spec.n_tiles):
        data, why = store.read(t)
        if data is None:
            if strict:
                raise ParameterError(
                    "out",
                    str(out),
                    f"a finished sweep (tile {t} of {spec.n_tiles} "
                    + ("is missing" if why is None else why)
                    + ": run run_sweep / precise-impact sweep again to finish it)",
                )
            continue
        for f in _FIELDS:
            arrays[f][data["index"]] = data[f]
        found += 1
    grid = {f: a.reshape(spec.shape) for f, a in arrays.items()}
    return SweepResult(spec=spec, **grid, complete=found == spec.n_tiles, stats=stats)


def load_sweep(out: str | os.PathLike, spec: SweepSpec) -> SweepResult:
    """Read every tile of a finished sweep into arrays of the grid's shape.

    Parameters
    ----------
    out : str or os.PathLike
        The sweep's directory (``run_sweep``'s ``out``).
    spec : SweepSpec
        The sweep's specification (every tile's identity is checked against it).

    Returns
    -------
    SweepResult
        ``complete`` is true; ``stats`` holds ``tiles_total``.

    Raises
    ------
    ParameterError
        A tile is missing (the sweep is not finished) or belongs to another sweep.

    See Also
    --------
    precise_impact.analysis.sweep.run_sweep : compute the tiles that this reads.
    precise_impact.analysis.sweep.SweepSpec : the grid the tiles belong to.
    precise_impact.analysis.sweep.SweepResult : the arrays returned.

    Examples
    --------
    >>> import precise_impact as pi
    >>> import tempfile
    >>> spec = pi.SweepSpec.make(pi.Params.make(), [("eta", "0.70", "0.74", 3)], periods=60,
    ...                          transient=20, tile_size=2)
    >>> with tempfile.TemporaryDirectory() as out:
    ...     _ = pi.run_sweep(spec, out, workers=1, progress=False)
    ...     res = pi.load_sweep(out, spec)
    ...
    >>> res.spec == spec
    True
    """
    return _gather(Path(out), spec, {"tiles_total": spec.n_tiles}, strict=True)


def assemble(result: SweepResult, out: Path) -> dict[str, str]:
    """Write ``sweep.npz``, ``sweep.csv`` and ``sweep.png`` of a complete sweep into ``out``.

    Parameters
    ----------
    result : SweepResult
        A complete sweep.
    out : pathlib.Path
        The directory.

    Returns
    -------
    dict of str to str
        The three paths under the keys ``'npz'``, ``'csv'``, ``'png'``.
    """
    files = {ext: out / f"sweep.{ext}" for ext in ("npz", "csv")}
    for path in files.values():
        result.save(path)
    files["png"] = out / "sweep.png"
    result.plot(files["png"])
    return {k: str(v) for k, v in files.items()}


def _plot(spec: SweepSpec, data: dict, path: Any = None):
    """The sweep's figure: the LLE and the detected period (a discrete colour per whole period,
    with the categories "none <= 32" and "refused"); written to ``path`` if given."""
    from matplotlib.colors import TwoSlopeNorm  # noqa: PLC0415 -- heavy: loaded on first plot

    fig = figure(figsize=(13, 5.0), layout="constrained")
    if len(spec.axes) == 1:
        name, vals = spec.axes[0]
        x = [float(v) for v in vals]
        ax1, ax2 = fig.subplots(1, 2)
        ax1.errorbar(x, data["lle"], yerr=data["stderr"], lw=0.8, label="LLE +- stderr")
        ax1.axhline(0, color="k", lw=0.5)
        ax1.set_xlabel(name)
        ax1.set_ylabel("LLE per unit time tau")
        ax1.set_title("largest Lyapunov exponent", fontsize=10)
        per = np.asarray(data["period"], dtype=float)
        index, cmap, norm, labels = period_colormap(per, _MAX_PERIOD)
        ax2.scatter(x, per, c=index, cmap=cmap, norm=norm, s=14, edgecolors="0.3", lw=0.4)
        ax2.step(x, per, where="mid", color="0.6", lw=0.6, zorder=0)
        ax2.set_xlabel(name)
        ax2.set_ylabel(f"detected period (0: none <= {_MAX_PERIOD}, < 0: refused)")
        ax2.yaxis.get_major_locator().set_params(integer=True)
        ax2.set_title("detected period (whole forcing periods)", fontsize=10)
    else:
        (n0, v0), (n1, v1) = spec.axes
        ext = [float(v1[0]), float(v1[-1]), float(v0[0]), float(v0[-1])]
        ax1, ax2 = fig.subplots(1, 2)
        lle = data["lle"]
        vmax = max(1e-6, float(np.nanmax(lle)))
        vmin = min(-1e-6, float(np.nanmin(lle)))
        im = ax1.imshow(
            lle,
            origin="lower",
            aspect="auto",
            extent=ext,
            cmap="RdBu_r",
            norm=TwoSlopeNorm(vcenter=0.0, vmin=vmin, vmax=vmax),
        )
        fig.colorbar(im, ax=ax1, label="LLE per unit time tau (red: chaos)")
        ax1.set_xlabel(n1)
        ax1.set_ylabel(n0)
        ax1.set_title("largest Lyapunov exponent", fontsize=10)
        index, cmap, norm, labels = period_colormap(data["period"], _MAX_PERIOD)
        im2 = ax2.imshow(
            np.ma.masked_invalid(index),
            origin="lower",
            aspect="auto",
            extent=ext,
            cmap=cmap,
            norm=norm,
            interpolation="nearest",
        )
        cb = fig.colorbar(im2, ax=ax2, label="detected period", ticks=range(len(labels)))
        cb.ax.set_yticklabels(labels, fontsize=8)
        cb.ax.minorticks_off()
        ax2.set_xlabel(n1)
        ax2.set_ylabel(n0)
        ax2.set_title("detected period (one colour per whole period)", fontsize=10)
    fig.suptitle(
        wrap_title(
            f"{spec.n_points} points, {spec.transient} transient + {spec.periods} periods each",
            fig,
        )
    )
    return finish(fig, path, dpi=110)
