"""The one QR of the tangent space: modified Gram-Schmidt on the 2x2 tangent matrix.

Shared by every Lyapunov computation, so they give the same bits for the same numbers.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from precise_impact.errors import IntegrationError

__all__ = ["gram_schmidt2"]


def gram_schmidt2(a0: Any, a1: Any, b0: Any, b1: Any, sqrt: Callable = math.sqrt):
    """QR of the tangent matrix with columns ``(a0, a1)`` and ``(b0, b1)``.

    Parameters
    ----------
    a0, a1, b0, b1 : float, number or numpy.ndarray
        The two columns (arrays: one matrix per element, e.g. per SIMD lane).
    sqrt : callable, default ``math.sqrt``
        The square root of the number type (``numpy.sqrt`` for arrays and object numbers).

    Returns
    -------
    q0, q1 : the first orthonormal column
    u0, u1 : the second orthonormal column
    r11, r22 : the diagonal of R (``r22 == 0`` where the columns are parallel)

    Notes
    -----
    Where ``r22 == 0`` (a plastic impact, ``R = 0``, collapses the tangent space onto one
    direction: the second exponent is ``-inf``) the second column is re-seeded
    orthogonal to the first, ``(-q1, q0)``, so the first exponent stays well defined.
    """
    if isinstance(a0, np.ndarray) and a0.dtype.kind == "f":
        with np.errstate(over="ignore", under="ignore"):
            r11 = sqrt(a0 * a0 + a1 * a1)
        bad = ~((r11 > _SAFE_LO) & (r11 < _SAFE_HI))
        if bad.any():  # lanes whose squares under- or overflow: the scaled form there only
            with np.errstate(all="ignore"):
                out = _gram_schmidt2_plain(a0, a1, b0, b1, sqrt, r11)
            scaled = _gram_schmidt2_scaled(a0, a1, b0, b1, sqrt)
            return tuple(np.where(bad, sc, o) for sc, o in zip(scaled, out, strict=True))
        return _gram_schmidt2_plain(a0, a1, b0, b1, sqrt, r11)
    r11 = sqrt(a0 * a0 + a1 * a1)
    if isinstance(r11, float) and not _SAFE_LO < r11 < _SAFE_HI:
        return _gram_schmidt2_scaled(a0, a1, b0, b1, sqrt)
    return _gram_schmidt2_plain(a0, a1, b0, b1, sqrt, r11)


#: Column norms outside ``(_SAFE_LO, _SAFE_HI)`` have squares that under- or overflow in
#: float64 (``1.5e-154 ** 2`` is below the smallest normal number): measured, tangent
#: entries of 1e-173 (eta = 0.0039, 8 periods between QRs) gave ``r11 = 0`` and a
#: ZeroDivisionError.  There the columns are scaled by a power of two first (exact).
_SAFE_LO, _SAFE_HI = 1e-150, 1e150


def _gram_schmidt2_plain(a0: Any, a1: Any, b0: Any, b1: Any, sqrt: Callable, r11: Any):
    q0, q1 = a0 / r11, a1 / r11
    proj = q0 * b0 + q1 * b1
    c0, c1 = b0 - proj * q0, b1 - proj * q1
    r22 = sqrt(c0 * c0 + c1 * c1)
    if isinstance(r22, np.ndarray):
        safe = r22 > 0
        den = np.where(safe, r22, 1.0)
        return q0, q1, np.where(safe, c0 / den, -q1), np.where(safe, c1 / den, q0), r11, r22
    if r22 == 0:
        return q0, q1, -q1, q0, r11, r22
    return q0, q1, c0 / r22, c1 / r22, r11, r22


def _gram_schmidt2_scaled(a0: Any, a1: Any, b0: Any, b1: Any, sqrt: Callable):
    """:func:`gram_schmidt2` of the matrix scaled by ``2^-e`` (``2^e`` ~ its largest entry):
    the same ``q``, ``u``; ``r11``, ``r22`` scaled back."""
    big = np.maximum(np.maximum(np.abs(a0), np.abs(a1)), np.maximum(np.abs(b0), np.abs(b1)))
    if np.any(big == 0) or not np.all(np.isfinite(big)):
        raise IntegrationError(
            "the tangent basis is zero or not finite (under- or overflow of the tangent "
            "flow between two re-orthonormalisations): the Lyapunov exponents cannot be "
            "resolved here"
        )
    f = np.ldexp(1.0, -np.frexp(big)[1])
    if isinstance(a0, float):
        f = float(f)
    a0, a1, b0, b1 = a0 * f, a1 * f, b0 * f, b1 * f
    r11 = sqrt(a0 * a0 + a1 * a1)
    q0, q1, u0, u1, r11, r22 = _gram_schmidt2_plain(a0, a1, b0, b1, sqrt, r11)
    return q0, q1, u0, u1, r11 / f, r22 / f
