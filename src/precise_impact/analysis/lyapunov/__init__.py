"""Lyapunov exponents: variational (saltation), two-trajectory (Benettin) and from a measured
time series (Rosenstein, Kantz: :mod:`.timeseries`)."""

from __future__ import annotations

from typing import Any

from precise_impact.analysis.lyapunov.fast import fast_spectrum
from precise_impact.analysis.lyapunov.result import (
    Attractor,
    LyapunovResult,
    StartEstimate,
    block_stderr,
)
from precise_impact.analysis.lyapunov.two_trajectory import two_trajectory_lle
from precise_impact.analysis.lyapunov.variational import variational_spectrum
from precise_impact.core.budget import enforce_max_time
from precise_impact.core.compat import warn_renamed
from precise_impact.core.params import Params, as_params, check_count
from precise_impact.errors import ParameterError

__all__ = [
    "LYAPUNOV_METHODS",
    "LYAPUNOV_ENGINES",
    "Attractor",
    "StartEstimate",
    "lyapunov",
    "LyapunovResult",
    "block_stderr",
]

#: The algorithms (``method=``).
LYAPUNOV_METHODS = ("variational", "two-trajectory")

#: Every ``(method, model)`` pair that runs: the variational method on heyoka or on the
#: compiled closed form (``model='fast'``, float64), the two-trajectory method on heyoka.
LYAPUNOV_ENGINES = (
    ("variational", "heyoka"),
    ("variational", "fast"),
    ("two-trajectory", "heyoka"),
)


def lyapunov(
    params: Params,
    method: str = "variational",
    *,
    model: str = "heyoka",
    max_time: Any = None,
    **kwargs: Any,
) -> LyapunovResult:
    """Largest Lyapunov exponent (and, variationally, the spectrum) of the impact oscillator.

    Parameters
    ----------
    params : Params
        System and initial condition (``eta = 0.712`` is the paper's chaotic case).
    method : str, default ``'variational'``
        The algorithm, one of :data:`LYAPUNOV_METHODS`: ``'variational'`` (tangent
        flow, saltation matrix at each impact, QR re-orthonormalisation:
        :func:`~precise_impact.analysis.lyapunov.variational.variational_spectrum`) or
        ``'two-trajectory'`` (Benettin's renormalised pair of orbits:
        :func:`~precise_impact.analysis.lyapunov.two_trajectory.two_trajectory_lle`).
        ``'fast'`` is the 0.2 spelling of ``method='variational', model='fast'``
        (a :class:`DeprecationWarning`).
    model : str, default ``'heyoka'``
        The engine: ``'heyoka'`` (Taylor integration, every precision) or ``'fast'`` (the
        variational method on the compiled closed form, float64, every core:
        :func:`~precise_impact.analysis.lyapunov.fast.fast_spectrum`); the pairs that run
        are :data:`LYAPUNOV_ENGINES`.
    max_time : decimal or None, default ``None``
        Time budget in seconds (``1 <= max_time <= 604800``): the estimated cost of the
        runs (:func:`~precise_impact.core.budget.estimate_cost`, job ``'lle'``) is checked
        against it before any work (:class:`~precise_impact.errors.OverBudgetError`);
        ``None``: no budget.
    **kwargs
        Passed on to that method; every keyword and its default is documented there
        (common to all: ``periods=20000``, ``transient=1000``, ``precision='float64'``,
        ``segments=20``, ``progress=False``).

    Returns
    -------
    LyapunovResult
        ``lle`` with its batch-means ``stderr``, ``spectrum`` (variational only), the
        running estimate, impact counts and the method's diagnostics in ``stats``.  The
        variational and fast methods also say which attractor each start ended on
        (``stats['attractors']``): on a periodic attractor ``lle`` and ``spectrum`` are the
        exact Floquet values of the Newton-refined orbit (``stats['lle_source'] =
        'floquet'``, the finite-time estimate in ``stats['finite_time']`` with an error bar
        that includes its ``1/t`` offset), and starts on different attractors are reported
        separately, never averaged: ``lle`` is the attractor with the most starts, every
        start's values are in ``stats['per_start']``
        (:mod:`~precise_impact.analysis.lyapunov.attractors`).

    Raises
    ------
    ParameterError
        ``method`` is not one of :data:`LYAPUNOV_METHODS`, or a keyword is out of range.
    OverBudgetError
        The estimated cost is over ``max_time``, before any work.

    See Also
    --------
    precise_impact.solvers.simulate.simulate : the trajectory whose exponent is measured.
    precise_impact.analysis.bifurcation.bifurcation : the exponent along a range of eta.
    precise_impact.analysis.lyapunov.result.LyapunovResult : the result's fields.

    References
    ----------
    .. [1] V. Denysenko, M. Balcerzak, A. Dabrowski, "Electronic equivalent of a
           mechanical impact oscillator" (the chaotic case eta = 0.712, LLE ~ 0.03).
    .. [2] G. Benettin, L. Galgani, A. Giorgilli, J.-M. Strelcyn, Meccanica 15 (1980) 9-30.

    Examples
    --------
    >>> import precise_impact as pi
    >>> r = pi.lyapunov(pi.Params.make(eta="0.712"), periods=400, transient=100)
    >>> r.method, abs(sum(r.spectrum) + 0.1) < 1e-12    # lambda1 + lambda2 = -2 zeta (R = 1)
    ('variational', True)
    """

    params = as_params(params)
    if method == "fast":  # the 0.2 spelling
        warn_renamed("method='fast'", "method='variational', model='fast'", "lyapunov")
        method, model = "variational", "fast"
    if method not in LYAPUNOV_METHODS:
        raise ParameterError("method", method, "one of " + ", ".join(LYAPUNOV_METHODS))
    if (method, model) not in LYAPUNOV_ENGINES:
        raise ParameterError(
            "model",
            model,
            f"one of {', '.join(m for k, m in LYAPUNOV_ENGINES if k == method)} "
            f"with method={method!r}",
        )
    engine = "fast" if model == "fast" else method
    if max_time is not None:
        starts = kwargs.get("initial_conditions")
        enforce_max_time(
            max_time,
            "lle",
            periods=check_count(kwargs.get("periods", 20000)),
            transient=check_count(kwargs.get("transient", 1000), "transient"),
            precision=kwargs.get("precision", "float64"),
            model=engine,
            runs=None if starts is None else check_count(starts, "initial_conditions"),
        )
    if engine == "variational":
        return variational_spectrum(params, **kwargs)
    if engine == "fast":  # the budget also bounds a fallback to heyoka decided mid-run
        return fast_spectrum(params, max_time=max_time, **kwargs)
    if engine == "two-trajectory":
        return two_trajectory_lle(params, **kwargs)
    raise ParameterError("method", method, "one of " + ", ".join(LYAPUNOV_METHODS))
