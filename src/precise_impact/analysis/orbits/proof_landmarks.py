"""Proven bifurcation points: a Krawczyk test on the landmarks' augmented systems in arb.

:func:`prove_landmark` proves a float64 landmark (:mod:`~precise_impact.analysis.orbits.landmarks`)
a regular zero and a crossing, not a touch (Krawczyk 1969; Moore et al. 2009, sec. 8.2).  The
operator, enclosures and sign change: ``docs/numerics.rst``, "Proven bifurcation points".
"""

from __future__ import annotations

import dataclasses
import math
import time
from decimal import ROUND_CEILING, ROUND_FLOOR, Decimal, localcontext
from fractions import Fraction
from typing import Any

import numpy as np

from precise_impact.analysis.orbits.krawczyk import krawczyk, newton_points
from precise_impact.analysis.orbits.landmarks import (
    BranchPoint,
    check_theta,
    end_point,
    interval_ends,
    seed_landmark,
)
from precise_impact.core.dual import BALL_DUAL, BallDual, seed
from precise_impact.core.params import decimal_str, exact
from precise_impact.core.precision import float_up, log10_fraction
from precise_impact.core.result import ResultMixin
from precise_impact.errors import (
    CertificationError,
    ConvergenceError,
    ParameterError,
    check_type,
)
from precise_impact.solvers.certified.single import (
    ball_str,
    exact_value,
    log10_str,
    radius_str,
    to_ball,
    working_bits,
)

__all__ = ["prove_landmark", "locate_landmark", "ProvenLandmark", "landmark_unknowns", "POINTS"]

#: The test function each kind's last equation is.
_TEST = {
    "graze_free": "x(t_m) - x_w",
    "graze": "x(t_m) - x_w",
    "period-doubling": "1 + tr M + det M",
    "fold": "1 - tr M + det M",
}


# ------------------------------------------------------------------------------ the result
@dataclasses.dataclass
class ProvenLandmark(ResultMixin):
    """A bifurcation point proven to exist, unique in its box, regular, and a crossing of its
    test function (:func:`prove_landmark`).

    Attributes
    ----------
    kind : str
        ``graze_free``, ``graze``, ``period-doubling`` or ``fold``.
    period, impacts : int
        Of the orbit at the landmark.
    theta : dict
        ``zeta``, ``a``, ``x_w``, ``R`` as exact decimals (the values proven at).
    bits : int
        Working precision.
    eta : tuple of str
        Decimal ``(midpoint, radius)`` of the proven enclosure of the landmark's forcing
        frequency (radius rounded up, so ``[mid - rad, mid + rad]`` contains it).
    eta_lower, eta_upper : str
        The enclosure's ends as decimals, rounded outward (4 digits below its width).
    width : float
        ``eta_upper - eta_lower`` of those decimals, rounded up to a float64: a bound (below
        1e-308 the smallest subnormal ``5e-324``, never 0.0; its size is ``log10_width``).
    log10_width : float
        ``log10`` of that width, at any magnitude (``-400`` for a width of 1e-400).
    unknowns : dict
        Every unknown of the augmented system: name -> ``(midpoint, radius)`` decimal strings.
    box_radius : str
        Half-width ``r`` of the Krawczyk box ``Y`` (every coordinate).
    contraction : float
        ``max_i |K(Y)_i - y_i| / r`` (``< 1`` proves), rounded up (as ``width``: ``5e-324``
        below the float range).
    log10_contraction : float
        ``log10`` of the contraction, at any magnitude (``-inf``: ``K(Y)`` is the point).
    test_function : str
        The defining condition ``g``.
    sides : list of dict
        The sign change: per side the branch coordinate held (``coordinate``, ``value``), the
        enclosure of ``g`` there (``g``: ``(midpoint, radius)``) and its proven ``sign``.  Both
        orbits and the landmark lie on one branch: for every value of the coordinate between
        the two, the branch equations have exactly one zero in a common tube (Krawczyk with
        the coordinate a ball), so ``g`` changes sign along the branch through the landmark.
    eta_float64 : float
        The float64 landmark the proof started from.
    float64_offset_ulps : float
        ``|eta_float64 - mid| / ulp(eta_float64)``: how far the float64 value is from the
        proven one, in units of its last place.
    elapsed_s : float
        Wall time (diagnostic).

    See Also
    --------
    precise_impact.analysis.orbits.proof_landmarks.prove_landmark : returns it.
    precise_impact.analysis.orbits.landmarks.BranchPoint : the float64 landmark.
    precise_impact.analysis.orbits.proof.ProvenOrbit : a proven periodic orbit.
    """

    kind: str
    period: int
    impacts: int
    theta: dict
    bits: int
    eta: tuple
    eta_lower: str
    eta_upper: str
    width: float
    log10_width: float
    unknowns: dict
    box_radius: str
    contraction: float
    log10_contraction: float
    test_function: str
    sides: list
    eta_float64: float
    float64_offset_ulps: float
    elapsed_s: float

    def contains(self, value: Any) -> bool:
        """``True`` if the exact value (a decimal string, Fraction, float or mpmath number)
        lies in ``[eta_lower, eta_upper]``."""
        q = Fraction(str(value)) if not isinstance(value, (Fraction, float, int)) else value
        return Fraction(self.eta_lower) <= Fraction(q) <= Fraction(self.eta_upper)


