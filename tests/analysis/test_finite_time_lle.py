"""The finite-time LLE of a recorded stretch (tangent map along recorded impacts) against exact
values: ``-zeta`` without impacts, ``ln|mu_max| / T`` of a periodic orbit's Newton monodromy
(another method), and the record truth of synthetic captures."""

from __future__ import annotations

import math

import numpy as np
import pytest

import precise_impact as pi
from precise_impact import finite_time_lle
from precise_impact.errors import ParameterError


def test_no_impacts_is_minus_zeta():
    # the homogeneous flow alone: sigma_max(Phi(t)) = exp(-zeta t) times the norm of a bounded
    # rotation-like matrix (cos + zeta sin / wd ...: its log below 1 for zeta <= 0.5, measured
    # 0.54), so the exponent is -zeta to 1 / t
    for zeta in ("0", "0.05", "0.5"):
        p = pi.Params.make(eta="0.712", zeta=zeta)
        got = finite_time_lle(p, [], [], 0.0, 1e5)
        assert got == pytest.approx(-float(zeta), abs=1.0 / 1e5), (zeta, got)


@pytest.mark.parametrize(("eta", "R", "period"), [("0.74", "1", 3), ("1.3", "0.8", 1)])
def test_periodic_orbit_gives_its_floquet_exponent(eta, R, period):
    # on a stable periodic orbit the tangent map of N forcing periods is M^(N/period):
    # ln sigma_max(M^k) = k ln|mu_max| + O(ln cond(eigenvectors)), so the finite-time exponent
    # is ln|mu_max| / T to 1 / (duration) (the eigenvector condition's log measured 0.3)
    p = pi.Params.make(eta=eta, R=R)
    orbit = pi.find_orbit(p, period)
    tr = pi.simulate(p, periods=3000, model="fast")
    f = tr.as_float64()
    T = 2 * math.pi / float(eta)
    t0, t1 = 1000 * T, 3000 * T  # 1000 periods of transient: the orbit is reached
    got = finite_time_lle(p, f["impacts_t"], f["impacts_v_before"], t0, t1)
    assert tr.n_impacts > 1000
    assert got == pytest.approx(float(orbit.lle), abs=1.0 / (t1 - t0)), (got, orbit.lle)


def test_chaotic_stretches_scatter_about_the_asymptotic_exponent():
    # 200-period stretches of one fast trajectory at eta = 0.712: their mean is the asymptotic
    # LLE (0.0304) within the scatter of a mean of 10 (~11 % / sqrt(10) -> 3 sigma = 11 %)
    p = pi.Params.make(eta="0.712")
    tr = pi.simulate(p, periods=2100, model="fast")
    f = tr.as_float64()
    T = 2 * math.pi / 0.712
    vals = [
        finite_time_lle(
            p, f["impacts_t"], f["impacts_v_before"], (100 + 200 * k) * T, (300 + 200 * k) * T
        )  # fmt: skip
        for k in range(10)
    ]
    assert np.mean(vals) == pytest.approx(0.0304, rel=0.11)
    assert 0.03 < np.std(vals) / np.mean(vals) < 0.3  # they do scatter (measured ~11 %)


def test_synthetic_capture_records_its_stretchs_exponent():
    cap = pi.synth_capture("fig6-period3-ideal", model="circuit", eta="0.712", periods=50,
                           transient=20, channels=("V_s", "V_q"))  # fmt: skip
    ft = cap.source["truth"]["lle_record"]
    assert ft is not None and 0.0 < ft < 0.1
    sc = pi.synth_capture("fig6-period3-ideal", model="switched-capacitor", eta="0.712",
                          periods=20, transient=5, channels=("V_s", "V_q"))  # fmt: skip
    assert sc.source["truth"]["lle_record"] is None  # not the mechanics: no truth claimed


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"params": {"zeta": "1.5"}}, "zeta"),
        ({"t_end": 0.0}, "t_end"),
        ({"t_end": math.nan}, "t_end"),
        ({"impacts_v_before": [1.0, 2.0]}, "impacts_v_before"),
        ({"impacts_v_before": [-0.1]}, "impacts_v_before"),
    ],
)
def test_bad_input_names_the_parameter(kwargs, name):
    kw = {"params": {}, "impacts_t": [5.0], "impacts_v_before": [0.3], "t_start": 0.0,
          "t_end": 10.0}  # fmt: skip
    kw.update(kwargs)
    kw["params"] = pi.Params.make(eta="0.712", **kw["params"])
    with pytest.raises(ParameterError) as e:
        finite_time_lle(**kw)
    assert e.value.name == name
