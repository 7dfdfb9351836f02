"""Validation of every input rule, and exact conversion into every precision."""

from __future__ import annotations

from decimal import Decimal
from fractions import Fraction

import mpmath
import pytest
from hypothesis import given
from hypothesis import strategies as st

from precise_impact import ParameterError, Params, Precision, simulate
from precise_impact.core.params import decimal_str


@pytest.mark.parametrize(
    "values, name, phrase",
    [
        ({"zeta": "-0.01"}, "zeta", "0 <= zeta <= 1000"),
        ({"eta": "0"}, "eta", "0.001 <= eta <= 1000"),
        ({"eta": "-0.7"}, "eta", "0.001 <= eta <= 1000"),
        ({"R": "1.5"}, "R", "0 <= R <= 1"),
        ({"R": "-0.1"}, "R", "0 <= R <= 1"),
        ({"x0": "2.0001"}, "x0", "x0 <= x_w"),
        ({"x0": "3", "x_w": "2.5"}, "x0", "x0 <= x_w = 2.5"),
        ({"a": "nan"}, "a", "finite"),
        ({"a": "inf"}, "a", "finite"),
        ({"v0": float("nan")}, "v0", "finite"),
        ({"t0": float("-inf")}, "t0", "finite"),
        ({"x_w": Decimal("Infinity")}, "x_w", "finite"),
        ({"eta": "abc"}, "eta", "decimal number"),
        ({"eta": True}, "eta", "boolean"),
        ({"eta": [0.7]}, "eta", "got list"),
        ({"omega": "1"}, "omega", "unknown parameter"),
    ],
)
def test_every_rule_has_a_clear_error(values, name, phrase):
    with pytest.raises(ParameterError) as e:
        Params.make(**values)
    assert e.value.name == name
    assert name in str(e.value) and phrase in str(e.value)


@pytest.mark.parametrize(
    "spec, phrase",
    [
        ("float32", "'float64', 'longdouble'"),
        ("mp:32", "BITS >= 64"),
        ("mp:x", "mp:BITS"),
        (53, "mp:BITS"),
    ],
)
def test_precision_errors(spec, phrase):
    with pytest.raises(ParameterError) as e:
        Precision.parse(spec)
    assert e.value.name == "precision" and phrase in str(e.value)


def test_bad_run_arguments_fail_before_work():
    for kwargs, name in [
        ({"periods": -1}, "periods"),
        ({"periods": 2.5}, "periods"),
        ({"model": "rk4"}, "model"),
        ({"tol": "0"}, "tol"),
        ({"tol": "2"}, "tol"),
        ({"model": "analytical", "tol": "1e-10"}, "tol"),
        ({"model": "analytical", "precision": "float128"}, "precision"),
    ]:
        with pytest.raises(ParameterError) as e:
            simulate(Params.make(), **{"periods": 1, **kwargs})
        assert e.value.name == name


def test_defaults_are_the_papers():
    p = Params.make()
    assert p.decimal() == {
        "zeta": "0.05",
        "a": "1",
        "eta": "0.712",
        "x_w": "2",
        "R": "1",
        "x0": "0",
        "v0": "0",
        "t0": "0",
    }


def test_values_are_exact_decimals():
    """0.712 given as a float means the decimal 0.712, not its binary approximation."""
    assert Params.make(eta=0.712).eta == Fraction(712, 1000)
    assert Params.make(eta="0.712").eta == Fraction(89, 125)
    assert Params.make(eta=Decimal("0.712")).eta == Fraction(89, 125)
    assert Params.make(x_w="102/53").x_w == Fraction(102, 53)
    assert decimal_str(Fraction(1, 3)) == "1/3" and decimal_str(Fraction(-5, 4)) == "-1.25"


@pytest.mark.parametrize(
    "spec", ["float64", "longdouble", "float128", "mp:64", "mp:237", "mp:1000"]
)
@given(num=st.integers(-(10**30), 10**30), den=st.integers(1, 10**30))
def test_conversion_is_one_correct_rounding(spec, num, den):
    """from_fraction(q) is the nearest number of the precision: |x - q| <= ulp/2.

    Independent reference: exact rational arithmetic (Fraction), not floats.
    """
    P = Precision.parse(spec)
    q = Fraction(num, den)
    x = P.to_fraction(P.from_fraction(q))
    if q == 0:
        assert x == 0
        return
    # ulp of the binade containing q, at the precision's significand width
    e = abs(q).numerator.bit_length() - abs(q).denominator.bit_length()
    if Fraction(2) ** e > abs(q):
        e -= 1
    half_ulp = Fraction(2) ** (e - P.bits)
    assert abs(x - q) <= half_ulp
    # and the printed string round-trips exactly
    assert P.to_fraction(P.from_decimal(P.to_str(P.from_fraction(q)))) == x


def test_multiprecision_pins_eta_to_1e70_at_237_bits():
    """heyoka real at 237 bits holds 0.712 to 2^-237 ~ 4e-72 relative (heyoka.py test style)."""
    P = Precision.parse("mp:237")
    with mpmath.workprec(500):
        assert abs(P.to_mpf(P.from_decimal("0.712")) - mpmath.mpf(89) / 125) < mpmath.mpf("1e-70")
        assert (
            abs(P.to_mpf(P.from_decimal("0.712")) - mpmath.mpf(89) / 125) > 0
        )  # not exact in binary


def test_sample_times_are_correctly_rounded():
    P = Precision.parse("float64")
    ts = P.sample_times(Fraction(0), Fraction(89, 125), 1000)
    with mpmath.workprec(200):
        T = 2 * mpmath.pi * 125 / 89
        for k in (1, 10, 999, 1000):
            assert ts[k] == float(mpmath.mpf(k) * T)