def landmark_unknowns(bp: BranchPoint) -> list[str]:
    """The names of a landmark's unknowns, in the order of ``bp.y``.

    Parameters
    ----------
    bp : BranchPoint
        The landmark.

    Returns
    -------
    list of str
        ``t_i, v_i`` per impact (``x_0, v_0`` without impacts), ``t_m`` for a grazing, ``eta``.

    See Also
    --------
    precise_impact.analysis.orbits.landmarks.BranchPoint : whose ``y`` they name.

    Examples
    --------
    >>> import numpy as np
    >>> from precise_impact.analysis.orbits.landmarks import BranchPoint
    >>> from precise_impact.analysis.orbits.proof_landmarks import landmark_unknowns
    >>> bp = BranchPoint("period-doubling", 1, 1, np.zeros(3), np.array([0.05, 1.0, 2.0]))
    >>> landmark_unknowns(bp)
    ['t_1', 'v_1', 'eta']
    """
    n = bp.impacts
    names = ["x_0", "v_0"] if n == 0 else [f"{c}_{i + 1}" for i in range(n) for c in ("t", "v")]
    if bp.kind in ("graze_free", "graze"):
        names.append("t_m")
    return [*names, "eta"]


# ------------------------------------------------------------------------------ the proof
def prove_landmark(
    bp: BranchPoint,
    width: Any = "1e-40",
    *,
    theta: Any = None,
    bits: int | None = None,
) -> ProvenLandmark:
    """Prove a located landmark: a box of at most ``width`` in every unknown that contains
    exactly one zero of its augmented system (Krawczyk), and the test function's sign change
    on either side.

    Parameters
    ----------
    bp : BranchPoint
        The landmark located in float64 (kind ``graze_free``, ``graze``,
        ``period-doubling`` or ``fold``): from
        :func:`~precise_impact.analysis.orbits.landmarks.seed_landmark`,
        :func:`~precise_impact.analysis.orbits.landmarks.landmark_from_continuation` or
        :func:`~precise_impact.analysis.orbits.landmarks.end_point`.
    width : decimal, default ``"1e-40"``
        Largest width of the proven intervals (``1e-1000 <= width <= 1e-6``): the Krawczyk
        box is ``y* + [-width/2, width/2]`` in every unknown.
    theta : mapping or None, default ``None``
        Exact ``zeta``, ``a``, ``x_w``, ``R`` (decimal strings or Fractions) to prove at;
        ``None``: ``bp.theta`` and ``bp.R`` read as their shortest decimals (``0.05`` is
        ``1/20``), so the float64 landmark of the paper's parameters is proven at them.
    bits : int or None, default ``None``
        Working precision (``64 <= bits <= 4096``); ``None``: ``log2(1 / width) + 96``
        (rounding ``2^-bits`` far below the box, so the test closes unless the point is
        degenerate).

    Returns
    -------
    ProvenLandmark
        The enclosure of ``eta`` (and every unknown), its width, the sign change.

    Raises
    ------
    ParameterError
        Bad input (a kind without a test function, a width or bits out of range), before
        any work.
    CertificationError
        The proof cannot close: a singular Jacobian (a degenerate point: two landmarks
        merging, a touch instead of a crossing), ``K(Y)`` not inside ``Y`` (the point is not
        a zero to the box's accuracy), or no sign change of the test function.  Nothing is
        returned then.

    See Also
    --------
    precise_impact.analysis.orbits.proof.prove_orbit : the same test on a periodic orbit.
    precise_impact.analysis.orbits.landmarks.BranchPoint : the augmented systems.
    precise_impact.core.flow.grazing_frequencies : the closed form of the free grazing.

    References
    ----------
    .. [1] R. Krawczyk, "Newton-Algorithmen zur Bestimmung von Nullstellen mit
           Fehlerschranken", Computing 4 (1969) 187-201.
    .. [2] R. E. Moore, R. B. Kearfott, M. J. Cloud, *Introduction to Interval Analysis*,
           SIAM 2009, sec. 8.2.

    Examples
    --------
    >>> from precise_impact.analysis.orbits.landmarks import seed_landmark
    >>> from precise_impact.analysis.orbits.proof_landmarks import prove_landmark
    >>> bp = seed_landmark("graze_free", (0.05, 1.0, 2.0), 0.7106)
    >>> pl = prove_landmark(bp, "1e-40")
    >>> pl.eta_lower[:12], pl.width <= 1e-40
    ('0.7106873690', True)
    """
    t_start = time.perf_counter()
    check_type(bp, BranchPoint, "bp", "a BranchPoint from locate_landmark or seed_landmark")
    if bp.kind not in _TEST:
        raise ParameterError("kind", bp.kind, "graze_free, graze, period-doubling or fold")
    w = check_width(width)
    bits = _proof_bits(w, bits)
    th = _exact_theta(bp, theta)
    r = w / 2
    y0 = np.asarray(bp.y, dtype=float)
    k = _branch_coordinate(bp)
    names = landmark_unknowns(bp)

    with working_bits(bits):
        tb = [to_ball(th[n]) for n in ("zeta", "a", "x_w")]
        Rb = to_ball(th["R"])
        lm = dataclasses.replace(bp, R=Rb)

        def full(ys: list, grad: bool) -> tuple[list, list]:
            return _evaluate(lm, ys, tb, grad)

        what = f"{bp.kind} landmark at eta ~ {bp.eta:.17g}"
        c = newton_points(full, y0, bits, what)
        K, contraction = _krawczyk(full, c, r, what, names)
        tube, sides = _sign_change(bp, lm, tb, c, k, r, bits, what, names)
        if not all(t.contains(b) for t, b in zip(tube, K, strict=True)):  # pragma: no cover
            raise CertificationError(f"{what}: the landmark is not in the branch's tube")
        _check_crossing(bp, sides)
        lo_s, hi_s, eta_mid = _eta_interval(K[-1])
        unknowns = {n: ball_str(b) for n, b in zip(names, K, strict=True)}
        eta_str = ball_str(K[-1])
    ulp = math.ulp(bp.eta)
    width = Fraction(hi_s) - Fraction(lo_s)
    return ProvenLandmark(
        kind=bp.kind,
        period=int(bp.period),
        impacts=int(bp.impacts),
        theta={n: _dec(q) for n, q in th.items()},
        bits=bits,
        eta=eta_str,
        eta_lower=lo_s,
        eta_upper=hi_s,
        width=float_up(width),
        log10_width=log10_fraction(width),
        unknowns=unknowns,
        box_radius=_dec(r),
        contraction=float_up(contraction),
        log10_contraction=log10_fraction(contraction),
        test_function=_TEST[bp.kind],
        sides=sides,
        eta_float64=bp.eta,
        float64_offset_ulps=float(abs(Fraction(bp.eta) - eta_mid) / Fraction(ulp)),
        elapsed_s=time.perf_counter() - t_start,
    )


