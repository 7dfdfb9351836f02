"""An independent cross-check of the identification: PySINDy (Brunton, Proctor and Kutz, PNAS
113, 3932, 2016; de Silva et al., JOSS 5, 2104, 2020) on the flights between the impacts.

Between impacts the oscillator is linear, ``x' = v``, ``v' = -x - 2 zeta v + a cos(eta tau -
phase)``: a sparse regression of the states' derivatives on the library ``(1, x, v, cos, sin)``
recovers its coefficients without the closed form, the multiple shooting or the impact model.
Its accuracy is its derivative's: the second-order finite difference on a grid of h = 2 pi /
(100 eta) errs by ~h^2 / 6 ~ 7e-4 relative, and the impacts' neighbourhoods are cut out.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from precise_impact.lab.identify import identify
from precise_impact.lab.synth import synth_capture

ps = pytest.importorskip("pysindy", reason="pip install 'precise_impact[test]' (pysindy)")

SCENE = "fig6-period3-ideal"
ETA = 0.74
#: Samples left out on each side of an impact (the finite difference must not straddle one).
GUARD = 3


def _flights(cap):
    """The noise-free record in the oscillator's variables, cut at its impacts: one
    ``(states, forcing)`` pair per flight (forcing columns ``cos, sin`` of ``Omega t``)."""
    tr = cap.source["truth"]
    # the forcing in the file's time base (phase 0 at t = 0), as the identification reports it
    m = cap.to_mechanical(SCENE, tr["forcing_omega_rad_s"], 0.0)
    cut = np.searchsorted(cap.t, tr["impacts_t"])
    edges = [0, *cut.tolist(), len(cap.t)]
    out = []
    for lo, hi in zip(edges[:-1], edges[1:], strict=True):
        lo, hi = lo + GUARD, hi - GUARD
        if hi - lo > 20:
            u = np.column_stack([np.cos(m.phase[lo:hi]), np.sin(m.phase[lo:hi])])
            out.append((np.column_stack([m.x[lo:hi], m.v[lo:hi]]), u))
    return out, float(m.tau[1] - m.tau[0])


def test_sindy_on_the_flights_recovers_the_identified_linear_coefficients():
    """40 noise-free periods of the period-3 orbit: SINDy's ``v'`` row equals ``-x - 2 zeta v
    + a cos(phase)`` of the identification (both from the same record) within SINDy's
    finite-difference accuracy, and its ``x'`` row is ``v``."""
    cap = synth_capture(SCENE, periods=40, bits=0, noise=0.0, seed=1,
                        sample_rate=100 * ETA * 1000 / (2 * math.pi))  # fmt: skip
    r = identify(cap, SCENE)
    flights, dt = _flights(cap)
    lib = ps.PolynomialLibrary(degree=1)
    model = ps.SINDy(feature_library=lib, optimizer=ps.STLSQ(threshold=1e-3),
                     differentiation_method=ps.FiniteDifference(order=2))  # fmt: skip
    model.fit([f for f, _ in flights], t=dt, u=[u for _, u in flights])
    names = model.get_feature_names()  # 1, x0, x1, u0, u1
    coef = dict(zip(names, model.coefficients()[1], strict=True))
    xdot = dict(zip(names, model.coefficients()[0], strict=True))
    zeta, a, phase = r.value("zeta"), r.value("a"), r.value("phase")
    # SINDy's own accuracy: ~1e-3 relative on the O(1) terms (h^2 / 6 with the cut ends)
    assert abs(xdot["x1"] - 1) < 2e-3 and max(abs(xdot[k]) for k in ("x0", "u0", "u1")) < 2e-3
    assert abs(coef["x0"] + 1) < 3e-3, coef
    assert abs(-coef["x1"] / 2 - zeta) < 2e-3, (coef, zeta)
    # the forcing a cos(phase_t - phase) = a cos(phase) cos + a sin(phase) sin
    assert abs(coef["u0"] - a * math.cos(phase)) < 3e-3, (coef, a, phase)
    assert abs(coef["u1"] - a * math.sin(phase)) < 3e-3, (coef, a, phase)
    assert abs(-coef["x1"] / 2 - 0.05) < 2e-3  # and both are the truth
