"""Periodic orbits of the stroboscopic map by Newton's method, with Floquet multipliers.

The exact Jacobian (closed-form flow and saltation matrices) gives quadratic convergence to
stable and unstable orbits alike; at the fixed point it is the monodromy matrix, whose
eigenvalues give the exact LLE ``ln |mu_max| / (p T)``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from fractions import Fraction
from typing import Any

import numpy as np

from precise_impact.analysis.orbits.one_impact import flow_matrix, one_impact_orbits
from precise_impact.analysis.orbits.result import (
    UNDERFLOW,
    PeriodicOrbit,
    area_preserving,
    classify,
)
from precise_impact.analysis.orbits.shooting import ShootingSystem, from_orbit
from precise_impact.core.budget import DEFAULT_MAX_TIME, check_cost, parse_max_time, run_cost
from precise_impact.core.compat import UNSET, warn_renamed
from precise_impact.core.flight import MpmathOps
from precise_impact.core.impact import oscillator_saltation
from precise_impact.core.mpcontext import mp_export
from precise_impact.core.params import Params, check_count, exact, params_or_values
from precise_impact.core.precision import Precision
from precise_impact.errors import ConvergenceError, IntegrationError, ParameterError
from precise_impact.solvers.closed_form import AnalyticalSolver

__all__ = ["find_orbit", "ConvergenceError"]

_EPS = 2.0**-52

#: Largest multiprecision of the Newton refinement (each step runs the mpmath closed forms).
MAX_BITS = 2048


def _map(params: Params, z: np.ndarray, period: int):
    from precise_impact.solvers.fast.single import (  # noqa: PLC0415 -- heavy: numba ~0.5 s, loaded on first use
        STATUS_OK,
        STATUS_TEXT,
        orbit_map,
    )

    f = float
    st, x, v, m00, m01, m10, m11, n = orbit_map(
        f(params.eta),
        f(params.zeta),
        f(params.a),
        f(params.x_w),
        f(params.R),
        f(params.t0),
        f(z[0]),
        f(z[1]),
        period,
    )
    if st != STATUS_OK:
        raise IntegrationError(
            f"the orbit map cannot be evaluated from (x, v) = ({z[0]!r}, {z[1]!r}): "
            f"{STATUS_TEXT[int(st)]}"
        )
    return np.array([x, v]), np.array([[m00, m01], [m10, m11]]), int(n)


def _mpq(q, ctx) -> Any:
    return ctx.mpf(q.numerator) / q.denominator


def _fraction(z) -> Any:
    """An mpmath number as the exact Fraction it is (mantissa x 2^exponent)."""
    sign, man, exp, _ = z._mpf_
    q = Fraction(int(man)) * Fraction(2) ** int(exp)
    return -q if sign else q


def _map_mp(params: Params, z: tuple, period: int, ops: Any):
    """The map and its Jacobian in multiprecision: the robust analytical solver (mpmath) gives
    the flights and impacts, the closed-form flow and saltation matrices the Jacobian; numbers
    of ``ops.ctx`` (this computation's own mpmath context)."""
    bits, ctx = ops.prec, ops.ctx
    P = Precision.parse(f"mp:{bits}")
    q = params.replace(x0=_fraction(z[0]), v0=_fraction(z[1]))
    tr = AnalyticalSolver(finder="robust", precision=f"mp:{bits}").solve(q, period)
    eta, zeta, a, xw, R, t0 = (
        _mpq(getattr(params, n), ctx) for n in ("eta", "zeta", "a", "x_w", "R", "t0")
    )
    w = ctx.sqrt(1 - zeta * zeta)
    M = ctx.eye(2)
    t_prev = t0
    at = lambda y: ops.mpf(P.to_mpf(y))  # noqa: E731  (exact, in ctx)
    for ti, vb in zip(tr.impacts_t, tr.impacts_v_before, strict=True):
        ti, vb = at(ti), at(vb)
        M = (
            ctx.matrix(oscillator_saltation(ti, vb, eta, zeta, a, xw, R, ctx.cos))
            * flow_matrix(ti - t_prev, zeta, w, ops)
            * M
        )
        t_prev = ti
    M = flow_matrix(at(tr.t[-1]) - t_prev, zeta, w, ops) * M
    return (at(tr.x[-1]), at(tr.v[-1])), M, len(tr.impacts_t)


def _newton_mp(params: Params, z0: tuple, period: int, bits: int, max_iterations: int):
    """Newton's method at ``bits`` in an mpmath context of this computation's own (mpmath's
    module-level precision, which ``workprec`` sets, is shared by every thread)."""
    ops = MpmathOps(bits=bits)
    mp = ops.ctx
    steps = []
    z = mp.matrix([mp.mpf(z0[0]), mp.mpf(z0[1])])
    tiny = mp.mpf(2) ** (8 - bits)
    last = mp.inf
    for _ in range(max_iterations):
        fz, M, n = _map_mp(params, (z[0], z[1]), period, ops)
        F = mp.matrix([fz[0] - z[0], fz[1] - z[1]])
        dz = mp.lu_solve(M - mp.eye(2), -F)
        z = z + dz
        size = max(abs(dz[0]), abs(dz[1]))
        steps.append(size)
        if size <= tiny * (1 + max(abs(z[0]), abs(z[1]))) or (
            size >= last and last < mp.mpf(2) ** (-bits // 2)
        ):
            break
        last = size
    else:
        raise ConvergenceError(
            f"no convergence in {max_iterations} multiprecision Newton iterations"
        )
    fz, M, n = _map_mp(params, (z[0], z[1]), period, ops)
    residual = max(abs(fz[0] - z[0]), abs(fz[1] - z[1]))
    mu = sorted(mp.eig(M)[0], key=lambda m: -abs(m))
    T = 2 * mp.pi / _mpq(params.eta, mp)
    lle = float(mp.log(abs(mu[0])) / (period * T))
    return z[0], z[1], list(mu), lle, float(residual), n, len(steps), [float(h) for h in steps]


def _closed_form_seed(params: Params, period: int, near: np.ndarray | None):
    """The closed-form 1:``period`` orbit (:func:`one_impact_orbits`) to start Newton from:
    the one nearest ``near``, else the stable one, else the least unstable; ``None`` if none."""
    if not (0 <= params.zeta < 1 and 0 <= params.R <= 1):
        return None
    found = one_impact_orbits(params, dps=30, period=period)
    if not found:
        return None
    if near is not None:
        best = min(found, key=lambda o: math.hypot(float(o.x) - near[0], float(o.v) - near[1]))
    else:
        best = min(found, key=lambda o: (not o.stable, float(abs(o.multipliers[0]))))
    return np.array([float(best.x), float(best.v)])


def find_orbit(
    params: Any = None,
    period: int = 1,
    *,
    guess: Sequence[Any] | None = None,
    transient: int = 2000,
    impacts: int | None = None,
    max_iterations: int = 50,
    precision: str = "float64",
    guess_from: str = "simulation",
    seed: Any = UNSET,
    max_time: Any = None,
    **param_values: Any,
) -> PeriodicOrbit:
    """A periodic orbit of the stroboscopic map (stable or unstable) by Newton's method.

    Parameters
    ----------
    params : Params, mapping or None, default ``None``
        The system; ``None`` builds it from ``param_values`` (the paper's defaults).
    period : int, default 1
        Forcing periods ``p`` of the orbit (``1 <= p <= 1000``).
    guess : pair or None, default ``None``
        Starting state ``(x, v)`` at the stroboscopic time ``t0``.  ``None``: the state
        after ``transient`` periods from ``(x0, v0)`` (a stable orbit attracts it).
    transient : int, default 2000
        Periods simulated for the default guess.
    impacts : int or None, default ``None``
        Required impacts per orbit; ``None`` accepts what Newton converges to.
    max_iterations : int, default 50
        Newton iterations at most.
    precision : str, default ``'float64'``
        ``'float64'`` (the compiled closed forms) or ``'mp:BITS'`` (``BITS <= 2048``): the float64
        orbit refined by Newton in multiprecision, the map evaluated by the robust analytical solver
        (mpmath) and its Jacobian by the closed-form flow and saltation matrices;
        quadratic convergence to the working precision.
    guess_from : str, default ``'simulation'``
        Where Newton starts when ``guess`` is ``None``: ``'simulation'`` (the state after
        ``transient`` periods), ``'closed-form'`` (the closed-form 1:``period`` orbit of
        :func:`~precise_impact.analysis.orbits.one_impact.one_impact_orbits`: one impact per
        ``period`` forcing periods, the stable one if there is one, else the least unstable;
        requires ``impacts`` ``None`` or 1, and :class:`ConvergenceError` if there is none),
        or ``'auto'`` (the closed form when ``impacts == 1`` and one exists, else the
        simulation).  With a ``guess`` and ``'closed-form'``, the closed-form orbit nearest
        the guess.
    seed : str
        Deprecated spelling of ``guess_from`` (``seed`` is an RNG seed elsewhere).
    max_time : decimal or None, default ``None``
        Time budget in seconds for the transient (``None``: none): a transient whose estimate
        is over it is refused before any work (:class:`~precise_impact.errors.OverBudgetError`).
        The transient is run in chunks, only its last state kept (its memory is bounded).
    **param_values
        Parameter values replacing those of ``params``.

    Returns
    -------
    PeriodicOrbit
        The orbit's point at ``t0``, its impacts, Floquet multipliers, stability, exact
        LLE and the residual ``|P^p(z) - z|``.

    Raises
    ------
    ParameterError
        Bad input, before any work.
    OverBudgetError
        The transient's estimate is over ``max_time``, before any work.
    ConvergenceError
        No convergence within ``max_iterations``, or to an orbit with another impact count.
    IntegrationError
        The map cannot be evaluated (a tangential contact or chattering on the way).

    See Also
    --------
    precise_impact.analysis.orbits.proof.prove_orbit : prove the orbit exists, with an enclosure.
    precise_impact.analysis.orbits.one_impact.one_impact_orbits
        Every 1:1 impacting orbit in closed form.
    precise_impact.analysis.orbits.continuation.continue_orbit
        Follow the orbit as a parameter changes.

    Notes
    -----
    The iteration stops when the Newton step is at rounding level, ``|dz| <= 16 eps
    (1 + |z|)``, or stops shrinking (rounding dominates); quadratic convergence then
    leaves ``|z - z*|`` at the level of the step before.  The residual is reported, not
    assumed.

    References
    ----------
    .. [1] A. B. Nordmark, J. Sound Vib. 145 (1991) 279-297 (impacting periodic orbits,
           grazing).
    .. [2] M. di Bernardo, C. J. Budd, A. R. Champneys, P. Kowalczyk, *Piecewise-smooth
           Dynamical Systems*, Springer 2008, secs. 2.5 and 6 (saltation, Floquet
           multipliers of impacting orbits).

    Examples
    --------
    >>> import precise_impact as pi
    >>> o = pi.find_orbit(pi.Params.make(eta="0.74"), 3)
    >>> o.period, o.impacts, bool(max(abs(m) for m in o.multipliers) < 1)
    (3, 2, True)
    """
    params = params_or_values(params, param_values)
    if seed is not UNSET:  # the 0.2 spelling
        warn_renamed("seed=", "guess_from=", "find_orbit")
        if seed not in ("simulation", "closed-form", "auto"):  # named as the caller spelled it
            raise ParameterError("seed", seed, "'simulation', 'closed-form' or 'auto'")
        guess_from = seed
    period, transient, max_iterations, impacts, Pq = _check_options(
        params, period, transient, max_iterations, impacts, guess_from, precision
    )
    g = _parse_guess(params, guess)
    if g is None and guess_from != "closed-form":
        transient_cost(transient, max_time)
    z = _seed(params, period, g, guess_from, impacts, transient)
    z, it, steps = _newton_float(params, z, period, max_iterations)
    fz, M, n = _map(params, z, period)
    residual = float(np.max(np.abs(fz - z)))
    if residual > 1e-6 * (1 + float(np.max(np.abs(z)))):
        raise ConvergenceError(f"Newton stopped at residual {residual:.3g}: not a periodic orbit")
    if impacts is not None and n != impacts:
        raise ConvergenceError(
            f"converged to a period-{period} orbit with {n} impacts, not {impacts}"
        )
    if Pq.kind == "mp":  # refine the float64 orbit to the working precision (quadratic convergence)
        return _refined_orbit(params, period, z, n, Pq, max_iterations, it, steps)
    mu = sorted(np.linalg.eigvals(M).tolist(), key=lambda m: -abs(m))
    T = 2 * math.pi / float(params.eta)
    if abs(mu[0]) > UNDERFLOW:
        lle = math.log(abs(mu[0])) / (period * T)
    else:  # M underflowed (zeta p T > ~670): the logarithm from the scaled monodromy
        lle = _underflowed_lle(params, z, period, n)
    kind = classify(mu, area_preserving(params.zeta, params.R, n))
    return PeriodicOrbit(
        params=params,
        period=period,
        impacts=n,
        t=float(params.t0),
        x=float(z[0]),
        v=float(z[1]),
        multipliers=[complex(m) for m in mu],
        stable=kind == "stable",
        lle=0.0 if kind == "elliptic" else lle,
        residual=residual,
        iterations=it,
        stability=kind,
        steps=steps,
    )


def _underflowed_lle(params: Params, z: np.ndarray, period: int, n: int) -> float:
    """``ln |mu_max| / (p T)`` of the orbit through ``z`` from logarithms, for multipliers that
    underflow in float64 (``ShootingSystem.floquet_lle``: exactly ``-zeta`` without impacts)."""
    base = {k: float(getattr(params, k)) for k in ("eta", "zeta", "a", "x_w", "R", "t0")}
    system = ShootingSystem(base, "eta", period, n)
    if n == 0:
        return system.floquet_lle(np.asarray(z, dtype=float), base["eta"])  # -zeta, exactly
    try:
        u = from_orbit(system, params, float(z[0]), float(z[1]), base["eta"])
    except ValueError as err:  # the simulated period met another impact count
        raise IntegrationError(f"the impacts for the orbit's LLE not found: {err}") from err
    return system.floquet_lle(u, base["eta"])


def _check_options(
    params: Params,
    period: Any,
    transient: Any,
    max_iterations: Any,
    impacts: Any,
    seed: str,
    precision: str,
):
    """The counts, ``seed`` and ``precision`` of :func:`find_orbit` checked (``ParameterError``)."""
    period = check_count(period, "period", 1000, minimum=1)
    transient = check_count(transient, "transient")
    max_iterations = check_count(max_iterations, "max_iterations", 10_000, minimum=1)
    if impacts is not None:
        impacts = check_count(impacts, "impacts", 10**6)
    if seed not in ("simulation", "closed-form", "auto"):
        raise ParameterError("guess_from", seed, "'simulation', 'closed-form' or 'auto'")
    if seed == "closed-form" and impacts not in (None, 1):
        raise ParameterError(
            "impacts",
            str(impacts),
            "None or 1 with guess_from='closed-form' (one impact per orbit)",
        )

    Pq = Precision.parse(precision)
    if Pq.kind not in ("float64", "mp") or (Pq.kind == "mp" and Pq.bits > MAX_BITS):
        raise ParameterError(
            "precision", precision, f"'float64' or 'mp:BITS' with BITS <= {MAX_BITS}"
        )
    if not params.zeta < 1:
        raise ParameterError(
            "zeta", str(params.zeta), "0 <= zeta < 1 (underdamped) for the orbit finder"
        )
    return period, transient, max_iterations, impacts, Pq


def _parse_guess(params: Params, guess: Sequence[Any] | None) -> np.ndarray | None:
    """The guess ``(x, v)`` as a float64 array (``None``: none), checked to lie left of the wall."""
    if guess is None:
        return None
    if isinstance(guess, (str, bytes)) or not isinstance(guess, Sequence) or len(guess) != 2:
        raise ParameterError("guess", guess, "a pair (x, v) or None")
    g = np.array([float(exact("guess[0]", guess[0])), float(exact("guess[1]", guess[1]))])
    if g[0] > float(params.x_w):
        raise ParameterError(
            "guess[0]", str(guess[0]), f"a position <= x_w = {float(params.x_w)!r}"
        )
    return g


def _seed(
    params: Params,
    period: int,
    g: np.ndarray | None,
    seed: str,
    impacts: int | None,
    transient: int,
) -> np.ndarray:
    """Where Newton starts: the closed-form orbit, the guess, or the state after the transient."""
    z = None
    if seed == "closed-form" or (seed == "auto" and g is None and impacts == 1):
        z = _closed_form_seed(params, period, g)
        if z is None and seed == "closed-form":
            raise ConvergenceError(
                f"no admissible closed-form orbit with one impact per {period} period(s) here"
            )
    if z is None and g is not None:
        z = g
    elif z is None:
        z = _transient_end(params, transient)
    return z


#: Periods of the transient run at a time: only its last state is kept, so its memory is that
#: of one chunk (~2.4 MB of samples) however long it is (10^8 periods in one run held 2.4 GB).
TRANSIENT_CHUNK = 100_000


def _transient_end(params: Params, transient: int) -> np.ndarray:
    """The state after ``transient`` periods from ``(x0, v0)`` at ``t0``, run in chunks of
    :data:`TRANSIENT_CHUNK` periods restarted at ``t0`` (the flow is ``T``-periodic); one run,
    bit-identical to before, up to one chunk."""
    from precise_impact.solvers.fast.single import FastSolver  # noqa: PLC0415 -- heavy: numba ~0.5 s, loaded on first use

    solver = FastSolver()
    q = params
    left = transient
    while True:
        tr = solver.solve(q, min(left, TRANSIENT_CHUNK))
        z = np.array([float(tr.x[-1]), float(tr.v[-1])])
        left -= min(left, TRANSIENT_CHUNK)
        if left == 0:
            return z
        q = params.replace(x0=Fraction(z[0]), v0=Fraction(z[1]))


def transient_cost(transient: int, max_time: Any = DEFAULT_MAX_TIME) -> None:
    """Refuse a transient whose estimated run time is over ``max_time`` seconds (``None``: no
    budget), before any work (:class:`~precise_impact.errors.OverBudgetError`): priced as a
    float64 run whose samples are not kept (the fast engine's fallback, heyoka, sets the
    price per period)."""
    if max_time is None:
        return
    cost = run_cost(Precision.parse("float64"), transient, stored=False)
    check_cost(
        dataclasses.replace(cost, what=f"a transient of {cost.what}"), parse_max_time(max_time)
    )


def _newton_float(
    params: Params, z: np.ndarray, period: int, max_iterations: int
) -> tuple[np.ndarray, int, list]:
    """Float64 Newton on ``P^p(z) - z`` from ``z``: the last iterate, the iterations, the steps."""
    last = math.inf
    steps: list = []
    for _ in range(max_iterations):
        fz, M, n = _map(params, z, period)
        F = fz - z
        J = M - np.eye(2)
        try:
            dz = np.linalg.solve(J, -F)
        except np.linalg.LinAlgError as err:
            raise ConvergenceError(
                f"M - I is singular at (x, v) = ({z[0]!r}, {z[1]!r}): a multiplier +1 (fold)"
            ) from err
        z = z + dz
        if z[0] > float(params.x_w):  # a step beyond the wall: back to it
            z[0] = float(params.x_w)
        size = float(np.max(np.abs(dz)))
        steps.append(size)
        if size <= 16 * _EPS * (1 + float(np.max(np.abs(z)))) or (size >= last and last < 1e-8):
            break
        last = size
    else:
        raise ConvergenceError(
            f"no convergence in {max_iterations} Newton iterations (last step {last:.3g}) "
            f"from the guess; try another guess, period or impacts"
        )
    return z, len(steps), steps  # one step per iteration taken


def _refined_orbit(
    params: Params,
    period: int,
    z: np.ndarray,
    n: int,
    Pq: Any,
    max_iterations: int,
    it: int,
    steps: list,
) -> PeriodicOrbit:
    """The float64 orbit ``z`` refined by multiprecision Newton to ``Pq.bits``, as the result."""
    x, v, mu, lle, res, n_mp, it_mp, steps_mp = _newton_mp(
        params, (z[0], z[1]), period, Pq.bits, max_iterations
    )
    if n_mp != n:
        raise ConvergenceError(f"the multiprecision refinement found {n_mp} impacts, float64 {n}")
    kind = classify(mu, area_preserving(params.zeta, params.R, n))
    return PeriodicOrbit(
        params=params,
        period=period,
        impacts=n,
        t=float(params.t0),
        x=mp_export(x),
        v=mp_export(v),
        multipliers=[mp_export(m) for m in mu],
        stable=kind == "stable",
        lle=0.0 if kind == "elliptic" else lle,
        residual=res,
        iterations=it + it_mp,
        precision=Pq.name,
        stability=kind,
        steps=steps + steps_mp,
    )