def _proof_bits(w: Fraction, bits: Any) -> int:
    """The working bits: ``log2(1 / w) + 96`` when ``bits`` is None, else ``bits`` checked."""
    if bits is None:
        # log2(1 / w) from the integers (float(1 / w) overflows past 1e308)
        bits = math.ceil(math.log2(w.denominator) - math.log2(w.numerator)) + 96
    elif not isinstance(bits, int) or isinstance(bits, bool) or not 64 <= bits <= 4096:
        raise ParameterError("bits", str(bits), "an integer, 64 <= bits <= 4096")
    return bits


def _sign_change(
    bp: BranchPoint,
    lm: BranchPoint,
    tb: list,
    c: list,
    k: int,
    r: Fraction,
    bits: int,
    what: str,
    names: list,
) -> tuple[list, list]:
    """The branch's tube through the landmark and the test function's sign at ``s* -+ 2 r``."""
    # the sign change: the branch's orbits at s = s* -+ 2 r (s the coordinate moving most),
    # each proven unique in a small box, and all of them (s in [s* - 2r, s* + 2r], the
    # landmark's box included) on one branch: unique zeros of the branch equations for
    # every s of that range in one tube (Krawczyk with s a ball)
    y0 = np.asarray(bp.y, dtype=float)
    rq = to_ball(r)
    tube_r = r * 4 * max(1, math.ceil(_slope(bp, k)))
    S = c[k] + flint_ball(0, (2 * rq).upper())
    tube, _ = _krawczyk(_branch(lm, tb, k, S), c, tube_r, f"{what}: the branch through it", names)
    sides = []
    for sgn in (-1, 1):
        s_val = c[k] + sgn * 2 * rq
        label = f"{what}: the branch at {names[k]} {'-+'[sgn > 0]} 2r"
        # the float64 prediction (a shift of 2r below the float range is 0.0: the start is
        # then y0 itself, as good a start as float64 can give)
        start = _predict(bp, y0, k, float(exact_value((s_val - c[k]).mid())))
        cs = newton_points(_branch(lm, tb, k, s_val), start, bits, label)
        Ks, _ = _krawczyk(_branch(lm, tb, k, s_val), cs, r / 4, label)
        if not all(t.contains(b) for t, b in zip(tube, Ks, strict=True)):  # pragma: no cover
            raise CertificationError(f"{label}: the orbit is not in the branch's tube")
        gval = _evaluate(lm, Ks, tb, False)[0][-1]
        sign = 1 if gval > 0 else (-1 if gval < 0 else 0)
        sides.append(
            {
                "coordinate": names[k],
                "value": ball_str(s_val, 50)[0],
                "g": ball_str(gval),
                "sign": sign,
            }
        )
    return tube, sides


