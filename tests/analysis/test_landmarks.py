"""The augmented branch-point systems share their equations with continuation's shooting
system, and locate the landmarks continuation finds."""

from __future__ import annotations

import numpy as np
import pytest

from precise_impact.analysis.orbits.landmarks import BranchPoint, seed_landmark
from precise_impact.analysis.orbits.shooting import ShootingSystem
from precise_impact.core import flight

THETA = (0.05, 1.0, 2.0)


def test_orbit_equations_are_the_shooting_systems():
    """The first 2n equations of a BranchPoint are ShootingSystem.residual (same closed
    forms: equal to rounding) and its dual Jacobian is ShootingSystem's exact one."""
    o = seed_landmark("orbit", THETA, 0.74, 3, None)
    n = o.impacts
    sysm = ShootingSystem(
        {"eta": 0.74, "zeta": 0.05, "a": 1.0, "x_w": 2.0, "R": 1.0, "t0": 0.0}, "eta", 3, n
    )
    u = o.y[: 2 * n] + 1e-3  # off the orbit: residuals of size 1e-3
    G, J = sysm.residual(u, 0.74, jacobian=True)
    F = o.residual(list(np.append(u, 0.74)), list(THETA), flight.FLOAT)
    np.testing.assert_allclose(F[: 2 * n], G, rtol=0, atol=1e-14)
    _, Fy, _ = o.jacobian(np.append(u, 0.74))
    np.testing.assert_allclose(Fy[: 2 * n, : 2 * n], J, rtol=1e-12, atol=1e-13)


def test_fig6_orbit_is_stable_admissible_and_its_states_are_find_orbits():
    import precise_impact as pi

    o = seed_landmark("orbit", THETA, 0.74, 3, None)
    assert o.impacts == 2 and o.stable() and o.admissible()
    ref = pi.find_orbit(pi.Params.make(eta="0.74"), 3)
    assert np.ravel(ref.x)[0] == pytest.approx(o.states()[0][0], abs=1e-10)


def test_bad_kind():
    with pytest.raises(ValueError):
        seed_landmark("cusp", THETA, 0.74)
    with pytest.raises(ValueError):  # a period-doubling needs an impacting orbit's equations
        BranchPoint("period-doubling", 1, 0, np.zeros(3), np.array(THETA))
