"""Krawczyk's test in python-flint balls: the one interval Newton of the package's proofs.

``K(Y) = c - C F(c) + (I - C F'(Y)) (Y - c)`` inside the interior of ``Y`` proves exactly one
zero of ``F`` in ``Y``; used by :func:`~precise_impact.analysis.orbits.proof.prove_orbit` and
:func:`~precise_impact.analysis.orbits.proof_landmarks.prove_landmark`.  Reference: Krawczyk
1969; Moore, Kearfott, Cloud, *Introduction to Interval Analysis*, SIAM 2009, sec. 8.2.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from fractions import Fraction
from typing import Any

from precise_impact.errors import CertificationError
from precise_impact.solvers.certified.single import exact_value, to_ball

__all__ = ["point_inverse", "newton_points", "krawczyk"]

#: ``fun(ys, grad) -> (F, J)``: ``F(ys)`` as balls, and with ``grad`` the Jacobian enclosed
#: over the balls ``ys`` (rows of balls).
Residual = Callable[[list, bool], tuple[list, list]]


def point_inverse(J: list, what: str) -> Any:
    """``C``: the midpoint matrix's inverse rounded to points (any ``C`` is valid in Krawczyk's
    operator; a near-inverse makes it contract); :class:`CertificationError` naming ``what``
    when the midpoint matrix is singular (a degenerate zero)."""
    import flint  # noqa: PLC0415 -- heavy: python-flint ~0.1 s, loaded on first proof

    mid = flint.arb_mat([[x.mid() for x in row] for row in J])
    try:
        inv = mid.inv()
    except ZeroDivisionError as e:
        raise CertificationError(
            f"{what}: the Jacobian of the system is singular (a degenerate point: "
            "not a regular zero): no proof"
        ) from e
    m = len(J)
    C = flint.arb_mat([[inv[i, j].mid() for j in range(m)] for i in range(m)])
    if not all(C[i, j].is_finite() for i in range(m) for j in range(m)):  # pragma: no cover
        raise CertificationError(f"{what}: the Jacobian's inverse is not finite: no proof")
    return C


def newton_points(fun: Residual, y0: Any, bits: int, what: str) -> list:
    """A float64 zero ``y0`` refined by Newton on points to ``bits`` (exact ball centres)."""
    import flint  # noqa: PLC0415 -- heavy: python-flint ~0.1 s, loaded on first proof

    y = [to_ball(Fraction(float(v))) for v in y0]
    # quadratic from ~1e-16: log2(bits / 50) + 3 steps reach the working precision, one more
    # for a start a few ulps off
    for _ in range(int(math.log2(max(bits, 64) / 50)) + 4):
        F, J = fun(y, True)
        C = point_inverse(J, what)
        dy = C * flint.arb_mat([[f] for f in F])
        y = [flint.arb((y[i] - dy[i, 0]).mid()) for i in range(len(y))]
    return y


def krawczyk(fun: Residual, c: list, r: Fraction, what: str) -> tuple[list, list, Fraction, list]:
    """Krawczyk's operator on ``Y = c + [-r, r]^m``.

    Returns ``(K, Y, contraction, inside)``: the operator's balls, the box, ``max |K - c| / r``
    (an exact rational: it is ``~r`` itself, 1e-331 at 2200 bits, below the float range)
    and, per unknown, whether ``K`` lies in the interior of ``Y`` (all true: the proof).
    """
    import flint  # noqa: PLC0415 -- heavy: python-flint ~0.1 s, loaded on first proof

    m = len(c)
    rb = to_ball(r).upper()
    Y = [ci + flint.arb(0, rb) for ci in c]
    Fc, Jc = fun(c, True)
    C = point_inverse(Jc, what)
    _, JY = fun(Y, True)
    eye = flint.arb_mat([[int(i == j) for j in range(m)] for i in range(m)])
    B = eye - C * flint.arb_mat(JY)
    dY = flint.arb_mat([[flint.arb(0, rb)] for _ in range(m)])
    Kc = C * flint.arb_mat([[f] for f in Fc])
    KB = B * dY
    K = [c[i] - Kc[i, 0] + KB[i, 0] for i in range(m)]
    # exactly, in rationals: float(r) was 0.0 below 1e-308 (a ZeroDivisionError at 2200 bits)
    contraction = max(exact_value(abs(K[i] - c[i]).upper()) for i in range(m)) / r
    inside = [bool(Y[i].contains_interior(K[i])) for i in range(m)]
    return K, Y, contraction, inside