def _check_crossing(bp: BranchPoint, sides: list) -> None:
    """Refuse a test function not proven nonzero beside the box, or of one sign on both sides."""
    if sides[0]["sign"] == 0 or sides[1]["sign"] == 0:
        raise CertificationError(
            f"{bp.kind} landmark at eta ~ {bp.eta!r}: the test function {_TEST[bp.kind]} "
            "is not proven nonzero beside the box (enclosures "
            f"{sides[0]['g']} and {sides[1]['g']}): no proof"
        )
    if sides[0]["sign"] == sides[1]["sign"]:
        raise CertificationError(
            f"{bp.kind} landmark at eta ~ {bp.eta!r}: the test function {_TEST[bp.kind]} "
            "has the same sign on both sides (a touch, not a crossing): degenerate point"
        )


def _eta_interval(e: Any) -> tuple[str, str, Fraction]:
    """The enclosure ``e`` of eta as outward-rounded decimal ends, and its exact midpoint."""
    lo_q, hi_q = exact_value(e.lower()), exact_value(e.upper())
    # the ends rounded outward to 4 digits below the width (the stated interval is the
    # decimal one, so its width is computed from the decimals)
    scale = max(abs(lo_q), abs(hi_q), Fraction(1, 10**1200))
    digits = 4 + max(1, math.ceil(log10_fraction(scale / max(hi_q - lo_q, scale / 10**1300))))
    lo_s, hi_s = _round_dec(lo_q, -1, digits), _round_dec(hi_q, 1, digits)
    return lo_s, hi_s, exact_value(e.mid())


def check_width(width: Any) -> Fraction:
    """``width`` of :func:`prove_landmark` as a Fraction, refused outside ``[1e-1000, 1e-6]``
    (the automatic bits, ``log2(1 / width) + 96``, stay within 4096)."""
    w = exact("width", width, 1100)
    if not Fraction(1, 10**1000) <= w <= Fraction(1, 10**6):
        raise ParameterError("width", str(width), "1e-1000 <= width <= 1e-6")
    return w


def _exact_theta(bp: BranchPoint, theta: Any) -> dict:
    """``zeta, a, x_w, R`` as Fractions: given, or ``bp``'s floats as their shortest decimals."""
    floats = dict(zip(("zeta", "a", "x_w"), (float(t) for t in bp.theta), strict=True))
    floats["R"] = float(bp.R)
    out = {}
    for n, f in floats.items():
        given = None if theta is None else theta.get(n)
        out[n] = exact(n, repr(f) if given is None else given, 100)
    return out


