"""Lyapunov spectrum on the compiled closed-form engine (float64, every core).

The variational method's quantity with the exact 2x2 tangent flow between impacts (no ODE to
integrate), computed by :func:`precise_impact.solvers.fast.lle.lle_batch`; a start the engine
does not resolve sends the estimate to heyoka (``stats['engine']`` says so).
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from precise_impact.analysis.lyapunov.attractors import (
    MAX_PERIOD,
    TEST_BLOCK_PERIODS,
    TEST_BLOCKS,
    attribute,
)
from precise_impact.analysis.lyapunov.batch import batch_lle, refused_row
from precise_impact.analysis.lyapunov.result import LyapunovResult
from precise_impact.analysis.lyapunov.variational import variational_spectrum
from precise_impact.analysis.periodicity import detect_period
from precise_impact.core.budget import Deadline, estimate_cost, parse_max_time
from precise_impact.core.impact import elastic_bounce_count, elastic_bounce_refusal
from precise_impact.core.params import as_params, check_count
from precise_impact.core.stats import lle_stderr
from precise_impact.errors import EndlessBouncesError, ParameterError
from precise_impact.io.progress import ProgressArg, check_progress, say
from precise_impact.solvers.base import Unresolved, note_fallback, with_fallback

__all__ = ["fast_spectrum", "fast_batch", "fast_batch_rows", "point_rows", "ROW_FIELDS"]


def fast_spectrum(
    params,
    periods: int = 20000,
    transient: int = 1000,
    initial_conditions: int = 4,
    segments: int = 20,
    precision: str = "float64",
    max_impacts: int = 10**8,
    progress: ProgressArg = False,
    attractors: bool = True,
    max_time: Any = None,
) -> LyapunovResult:
    """Both Lyapunov exponents from the compiled engine.

    Parameters
    ----------
    params : Params or mapping
        System; the starts are ``(x0, v0 + j/4)``, ``j = 0 .. initial_conditions - 1``
        (as the variational method).
    periods : int, default 20000
        Measured forcing periods in all, split over the starts (as the variational method).
    transient : int, default 1000
        Discarded periods per start (its logs, not its tangent basis).
    initial_conditions : int, default 4
        Starts, run in parallel on every core.
    segments : int, default 20
        Batch-means blocks in all (split over the starts) for ``stderr``.
    precision : str, default ``'float64'``
        Only ``'float64'`` (the engine's type); other precisions: ``method='variational'``.
    max_impacts : int, default ``10**8``
        Impact budget per start.
    progress : bool, None or callable, default ``False``
        Periods done on stderr once the run has gone 2 s
        (:data:`~precise_impact.io.progress.ProgressArg`), and a line when the estimate
        falls back to heyoka.
    attractors : bool, default ``True``
        Group the starts by attractor and give a periodic attractor's exact (Floquet) LLE
        (:func:`~precise_impact.analysis.lyapunov.attractors.attribute`).
    max_time : decimal or None, default ``None``
        Time budget in seconds from this call: a start the engine does not resolve sends
        the estimate to heyoka only if heyoka's estimated cost
        (:func:`~precise_impact.core.budget.estimate_cost`) fits in what is left of it,
        else :class:`~precise_impact.errors.BudgetExceededError`.  (The compiled run
        itself is priced by :func:`~precise_impact.analysis.lyapunov.lyapunov`.)

    Returns
    -------
    LyapunovResult
        ``method = 'fast'``; ``stats`` has ``engine``, ``per_start`` (LLE, lambda2,
        impacts and status of every start; with ``attractors``: also its ``stderr``,
        ``impact_rate``, ``impact_rate_stderr``, ``periods`` and ``attractor`` id, as
        :func:`~precise_impact.analysis.lyapunov.attractors.attribute` says).

    Raises
    ------
    Interrupted
        Ctrl-C or SIGTERM (within milliseconds: the compiled loops poll a stop flag).
    BudgetExceededError
        The heyoka fallback would not fit in what is left of ``max_time``.

    References
    ----------
    .. [1] G. Benettin, L. Galgani, A. Giorgilli, J.-M. Strelcyn, Meccanica 15 (1980) 9-30.
    .. [2] P. C. Müller, Chaos Solitons Fractals 5 (1995) 1671-1681 (saltation matrices).
    """
    params = as_params(params)
    deadline = Deadline(None if max_time is None else parse_max_time(max_time), "lle")
    progress = check_progress(progress)
    n, periods, transient, segments, max_impacts = _check_counts(
        precision, initial_conditions, periods, transient, segments, max_impacts
    )
    per = periods // n
    blocks, m = _blocks(per, n, segments, attractors)
    from precise_impact.solvers.fast.lle import kernel_inputs  # noqa: PLC0415 -- heavy: numba engine, loaded on first use

    pars, starts = kernel_inputs(params, n)

    def compiled() -> LyapunovResult:
        return _compiled_spectrum(
            params, pars, starts, per, n, blocks, m, transient, max_impacts, attractors, progress
        )

    def variational() -> LyapunovResult:
        return variational_spectrum(
            params,
            periods=per * n,
            transient=transient,
            initial_conditions=n,
            segments=segments,
            max_impacts=max_impacts,
        )

    def admit(u: Unresolved) -> None:
        cost = estimate_cost(
            "lle", periods=per * n, transient=transient, runs=n, model="variational"
        )
        deadline.admit(cost, f"the fast engine does not resolve this orbit ({u.why}); heyoka")
        say(
            f"lle: the fast engine does not resolve this orbit ({u.why}); the estimate is "
            f"computed by heyoka instead ({cost.describe()})",
            progress,
        )

    return with_fallback(
        compiled, variational, note_fallback("heyoka variational"), before_fallback=admit
    )()


def _check_counts(precision, initial_conditions, periods, transient, segments, max_impacts):
    """``(n, periods, transient, segments, max_impacts)`` of :func:`fast_spectrum`, checked."""
    if precision not in ("float64",):
        raise ParameterError(
            "precision", precision, "'float64' for method 'fast' (other precisions: 'variational')"
        )
    n = check_count(initial_conditions, "initial_conditions", 1000, minimum=1)
    periods = check_count(periods, "periods", minimum=n)
    transient = check_count(transient, "transient")
    segments = check_count(segments, "segments", 10**6, minimum=2)
    max_impacts = check_count(max_impacts, "max_impacts", 10**12, minimum=1)
    return n, periods, transient, segments, max_impacts


def _blocks(per: int, n: int, segments: int, attractors: bool) -> tuple[int, int]:
    """``(blocks, m)``: the error bar's blocks per start, each split in ``m`` test blocks."""
    blocks = max(2, min(per, -(-segments // n)))
    # finer blocks for the attractors' per-start tests (module attractors, *Grouping*): up to
    # TEST_BLOCKS per start of >= TEST_BLOCK_PERIODS periods, summed back into ``blocks`` for
    # the error bar (m is chosen so that the summed blocks are exactly the ``per // blocks``
    # periods of the plain run: the same blocks, to rounding)
    m = (
        max(1, min(-(-TEST_BLOCKS // blocks), per // (TEST_BLOCK_PERIODS * blocks)))
        if attractors
        else 1
    )
    while m > 1 and (per // (blocks * m)) * m != per // blocks:
        m -= 1
    return blocks, m


def _compiled_spectrum(
    params, pars, starts, per, n, blocks, m, transient, max_impacts, attractors, progress
) -> LyapunovResult:
    """The spectrum from the compiled kernel (Unresolved: the fallback runs heyoka)."""
    from precise_impact.solvers.fast.control import STATUS_INTERRUPTED  # noqa: PLC0415 -- heavy: numba engine, loaded on first use
    from precise_impact.solvers.fast.lle import lle_batch  # noqa: PLC0415 -- heavy: numba engine, loaded on first use
    from precise_impact.solvers.fast.single import STATUS_OK, STATUS_TEXT  # noqa: PLC0415 -- heavy: numba engine, loaded on first use

    if not params.zeta < 1 or (params.zeta == 0 and params.eta == 1):
        raise Unresolved("fast", "zeta >= 1")
    start = time.perf_counter()
    status, log1, log2, *_ = out = lle_batch(
        pars,
        starts,
        per,
        transient,
        blocks * m,
        max_impacts,
        min(per, 3 * MAX_PERIOD),
        abort_on_failure=True,  # one start unresolved sends all to heyoka: stop the others
        progress=progress,
    )
    _refuse_endless_bounces(pars, starts, status, log1, log2, per + transient, max_impacts)
    if np.any(status != STATUS_OK):
        bad = {STATUS_TEXT[int(s)] for s in status if s not in (STATUS_OK, STATUS_INTERRUPTED)}
        raise Unresolved("fast", "; ".join(sorted(bad)))
    elapsed = time.perf_counter() - start
    return _fast_result(
        params,
        per,
        n,
        blocks,
        m,
        transient,
        attractors,
        elapsed,
        out,
    )


def bounce_refusal(row, start, status, tc, vc, total_periods: int, max_impacts: int):
    """The refusal message of a start the kernel stopped with ``STATUS_ENDLESS_BOUNCES``
    (``tc, vc``: the impact it predicted from; ``row`` = eta, zeta, a, x_w, R), else ``None``."""
    from precise_impact.solvers.fast.single import STATUS_ENDLESS_BOUNCES  # noqa: PLC0415 -- heavy: numba engine, loaded on first use

    if status != STATUS_ENDLESS_BOUNCES:
        return None
    eta, zeta, a, xw = (float(v) for v in row[:4])
    t_end = float(start[0]) + total_periods * 2 * math.pi / eta
    n, end, s = elastic_bounce_count(float(tc), float(vc), t_end, eta, zeta, a, xw, 2.0**-52)
    return elastic_bounce_refusal(float(tc), n, end, s, max_impacts)


def _refuse_endless_bounces(pars, starts, status, log1, log2, total_periods, max_impacts):
    """Raise :class:`EndlessBouncesError` for the first start predicted to bounce without end."""
    for i in range(len(status)):
        why = bounce_refusal(
            pars[i], starts[i], status[i], log1[i], log2[i], total_periods, max_impacts
        )
        if why is not None:
            raise EndlessBouncesError(why)


def _fast_result(params, per, n, blocks, m, transient, attractors, elapsed, out) -> LyapunovResult:
    """The :class:`LyapunovResult` of a resolved compiled run (``out``: ``lle_batch``'s arrays)."""
    from precise_impact.solvers.fast.single import STATUS_TEXT  # noqa: PLC0415 -- heavy: numba engine, loaded on first use

    status, log1, log2, imps, fine, fine_imps, xt, vt, refined = out
    bsums = fine.reshape(n, blocks, m).sum(axis=2)
    T = 2 * math.pi / float(params.eta)
    time_total = per * T * n
    per_block = per // blocks
    block_means = (bsums / (per_block * T)).ravel()
    lam1, lam2 = float(log1.sum() / time_total), float(log2.sum() / time_total)
    running = np.cumsum(bsums.sum(axis=0)) / (np.arange(1, blocks + 1) * per_block * T * n)
    per_start = [
        {
            "lle": float(log1[i] / (per * T)),
            "lambda2": float(log2[i] / (per * T)),
            "impacts": int(imps[i]),
            "status": STATUS_TEXT[int(status[i])],
        }
        for i in range(n)
    ]
    result = LyapunovResult(
        params=params,
        method="fast",
        precision="float64",
        lle=lam1,
        spectrum=(lam1, lam2),
        lle_stderr=lle_stderr(block_means, lam1, per * n + float(imps.sum()), time=time_total),
        periods=per * n,
        transient=transient,
        n_impacts=int(imps.sum()),
        running=running,
        segments=block_means,
        elapsed_s=elapsed,
        initial_conditions=n,
        strobe_x=xt[0],
        strobe_v=vt[0],
        stats={"engine": "fast", "per_start": per_start, "refined_flights": int(refined.sum())},
    )
    if attractors:
        bm = fine / ((per // (blocks * m)) * T)  # batch means per start, the finer blocks
        # impacts per period in the same finer blocks, counted by the engine on the same orbits
        rates = list(fine_imps / (per // (blocks * m))) if n > 1 else None
        attribute(
            result,
            list(zip(xt, vt, strict=True)),
            [(d["lle"], d["lambda2"], bm[i]) for i, d in enumerate(per_start)],
            impact_blocks=rates,
            periods=[per] * n,
        )
    result.order_spectrum()
    return result


def fast_batch(
    points,
    periods: int = 2000,
    transient: int = 1000,
    segments: int = 10,
    max_period: int = 32,
    max_impacts: int = 10**7,
    parallel: bool = False,
) -> list[dict]:
    """:func:`~precise_impact.analysis.lyapunov.batch.batch_lle` on the compiled engine.

    Parameters
    ----------
    points : sequence of Params
        One parameter point (with its own initial condition) per entry.
    periods : int, default 2000
        Measured periods per point.
    transient : int, default 1000
        Discarded periods per point (logs only; the tangent basis runs on).
    segments : int, default 10
        Batch-means blocks per point for ``stderr``.
    max_period : int, default 32
        Longest period :func:`~precise_impact.analysis.periodicity.detect_period` looks for
        (on the last ``3 max_period`` stroboscopic samples).
    max_impacts : int, default ``10**7``
        Impact budget per point.
    parallel : bool, default ``False``
        Points on every core (numba threads); ``False`` inside a sweep's worker processes.

    Returns
    -------
    list of dict
        As ``batch_lle``: ``lle``, ``lambda2``, ``stderr``, ``period``,
        ``impacts_per_period``, ``x_last``, ``v_last``, ``grazing`` (0), and ``engine``
        (``'fast'``, or ``'heyoka'`` for a point the engine did not resolve, computed by
        ``batch_lle`` instead).
    """
    points = [as_params(p, "points") for p in points]
    return fast_batch_rows(
        point_rows(points),
        lambda idx: [points[i] for i in idx],
        periods,
        transient,
        segments,
        max_period,
        max_impacts,
        parallel,
    )


def point_rows(points) -> np.ndarray:
    """``points`` as float rows ``(eta, zeta, a, x_w, R, t0, x0, v0)`` (each value rounded once).

    Parameters
    ----------
    points : sequence of Params

    Returns
    -------
    numpy.ndarray
        Shape ``(len(points), 8)``.
    """
    return np.array([[float(getattr(p, n)) for n in ROW_FIELDS] for p in points]).reshape(
        -1, len(ROW_FIELDS)
    )


#: The columns of :func:`point_rows` (and of :meth:`~precise_impact.SweepSpec.rows`).
ROW_FIELDS = ("eta", "zeta", "a", "x_w", "R", "t0", "x0", "v0")


def fast_batch_rows(
    rows: np.ndarray,
    fallback_points,
    periods: int = 2000,
    transient: int = 1000,
    segments: int = 10,
    max_period: int = 32,
    max_impacts: int = 10**7,
    parallel: bool = False,
) -> list[dict]:
    """:func:`fast_batch` on float rows (a sweep's tile: no exact parameters per point).

    Parameters
    ----------
    rows : numpy.ndarray
        Shape ``(n, 8)``, columns :data:`ROW_FIELDS` (:func:`point_rows`).
    fallback_points : callable
        ``fallback_points(indices)`` returns the exact :class:`~precise_impact.Params` of
        those rows, called only for points the engine does not resolve (computed by
        ``batch_lle``).
    periods, transient, segments, max_period, max_impacts, parallel
        As :func:`fast_batch`.

    Returns
    -------
    list of dict
        As :func:`fast_batch`.
    """
    from precise_impact.solvers.fast.lle import lle_batch, lle_batch_serial  # noqa: PLC0415 -- heavy: numba engine, loaded on first use
    from precise_impact.solvers.fast.single import STATUS_OK  # noqa: PLC0415 -- heavy: numba engine, loaded on first use

    periods = check_count(periods, "periods", minimum=1)
    transient = check_count(transient, "transient")
    segments = check_count(segments, "segments", 10**6, minimum=1)
    max_period = check_count(max_period, "max_period", 1000, minimum=1)
    keep = min(periods, 3 * max_period)
    blocks = min(segments, periods)
    rows = np.asarray(rows, dtype=float).reshape(-1, len(ROW_FIELDS))
    eta, zeta = rows[:, 0], rows[:, 1]
    ok_pts = np.flatnonzero(
        (zeta < 1) & ~((zeta == 0) & (eta == 1))
    )  # underdamped, not the undamped resonance
    run = lle_batch if parallel else lle_batch_serial

    def compiled() -> list:
        status, log1, log2, imps, bsums, _, xt, vt, refined = run(
            rows[ok_pts, :5], rows[ok_pts, 5:], periods, transient, blocks, max_impacts, keep
        )
        results: list = [None] * len(rows)
        per_block = periods // blocks
        for j, i in enumerate(ok_pts.tolist()):
            why = bounce_refusal(
                rows[i, :5],
                rows[i, 5:],
                status[j],
                log1[j],
                log2[j],
                periods + transient,
                max_impacts,
            )
            if why is not None:  # refused, not handed to heyoka (which would refuse it too)
                results[i] = dict(refused_row(why), engine="fast")
                continue
            if status[j] != STATUS_OK:
                continue
            T = 2 * math.pi / eta[i]
            bm = bsums[j] / (per_block * T)
            lle = float(log1[j] / (periods * T))
            results[i] = {
                "lle": lle,
                "lambda2": float(log2[j] / (periods * T)),
                # one term per flight: periods + impacts (core.stats.lle_stderr)
                "stderr": lle_stderr(bm, lle, periods + float(imps[j]), time=periods * T),
                "period": detect_period(xt[j], vt[j], max_period),
                "impacts_per_period": float(imps[j] / periods),
                "x_last": float(xt[j][-1]),
                "v_last": float(vt[j][-1]),
                "grazing": 0,
                "refined_flights": int(refined[j]),
                "engine": "fast",
                "status": "ok",
            }
        if any(r is None for r in results):
            raise Unresolved("fast", "points the compiled engine does not resolve", results)
        return results

    def variational(indices) -> list:
        return batch_lle(
            fallback_points(indices),
            periods=periods,
            transient=transient,
            segments=max(2, segments),
            max_period=max_period,
            max_impacts=max_impacts,
        )

    return with_fallback(compiled, variational, lambda r, why: dict(r, engine="heyoka"))()
