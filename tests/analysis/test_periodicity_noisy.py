"""Periods of measured (noisy) stroboscopic sequences: detect_period_noisy."""

from __future__ import annotations

import numpy as np
import pytest

import precise_impact as pi
from precise_impact.analysis.periodicity import detect_period, detect_period_noisy
from precise_impact.errors import ParameterError


@pytest.fixture(scope="session")
def strobes():
    out = {}
    for eta in ("0.74", "0.712"):
        tr = pi.simulate(pi.Params.make(eta=eta), 300, model="fast")
        f = tr.as_float64()
        out[eta] = (f["x"][100:], f["v"][100:])
    return out


@pytest.mark.parametrize("noise", [0.003, 0.03, 0.1])
def test_period_3_found_and_chaos_never_periodic(strobes, noise):
    rng = np.random.default_rng(5)
    for eta, want in (("0.74", 3), ("0.712", 0)):
        x, v = strobes[eta]
        xn = x + noise * rng.normal(size=len(x))
        vn = v + noise * rng.normal(size=len(v))
        assert detect_period_noisy(xn, vn, noise, noise, max_period=16) == want, (eta, noise)


def test_a_relative_tolerance_wide_enough_for_the_noise_fakes_a_period(strobes):
    # what the chi-square test replaces: every point within 6 sigma sqrt 2 of its p-th
    # predecessor (scaled by 1 + |x| + |v|) calls the chaos at 0.712 periodic at 10 % noise
    # ('period 1' or 'period 3' depending on the chaotic record: any period is a fake one)
    x, v = strobes["0.712"]
    rng = np.random.default_rng(5)
    xn, vn = x + 0.1 * rng.normal(size=len(x)), v + 0.1 * rng.normal(size=len(v))
    assert detect_period(xn, vn, max_period=16, rtol=6 * 2**0.5 * 0.1) > 0
    assert detect_period_noisy(xn, vn, 0.1, 0.1, max_period=16) == 0


def test_short_records_and_bad_noise():
    xs = np.tile([0.1, 0.7, -0.4], 2)  # 6 points: period 3 needs 9
    assert detect_period_noisy(xs, xs, 0.01, 0.01) == 0
    with pytest.raises(ParameterError):
        detect_period_noisy(xs, xs, 0.0, 0.01)


@pytest.mark.parametrize("bad", [float("inf"), float("nan"), -0.01, 0.0, "x"])
@pytest.mark.parametrize("which", ["sigma_x", "sigma_v"])
def test_non_finite_or_negative_noise_is_refused(bad, which):
    # sigma = inf made every chi2 zero: any sequence, chaos included, came out 'period 1'
    xs = np.tile([0.1, 0.7, -0.4], 20)
    kw = {"sigma_x": 0.01, "sigma_v": 0.01, which: bad}
    with pytest.raises(ParameterError) as e:
        detect_period_noisy(xs, xs, **kw)
    assert e.value.name == which and "finite" in e.value.allowed and "> 0" in e.value.allowed