def _evaluate(bp: BranchPoint, ys: list, theta: list, grad: bool) -> tuple[list, list]:
    """``F(ys)`` in balls, and ``F'`` enclosed over the balls ``ys`` when ``grad``."""
    import flint  # noqa: PLC0415 -- heavy: python-flint ~0.1 s, loaded on first proof

    m = len(ys)
    args = seed(ys, dual=BallDual) if grad else list(ys)
    F = bp.residual(args, theta, BALL_DUAL)
    vals = [f.v if isinstance(f, BallDual) else BallDual.coerce(f) for f in F]
    if not grad:
        return vals, []
    J = [list(f.g) if isinstance(f, BallDual) else [flint.arb(0)] * m for f in F]
    return vals, J


def _krawczyk(fun: Any, c: list, r: Fraction, what: str, names: list | None = None):
    """:func:`~precise_impact.analysis.orbits.krawczyk.krawczyk` on ``c + [-r, r]^m``: the box
    intersected with ``K(Y)`` and the contraction; :class:`CertificationError` unless ``K(Y)``
    lies in the interior of ``Y``."""
    K, Y, contraction, inside = krawczyk(fun, c, r, what)
    if not all(inside):
        m = len(c)
        bad = [names[i] if names else str(i) for i in range(m) if not inside[i]]
        finite = all(K[i].is_finite() for i in range(m))
        why = (
            "the Jacobian enclosure over the box is not finite (a singular point in it)"
            if not finite
            else f"K(Y) is not inside Y in {', '.join(bad)} "
            f"(contraction {log10_str(log10_fraction(contraction))})"
        )
        raise CertificationError(
            f"{what}: the Krawczyk test on a box of radius {radius_str(r)} did not close: "
            f"{why}; a degenerate point (Jacobian singular or nearly so) or a box too small "
            "for the working precision: no proof"
        )
    return [Y[i].intersection(K[i]) for i in range(len(c))], contraction


def flint_ball(mid: Any, rad: Any) -> Any:
    """``flint.arb(mid, rad)``."""
    import flint  # noqa: PLC0415 -- heavy: python-flint ~0.1 s, loaded on first proof

    return flint.arb(mid, rad)


def _branch(lm: BranchPoint, theta: list, k: int, s: Any) -> Any:
    """The branch equations (all of ``F`` but the test function) and ``y_k = s`` (a ball)."""
    import flint  # noqa: PLC0415 -- heavy: python-flint ~0.1 s, loaded on first proof

    def fun(ys: list, grad: bool) -> tuple[list, list]:
        F, J = _evaluate(lm, ys, theta, grad)
        row = [flint.arb(int(i == k)) for i in range(len(ys))]
        return [*F[:-1], ys[k] - s], ([*J[:-1], row] if grad else [])

    return fun


def _slope(bp: BranchPoint, k: int) -> float:
    """``max_j |t_j / t_k|`` of the branch's tangent ``t``: how far the branch moves in any
    unknown per unit of ``y_k``."""
    _, Fy, _ = bp.jacobian()
    t = _null_vector(Fy[:-1])
    return float(np.max(np.abs(t)) / abs(t[k]))


def _branch_coordinate(bp: BranchPoint) -> int:
    """The unknown the branch moves most in at the landmark (the null vector of the branch
    equations, all but the last row of ``F_y``): ``eta`` unless the branch turns there (a
    fold)."""
    _, Fy, _ = bp.jacobian()
    t = _null_vector(Fy[:-1])
    if abs(t[-1]) >= 1e-3 * float(np.max(np.abs(t))):
        return len(t) - 1
    return int(np.argmax(np.abs(t)))


def _null_vector(A: np.ndarray) -> np.ndarray:
    """The unit null vector of an ``(m-1) x m`` matrix of full rank (last right singular
    vector)."""
    return np.linalg.svd(A)[2][-1]


def _predict(bp: BranchPoint, y0: np.ndarray, k: int, ds: float) -> np.ndarray:
    """The branch point at ``y_k = y*_k + ds`` to first order (along the tangent)."""
    _, Fy, _ = bp.jacobian()
    t = _null_vector(Fy[:-1])
    return y0 + (ds / t[k]) * t


def _dec(q: Fraction) -> str:
    return decimal_str(q)


