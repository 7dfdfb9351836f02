"""The one Krawczyk test (analysis/orbits/krawczyk.py) on systems whose zeros are known exactly,
and the dual numbers of balls (core/dual.BallDual) that enclose its Jacobians."""

from __future__ import annotations

import math
from fractions import Fraction

import mpmath
import pytest

from precise_impact.analysis.orbits.krawczyk import krawczyk, newton_points
from precise_impact.core.dual import BALL_DUAL, DUAL, BallDual, seed
from precise_impact.errors import CertificationError
from precise_impact.solvers.certified.single import working_bits

flint = pytest.importorskip("flint")


def _cubic(ys, grad):
    """``x^2 - 2 = 0``, ``y - x^3 = 0``: the zero (sqrt 2, 2 sqrt 2), Jacobian by BallDual."""
    if grad:
        ys = seed(ys, dual=BallDual)
    x, y = ys
    F = [x * x - 2, y - x * x * x]
    if not grad:
        return F, []
    return [f.v for f in F], [list(f.g) for f in F]


def test_the_zero_of_a_known_system_is_proven_and_enclosed():
    with working_bits(256):
        c = newton_points(_cubic, (1.4, 2.8), 256, "cubic")
        K, Y, contraction, inside = krawczyk(_cubic, c, Fraction(1, 10**30), "cubic")
        assert all(inside) and contraction < 1e-20  # K(Y) contracts by ~ r |F''| |C|
        s2 = flint.arb(2).sqrt()
        assert K[0].overlaps(s2) and K[1].overlaps(2 * s2)
        # quadratic contraction: rad K = |I - C F'(Y)| r <= |C| |F''| r^2 (plus 2^-256 roundings)
        # with C = F'(c)^-1 = [[1/(2x), 0], [3x/2, 1]] and |F''| <= 6x on the box (x ~ 1.41):
        # row 1 <= 1 r^2, row 2 <= 3x/2 * 2 + 6x ~ 13 r^2 (r = 1e-30; a plain box would be r)
        assert float(K[0].rad()) <= 1 * 1e-60 and float(K[1].rad()) <= 13 * 1e-60


def test_a_box_too_wide_for_the_zero_does_not_close():
    # Y = 1.4 + [-1, 1] holds x = 0, where the Jacobian 2x is singular: K is not inside Y
    with working_bits(128):
        c = [flint.arb(Fraction(7, 5).numerator) / 5, flint.arb(Fraction(14, 5).numerator) / 5]
        _, _, _, inside = krawczyk(_cubic, c, Fraction(3, 2), "cubic")
    assert not all(inside)


def test_a_double_root_is_refused_not_proven():
    # x^2 = 0: F'(0) = 0, the centre's Jacobian is singular
    def square(ys, grad):
        x = seed(ys, dual=BallDual)[0] if grad else ys[0]
        f = x * x
        return ([f.v], [list(f.g)]) if grad else ([f], [])

    with working_bits(128), pytest.raises(CertificationError, match="singular"):
        krawczyk(square, [flint.arb(0)], Fraction(1, 10**6), "x^2")


def test_ball_duals_enclose_the_float_duals_and_a_50_digit_derivative():
    """The flight formula's derivative in balls (BALL_DUAL) holds mpmath's numerical
    derivative at 50 digits (the same exact constants: 7/10, 1/20) and the float64 dual's
    (DUAL) to its rounding."""

    def f(t, ops):
        c, s = ops.cos_sin(t * 7 / 10)
        return ops.exp(t / -20) * (c * 2 + s) + ops.sqrt(t * t + 1) * ops.pi

    t0 = 1.25  # exact in binary
    with mpmath.workdps(60):
        d = mpmath.diff(
            lambda t: (
                mpmath.exp(-t / 20) * (2 * mpmath.cos(t * 7 / 10) + mpmath.sin(t * 7 / 10))
                + mpmath.sqrt(t * t + 1) * mpmath.pi
            ),
            mpmath.mpf(5) / 4,
        )
        text = mpmath.nstr(d, 50)
    with working_bits(200):
        (tb,) = seed([flint.arb(t0)], dual=BallDual)
        fb = f(tb, BALL_DUAL)
        ref = flint.arb(text)  # parsed at 200 bits
        # the ball (radius ~1e-59) within the 50 printed digits of mpmath's derivative
        assert abs(fb.g[0] - ref).upper() < flint.arb("1e-48")
        assert fb.g[0].rad() < flint.arb("1e-55")
    fd = f(seed([t0])[0], DUAL)
    # float64 dual: a few ulps of the terms' scale (~4 for the value, ~2 for the derivative)
    assert abs(float(fb.g[0].mid()) - fd.g[0]) < 64 * 2**-53 * 4
    assert abs(float(fb.v.mid()) - fd.v) < 64 * 2**-53 * 8
    assert math.isfinite(fd.g[0])


@pytest.mark.parametrize(
    ("bits", "r"),
    [
        (2200, Fraction(1, 2**1100)),  # prove_orbit's default box at 2200 bits: 7e-332
        (4096, Fraction(1, 2**2048)),  # and at 4096: 3e-617
        (2200, Fraction(1, 10**400)),
        (4096, Fraction(1, 10**400)),
    ],
)
def test_boxes_below_the_float_range_are_proven_exactly(bits, r):
    """Issue 35 item 2: the contraction was ``float(...) / float(r)``, a ZeroDivisionError once
    ``r < 1e-308`` (prove_orbit at 2200 bits).  Now an exact rational, checked here against
    the bound of the quadratic contraction, and K against sqrt 2 from mpmath at 1500 digits."""
    from precise_impact.core.precision import log10_fraction
    from precise_impact.solvers.certified.single import exact_value

    with working_bits(bits):
        c = newton_points(_cubic, (1.4, 2.8), bits, "cubic")
        K, _, contraction, inside = krawczyk(_cubic, c, r, "cubic")
        assert all(inside) and isinstance(contraction, Fraction)
        # max |K - c| / r <= (|C F(c)| + rad K) / r: rad K <= 13 r^2 (first test) and the
        # Newton point's residual ~2^-bits, so <= 14 r + 2^(8 - bits) / r, far below 1
        assert 0 < contraction <= 14 * r + Fraction(2**8, 2**bits) / r
        assert log10_fraction(contraction) < -250
        rb = flint.arb(flint.fmpq(r.numerator, r.denominator))
        for k, scale in ((0, 1), (1, 13)):  # rad K as bounded above, in arb, not in floats
            bound = scale * rb * rb + flint.arb(2) ** (8 - bits)
            assert K[k].rad() < bound.lower() and K[k].rad() < flint.arb(10) ** -600
        lo = [exact_value(b.lower()) for b in K]
        hi = [exact_value(b.upper()) for b in K]
    with mpmath.workdps(1500):
        s2 = mpmath.sqrt(2)
        refs = [Fraction(mpmath.nstr(s2, 1500)), Fraction(mpmath.nstr(2 * s2, 1500))]
    err = Fraction(1, 10**1495)  # the 1500 printed digits' rounding
    for q, a, b in zip(refs, lo, hi, strict=True):
        assert a - err <= q <= b + err
