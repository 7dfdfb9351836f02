"""Readers of oscilloscope capture files, on files in the instruments' own layouts, and their
one-line refusals (damaged, truncated, wrong unit, wrong channel)."""

from __future__ import annotations

import numpy as np
import pytest

from precise_impact.cli.main import main
from precise_impact.errors import ParameterError
from precise_impact.lab.scope_files import WRITE_FORMATS, read_capture, sniff_format, write_capture
from precise_impact.lab.synth import synth_capture

SUFFIX = {"npz": ".npz", "keysight-bin": ".bin", "tek-tbs": ""}


@pytest.fixture(scope="session")
def cap():
    return synth_capture("fig6-period3-ideal", periods=8, transient=5, trigger_offset=-2e-3)


def _write(cap, tmp_path, fmt):
    p = tmp_path / (f"cap_{fmt}" + SUFFIX.get(fmt, ".csv"))
    write_capture(cap, p, fmt)
    return p


# the digits each layout writes: volts to 5-7 significant digits of values ~2 V
DIGITS = {"rigol": 5e-5, "tek": 5e-4, "siglent": 5e-5, "tek-tbs": 5e-5}


@pytest.mark.parametrize("fmt", WRITE_FORMATS)
def test_round_trip_every_layout(cap, tmp_path, fmt):
    if fmt == "keysight-bin":
        pytest.importorskip("RigolWFM")
    p = _write(cap, tmp_path, fmt)
    r = read_capture(p)
    assert r.n_samples == cap.n_samples
    assert r.sample_interval == pytest.approx(cap.sample_interval, rel=1e-6)
    assert np.max(np.abs(r.t - cap.t)) < 1e-9
    tol = DIGITS.get(fmt, 1e-6) * 3  # the layout's printed digits (float32 for .bin)
    for k in ("V_s", "V_q", "V_3"):
        assert np.max(np.abs(getattr(r, k) - getattr(cap, k))) < tol, k
    if fmt not in ("csv", "npz"):
        assert r.source["channel_map"] == {"V_s": "CH1", "V_q": "CH2", "V_3": "CH3"}


def test_layouts_are_the_instruments(cap, tmp_path):
    lines = {f: None for f in ("rigol", "keysight", "tek", "siglent")}
    for f in lines:
        lines[f] = _write(cap, tmp_path, f).read_text().splitlines()
    assert lines["rigol"][0] == "X,CH1,CH2,CH3,Start,Increment,"
    assert lines["rigol"][1].startswith("Sequence,Volt,Volt,Volt,")
    assert lines["rigol"][2].startswith("0,") and lines["rigol"][2].endswith(",")
    assert lines["keysight"][:2] == ["x-axis,1,2,3", "second,Volt,Volt,Volt"]
    assert lines["tek"][0].startswith("Model,") and "TIME,CH1,CH2,CH3" in lines["tek"]
    assert lines["siglent"][0] == f"Record Length,Analog:{cap.n_samples}"
    assert "Second,Volt,Volt,Volt" in lines["siglent"]
    tbs = _write(cap, tmp_path, "tek-tbs")
    row = (tbs / "F0000CH1.CSV").read_text().splitlines()[1].split(",")
    assert row[0] == "Sample Interval" and float(row[1]) == pytest.approx(cap.sample_interval)
    assert len(row) == 6  # header in A-B, the sample in D-E, a trailing comma
    assert sniff_format(tbs) == "tek-tbs"
    # one channel file of a Save-All folder reads its siblings
    assert read_capture(tbs / "F0000CH2.CSV").n_samples == cap.n_samples


def test_channels_chosen_by_name(cap, tmp_path):
    p = _write(cap, tmp_path, "rigol")
    r = read_capture(p, "V_s=CH2,V_q=CH1")
    assert np.array_equal(r.V_s, read_capture(p).V_q) and r.V_3 is None
    r2 = read_capture(p, "CH3,CH1")
    assert r2.source["channel_map"] == {"V_s": "CH3", "V_q": "CH1"}


def _refused(path, **kw):
    with pytest.raises(ParameterError) as e:
        read_capture(path, **kw)
    msg = str(e.value)
    assert "\n" not in msg
    return msg


def test_damaged_files(cap, tmp_path):
    p = _write(cap, tmp_path, "keysight")
    lines = p.read_text().splitlines()
    lines[10] = lines[10].replace(",", ",#", 1)
    p.write_text("\n".join(lines) + "\n")
    assert "line 11" in _refused(p) and "damaged" in _refused(p)
    z = tmp_path / "bad.npz"
    z.write_bytes(b"PK\x03\x04 not a zip")
    assert "NPZ" in _refused(z)


