"""The one QR of the tangent space: modified Gram-Schmidt on the 2x2 tangent matrix.

Shared by every Lyapunov computation, so they give the same bits for the same numbers.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

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
    r11 = sqrt(a0 * a0 + a1 * a1)
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
