"""Periods of stroboscopic sequences: the one home of period detection."""

from __future__ import annotations

import math

import numpy as np

from precise_impact.errors import ParameterError

__all__ = ["detect_period", "detect_period_noisy"]


def detect_period(xs: np.ndarray, vs: np.ndarray, max_period: int = 32, rtol: float = 1e-6) -> int:
    """Smallest period ``p <= max_period`` of a stroboscopic sequence, else 0.

    Parameters
    ----------
    xs, vs : numpy.ndarray
        Stroboscopic samples of ``x`` and ``v`` (float64), one per forcing period.
    max_period : int, default 32
        Largest period tried.
    rtol : float, default 1e-6
        Every one of the last ``2 max_period`` samples must repeat after ``p`` periods
        to ``rtol * (1 + |x|)``.

    Returns
    -------
    int
        The period; 0 means no period up to ``max_period`` (chaotic, quasi-periodic,
        or still transient).

    See Also
    --------
    precise_impact.analysis.orbits.branch.brute_force_diagram
        Stroboscopic samples along a parameter.
    precise_impact.analysis.orbits.newton.find_orbit : the periodic orbit itself.
    precise_impact.solvers.simulate.simulate : a trajectory's stroboscopic samples.

    Examples
    --------
    >>> import numpy as np
    >>> from precise_impact import detect_period
    >>> xs = np.tile([0.1, 0.7, -0.4], 40)
    >>> detect_period(xs, xs)
    3
    """
    n = len(xs)
    w = min(n, 2 * max_period)
    for p in range(1, max_period + 1):
        if n < w + p:
            break
        a = slice(n - w, n)
        b = slice(n - w - p, n - p)
        tol = rtol * (1 + np.abs(xs[a]) + np.abs(vs[a]))
        if np.all(np.abs(xs[a] - xs[b]) <= tol) and np.all(np.abs(vs[a] - vs[b]) <= tol):
            return p
    return 0


def detect_period_noisy(
    xs: np.ndarray,
    vs: np.ndarray,
    sigma_x: float,
    sigma_v: float,
    max_period: int = 32,
    z: float = 5.0,
) -> int:
    """Smallest period ``p <= max_period`` of a *measured* stroboscopic sequence, else 0.

    :func:`detect_period` asks every sample to repeat to a relative tolerance: right for
    computed sequences, wrong for measured ones, where each point carries noise (a tolerance
    wide enough for the noise makes every chaotic record "periodic" once the noise reaches a
    few percent).  Here each point carries independent noise of standard deviations
    ``sigma_x``, ``sigma_v``; for a true period ``p`` the differences ``d_k = z_{k+p} - z_k``
    are noise alone, of variance ``2 sigma^2``, so

    ``chi2_p = mean over k and both coordinates of (d_k / (sqrt(2) sigma))^2``

    is 1 up to its sampling error, and a chaotic (or longer-period) sequence adds its own
    spread: ``1 + (spread / sigma)^2``.  ``p`` is accepted when
    ``chi2_p <= 1.5 + z / sqrt(m)`` (``m`` differences; ``z / sqrt(m)`` covers the sampling
    error of ``chi2`` at ``z`` standard deviations, the 1.5 a 20 % error of the noise estimate).
    At least ``3 p`` points are needed to test ``p``.

    Parameters
    ----------
    xs, vs : numpy.ndarray
        The section points (float64), one per forcing period.
    sigma_x, sigma_v : float
        Standard deviation of the noise of one point of each coordinate (> 0).
    max_period : int, default 32
        Largest period tried.
    z : float, default 5
        Standard deviations of ``chi2``'s sampling error allowed.

    Returns
    -------
    int
        The period; 0: none up to ``max_period`` (chaotic, or a record too short).

    See Also
    --------
    precise_impact.analysis.periodicity.detect_period : computed (noise-free) sequences.
    precise_impact.lab.attractor.analyse_capture : the period of an oscilloscope capture.

    Examples
    --------
    >>> import numpy as np
    >>> from precise_impact.analysis.periodicity import detect_period_noisy
    >>> rng = np.random.default_rng(0)
    >>> xs = np.tile([0.1, 0.7, -0.4], 60) + 0.01 * rng.normal(size=180)
    >>> detect_period_noisy(xs, xs, 0.01, 0.01)
    3
    """
    xs = np.asarray(xs, dtype=float)
    vs = np.asarray(vs, dtype=float)

    for name, sig in (("sigma_x", sigma_x), ("sigma_v", sigma_v)):
        # inf would make every chi2 zero (every sequence 'period 1'); NaN every test false
        try:
            ok = math.isfinite(float(sig)) and float(sig) > 0
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise ParameterError(name, sig, "a finite noise deviation > 0")
    n = len(xs)
    for p in range(1, max_period + 1):
        if n < 3 * p:
            break
        dx = (xs[p:] - xs[:-p]) / sigma_x
        dv = (vs[p:] - vs[:-p]) / sigma_v
        m = len(dx)
        chi2 = float(np.mean(dx * dx) + np.mean(dv * dv)) / 4.0
        if chi2 <= 1.5 + z / np.sqrt(m):
            return p
    return 0
