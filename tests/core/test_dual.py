"""Forward-mode dual numbers: derivatives exact to rounding, through the closed-form flight."""

from __future__ import annotations

import math

import numpy as np
import pytest

from precise_impact.core import flight
from precise_impact.core.dual import DUAL, Dual, seed


def test_elementary_derivatives_match_analytic():
    (x,) = seed([0.7])
    cases = [
        (DUAL.exp(x) * DUAL.sin(x), math.exp(0.7) * (math.sin(0.7) + math.cos(0.7))),
        (1 / (x * x + 1), -2 * 0.7 / (0.7**2 + 1) ** 2),
        (DUAL.sqrt(x) - DUAL.cos(3 * x), 0.5 / math.sqrt(0.7) + 3 * math.sin(2.1)),
        ((2 - x) / x, -2 / 0.7**2),
        (x**1.5, 1.5 * 0.7**0.5),
    ]
    for d, want in cases:
        assert d.g[0] == pytest.approx(want, rel=4e-16, abs=0)


def test_flight_in_duals_equals_float_and_its_derivative_the_flow_matrix():
    """d(x, v)(t) / d(x0, v0) of a flight is Phi(t - s): the dual evaluation of the closed form
    gives the flow matrix to rounding, and the values bit for bit as in float64."""
    eta, zeta, a = 0.74, 0.05, 1.0
    P, Q = flight.steady_coefficients(eta, zeta, a)
    wd = flight.damped_frequency(zeta, flight.FLOAT)
    x0, v0 = seed([1.3, -0.4])
    fd = flight.Flight(P, Q, eta, zeta, wd, DUAL, 0.2, x0, v0)
    ff = flight.Flight(P, Q, eta, zeta, wd, flight.FLOAT, 0.2, 1.3, -0.4)
    xd, vd = fd.at(5.0)
    xf, vf = ff.at(5.0)
    assert (xd.v, vd.v) == (xf, vf)
    phi = np.array(flight.flow_matrix(4.8, zeta, wd, flight.FLOAT)).reshape(2, 2)
    np.testing.assert_allclose(np.array([xd.g, vd.g]), phi, rtol=1e-14, atol=1e-16)


def test_comparisons_use_the_value():
    a, b = Dual(1.0, np.ones(1)), Dual(2.0, np.zeros(1))
    assert a < b and b > 1 and a == 1.0 and a != b
