"""Synthetic captures: the measurement model applied to a model's trajectory, truth recorded."""

from __future__ import annotations

import math

import numpy as np
import pytest

from precise_impact.errors import ParameterError
from precise_impact.lab.capture import Capture
from precise_impact.lab.synth import Measurement, synth_capture


def test_clean_capture_is_the_model_in_volts():
    # unquantised, noiseless: V_3 is exactly V_A cos(Omega t_true) at the recorded phase
    c = synth_capture("fig6-period3-ideal", periods=20, bits=0, noise=0.0, transient=20)
    tr = c.source["truth"]
    ph = tr["forcing_omega_rad_s"] * c.t + tr["forcing_phase0_rad"]
    assert np.max(np.abs(c.V_3 - np.cos(ph))) < 1e-9  # V_A = 1 V; phase from ~1e3 rad: 1e-12
    # the wall: V_s never below V_wall = -2 V by more than the Hermite error
    assert c.V_s.min() > -2 - 1e-6
    assert isinstance(c, Capture) and c.units["V_s"] == "V"


def test_timebase_error_scales_the_forcing_frequency():
    c = synth_capture("fig6-period3-ideal", periods=5, transient=5, timebase_ppm=100.0)
    assert c.source["truth"]["forcing_omega_rad_s"] == pytest.approx(740 / (1 + 1e-4), rel=1e-15)


def test_quantisation_and_noise_levels():
    c = synth_capture("fig6-period3-ideal", periods=20, transient=20, bits=8, noise=0.0, seed=1)
    rng = c.source["measurement"]["channel_ranges"]["V_s"]
    lsb = rng["full_scale"] / 256
    codes = (c.V_s - rng["low"]) / lsb - 0.5
    assert np.max(np.abs(codes - np.round(codes))) < 1e-6
    assert len(np.unique(np.round(codes))) <= 256


@pytest.mark.parametrize(
    "kw, name",
    [
        ({"bits": 30}, "bits"),
        ({"noise": -0.1}, "noise"),
        ({"periods": 1}, "periods"),
        ({"sample_rate": 0.0}, "sample_rate"),
        ({"gain_error": {"V_x": 0.1}}, "gain_error"),
        ({"timebase_ppm": math.nan}, "timebase_ppm"),
    ],
)
def test_bad_measurement_refused(kw, name):
    with pytest.raises(ParameterError) as e:
        Measurement(**kw).check()
    assert e.value.name == name


def test_spice_model_capture():
    # the ngspice model through the same path (skipped without ngspice)
    import precise_impact as pi

    try:
        pi.models.circuit.spice.find_ngspice()
    except pi.OptionalDependencyError:
        pytest.skip("ngspice not installed")
    c = synth_capture("fig6-period3-ideal", model="spice", periods=12, transient=10, noise=0.0)
    truth = c.source["truth"]
    assert truth["model"] == "spice" and len(truth["impacts_t"]) > 0
    assert c.V_s.min() > -2 - 0.05  # the wall at V_wall = -2 V, within the 8-bit step


# ---------------------------------------------------------------- bounds, budgets, round trips
@pytest.mark.parametrize(
    "args, name, status",
    [
        (["--sample-rate", "1e-6"], "sample_rate", 2),  # was exit 3 naming periods
        (["--sample-rate", "1"], "sample_rate", 2),  # was "capture ... >= 16 samples"
        (["--full-scale", "V_s=1,V_s=2"], "full-scale", 2),  # was: the last one kept
        (["--gain-error", "V_q=0.1,V_q=0.2"], "gain-error", 2),
        (["--offset-error", "V_3=1,V_3=1"], "offset-error", 2),
        (["--trigger-offset", "1e6", "--sample-rate", "1e9", "--periods", "2"], "trigger", 2),
        (["--periods", "1e5", "--max-time", "1"], "max_time", 3),  # was > 20 s, no budget
    ],
)
def test_cli_synth_bounds_before_any_work(tmp_path, capsys, args, name, status):
    from precise_impact.cli.main import main

    f = tmp_path / "c.csv"
    assert main(["capture", "synth", *args, "--out", str(f)]) == status
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and name in err[0]
    assert not f.exists()


@pytest.mark.parametrize(
    "kw",
    [
        {"trigger_offset": 1e6},  # was written with %.10g times: 'median step 0 s'
        {"trigger_offset": -1e6},
        {"offset_error": 1e6},  # was written with %.7g volts: the signal wiped
        {"offset_error": -1e6, "bits": 0},
        {"bits": 24, "noise": 0.0},
    ],
)
def test_every_file_synth_writes_reads_back(tmp_path, kw):
    from precise_impact.errors import ParameterError
    from precise_impact.lab.scope_files import WRITE_FORMATS, read_capture

    cap = synth_capture(periods=3, transient=2, **kw)
    for fmt in WRITE_FORMATS:
        if fmt == "keysight-bin":
            pytest.importorskip("RigolWFM")
        p = (
            tmp_path
            / f"c_{fmt}{ {'npz': '.npz', 'keysight-bin': '.bin', 'tek-tbs': ''}.get(fmt, '.csv') }"
        )
        try:
            cap.save(p, fmt)
        except ParameterError as e:  # a layout whose digits cannot carry it refuses to write
            assert e.name == "format" and fmt not in ("csv", "npz")
            assert not p.exists()
            continue
        r = read_capture(p)
        # times: the reader fits t0 + k dt to the printed times (its rounding, ulps of t)
        assert np.max(np.abs(r.t - cap.t)) <= 1e-3 * cap.sample_interval, fmt
        if fmt in ("csv", "npz"):  # every bit of the voltages kept
            for k in ("V_s", "V_q", "V_3"):
                assert np.array_equal(getattr(r, k), getattr(cap, k)), (fmt, k)
        else:  # within the layout's digits: 1e-3 of each channel's peak-to-peak
            for k in ("V_s", "V_q", "V_3"):
                y = getattr(cap, k)
                assert np.max(np.abs(getattr(r, k) - y)) <= 1e-3 * np.ptp(y), (fmt, k)
