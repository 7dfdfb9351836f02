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
