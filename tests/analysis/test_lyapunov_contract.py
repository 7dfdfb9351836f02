"""Every Lyapunov method on every engine (``LYAPUNOV_ENGINES``, the registry) against exact values.

* A non-impacting orbit is the linear damped oscillator: LLE = -zeta exactly.
* The exponents sum to -2 zeta + (impact rate) ln R^2 on any orbit, chaotic included
  (det of the flow is exp(-2 zeta tau), det of a saltation matrix R^2): checked per start on the
  chaotic attractor with R = 0.8, where a dropped impact or a wrong saltation matrix shows.
* A periodic orbit's finite-time LLE converges to ln|mu_max| / T of the orbit found by Newton's
  method (an independent algorithm: the stroboscopic map's fixed point and its Jacobian).
"""

from __future__ import annotations

import math

import pytest

import precise_impact as pi
from helpers import (
    EPS,
    ETA_CHAOTIC,
    ETA_PERIOD3,
    exponent_sum,
    forcing_period,
    non_impacting,
    paper,
)

ENGINES = list(pi.LYAPUNOV_ENGINES)
IDS = [f"{m}-{e}" for m, e in ENGINES]


def test_the_registry_is_what_is_tested():
    assert {m for m, _ in ENGINES} == set(pi.LYAPUNOV_METHODS)
    assert {e for _, e in ENGINES} == {"heyoka", "fast"}


@pytest.mark.parametrize("method, model", ENGINES, ids=IDS)
def test_non_impacting_lle_is_minus_zeta(method, model):
    """The finite-time estimate of a linear flow with complex eigenvalues is -zeta + O(1/t); the
    package reports the exact Floquet value on a periodic attractor: -zeta to a few ulps
    (|-0.05| has ulp 6.9e-18; 64 ulps allow for the log and division of the Floquet value)."""
    p = non_impacting()
    r = pi.lyapunov(p, method=method, model=model)
    assert abs(r.lle + float(p.zeta)) <= 64 * EPS * float(p.zeta)


@pytest.mark.parametrize(
    "method, model",
    [e for e in ENGINES if e[0] != "two-trajectory"],
    ids=[i for i, e in zip(IDS, ENGINES, strict=True) if e[0] != "two-trajectory"],
)
def test_exponents_sum_to_the_exact_volume_rate_on_chaos(method, model):
    """Two-exponent methods, chaotic eta = 0.712 with R = 0.8 (impacts change the volume).
    Rounding: each of the ~1e4 flights and QRs perturbs ln det by a few eps (|ln det| per step
    <= ~2), so the log-sum errs by <= 1e5 * 4 * eps ~ 1e-10 over t >= 4e4 time units: 1e-14
    on the rate, far below the 0.0446 a single dropped impact per 1e3 periods would shift."""
    p = paper(ETA_CHAOTIC, R="0.8")
    r = pi.lyapunov(p, method=method, model=model, attractors=False)
    T = forcing_period(p)
    per_start = r.stats.get("per_start")
    if per_start:  # ensemble: each start ran periods / starts periods
        n = len(per_start)
        for s in per_start:
            t = r.periods / n * T
            total = s["lle"] + s["lambda2"]
            assert abs(total - exponent_sum(p, s["impacts"], t)) < 1e-13, s
    else:
        t = r.periods * T
        assert abs(sum(r.spectrum) - exponent_sum(p, r.n_impacts, t)) < 1e-13


@pytest.mark.parametrize("method, model", ENGINES, ids=IDS)
def test_periodic_finite_time_lle_converges_to_the_floquet_value(method, model):
    """Period 3 at eta = 0.74 (R = 0.8): the finite-time estimate (attractor identification off,
    so the integrator itself is tested) lies within its stated error bar of ln|mu_max| / (3 T)
    from the Newton-refined orbit."""
    p = paper(ETA_PERIOD3, R="0.8")
    orbit = pi.find_orbit(p, 3)
    exact = math.log(max(abs(m) for m in orbit.multipliers)) / (3 * forcing_period(p))
    assert abs(exact - orbit.lle) < 1e-14
    kw = {} if method == "two-trajectory" else {"attractors": False}
    r = pi.lyapunov(p, method=method, model=model, **kw)
    assert abs(r.lle - exact) <= 4 * r.lle_stderr + 1e-12, (r.lle, exact, r.lle_stderr)
