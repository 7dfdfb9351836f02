"""``Precision.floats`` (arrays to float64) equals ``to_float`` element by element, bit for bit,
in every precision: one rounding to nearest (numpy's for float64 and long double, mpmath's
exact values for the others), ties included."""

from __future__ import annotations

import random
from decimal import Decimal, localcontext

import numpy as np
import pytest

from precise_impact.core.precision import Precision

KINDS = ["float64", "longdouble", "float128", "mp:128"]


def _exact(k: int) -> str:
    """``1 + k 2^-53`` as an exact decimal (a tie between two float64s for odd ``k``)."""
    with localcontext() as c:
        c.prec = 80
        return str(Decimal(1) + k * Decimal(2) ** -53)


def _values(P: Precision) -> list:
    rng = random.Random(7)
    decimals = [f"{rng.uniform(-3, 3):.30f}" for _ in range(200)]
    decimals += ["0", "-0.5", "1e-300", "123456789.123456789123456789"]
    vals = [P.from_decimal(d) for d in decimals]
    if P.kind in ("longdouble", "float128", "mp"):  # exact ties between two float64s
        vals += [P.from_decimal(_exact(1)), P.from_decimal(_exact(3))]
    return vals


@pytest.mark.parametrize("kind", KINDS)
def test_floats_is_to_float_element_by_element(kind):
    P = Precision.parse(kind)
    vals = _values(P)
    one = np.array([P.to_float(v) for v in vals])
    many = P.floats(P.array(vals))
    assert many.dtype == np.float64
    assert np.array_equal(one.view(np.int64), many.view(np.int64))  # bit for bit (signed zeros)


def test_ties_round_to_even():
    P = Precision.parse("mp:128")
    got = P.floats(P.array([P.from_decimal(_exact(1)), P.from_decimal(_exact(3))]))
    assert got[0] == 1.0 and got[1] == 1 + 4 * 2.0**-53  # halfway: to the even neighbour


@pytest.mark.parametrize("kind", KINDS)
def test_floats_of_nothing(kind):
    P = Precision.parse(kind)
    assert P.floats(None).shape == (0,) and P.floats(P.array([])).shape == (0,)
