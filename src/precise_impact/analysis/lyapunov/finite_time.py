"""The finite-time largest Lyapunov exponent of a recorded stretch of a trajectory.

``ln sigma_max(M) / T``, with ``M`` the record's tangent map (flight flows and saltation
matrices along the recorded impacts): what an estimate from a record (:mod:`.timeseries`) is
validated against; why: docs/guide/captures.rst, "The finite-time exponent of a record".
Reference: di Bernardo et al., *Piecewise-smooth Dynamical Systems* (2008), sec. 2.5.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from precise_impact.core.flight import FloatOps, damped_frequency, flow_and_decay
from precise_impact.core.impact import oscillator_saltation
from precise_impact.core.params import as_params
from precise_impact.errors import ParameterError

__all__ = ["finite_time_lle"]


def finite_time_lle(
    params: Any, impacts_t: Any, impacts_v_before: Any, t_start: float, t_end: float
) -> float:
    """The largest finite-time Lyapunov exponent of the stretch ``[t_start, t_end]``.

    ``ln sigma_max(M) / (t_end - t_start)``, ``M`` the product of the flights' homogeneous flows
    and the impacts' saltation matrices along the given impacts (float64; the product is
    renormalised after every factor, so no overflow).

    Parameters
    ----------
    params : Params or mapping
        The system (``0 <= zeta < 1``: the underdamped flight's closed form).
    impacts_t : array_like
        Impact times (the oscillator's time, ascending); those outside the stretch are ignored.
    impacts_v_before : array_like
        The incoming velocities (``> 0``) at those impacts.
    t_start, t_end : float
        The stretch, ``t_start < t_end``.

    Returns
    -------
    float
        The exponent per unit of the oscillator's time.

    Raises
    ------
    ParameterError
        ``zeta`` outside ``[0, 1)``, an empty or reversed stretch, impact arrays of different
        lengths, an incoming velocity ``<= 0`` inside the stretch (no saltation matrix).

    See Also
    --------
    precise_impact.lyapunov : the asymptotic exponent (variational, long runs).
    precise_impact.timeseries_lle : the estimate from a measured record.
    precise_impact.core.impact.oscillator_saltation : the impact's tangent map.

    Examples
    --------
    A stretch without impacts contracts at exactly ``-zeta``:

    >>> import precise_impact as pi
    >>> p = pi.Params.make(eta="0.712")
    >>> round(pi.finite_time_lle(p, [], [], 0.0, 1000.0), 4)
    -0.05
    """
    p = as_params(params)
    ops = FloatOps
    zeta = ops.num(p.zeta)
    if not 0 <= zeta < 1:
        raise ParameterError("zeta", zeta, "0 <= zeta < 1 for a finite-time exponent")
    t0, t1 = float(t_start), float(t_end)
    if not (math.isfinite(t0) and math.isfinite(t1) and t0 < t1):
        raise ParameterError("t_end", t_end, f"a finite time > t_start = {t_start!r}")
    ts = np.asarray(impacts_t, dtype=float).ravel()
    vs = np.asarray(impacts_v_before, dtype=float).ravel()
    if ts.shape != vs.shape:
        raise ParameterError(
            "impacts_v_before", f"{vs.size} values", f"one per impact time ({ts.size})"
        )
    inside = (ts > t0) & (ts <= t1)
    ts, vs = ts[inside], vs[inside]
    if np.any(~(vs > 0)):
        raise ParameterError(
            "impacts_v_before", float(vs[~(vs > 0)][0]), "> 0 at every impact of the stretch"
        )
    eta, a, x_w, R = (ops.num(q) for q in (p.eta, p.a, p.x_w, p.R))
    wd = damped_frequency(zeta, ops)
    m = np.eye(2)
    log_scale = 0.0
    t_prev = t0

    # a flight's decay exp(-zeta tau) leaves the matrix for the log (no underflow): flights
    # longer than 300 / zeta in pieces (exp(-300) is a normal float64)
    piece = 300.0 / zeta if zeta > 0 else math.inf

    def flight(tau: float) -> np.ndarray:
        nonlocal log_scale
        out = np.eye(2)
        while True:
            step = min(tau, piece)
            phi, e = flow_and_decay(step, zeta, wd, ops)
            out = (np.array(phi).reshape(2, 2) / e) @ out
            log_scale -= zeta * step
            tau -= step
            if tau <= 0:
                return out

    for t, v in zip(ts.tolist(), vs.tolist(), strict=True):
        m = flight(t - t_prev) @ m
        m = np.array(oscillator_saltation(t, v, eta, zeta, a, x_w, R, math.cos)) @ m
        s = float(np.max(np.abs(m)))
        if s == 0.0:  # a tangent map of rank 0: every perturbation dies
            return -math.inf
        m /= s
        log_scale += math.log(s)
        t_prev = t
    m = flight(t1 - t_prev) @ m
    sigma = float(np.linalg.norm(m, 2))
    if sigma == 0.0:
        return -math.inf
    return (log_scale + math.log(sigma)) / (t1 - t0)
