"""Proven periodic orbits: a Krawczyk test on the stroboscopic map with impacts.

The certified engine encloses ``P^p`` at the centre and its Jacobian over the box; existence,
local uniqueness and enclosed Floquet multipliers follow (Krawczyk 1969; Moore).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from fractions import Fraction
from typing import Any

from precise_impact.analysis.orbits.krawczyk import krawczyk, newton_points
from precise_impact.analysis.orbits.newton import find_orbit
from precise_impact.core.params import Params, check_count, exact, params_or_values
from precise_impact.core.precision import float_down, float_up, log10_fraction
from precise_impact.core.result import ResultMixin
from precise_impact.errors import ParameterError
from precise_impact.solvers.certified.single import (
    ball_str,
    exact_value,
    period_jacobian,
    run_balls,
    working_bits,
)

__all__ = ["prove_orbit", "ProvenOrbit"]


@dataclasses.dataclass
class ProvenOrbit(ResultMixin):
    """A periodic orbit proven to exist, unique in its box, with enclosed multipliers
    (:func:`prove_orbit`).

    Attributes
    ----------
    params : Params
        The system (exact).
    period, impacts : int
        Forcing periods and impacts per orbit.
    bits : int
        Working precision.
    x, v : tuple of str
        The box: decimal midpoint and radius of each coordinate at ``t0`` (the orbit's point
        lies inside; the radii are rigorous, rounded up).
    proven : bool
        ``K(Z)`` lies in the interior of ``Z``: exactly one fixed point of ``P^p`` in the box.
    contraction : float
        ``max |K(Z)_i - z_i| / r``: how far inside the box the Krawczyk image lies (``< 1``
        proves), rounded up: a bound (it is about ``r``, so below 1e-308, from ~2100 bits on,
        it is the smallest subnormal ``5e-324``, never 0.0; its size is ``log10_contraction``).
    log10_contraction : float
        ``log10`` of the contraction at any magnitude (``-inf``: ``K(Z)`` is the point ``z``).
    multipliers : list of dict
        Each multiplier's enclosure: ``{"re", "im", "rad", "abs_upper"}`` (decimal strings; a
        complex ball ``re + i im`` with radius ``rad`` per part).
    stable : bool or None
        ``True``: both multipliers proven inside the unit circle; ``False``: one proven outside;
        ``None``: the enclosures straddle it.
    lle : tuple of float
        Enclosure ``(lower, upper)`` of ``ln |mu_max| / (p T)``.
    elapsed_s : float
        Wall time (diagnostic).

    See Also
    --------
    precise_impact.analysis.orbits.proof.prove_orbit : returns it.
    precise_impact.analysis.orbits.result.PeriodicOrbit : the floating-point counterpart.
    """

    params: Params
    period: int
    impacts: int
    bits: int
    x: tuple
    v: tuple
    proven: bool
    contraction: float
    log10_contraction: float
    multipliers: list
    stable: Any
    lle: tuple
    elapsed_s: float


def _jacobian(c, impacts, period):
    """``M``: flow and saltation matrices along the impacts (balls), from ``t0`` to ``t0 + p T``."""
    return period_jacobian(c, c.t0, impacts, c.t0 + period * c.T)


def _final(samples):
    return samples[-1][2], samples[-1][3]


def prove_orbit(
    params: Any = None,
    period: int = 1,
    *,
    guess: Sequence[Any] | None = None,
    impacts: int | None = None,
    bits: int = 256,
    radius: Any = None,
    transient: int = 2000,
    **param_values: Any,
) -> ProvenOrbit:
    """Prove a periodic orbit of the stroboscopic map: existence and local uniqueness in a small
    box (Krawczyk), its multipliers enclosed, stability proven when they are.

    Parameters
    ----------
    params : Params, mapping or None, default ``None``
        The system; ``None``: the paper's defaults with ``param_values``.
    period : int, default 1
        Forcing periods ``p`` (``1 <= p <= 1000``).
    guess : pair or None, default ``None``
        Starting state ``(x, v)`` at ``t0`` for the float64 Newton (``None``: after ``transient``
        periods; see :func:`~precise_impact.analysis.orbits.newton.find_orbit`).
    impacts : int or None, default ``None``
        Required impacts per orbit.
    bits : int, default 256
        Working precision of the ball arithmetic (``128 <= bits <= 4096``).
    radius : decimal or None, default ``None``
        Half-width ``r`` of the box; ``None``: ``2^(-bits/2)`` (far above the refined centre's
        error ``~2^-bits``, far below the orbit's scale).
    transient : int, default 2000
        Periods simulated for the default guess.
    **param_values
        Parameter values replacing those of ``params``.

    Returns
    -------
    ProvenOrbit
        The box, whether it is proven, the enclosed multipliers, stability and LLE.

    Raises
    ------
    ParameterError
        Bad input, before any work.
    ConvergenceError
        The float64 Newton found no orbit.
    CertificationError
        The engine could not prove the impact sequence over the box (a graze within it).

    See Also
    --------
    precise_impact.analysis.orbits.newton.find_orbit : the same orbit in floating point, unproven.
    precise_impact.solvers.certified.single.certify : a certified transient from an initial state.
    precise_impact.analysis.orbits.proof.ProvenOrbit : the enclosure's fields.

    References
    ----------
    .. [1] R. Krawczyk, "Newton-Algorithmen zur Bestimmung von Nullstellen mit
           Fehlerschranken", Computing 4 (1969) 187-201.
    .. [2] R. E. Moore, R. B. Kearfott, M. J. Cloud, *Introduction to Interval Analysis*,
           SIAM 2009, sec. 8.2.
    .. [3] P. Zgliczynski, "C^1 Lohner algorithm", Found. Comput. Math. 2 (2002) 429-465
           (validated Poincare maps).

    Examples
    --------
    >>> import precise_impact as pi
    >>> po = pi.prove_orbit(pi.Params.make(eta="0.70"), 1)
    >>> po.period, po.impacts, po.bits
    (1, 0, 256)
    """
    t_start = time.perf_counter()
    params = params_or_values(params, param_values)
    period = check_count(period, "period", 1000, minimum=1)
    bits = check_count(bits, "bits", 4096, minimum=128)
    r = _box_radius(radius, bits)
    o = find_orbit(params, period, guess=guess, impacts=impacts, transient=transient)

    with working_bits(bits):
        runs: list = []
        fun = _orbit_residual(params, period, bits, runs)
        what = f"the period-{period} orbit at eta = {params.eta}"
        z = newton_points(fun, (o.x, o.v), bits, what)
        _, box, contraction, inside = krawczyk(fun, z, r, what)
        centre_impacts, box_impacts = runs[-2][0], runs[-1][0]
        if len(box_impacts) != len(centre_impacts):  # pragma: no cover - proven or raised
            raise ParameterError(
                "radius", str(radius), "a box small enough for one impact sequence"
            )
        n_impacts, proven, (_, MZ, c) = len(centre_impacts), all(inside), runs[-1]
        mult, ups, lows = _multipliers(MZ)
        stable, lle = _stability_and_lle(ups, lows, period * c.T)
        xs, vs = ball_str(box[0]), ball_str(box[1])
    return ProvenOrbit(
        params=params,
        period=period,
        impacts=n_impacts,
        bits=bits,
        x=xs,
        v=vs,
        proven=bool(proven),
        contraction=float_up(contraction),
        log10_contraction=log10_fraction(contraction),
        multipliers=mult,
        stable=stable,
        lle=lle,
        elapsed_s=time.perf_counter() - t_start,
    )


def _box_radius(radius: Any, bits: int) -> Fraction:
    """The box half-width ``r`` (default ``2^(-bits/2)``), refused outside its usable range."""
    r = Fraction(1, 2 ** (bits // 2)) if radius is None else exact("radius", radius, 3000)
    # a box narrower than ~2^32 ulps of its centre cannot contain the rounding of the Newton
    # point and of F at the working precision: refused instead of attempted (radius = 1e-400 at
    # 128 bits used to end in a float division by zero)
    r_min = Fraction(1, 2 ** (bits - 32))
    if not r_min <= r <= Fraction(1, 1000):
        raise ParameterError(
            "radius", str(radius), f"2^-{bits - 32} <= radius <= 1e-3 at bits={bits}"
        )
    return r


def _orbit_residual(params: Params, period: int, bits: int, runs: list):
    """``F(z) = P^p(z) - z`` and ``F' = M - I`` (flow and saltation product over the balls ``z``)
    for :mod:`~precise_impact.analysis.orbits.krawczyk`; each run's ``(impacts, M, constants)``
    is appended to ``runs``."""

    def fun(z: list, grad: bool) -> tuple[list, list]:
        samples, imps, c = run_balls(params, period, bits, start=(z[0], z[1]))
        fx, fv = _final(samples)
        M = _jacobian(c, imps, period)
        runs.append((imps, M, c))
        F = [fx - z[0], fv - z[1]]
        return F, [[M[0][0] - 1, M[0][1]], [M[1][0], M[1][1] - 1]]

    return fun


def _multipliers(MZ: list) -> tuple[list, list, list]:
    """The two multipliers of ``MZ`` enclosed: their records, ``|mu|`` upper and lower bounds."""
    import flint  # noqa: PLC0415 -- heavy: python-flint ~0.1 s, loaded on first proof

    tr = MZ[0][0] + MZ[1][1]
    dt = MZ[0][0] * MZ[1][1] - MZ[0][1] * MZ[1][0]
    disc = flint.acb(tr * tr - 4 * dt).sqrt()
    mus = [(flint.acb(tr) + disc) / 2, (flint.acb(tr) - disc) / 2]
    mult, ups, lows = [], [], []
    for m in mus:
        re_m, re_r = ball_str(m.real)
        im_m, im_r = ball_str(m.imag)
        au = abs(m).upper()
        ups.append(au)
        lows.append(abs(m).lower())
        mult.append(
            {
                "re": re_m,
                "im": im_m,
                "rad": max(re_r, im_r, key=Fraction),  # exactly: float() is 0.0 below 1e-308
                "abs_upper": ball_str(flint.arb(au), 12)[0],
            }
        )
    return mult, ups, lows


def _stability_and_lle(ups: list, lows: list, pT: Any) -> tuple[bool | None, tuple[float, float]]:
    """Stability (``None``: undecided) and the LLE interval from the multipliers' moduli."""
    import flint  # noqa: PLC0415 -- heavy: python-flint ~0.1 s, loaded on first proof

    unit = flint.arb(1)
    stable = (
        True if all(u < unit for u in ups) else (False if any(lo > unit for lo in lows) else None)
    )
    big = max(range(2), key=lambda i: exact_value(ups[i]))
    lle = ((flint.arb(lows[big]).log() / pT), (flint.arb(ups[big]).log() / pT))
    lo, hi = exact_value(lle[0].lower()), exact_value(lle[1].upper())
    return stable, (float_down(lo), float_up(hi))
