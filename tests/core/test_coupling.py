"""The master-slave coupling (core/coupling.py), the one set of formulas every pair engine uses.

Independent references: the error equation derived from the slave equations themselves in
exact rational arithmetic (``e = y - x`` must obey ``e'' + c1 e' + c0 e = 0`` whatever the
state), the slave reset from the impact law of each form's own variables, and the numba
copies of the compiled pair engine pinned to the core functions bit for bit.
"""

from __future__ import annotations

import random
from fractions import Fraction

import pytest

from precise_impact.core.coupling import (
    COUPLED_FORMS,
    FORM_IDS,
    error_coefficients,
    slave_derivative,
    slave_position_rate,
    slave_reset,
    slave_rhs,
    slave_velocity,
)
from precise_impact.core.flow import acceleration

RNG = random.Random(2023)


def _q():
    """A random rational in [-2, 2] with a small denominator."""
    return Fraction(RNG.randint(-200, 200), RNG.randint(1, 97))


@pytest.mark.parametrize("form", COUPLED_FORMS)
def test_the_error_equation_follows_from_the_slave_equations(form):
    """Exact arithmetic at 40 random states: ``e'' = -c1 e' - c0 e`` with ``(c1, c0)`` from
    :func:`error_coefficients` and ``e''`` computed from :func:`slave_rhs` and the master's
    :func:`acceleration` (the forcing cancels; any value of ``cos`` will do)."""
    for _ in range(40):
        t, x, v, y, w = (_q() for _ in range(5))
        eta, zeta, a, k = abs(_q()) + 1, abs(_q()) / 4, _q(), abs(_q())
        c = Fraction(RNG.randint(-9, 9), 10)

        def cos(_z, c=c):
            return c

        xdd = acceleration(t, x, v, eta, zeta, a, cos)
        dy, dw = slave_rhs(form, t, x, v, y, w, eta, zeta, a, k, cos)
        assert dy == slave_position_rate(form, x, y, w, k)
        if form == "first-order":  # y1' = y2 + k (x - y1): y'' = y2' + k (x' - y1')
            ydd = dw + k * (v - dy)
        else:
            ydd = dw
        e, ep, epp = y - x, dy - v, ydd - xdd
        c1, c0 = error_coefficients(form, zeta, k)
        assert epp == -c1 * ep - c0 * e
        # the velocity variable and y' convert both ways
        assert slave_derivative(form, k, e, w) == dy
        assert slave_velocity(form, k, e, dy) == w


def test_the_error_coefficients_differ_between_the_forms():
    z, k = Fraction(1, 20), Fraction(1, 10)
    assert error_coefficients("first-order", z, k) == error_coefficients("reduced", z, k)
    assert error_coefficients("paper", z, k) == (Fraction(1, 10) + k * Fraction(11, 10), 1 + 2 * k)
    assert error_coefficients("reduced", z, k) == (Fraction(3, 10), 1 + 2 * z * k + k * k)


@pytest.mark.parametrize("form", COUPLED_FORMS)
def test_the_slave_reset_flips_the_forms_own_velocity(form):
    """'first-order' flips y2, 'paper' flips y', 'reduced' flips y2 = y' - k (x - x_w) and
    converts back; the slave position rate after the impact is -R times the one before."""
    for _ in range(20):
        x, w, k, R, xw = _q(), _q(), abs(_q()), Fraction(RNG.randint(0, 10), 10), _q()
        wa = slave_reset(form, x, w, R, k, xw)
        if form == "reduced":
            assert wa - k * (x - xw) == -R * (w - k * (x - xw))
        else:
            assert wa == -R * w
        if form != "reduced":  # the rate at y = x_w: w + k (x - x_w) for 'first-order'
            rate_b = slave_position_rate(form, x, xw, w, k)
            rate_a = slave_position_rate(form, x, xw, wa, k)
            assert rate_a == -R * w + (k * (x - xw) if form == "first-order" else 0)
            assert rate_b == w + (k * (x - xw) if form == "first-order" else 0)


def test_the_numba_copies_are_the_core_formulas():
    """solvers/fast/coupled keeps compiled copies (numba cannot call the generic Python): each
    equals the core function bit for bit on 300 random float states per form."""
    pytest.importorskip("numba")
    from precise_impact.solvers.fast.coupled import (
        compiled_slave_derivative,
        compiled_slave_reset,
        compiled_slave_velocity,
    )
    from precise_impact.solvers.fast.coupled import error_coefficients as fast_coefficients

    assert fast_coefficients is error_coefficients
    mismatches = []
    for form in COUPLED_FORMS:
        fid = FORM_IDS[form]
        for _ in range(300):
            x, w, e, yd, xw = (RNG.uniform(-3, 3) for _ in range(5))
            k, R = RNG.uniform(0, 5), RNG.uniform(0, 1)
            pairs = [
                (compiled_slave_velocity(fid, k, e, yd), slave_velocity(form, k, e, yd)),
                (compiled_slave_derivative(fid, k, e, w), slave_derivative(form, k, e, w)),
                (compiled_slave_reset(fid, R, k, x, xw, w), slave_reset(form, x, w, R, k, xw)),
            ]
            mismatches += [(form, a, b) for a, b in pairs if a != b]
    assert not mismatches, mismatches[:5]