def _round_dec(q: Fraction, direction: int, digits: int = 50) -> str:
    """``q`` rounded to ``digits`` significant digits towards ``direction`` (-1 down, +1 up)."""
    with localcontext() as ctx:
        ctx.prec = digits
        ctx.rounding = ROUND_CEILING if direction > 0 else ROUND_FLOOR
        d = Decimal(q.numerator) / Decimal(q.denominator)
    return format(d, "f") if d != 0 else "0"


#: The landmark names of :func:`locate_landmark` (and ``certify --point``) and the branch-end
#: types of the continuation each one is.
POINTS = {"grazing": "grazing", "period-doubling": "period-doubling", "fold": "fold"}


def locate_landmark(
    point: str,
    theta: Any = (0.05, 1.0, 2.0),
    eta: float = 0.712,
    period: int = 1,
    side: str | None = None,
    R: float = 1.0,
) -> BranchPoint:
    """Locate a landmark in float64, ready for :func:`prove_landmark`.

    Without ``side``: the grazing of the non-impacting period-1 orbit nearest ``eta``
    (Newton on its augmented system; ``point`` must be ``'grazing'``).  With ``side``: the
    period-``period`` orbit at ``eta``
    (:func:`~precise_impact.analysis.orbits.landmarks.seed_landmark`), the end of its stable
    admissible interval on that side
    (:func:`~precise_impact.analysis.orbits.landmarks.interval_ends`, continuation within
    ``+- 0.06``), which must be a ``point``, polished on its augmented system
    (:func:`~precise_impact.analysis.orbits.landmarks.end_point`): how the tolerance budget
    finds the Fig. 6 period-3 window.

    Parameters
    ----------
    point : {'grazing', 'period-doubling', 'fold'}
        The landmark.
    theta : sequence of float, default ``(0.05, 1.0, 2.0)``
        ``(zeta, a, x_w)``.
    eta : float, default 0.712
        Where to start: near the free grazing, or inside the orbit's interval.
    period : int, default 1
        The orbit's period (with ``side``).
    side : {'low', 'high'} or None, default ``None``
        Which end of the orbit's interval in ``eta``.
    R : float, default 1.0
        Restitution coefficient.

    Returns
    -------
    BranchPoint
        The landmark.

    Raises
    ------
    ParameterError
        Bad input.
    ConvergenceError
        No orbit at ``eta``, or that end is not a ``point`` (the message names what it is).

    See Also
    --------
    precise_impact.analysis.orbits.proof_landmarks.prove_landmark : proves it.
    precise_impact.analysis.orbits.landmarks.landmark_from_continuation : another way to one.

    Examples
    --------
    >>> from precise_impact.analysis.orbits.proof_landmarks import locate_landmark
    >>> bp = locate_landmark("period-doubling", eta=0.99, side="low")
    >>> bp.kind, round(bp.eta, 6)
    ('period-doubling', 0.986317)
    """
    if not isinstance(point, str) or point not in POINTS:
        raise ParameterError("point", str(point)[:40], ", ".join(POINTS))
    theta = check_theta(theta)
    if side not in (None, "low", "high"):
        raise ParameterError("side", str(side), "low or high")
    if side is None:
        if point != "grazing":
            raise ParameterError(
                "side", "none", f"low or high for a {point} (an end of the orbit's interval)"
            )
        return seed_landmark("graze_free", theta, float(eta), R=R)
    try:
        orbit = seed_landmark("orbit", theta, float(eta), int(period), None, R=R)
    except ValueError as e:  # a non-impacting orbit: its grazing is the side=None landmark
        raise ConvergenceError(
            f"the period-{period} orbit at eta = {eta} does not impact ({e}); its grazing: no side"
        ) from e
    end = interval_ends(orbit)[side]
    if end is None:
        raise ConvergenceError(
            f"the period-{period} orbit at eta = {eta} has no {side} end within eta +- 0.06"
        )
    if end[0] != POINTS[point]:
        raise ConvergenceError(
            f"the {side} end of the period-{period} orbit at eta = {eta} is a {end[0]} at "
            f"eta = {end[1]:.10g}, not a {point}"
        )
    bp = end_point(orbit, end)
    if bp is None:
        raise ConvergenceError(
            f"the {side} end at eta = {end[1]:.10g} is a tangential impact: no augmented system"
        )
    return bp
