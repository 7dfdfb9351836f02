"""The Capture type: validation and the mapping to the dimensionless oscillator."""

from __future__ import annotations

import json

import numpy as np
import pytest

from precise_impact.core.params import Params
from precise_impact.errors import ParameterError
from precise_impact.lab.capture import Capture, design_of
from precise_impact.models.circuit.components import nominal_components, to_circuit


def _cap(n=100, dt=1e-4, **kw):
    t = np.arange(n) * dt
    return Capture.make(t, np.sin(t), np.cos(t), **kw)


def test_mapping_is_the_inverse_of_to_circuit():
    # a design with V_unit = 2 V and omega = 2000 rad/s: the exact inverse of to_circuit
    comp = nominal_components(Params.make(eta="0.74"), R="5e3", C="100e-9", V_unit=2)
    tau = np.linspace(0, 30, 200)
    x, v = np.sin(tau), np.cos(tau)
    t, Vs, Vq = to_circuit(comp, tau, x, v, 2000.0)
    m = Capture.make(t, Vs, Vq).to_mechanical(comp, forcing_phase0=0.5)
    # float64 round trip: a few ulps of values of order 1
    assert np.max(np.abs(m.x - x)) < 1e-14 and np.max(np.abs(m.v - v)) < 1e-14
    assert np.max(np.abs(m.tau - tau)) < 1e-12
    assert m.eta == pytest.approx(0.74, rel=1e-15)
    assert m.phase is not None and m.phase[0] == pytest.approx(0.5)


def test_design_of_accepts_scene_names_params_and_components():
    c1 = design_of("fig6-period3-ideal")
    assert design_of(c1) is c1
    assert design_of(Params.make(eta="0.74")) == c1
    with pytest.raises(ParameterError):
        design_of(3.0)


@pytest.mark.parametrize(
    "t, vs, problem",
    [
        (np.r_[np.arange(50), np.arange(51, 100)] * 1e-4, None, "uniformly"),  # a missing sample
        (np.arange(100) * 1e-4, np.r_[np.zeros(99), np.nan], "finite"),
        (np.arange(100) * 1e-4, np.zeros(99), "as many samples"),
        (np.arange(10) * 1e-4, None, ">= 16"),
    ],
)
def test_bad_captures_refused_with_one_line(t, vs, problem):
    vs = np.zeros(len(t)) if vs is None else vs
    with pytest.raises(ParameterError) as e:
        Capture.make(t, vs, np.zeros(len(t)), what="f.csv")
    assert problem in str(e.value) and "\n" not in str(e.value) and e.value.name == "f.csv"


def test_header_interval_that_disagrees_is_refused():
    with pytest.raises(ParameterError, match="wrong unit"):
        _cap(sample_interval=1e-1)  # a header in ms read as s


def test_summary_is_strict_json(tmp_path):
    c = _cap(source={"format": "x", "nan": float("nan")})
    json.dumps(c.to_dict(), allow_nan=False)
    assert c.duration == pytest.approx(100 * 1e-4) and c.sample_rate == pytest.approx(1e4)
    c.save(tmp_path / "c.json")


def test_wall_and_amplitude_come_from_dimensionless(monkeypatch):
    # x_w and a have one home (components.dimensionless); the capture used to rebuild them by hand
    import precise_impact.models.circuit.components as comps

    comp = design_of("fig6-period3-ideal")
    p = comps.dimensionless(comp)
    m = _cap().to_mechanical(comp)
    assert (m.x_w, m.a) == (float(p.x_w), float(p.a))
    import precise_impact.lab.capture as lab_capture  # binds dimensionless at import

    monkeypatch.setattr(lab_capture, "dimensionless", lambda c: p.replace(x_w="1.5", a="0.25"))
    m = _cap().to_mechanical(comp)
    assert (m.x_w, m.a) == (1.5, 0.25)


@pytest.mark.parametrize("bits", [2, 3])
def test_coarse_adc_is_not_clipping_nor_a_wrong_channel(bits):
    # a sinusoid on 3 bits spends 23 % of its samples on its top code (the flat 20 % limit
    # called that clipped); on 2 bits the code error (q^2/12), not only the white noise, is
    # taken out of the integrator check (was: 87 % explained, "a wrong channel?")
    from precise_impact.lab.capture import check_channels
    from precise_impact.lab.synth import synth_capture

    c = synth_capture(periods=50, transient=20, bits=bits)
    r = check_channels(c, "fig6-period3-ideal")
    assert r["r2"] > 0.95 and max(r["clipped"].values()) <= min(r["clip_limit"].values())
