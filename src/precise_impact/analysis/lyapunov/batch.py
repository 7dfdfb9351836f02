"""SIMD batch variational LLE (float64): many parameter points at once, for parameter sweeps.

The statistics per point (LLE, second exponent, batch-means error bar, period, impact rate) of
a sweep; the integration is :func:`precise_impact.solvers.heyoka.batch.integrate_group` (points
advancing together in heyoka's SIMD lanes; the hard cases in ``docs/numerics.rst``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from precise_impact.analysis.periodicity import detect_period
from precise_impact.core.params import Params, check_count
from precise_impact.core.stats import lle_stderr
from precise_impact.errors import IntegrationError, ParameterError
from precise_impact.solvers.heyoka.batch import default_batch_size, integrate_group

__all__ = ["batch_lle", "detect_period", "default_batch_size", "refused_row"]


def batch_lle(
    points: Sequence[Params],
    periods: int = 2000,
    transient: int = 1000,
    segments: int = 10,
    batch_size: int | None = None,
    max_period: int = 32,
    max_impacts: int = 10**7,
) -> list[dict]:
    """LLE (variational, saltation), its error bar, period and impacts per period for each point.

    Parameters
    ----------
    points : sequence of Params
        One parameter point (with its own initial condition) per entry.
    periods : int, default 2000
        Measured periods per point (>= 1).
    transient : int, default 1000
        Discarded periods per point.
    segments : int, default 10
        Batch-means blocks for the standard error (>= 2).
    batch_size : int or None, default ``None`` (:func:`default_batch_size`)
        SIMD lanes per heyoka batch integrator; points are processed in groups of
        this size (the last group padded with copies of its first point).
    max_period : int, default 32
        Longest period :func:`detect_period` looks for.
    max_impacts : int, default 10**7
        Impact budget per lane.

    Returns one dict per point: ``lle``, ``lambda2``, ``stderr``, ``period``,
    ``impacts_per_period``, ``x_last``/``v_last`` (the last stroboscopic sample) and
    ``grazing`` (tangential contacts over the whole run, transient included: events
    within the grazing depth of the wall, not impacts; see
    :mod:`precise_impact.analysis.lyapunov.variational`) and ``status``: ``'ok'``, or why the
    point was refused (``R = 1`` bounces on the wall predicted to come to rest or to outrun
    ``max_impacts``: :func:`refused_row`, NaN values).
    Raises :class:`~precise_impact.errors.MissedImpactError` if a lane's maximum of ``x``
    lies beyond the wall by more than 4 grazing depths (an impact heyoka missed).
    Each lane is integrated exactly as it would be alone (per-lane steps, events and
    period boundaries), so a point's result does not depend on its batch neighbours.
    References as :func:`~precise_impact.analysis.lyapunov.variational.variational_spectrum`.
    """
    periods = check_count(periods, "periods")
    if periods < 1:
        raise ParameterError("periods", periods, "an integer >= 1")
    transient = check_count(transient, "transient")
    segments = check_count(segments, "segments", 10**6)
    if segments < 2:
        raise ParameterError("segments", segments, "an integer >= 2")
    B = default_batch_size() if batch_size is None else check_count(batch_size, "batch_size", 64)
    if B < 1:
        raise ParameterError("batch_size", batch_size, "an integer with 1 <= batch_size <= 64")
    points = list(points)
    out: list[dict] = []
    for lo in range(0, len(points), B):
        group = points[lo : lo + B]
        args = (B, periods, transient, segments, max_period, max_impacts)
        try:
            out.extend(_run_group(group + [group[0]] * (B - len(group)), *args)[: len(group)])
        except IntegrationError:
            # a lane the integrator could not carry (e.g. a missed impact while chattering
            # into the wall): each point alone, and the failing ones get their reason as
            # status (a scan records it per point instead of stopping)
            for p in group:
                try:
                    out.extend(_run_group([p] * B, *args)[:1])
                except IntegrationError as e:
                    out.append(refused_row(f"integration stopped: {e}", failed=True))
    return out


def _run_group(group, B, periods, transient, segments, max_period, max_impacts):
    l1, l2, xs, vs, T, impacts, grazing, refused = integrate_group(
        group, B, periods, transient, max_impacts
    )
    results = []
    nb = min(segments, periods)
    for i in range(B):
        if refused[i] is not None:
            results.append(refused_row(refused[i], int(grazing[i])))
            continue
        blocks = np.array([blk.sum() for blk in np.array_split(l1[:, i], nb)]) / np.array(
            [len(blk) * T[i] for blk in np.array_split(l1[:, i], nb)]
        )
        tot = periods * T[i]
        lle = float(l1[:, i].sum() / tot)
        results.append(
            {
                "lle": lle,
                "lambda2": float(l2[:, i].sum() / tot),
                # one term per step: periods + impacts (core.stats.lle_stderr)
                "stderr": lle_stderr(blocks, lle, periods + float(impacts[i]), time=tot),
                "period": detect_period(xs[:, i], vs[:, i], max_period),
                "impacts_per_period": float(impacts[i] / periods),
                "x_last": float(xs[-1, i]),
                "v_last": float(vs[-1, i]),
                "grazing": int(grazing[i]),
                "status": "ok",
            }
        )
    return results


def refused_row(why: str, grazing: int = 0, failed: bool = False) -> dict:
    """A scan point refused with a reason (an ``R = 1`` bounce sequence without end:
    :class:`~precise_impact.errors.EndlessBouncesError`; ``failed``: the integrator stopped,
    :class:`~precise_impact.errors.IntegrationError`): NaN values and ``status = why``,
    ``status_code`` 1 (refused) or 2 (failed)."""
    nan = float("nan")
    return {
        "lle": nan,
        "lambda2": nan,
        "stderr": nan,
        "period": 0,
        "impacts_per_period": nan,
        "x_last": nan,
        "v_last": nan,
        "grazing": grazing,
        "status": why,
        "status_code": 2 if failed else 1,
    }