def test_damaged_and_truncated_binary(cap, tmp_path):
    pytest.importorskip("RigolWFM")
    b = _write(cap, tmp_path, "keysight-bin")
    blob = bytearray(b.read_bytes())
    blob[0:2] = b"XX"
    b.write_bytes(bytes(blob))
    assert "damaged" in _refused(b)
    b = _write(cap, tmp_path, "keysight-bin")
    b.write_bytes(b.read_bytes()[:-1000])
    assert "truncated" in _refused(b)


def test_truncated_files(cap, tmp_path):
    for fmt in ("tek", "siglent", "rigol", "csv"):
        p = _write(cap, tmp_path, fmt)
        text = p.read_text()
        p.write_text(text[: len(text) // 2])  # cut mid-row, no final newline
        assert "truncated" in _refused(p), fmt
    p = _write(cap, tmp_path, "siglent")
    lines = p.read_text().splitlines()
    p.write_text("\n".join(lines[:-100]) + "\n")  # whole rows missing: the header's length
    assert "header says" in _refused(p)


@pytest.mark.parametrize(
    "fmt, old, new",
    [
        ("rigol", "Sequence,Volt,Volt,Volt", "Sequence,Volt,Ampere,Volt"),
        ("keysight", "second,Volt", "Hertz,Volt"),  # an FFT export
        ("tek", "Horizontal Units,s", "Horizontal Units,Hz"),
        ("csv", "V_q [V]", "V_q [A]"),
    ],
)
def test_wrong_unit(cap, tmp_path, fmt, old, new):
    p = _write(cap, tmp_path, fmt)
    p.write_text(p.read_text().replace(old, new, 1))
    assert "wrong unit" in _refused(p)


def test_units_converted_to_si(cap, tmp_path):
    p = _write(cap, tmp_path, "csv")
    lines = p.read_text().splitlines()
    rows = [",".join(f"{float(a) * 1e3:.10g}" for a in r.split(",")) for r in lines[1:]]
    p.write_text("Time (ms),CH1 (mV),CH2 (mV),CH3 (mV)\n" + "\n".join(rows) + "\n")
    r = read_capture(p)
    assert np.max(np.abs(r.V_s - cap.V_s)) < 1e-6 and np.max(np.abs(r.t - cap.t)) < 1e-12


def test_wrong_channel(cap, tmp_path):
    p = _write(cap, tmp_path, "rigol")
    msg = _refused(p, channels="CH1,CH4")
    assert "wrong channel" in msg and "CH1, CH2, CH3" in msg
    assert "V_s and V_q" in _refused(p, channels="V_s=CH1,V_3=CH2")


@pytest.mark.parametrize("problem", ["damaged", "truncated", "wrong unit", "wrong channel"])
def test_cli_exit_2_one_line(cap, tmp_path, capsys, problem):
    p = _write(cap, tmp_path, "rigol")
    text = p.read_text()
    argv = ["capture", "score", str(p)]
    if problem == "damaged":
        p.write_text(text.replace("\n5,", "\n5,x", 1))
    elif problem == "truncated":
        p.write_text(text[:-7])
    elif problem == "wrong unit":
        p.write_text(text.replace("Sequence,Volt", "Sequence,Watt", 1))
    else:
        argv += ["--channels", "CH1,CH7"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and problem.split()[-1] in err


def _write_isf(path, cap, y, ch, yunit="V", ymult=1e-4):
    """A Tektronix .isf file in the layout of Tek's FAQ "What format is an ISF file?" (the
    WFMPRE preamble, then ':CURVE #<digits><bytes>' and big-endian int16 codes)."""
    codes = np.round(np.asarray(y) / ymult).astype(">i2")
    n = codes.size
    pre = (
        f":WFMPRE:BYT_NR 2;BIT_NR 16;ENCDG BIN;BN_FMT RI;BYT_OR MSB;NR_PT {n};"
        f'WFID "Ch{ch}, DC coupling, 1.0E0 V/div, 1.0E-3 s/div, {n} points, Sample mode";'
        f"PT_FMT Y;XINCR {cap.sample_interval:.6E};PT_OFF 0;XZERO {cap.t[0]:.6E};XUNIT "
        f'"s";YMULT {ymult:.6E};YZERO 0.0E0;YOFF 0.0E0;YUNIT "{yunit}";'
        f":CURVE #{len(str(2 * n))}{2 * n}"
    )
    path.write_bytes(pre.encode() + codes.tobytes() + b"\n")


def test_tektronix_isf_folder(cap, tmp_path):
    pytest.importorskip("RigolWFM")
    d = tmp_path / "isf"
    d.mkdir()
    _write_isf(d / "TEK00000.ISF", cap, cap.V_q, 2)  # file order differs from channel order
    _write_isf(d / "TEK00001.ISF", cap, cap.V_s, 1)
    r = read_capture(d, "V_s=CH1,V_q=CH2")
    assert np.max(np.abs(r.V_s - cap.V_s)) <= 0.5e-4 + 1e-12  # half a code of 1e-4 V
    assert np.max(np.abs(r.t - cap.t)) < 1e-9
    _write_isf(d / "TEK00001.ISF", cap, cap.V_s, 1, yunit="A")
    assert "wrong unit" in _refused(d, channels="V_s=CH1,V_q=CH2")


def test_rigol_mso5000_and_headerless_csv(cap, tmp_path):
    # MSO5000 / DHO: 'Time(s),CH1V,CH2V,CH3V' then time-first rows
    p = tmp_path / "RigolDS0.csv"
    rows = np.column_stack([cap.t, cap.V_s, cap.V_q, cap.V_3])
    with open(p, "w") as fh:
        fh.write("Time(s),CH1V,CH2V,CH3V,\n")
        np.savetxt(fh, rows, delimiter=",", fmt="%.9e")
    assert sniff_format(p) == "rigol-mso5000"
    r = read_capture(p)
    assert r.source["instrument"] == "Rigol MSO5000" and r.n_samples == cap.n_samples
    assert np.max(np.abs(r.V_q - cap.V_q)) < 1e-8
    # no header at all: time first, channels in order
    q = tmp_path / "bare.csv"
    with open(q, "w") as fh:
        np.savetxt(fh, rows[:, :3], delimiter=",", fmt="%.9e")
    r2 = read_capture(q)
    assert r2.V_3 is None and np.max(np.abs(r2.V_s - cap.V_s)) < 1e-8


def test_plots_write(cap, tmp_path):
    cap.plot(tmp_path / "cap.png", periods=3)
    assert (tmp_path / "cap.png").stat().st_size > 1000
    with pytest.raises(ParameterError):
        cap.plot(tmp_path / "cap.txt")


def test_coarsely_printed_times_and_a_missing_row(cap, tmp_path):
    p = _write(cap, tmp_path, "keysight")
    lines = p.read_text().splitlines()
    # times printed to 4 significant digits: steps of 5e-5 s vary by up to 2e-5 s
    body = [f"{float(r.split(',')[0]):.3e}," + r.split(",", 1)[1] for r in lines[2:]]
    p.write_text("\n".join(lines[:2] + body) + "\n")
    r = read_capture(p)
    assert r.sample_interval == pytest.approx(cap.sample_interval, rel=1e-4)
    assert np.max(np.abs(r.t - cap.t)) < 0.25 * cap.sample_interval
    # a row missing in the middle is half a sample off any grid: refused
    del lines[500]
    p.write_text("\n".join(lines) + "\n")
    assert "uniformly sampled" in _refused(p)


def _rigol_in_seconds(cap, tmp_path, unit="Second", scale=1.0, shift=0.0, stretch=1.0):
    """The Rigol CSV with its X column in time (``unit``; the DS1000Z firmwares that write
    ``Second`` under X) instead of the sample index:
    X = (start + shift + index * increment * stretch) / scale."""
    lines = _write(cap, tmp_path, "rigol").read_text().splitlines()
    head = lines[1].split(",")
    start, inc = float(head[-2]), float(head[-1])
    rows = []
    for line in lines[2:]:
        i, rest = line.split(",", 1)
        rows.append(f"{(start + shift + int(i) * inc * stretch) / scale:.9e},{rest}")
    p = tmp_path / f"rigol_{unit}.csv"
    p.write_text("\n".join([lines[0], ",".join([unit, *head[1:]]), *rows]) + "\n")
    return p


@pytest.mark.parametrize("unit, scale", [("Second", 1.0), ("s", 1.0), ("ms", 1e-3)])
def test_rigol_x_in_seconds(cap, tmp_path, unit, scale):
    # was refused: 'a header that disagrees with the data: wrong unit?' (X read as an index)
    r = read_capture(_rigol_in_seconds(cap, tmp_path, unit, scale))
    assert r.n_samples == cap.n_samples
    assert r.sample_interval == pytest.approx(cap.sample_interval, rel=1e-6)
    # the times as printed: 10 significant digits of ~1e-2 s, the grid fitted through them
    assert np.max(np.abs(r.t - cap.t)) < 1e-9
    assert np.max(np.abs(r.V_s - cap.V_s)) < 3 * DIGITS["rigol"]
    assert r.source["x_unit"] == unit


def test_rigol_x_contradiction_refused(cap, tmp_path):
    # times a whole second after the header's Start: a real contradiction, one line
    msg = _refused(_rigol_in_seconds(cap, tmp_path, shift=1.0))
    assert "X from 0.998 s, Start -0.002 s" in msg and "starts at the header's Start" in msg
    # an X column in hertz (an FFT export) is a wrong unit
    assert "wrong unit" in _refused(_rigol_in_seconds(cap, tmp_path, unit="Hertz"))
    # a time X column whose step is not the header's Increment: the step check refuses it
    assert "disagrees" in _refused(_rigol_in_seconds(cap, tmp_path, stretch=2.0))
