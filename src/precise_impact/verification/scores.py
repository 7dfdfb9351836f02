"""How far a model is from the reference: scores on :class:`Trajectory` objects.

Periodic regimes: state, impact and period errors; chaotic regimes: predictability horizon,
divergence rate, Wasserstein distances between Poincare clouds and impact velocities.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from precise_impact.analysis.periodicity import detect_period
from precise_impact.core.mpcontext import mp_context, mp_import
from precise_impact.core.trajectory import Trajectory
from precise_impact.errors import ParameterError
from precise_impact.verification.metrics import sample_errors

__all__ = [
    "DEFAULT_DELTAS",
    "REGIMES",
    "wasserstein_1d",
    "sliced_wasserstein",
    "separation",
    "predictability_horizon",
    "divergence_rate",
    "match_impacts",
    "detected_period",
    "periodic_scores",
    "chaotic_scores",
    "score",
]

#: Separation thresholds of the predictability horizon.
DEFAULT_DELTAS = (1e-6, 1e-3, 1e-1)
REGIMES = ("auto", "periodic", "chaotic")


def _f64(traj: Trajectory) -> dict[str, np.ndarray]:
    """``traj.as_float64()``; values a model does not record (None) become NaN quietly."""
    with np.errstate(invalid="ignore"):
        return traj.as_float64()


# ----------------------------------------------------------------- distances
def wasserstein_1d(a: Sequence[float], b: Sequence[float]) -> float:
    """Exact 1-Wasserstein distance between the empirical distributions of ``a`` and ``b``.

    ``W1 = integral_0^1 |F_a^-1(q) - F_b^-1(q)| dq`` evaluated exactly on the merged
    grid of quantile levels (equal sizes reduce to ``mean |sort(a) - sort(b)|``).
    """
    a = np.sort(np.asarray(a, dtype=float).ravel())
    b = np.sort(np.asarray(b, dtype=float).ravel())
    if len(a) == 0 or len(b) == 0:
        return math.nan
    if len(a) == len(b):
        return float(np.mean(np.abs(a - b)))
    qa = np.arange(1, len(a) + 1) / len(a)
    qb = np.arange(1, len(b) + 1) / len(b)
    q = np.union1d(qa, qb)
    w = np.diff(np.concatenate(([0.0], q)))
    ia = np.minimum(np.searchsorted(qa, q - 1e-15), len(a) - 1)
    ib = np.minimum(np.searchsorted(qb, q - 1e-15), len(b) - 1)
    return float(np.sum(w * np.abs(a[ia] - b[ib])))


def _directions(dim: int, n_proj: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    if dim == 1:
        return np.ones((1, 1))
    if dim == 2:
        # stratified random angles on [0, pi): evenly spaced with one random offset
        th = (np.arange(n_proj) + rng.random()) * math.pi / n_proj
        return np.stack([np.cos(th), np.sin(th)], axis=1)
    d = rng.normal(size=(n_proj, dim))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def sliced_wasserstein(p: np.ndarray, q: np.ndarray, n_proj: int = 256, seed: int = 0) -> float:
    """Sliced 1-Wasserstein distance between two point clouds (rows are points).

    Mean over ``n_proj`` random unit directions of the exact 1-D Wasserstein distance
    of the projected samples (:func:`wasserstein_1d`).  In 2-D the directions are
    stratified (evenly spaced angles with a random offset, ``seed``), so the average
    over directions has almost no Monte-Carlo noise.  For a pure shift ``s`` of a 2-D
    cloud the result is ``(2/pi)|s|`` (the mean of ``|cos|``); in 1-D it is ``|s|``.
    """
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    if p.ndim == 1:
        p = p[:, None]
    if q.ndim == 1:
        q = q[:, None]
    if p.shape[1] != q.shape[1]:
        raise ParameterError(
            "clouds", f"{p.shape} vs {q.shape}", "two clouds of the same dimension"
        )
    dirs = _directions(p.shape[1], n_proj, seed)
    pp, qq = p @ dirs.T, q @ dirs.T
    return float(np.mean([wasserstein_1d(pp[:, j], qq[:, j]) for j in range(dirs.shape[0])]))


# ----------------------------------------------------------------- separation
def separation(model: Trajectory, ref: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """``(t, sep)``: stroboscopic times and ``max(|x - x_ref|, |v - v_ref|)`` (exact
    differences)."""
    sep = np.asarray(sample_errors(model, ref), dtype=float)
    t = _f64(ref)["t"][: len(sep)]
    return t, sep


def predictability_horizon(t: Sequence[float], sep: Sequence[float], delta: float) -> float:
    """First time the separation exceeds ``delta``; ``inf`` if it never does.

    Between the last sample below ``delta`` and the first above it, the crossing is
    interpolated linearly in ``ln sep`` (exact for an exponential separation).
    """
    t = np.asarray(t, dtype=float)
    sep = np.asarray(sep, dtype=float)
    above = np.nonzero(sep > delta)[0]
    if len(above) == 0:
        return math.inf
    i = int(above[0])
    if i == 0:
        return float(t[0])
    s0, s1 = sep[i - 1], sep[i]
    if s0 <= 0:
        return float(t[i])
    f = (math.log(delta) - math.log(s0)) / (math.log(s1) - math.log(s0))
    return float(t[i - 1] + f * (t[i] - t[i - 1]))


def divergence_rate(
    t: Sequence[float], sep: Sequence[float], lo: float = 1e-12, hi: float = 1e-2
) -> dict[str, Any]:
    """Least-squares slope of ``ln sep`` against ``t`` over the growth window ``lo < sep < hi``.

    The window runs from the start up to the first sample with ``sep >= hi`` (after
    that the separation has saturated at the attractor's size); inside it only
    samples with ``lo < sep < hi`` are fitted.  Returns ``{"rate", "stderr",
    "t_start", "t_end", "points"}`` (``rate`` NaN with fewer than 3 points, and ``"why"``
    saying so).
    """
    t = np.asarray(t, dtype=float)
    sep = np.asarray(sep, dtype=float)
    stop = np.nonzero(sep >= hi)[0]
    end = int(stop[0]) if len(stop) else len(sep)
    idx = np.nonzero((sep[:end] > lo) & (sep[:end] < hi))[0]
    out = {
        "rate": math.nan,
        "stderr": math.nan,
        "t_start": math.nan,
        "t_end": math.nan,
        "points": int(len(idx)),
    }
    if len(idx) < 3:  # the JSON's nulls say why (strict JSON: NaN is null)
        out["why"] = (
            f"no fit: {len(idx)} samples with {lo:g} < sep < {hi:g} before sep first reached "
            f"{hi:g}; 3 needed"
        )
        return out
    tt, yy = t[idx], np.log(sep[idx])
    A = np.stack([tt, np.ones_like(tt)], axis=1)
    coef, *_ = np.linalg.lstsq(A, yy, rcond=None)
    resid = yy - A @ coef
    dof = len(tt) - 2
    se = (
        math.sqrt(float(resid @ resid) / dof / float(np.sum((tt - tt.mean()) ** 2)))
        if dof > 0
        else math.nan
    )
    out.update(rate=float(coef[0]), stderr=se, t_start=float(tt[0]), t_end=float(tt[-1]))
    return out


# ----------------------------------------------------------------- periodic
def match_impacts(
    model: Trajectory, ref: Trajectory, t_from: float = -math.inf, window: float | None = None
) -> dict[str, Any]:
    """Match each model impact (at ``t >= t_from``) to the nearest reference impact in time.

    A model impact is *matched* if its nearest reference impact lies within
    ``window`` (default: a quarter forcing period) and no other model impact is
    nearer to that reference impact.  Returns the largest and RMS time and
    ``v_before`` errors over matched pairs and the unmatched counts on both sides.
    """
    fm, fr = _f64(model), _f64(ref)
    if window is None:
        window = 0.25 * 2 * math.pi / float(ref.params.eta)
    tm_all, tr_all = fm["impacts_t"], fr["impacts_t"]
    im = np.nonzero(tm_all >= t_from)[0]
    ir = np.nonzero(tr_all >= t_from)[0]
    res: dict[str, Any] = {
        "model_impacts": int(len(im)),
        "reference_impacts": int(len(ir)),
        "matched": 0,
        "unmatched_model": int(len(im)),
        "unmatched_reference": int(len(ir)),
        "max_dt": math.nan,
        "rms_dt": math.nan,
        "max_dv": math.nan,
        "rms_dv": math.nan,
    }
    if len(im) == 0 or len(ir) == 0:
        return res
    tm, tr = tm_all[im], tr_all[ir]
    j = (
        np.clip(np.searchsorted(tr, tm), 1, len(tr) - 1)
        if len(tr) > 1
        else np.zeros(len(tm), dtype=int)
    )
    if len(tr) > 1:
        j = np.where(np.abs(tr[j - 1] - tm) <= np.abs(tr[j] - tm), j - 1, j)
    d = np.abs(tr[j] - tm)
    best: dict[int, int] = {}
    for k in np.argsort(d, kind="stable"):
        if d[k] <= window and int(j[k]) not in best:
            best[int(j[k])] = int(k)
    pairs = [(k, jr) for jr, k in best.items()]
    if not pairs:
        res["why"] = "no impact pairs within the window after the transient: dt, dv undefined"
        return res
    mk = np.array([im[k] for k, _ in pairs])
    rk = np.array([ir[jr] for _, jr in pairs])
    # exact differences (reference may be multiprecision)
    dt = np.array(sample_diff(model.impacts_t, ref.impacts_t, mk, rk, model, ref))
    dv = np.array(sample_diff(model.impacts_v_before, ref.impacts_v_before, mk, rk, model, ref))
    dv = dv[np.isfinite(dv)]  # models that do not record an impact velocity give NaN
    res["dv_pairs"] = int(len(dv))
    if len(dv) == 0:
        dv = np.array([math.nan])
        res["why"] = "the model records no impact velocity: dv undefined"
    res.update(
        matched=len(pairs),
        unmatched_model=int(len(im) - len(pairs)),
        unmatched_reference=int(len(ir) - len(pairs)),
        max_dt=float(np.max(dt)),
        rms_dt=float(np.sqrt(np.mean(dt**2))),
        max_dv=float(np.max(dv)),
        rms_dv=float(np.sqrt(np.mean(dv**2))),
    )
    return res


def sample_diff(a, b, ia, ib, ta: Trajectory, tb: Trajectory) -> list[float]:
    """``|a[ia] - b[ib]|`` computed exactly in mpmath, as floats."""
    # a context of this thread's own: mpmath's global precision is shared by every thread
    ctx = mp_context(max(ta.precision.bits, tb.precision.bits) + 16)
    return [
        math.nan
        if a[i] is None or b[j] is None
        else float(abs(mp_import(ctx, ta.precision.to_mpf(a[i])) - tb.precision.to_mpf(b[j])))
        for i, j in zip(ia, ib, strict=True)
    ]


def detected_period(
    traj: Trajectory, transient: int = 0, max_period: int = 32, rtol: float = 1e-6
) -> int:
    """Smallest p <= ``max_period`` with p-periodic stroboscopic samples after ``transient``; 0 if
    none."""
    f = _f64(traj)
    return int(
        detect_period(f["x"][transient:], f["v"][transient:], max_period=max_period, rtol=rtol)
    )


def _transient(traj: Trajectory, transient: int | None) -> int:
    n = traj.periods
    k = n // 5 if transient is None else int(transient)
    if not 0 <= k < n:
        raise ParameterError("transient", transient, f"0 <= transient < periods ({n})")
    return k


def periodic_scores(
    model: Trajectory,
    ref: Trajectory,
    transient: int | None = None,
    max_period: int = 32,
    rtol: float = 1e-6,
) -> dict[str, Any]:
    """Largest state error after ``transient`` periods, impact errors matched one by one,
    periods."""
    k = _transient(ref, transient)
    errs = sample_errors(model, ref)
    tk = float(_f64(ref)["t"][k])
    return {
        "transient_periods": k,
        "max_state_error": float(max(errs[k:])),
        "final_state_error": float(errs[-1]),
        "impacts": match_impacts(model, ref, t_from=tk),
        "period_model": detected_period(model, k, max_period, rtol),
        "period_reference": detected_period(ref, k, max_period, rtol),
    }


# ----------------------------------------------------------------- chaotic
def _cloud(traj: Trajectory, transient: int) -> np.ndarray:
    f = _f64(traj)
    return np.stack([f["x"][transient:], f["v"][transient:]], axis=1)


def _impact_v(traj: Trajectory, t_from: float) -> np.ndarray:
    f = _f64(traj)
    v = f["impacts_v_before"][f["impacts_t"] >= t_from]
    return v[np.isfinite(v)]


def chaotic_scores(
    model: Trajectory,
    ref: Trajectory,
    ref2: Trajectory | None = None,
    transient: int | None = None,
    deltas: Sequence[float] = DEFAULT_DELTAS,
    lle: float | None = None,
    model_lle: float | None = None,
    n_proj: int = 256,
    seed: int = 0,
) -> dict[str, Any]:
    """Predictability horizons, fitted divergence rate, attractor and impact-velocity distances,
    LLE gap.

    ``ref2`` (a second reference, e.g. from a perturbed initial condition) gives the
    sampling noise floor of the cloud distances; without it the floor is the
    distance between the two halves of ``ref``'s cloud (always reported too).
    """
    k = _transient(ref, transient)
    t, sep = separation(model, ref)
    rate = divergence_rate(t, sep)
    tk = float(_f64(ref)["t"][k])
    cm, cr = _cloud(model, k), _cloud(ref, k)
    h = len(cr) // 2
    out: dict[str, Any] = {
        "transient_periods": k,
        "initial_separation": float(sep[0]) if len(sep) else math.nan,
        "horizons": {f"{d:g}": predictability_horizon(t, sep, d) for d in deltas},
        "divergence": rate,
        "lle_reference": lle,
        "rate_over_lle": (rate["rate"] / lle) if lle else None,
        "sliced_wasserstein": sliced_wasserstein(cm, cr, n_proj, seed),
        "sw_floor_halves": sliced_wasserstein(cr[:h], cr[h:], n_proj, seed),
        "impact_v_wasserstein": wasserstein_1d(_impact_v(model, tk), _impact_v(ref, tk)),
        "impact_v_floor_halves": _half_w1(_impact_v(ref, tk)),
        "impacts_per_period_model": _rate(model, tk),
        "impacts_per_period_reference": _rate(ref, tk),
        "lle_model": model_lle,
        "lle_gap": (model_lle - lle) if (model_lle is not None and lle is not None) else None,
    }
    if ref2 is not None:
        c2 = _cloud(ref2, k)
        out["sw_floor_two_references"] = sliced_wasserstein(cr, c2, n_proj, seed)
        out["impact_v_floor_two_references"] = wasserstein_1d(
            _impact_v(ref, tk), _impact_v(ref2, tk)
        )
    out["sw_floor"] = out.get("sw_floor_two_references", out["sw_floor_halves"])
    out["impact_v_floor"] = out.get("impact_v_floor_two_references", out["impact_v_floor_halves"])
    return out


def _half_w1(v: np.ndarray) -> float:
    h = len(v) // 2
    return wasserstein_1d(v[:h], v[h:]) if h else math.nan


def _rate(traj: Trajectory, t_from: float) -> float:
    f = _f64(traj)
    span = f["t"][-1] - t_from
    n = int(np.sum(f["impacts_t"] >= t_from))
    return float(n * 2 * math.pi / float(traj.params.eta) / span) if span > 0 else math.nan


# ----------------------------------------------------------------- together
def score(
    model_traj: Trajectory,
    ref_traj: Trajectory,
    regime: str = "auto",
    lle: float | None = None,
    model_lle: float | None = None,
    ref2: Trajectory | None = None,
    transient: int | None = None,
    deltas: Sequence[float] = DEFAULT_DELTAS,
    max_period: int = 32,
    rtol: float = 1e-6,
    n_proj: int = 256,
    seed: int = 0,
) -> dict[str, Any]:
    """Every score of ``model_traj`` against ``ref_traj``.

    Parameters
    ----------
    model_traj, ref_traj : Trajectory
        The model's run and the reference, with the same parameters and sample times.
    regime : str, default ``'auto'``
        ``'periodic'``, ``'chaotic'`` or ``'auto'``: periodic if the reference's samples
        after the transient are p-periodic for some p <= ``max_period``, else chaotic.
    lle : float or None, default ``None``
        Reference LLE (e.g. from :func:`precise_impact.analysis.lyapunov.lyapunov`), for
        the divergence-rate comparison.
    model_lle : float or None, default ``None``
        The model's LLE, for the LLE gap.
    ref2 : Trajectory or None, default ``None``
        Second reference for the noise floor of the distribution distances.
    transient : int or None, default ``None``
        Samples discarded before the state errors, periods and clouds; ``None`` is
        ``periods // 5``.
    deltas : sequence of float, default :data:`DEFAULT_DELTAS`
        Separation thresholds of the predictability horizons (chaotic).
    max_period : int, default 32
        Largest period detected (:func:`~precise_impact.analysis.periodicity.detect_period`).
    rtol : float, default 1e-6
        Relative tolerance of the period detection.
    n_proj : int, default 256
        Random projections of the sliced Wasserstein distance between Poincare clouds.
    seed : int, default 0
        Seed of those projections.

    Returns
    -------
    dict
        ``regime``, ``max_state_error`` (all samples after the transient) and the
        periodic block (``period_model``, ``period_reference``, impact-by-impact
        errors) or the chaotic block (predictability horizons, divergence rate,
        cloud distances).

    Raises
    ------
    ParameterError
        Trajectories that do not match (parameters, sample count) or bad keywords.

    See Also
    --------
    precise_impact.verification.compare.compare
        Score models on a scene against a demonstrated reference.
    precise_impact.verification.accuracy.accuracy_table : errors of every model at several eta.
    precise_impact.analysis.periodicity.detect_period : the period score's building block.

    Examples
    --------
    >>> import precise_impact as pi
    >>> p = pi.Params.make(eta="0.74")
    >>> s = pi.score(pi.simulate(p, 20, model="fast"), pi.simulate(p, 20))
    >>> s["model"], s["periods"], s["regime"]
    ('fast', 20, 'chaotic')
    """
    if regime not in REGIMES:
        raise ParameterError("regime", regime, "one of " + ", ".join(REGIMES))
    k = _transient(ref_traj, transient)
    if regime == "auto":
        regime = "periodic" if detected_period(ref_traj, k, max_period, rtol) > 0 else "chaotic"
    out: dict[str, Any] = {
        "model": model_traj.model,
        "precision": model_traj.precision.name,
        "reference": f"{ref_traj.model} {ref_traj.precision.name}",
        "regime": regime,
        "periods": min(model_traj.periods, ref_traj.periods),
        "elapsed_s": model_traj.elapsed_s,
    }
    if regime == "periodic":
        out.update(periodic_scores(model_traj, ref_traj, k, max_period, rtol))
    else:
        out.update(
            chaotic_scores(model_traj, ref_traj, ref2, k, deltas, lle, model_lle, n_proj, seed)
        )
        out["period_model"] = detected_period(model_traj, k, max_period, rtol)
        out["period_reference"] = detected_period(ref_traj, k, max_period, rtol)
    return out
