"""Your own netlist (precise_impact.lab.netlist, ``precise-impact spice score``): real ngspice runs
and the raw files they write (binary and ASCII, multi-plot), LTspice files written by spicelib,
every damaged-file refusal, and the done-when comparison with ``compare`` (slow).

Measured figures behind the constants: benchmarks/results/netlist.md (benchmarks/bench_netlist.py).
"""

from __future__ import annotations

import json
import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from precise_impact.cli.main import main
from precise_impact.errors import ParameterError, SpiceError
from precise_impact.lab.netlist import (
    NodeMap,
    compress_like_ltspice,
    fit_forcing,
    load_map,
    lt_compression,
    read_raw,
    run_netlist,
    score_netlist,
)
from precise_impact.models.circuit.spice import spice_netlist
from precise_impact.scenes.scene import load_scene

needs_ngspice = pytest.mark.skipif(
    shutil.which("ngspice") is None,
    reason="ngspice not installed: apt-get install ngspice; CI installs it",
)
spicelib = pytest.importorskip("spicelib")

SCENE = "fig6-period3-ideal"
WRDATA = "wrdata spice_out.txt V(s) V(q) V(pol) V(cmp)"


def own_netlist(periods: int, tmax: float = 10e-6) -> str:
    """The project's generated netlist of SCENE, as a user would have it."""
    sc = load_scene(SCENE)
    return spice_netlist(sc.design(), None, periods, tmax, sc.params.x0, sc.params.v0)


def ngspice(tmp: Path, text: str) -> None:
    (tmp / "c.cir").write_text(text)
    subprocess.run(["ngspice", "-b", "c.cir"], cwd=tmp, check=True, capture_output=True)


@pytest.fixture(scope="session")
def raws(tmp_path_factory):
    """One real ngspice run (12 periods) written as binary raw, ASCII raw and wrdata text; and a
    two-plot file (the run, then R3 + 10 %, appended)."""
    if shutil.which("ngspice") is None:
        pytest.skip("ngspice not installed")
    d = tmp_path_factory.mktemp("raws")
    vec = "V(s) V(q) V(pol) V(v3) I(VBRK)"
    ctrl = (
        f"write b.raw {vec}\nset filetype=ascii\nwrite a.raw {vec}\n"
        "wrdata w.txt V(s) V(q) V(pol) V(v3)\nset filetype=binary\n"
        f"write m.raw {vec}\nalter R3 = 11000\nrun\nset appendwrite\nwrite m.raw {vec}"
    )
    ngspice(d, own_netlist(12).replace(WRDATA, ctrl))
    return d


# ------------------------------------------------------------------ reading raw files
@needs_ngspice
def test_rawread_binary_exact_and_ascii_within_an_ulp_of_ngspice(raws):
    ref = np.loadtxt(raws / "w.txt")  # wr_singlescale: time, V(s), V(q), V(pol), V(v3); 17 digits
    for name, rtol in (("b.raw", 0.0), ("a.raw", 1.2e-15)):
        # binary: the float64 values ngspice computed; ASCII: ngspice prints 16 significant
        # digits, within one ulp of float64 (2.2e-16 relative, x4 for the printed rounding)
        (run,) = read_raw(raws / name)
        assert run.dialect == "ngspice"
        cols = [run.time] + [run.traces[n][0] for n in ("v(s)", "v(q)", "v(pol)", "v(v3)")]
        for i, c in enumerate(cols):
            assert len(c) == len(ref)
            np.testing.assert_allclose(c, ref[:, i], rtol=rtol, atol=1e-300 if rtol else 0)
        assert run.traces["i(vbrk)"][1] == "current"


@needs_ngspice
def test_run_netlist_raw_files_are_ngspice_write_output(raws):
    # ngspice -b -r (what run_netlist runs, its .control block left out) against the 'write'
    # of the same run: binary bit for bit, ASCII within one ulp
    (want,) = read_raw(raws / "b.raw")
    for ascii_raw, rtol in ((False, 0.0), (True, 1.2e-15)):
        (got,), info = run_netlist(raws / "c.cir", ascii_raw=ascii_raw)
        assert info["notes"] == ["its .control block was not run (the .tran line is)"]
        np.testing.assert_allclose(got.time, want.time, rtol=rtol, atol=0)
        for n in ("v(s)", "v(q)", "v(pol)", "v(v3)"):
            np.testing.assert_allclose(got.traces[n][0], want.traces[n][0], rtol=rtol, atol=0)


@needs_ngspice
def test_multi_plot_file_gives_one_run_per_plot_and_step_picks_one(raws):
    runs = read_raw(raws / "m.raw")
    assert [r.label for r in runs] == ["plot 0 step 0", "plot 1 step 0"]
    # the second plot is the R3 + 10 % run: its waveform differs
    assert not np.array_equal(runs[0].traces["v(q)"][0][:50], runs[1].traces["v(q)"][0][:50])
    (second,) = read_raw(raws / "m.raw", step=1)
    np.testing.assert_array_equal(second.traces["v(s)"][0], runs[1].traces["v(s)"][0])
    with pytest.raises(ParameterError, match="step"):
        read_raw(raws / "m.raw", step=2)


@needs_ngspice
def test_fitted_forcing_recovers_the_design_source(raws):
    (run,) = read_raw(raws / "b.raw")
    f = fit_forcing(run.time, run.traces["v(v3)"][0])
    # V3 = 1 V cos(740 t): the fit is exact to rounding of the waveform's float64 values
    assert abs(f["Omega"] / 740 - 1) < 1e-12
    assert abs(f["amplitude"] - 1) < 1e-12 and abs(f["phase"]) < 1e-9
    assert f["Omega_stderr"] < 1e-9


# ------------------------------------------------------------------ damaged input: one line, exit 2
def _bad_files(raws: Path, tmp: Path) -> dict[str, tuple[list[str], str]]:
    b = (raws / "b.raw").read_bytes()
    (tmp / "trunc.raw").write_bytes(b[: len(b) // 2])
    rng = np.random.default_rng(1)
    (tmp / "garbage.raw").write_bytes(rng.integers(0, 256, 4000, dtype=np.uint8).tobytes())
    (tmp / "empty.raw").write_bytes(b"")
    (tmp / "c.txt").write_text("* a netlist with the wrong extension\n")
    (tmp / "ac.raw").write_text(
        "Title: t\nDate: d\nPlotname: AC Analysis\nFlags: complex\nNo. Variables: 2\n"
        "No. Points: 2\nVariables:\n\t0\tfrequency\tfrequency\n\t1\tv(a)\tvoltage\nValues:\n"
        "0\t1,0\n\t2,0\n1\t2,0\n\t3,0\n"
    )
    (tmp / "own.cir").write_text(own_netlist(3))
    good = ["--v-node", "q", "--scene", SCENE]
    (tmp / "inverted.toml").write_text(
        f'scene = "{SCENE}"\n[nodes]\nx = "s"\nv = "q"\n[gains]\nx = -1.0\n'
    )
    b_raw = str(raws / "b.raw")
    return {
        "x and v swapped": ([b_raw, "--x-node", "q", "--v-node", "s", "--scene", SCENE], "swapped"),
        "inverted x probe": ([b_raw, "--map", str(tmp / "inverted.toml")], "sign flipped"),
        "wrong forcing channel": (
            [b_raw, "--x-node", "s", *good, "--forcing-node", "pol"],
            "sinusoidal",
        ),
        "truncated": ([str(tmp / "trunc.raw"), "--x-node", "s", *good], "raw file"),
        "garbage": ([str(tmp / "garbage.raw"), "--x-node", "s", *good], "raw file"),
        "empty": ([str(tmp / "empty.raw"), "--x-node", "s", *good], "empty"),
        "extension": ([str(tmp / "c.txt"), "--x-node", "s", *good], "unknown extension"),
        "wrong unit": ([str(tmp / "ac.raw"), "--x-node", "a", *good], "not time"),
        "missing node raw": ([str(raws / "b.raw"), "--x-node", "nope", *good], "x-node"),
        "not a voltage": ([str(raws / "b.raw"), "--x-node", "i(vbrk)", *good], "current"),
        "missing node netlist": ([str(tmp / "own.cir"), "--x-node", "nope", *good], "x-node"),
    }


@needs_ngspice
@pytest.mark.parametrize(
    "case",
    [
        "x and v swapped",
        "inverted x probe",
        "wrong forcing channel",
        "truncated",
        "garbage",
        "empty",
        "extension",
        "wrong unit",
        "missing node raw",
        "not a voltage",
        "missing node netlist",
    ],
)
def test_damaged_files_get_one_line_exit_2(case, raws, tmp_path, capsys):
    argv, word = _bad_files(raws, tmp_path)[case]
    assert main(["spice", "score", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and word in err, err


def test_map_file_refusals(tmp_path):
    m = tmp_path / "m.toml"
    m.write_text('[nodes]\nx = "s"\n')
    with pytest.raises(ParameterError, match="map.nodes.v"):
        load_map(m)
    m.write_text('[nodes]\nx = "s"\nv = "q"\n[colours]\na = 1\n')
    with pytest.raises(ParameterError, match="map.colours"):
        load_map(m)
    m.write_text(
        '[nodes]\nx = "s"\nv = "q"\nforcing = "v3"\n[gains]\nx = 2.0\n[scales]\n'
        "forcing_phase = 0.0\n"
    )
    nm = load_map(m)
    assert nm == NodeMap(x="s", v="q", forcing="v3", gains={"x": 2.0}, forcing_phase=0.0)
    assert nm.corrected("x", np.array([1.5]))[0] == 3.0
    # a design without a scene must be whole: refused before the file is looked at
    with pytest.raises(ParameterError, match="map.components.R1"):
        score_netlist(tmp_path / "none.raw", map=NodeMap(x="s", v="q", components={"R3": "11e3"}))
    with pytest.raises(ParameterError, match="scene"):
        score_netlist(tmp_path / "none.raw", "s", "q")


# ------------------------------------------------------------------ LTspice
def test_compression_rule_keeps_every_dropped_point_within_tolerance():
    t = np.linspace(0, 1, 5001)
    y = np.sin(2 * math.pi * 3 * t) + 0.2 * np.sign(np.sin(2 * math.pi * 7 * t))
    keep = compress_like_ltspice(t, [y])
    assert keep[0] == 0 and keep[-1] == len(t) - 1 and len(keep) < len(t) / 5
    lin = np.interp(t, t[keep], y[keep])
    assert np.all(np.abs(lin - y) <= np.maximum(0.0025 * np.abs(y), 1e-5) + 1e-15)


def _lt_raw(path: Path, t: np.ndarray, ys: dict, flags: str | None) -> Path:
    """An LTspice-format raw file (spicelib's RawWrite writes LTspice's UTF-16 layout)."""
    from spicelib import RawWrite, Trace

    w = RawWrite(plot_name="Transient Analysis", fastacces=False)
    w.add_trace(Trace("time", t))
    for n, y in ys.items():
        w.add_trace(Trace(n, y))
    w.save(str(path))
    if flags is not None:
        enc = "utf_16_le"
        b = path.read_bytes()
        b = b.replace("Flags: real".encode(enc), f"Flags: {flags}".encode(enc), 1)
        path.write_bytes(b)
    return path


def test_ltspice_compression_is_detected_from_the_header_flag(tmp_path):
    t = np.linspace(0, 1e-2, 2001)
    ys = {"V(s)": np.sin(740 * t), "V(q)": np.cos(740 * t)}
    comp = lt_compression(read_raw(_lt_raw(tmp_path / "c.raw", t, ys, "real forward")))
    assert comp["compressed"] and "plotwinsize=0" in comp["warning"]
    assert len(comp["warning"].splitlines()) == 1
    plain = lt_compression(
        read_raw(_lt_raw(tmp_path / "u.raw", t, ys, "real forward nocompression"))
    )
    assert not plain["compressed"]


@needs_ngspice
def test_relative_includes_resolve_from_the_netlists_directory(tmp_path):
    # the netlist runs as a copy in a working directory of its own: '.include models/rc.lib'
    # must still find the user's file beside the netlist
    (tmp_path / "models").mkdir()
    (tmp_path / "models" / "rc.lib").write_text("* sub\n.subckt RCX a b\nR1 a b 1k\n.ends\n")
    net = tmp_path / "top.cir"
    net.write_text(
        "* uses an include\n.include models/rc.lib\nV1 in 0 SIN(0 1 1k)\nX1 in out RCX\n"
        "C1 out 0 100n\n.tran 1u 2m\n.end\n"
    )
    (run,), _ = run_netlist(net)
    # RC low-pass at 1 kHz, tau = 0.1 ms: steady amplitude 1/sqrt(1 + (2 pi f tau)^2) = 0.847
    assert 0.8 < run.node("out", "x")[len(run.time) // 2 :].max() < 0.9


@needs_ngspice
def test_ltspice_netlist_runs_in_ngspice_lt_mode(tmp_path):
    # an LTspice export: LTspice's B-source function uplim and '.tran 0 TSTOP'
    net = tmp_path / "osc.net"
    net.write_text(
        "* C:\\users\\me\\osc.asc\nV1 in 0 SINE(0 1 100)\nR1 in out 1k\nC1 out 0 1u\n"
        "B1 cl 0 V=uplim(V(out),0.3,0.01)\n.tran 0 20m 0 10u\n.options plotwinsize=0\n"
        ".backanno\n.end\n"
    )
    (run,), info = run_netlist(net)
    assert info["ltspice_mode"] == "ltpsa" and any(".tran" in n for n in info["notes"])
    cl = run.node("cl", "x")
    assert cl.max() <= 0.3 + 1e-9 < run.node("out", "x").max()
    with pytest.raises(SpiceError, match="uplim"):
        run_netlist(net, ltspice=False)


# ------------------------------------------------------------------ scoring
@needs_ngspice
def test_two_plot_raw_scores_each_run_from_its_first_sample_strict_json(raws, tmp_path, capsys):
    m = tmp_path / "map.toml"
    m.write_text(f'scene = "{SCENE}"\n[nodes]\nx = "s"\nv = "q"\nforcing = "v3"\nimpact = "pol"\n')
    argv = ["spice", "score", str(raws / "m.raw"), "--map", str(m), "--periods", "8", "--json"]
    assert main(argv) == 0
    d = json.loads(capsys.readouterr().out, parse_constant=lambda c: pytest.fail(c))
    a, b = d["runs"]
    for run in (a, b):
        # ngspice writes no t = 0 under uic: the first sample is t = T, read exactly (breakpoint)
        assert run["first_sample_s"] == pytest.approx(2 * math.pi / 740, rel=1e-15)
        assert run["samples_interpolated"] == 0 and run["periods"] == 8
        # the first sample, mapped, is the reference's start (float64 -> exact decimal: < 1 ulp)
        assert run["scores"]["initial_separation"] < 1e-15
    assert a["initial_state"] != b["initial_state"]  # each run its own reference
    sa, sb = a["scores"], b["scores"]
    assert sa["impacts_per_period_model"] == sa["impacts_per_period_reference"]
    # the second plot is R3 + 10 %: far off (measured 0.35 vs 1e-3)
    assert sb["sliced_wasserstein"] > 100 * sa["sliced_wasserstein"]
    assert d["compression"]["compressed"] is False and d["mapping"]["mode"] == "components"


@needs_ngspice
@pytest.mark.slow
def test_own_netlist_within_compare_and_r3_plus_10_percent_ranked_further(tmp_path):
    """Done-when: the project's own netlist run as a user's file scores within what compare
    reports for ngspice (same scene, same 20 periods), and R3 + 10 % is further off."""
    from precise_impact.verification.compare import compare

    c = compare(SCENE, ["spice"], periods=20, progress=False).models["spice"]
    own = tmp_path / "own.cir"
    # one period more: ngspice writes no t = 0 under uic, the scored span starts at t = T
    own.write_text(own_netlist(21))
    edited = tmp_path / "r3.cir"
    text = own.read_text()
    assert "\nR3 p n2 10000.0\n" in text
    edited.write_text(text.replace("\nR3 p n2 10000.0\n", "\nR3 p n2 11000.0\n"))
    kw = dict(x_node="s", v_node="q", forcing_node="v3", scene=SCENE, periods=20)
    ra = score_netlist(own, out=tmp_path / "own", **kw)
    a = ra.runs[0]["scores"]
    # the panel's verdict counts the periods from the run's start (t0 = one period), not tau = 0
    titles = " ".join(ax.get_title() for ax in ra.plot().axes)
    n = (a["horizons"]["0.001"] - ra.runs[0]["initial_state"]["t0"]) * 0.74 / (2 * math.pi)
    assert f"({n:.1f} periods)" in titles
    # a result like the others: short repr, save() = to_dict(), a runs table
    assert len(repr(ra)) <= 400 and repr(ra).startswith("NetlistScoreResult(")
    saved = json.loads(ra.save(tmp_path / "r.json").read_text())
    assert saved == json.loads(json.dumps(ra.to_dict(), allow_nan=False))
    pd = pytest.importorskip("pandas")
    df = ra.to_dataframe()
    assert isinstance(df, pd.DataFrame) and len(df) == 1 and ra.tables() == ("runs",)
    b = score_netlist(edited, **kw).runs[0]["scores"]
    for f in ("scores.json", "phase_portraits.png", "separation.png"):
        assert (tmp_path / "own" / f).stat().st_size > 0
    # the same file as an LTspice export (.net): ngspice's LTspice mode, the same numbers
    lt = tmp_path / "own.net"
    lt.write_text(text)
    rl = score_netlist(lt, **kw)
    assert rl.ngspice["ltspice_mode"] == "ltpsa" and ra.ngspice["ltspice_mode"] is None
    assert rl.runs[0]["scores"]["sliced_wasserstein"] == a["sliced_wasserstein"]
    fitted = score_netlist(own, scales="fitted", **kw)
    assert a["regime"] == c["regime"] == "chaotic"
    # within compare's: the attractor distances within 1.5x of compare's (measured 0.95x),
    # the 1e-3 horizon, counted from each run's own start, at least 0.8x of compare's
    assert a["sliced_wasserstein"] <= 1.5 * c["sliced_wasserstein"]
    assert a["impact_v_wasserstein"] <= 1.5 * c["impact_v_wasserstein"]
    h0 = a["horizons"]["0.001"] - 2 * math.pi / 0.74
    assert h0 >= 0.8 * c["horizons"]["0.001"]
    # R3 + 10 %: further off on every measure
    assert b["sliced_wasserstein"] > 100 * a["sliced_wasserstein"]
    assert b["impact_v_wasserstein"] > 100 * a["impact_v_wasserstein"]
    assert b["horizons"]["0.001"] < a["horizons"]["0.001"]
    # fitted scales: the design's to within their stated errors, and the same scores
    m = fitted.mapping
    assert abs(m["omega"] - 1000) <= 3 * m["omega_stderr"] + 1e-12
    assert abs(m["R8C1"] - 1e-3) <= m["R8C1_stderr"]
    assert fitted.runs[0]["scores"]["sliced_wasserstein"] <= 1.5 * c["sliced_wasserstein"]


@needs_ngspice
@pytest.mark.slow
def test_ltspice_files_compressed_and_not_score_as_measured(tmp_path):
    """An LTspice-layout file (float32 traces) of a dense ngspice run scores like ngspice's own
    raw; compressed with LTspice's defaults it warns and scores >= 10x further off (measured over
    20 periods: sliced W 1.5e-3 vs 1.4e-5, benchmarks/results/netlist.md)."""
    ngspice(tmp_path, own_netlist(13, 1e-6).replace(WRDATA, "write d.raw V(s) V(q) V(pol) V(v3)"))
    (run,) = read_raw(tmp_path / "d.raw")
    ys = {n.upper(): run.traces[n][0] for n in ("v(s)", "v(q)", "v(pol)", "v(v3)")}
    keep = compress_like_ltspice(run.time, list(ys.values()))
    plain = _lt_raw(tmp_path / "u.raw", run.time, ys, "real forward nocompression")
    packed = _lt_raw(
        tmp_path / "k.raw", run.time[keep], {n: y[keep] for n, y in ys.items()}, "real forward"
    )
    kw = dict(impact_node="pol", scene=SCENE, periods=12, progress=False)
    own = score_netlist(tmp_path / "d.raw", "s", "q", "v3", **kw)
    u = score_netlist(plain, "s", "q", "v3", **kw)
    k = score_netlist(packed, "s", "q", "v3", **kw)
    assert (own.dialect, u.dialect) == ("ngspice", "ltspice")
    assert u.runs[0]["data_precision"] == "float32" and not u.warnings
    assert k.compression["compressed"] and len(k.warnings) == 1
    so, su, sk = (r.runs[0]["scores"]["sliced_wasserstein"] for r in (own, u, k))
    # float32 traces (6e-8 relative) move the attractor distance by far less than it is
    assert su == pytest.approx(so, rel=0.05)
    assert sk > 10 * su


def test_spice_netlist_writes_the_scenes_netlist_that_spice_score_runs(tmp_path, capsys):
    """``spice netlist`` (the README's starting point) writes exactly ``spice_netlist`` of the
    scene's design, effects and start, and ``spice score`` runs it back: the ideal circuit
    agrees with the mechanics from its first sample (sliced W of the sections below the
    1e-2 that ngspice's default tolerances reach over 10 periods; measured ~1e-3)."""
    path = tmp_path / "fig6.cir"
    assert (
        main(["spice", "netlist", "fig6-period3-ideal", "--periods", "11", "--out", str(path)]) == 0
    )
    assert path.read_text() == own_netlist(11)
    capsys.readouterr()
    assert main(["spice", "netlist", "fig6-period3-ideal", "--out", str(path)]) == 2  # no --force
    assert "out" in capsys.readouterr().err
    assert (
        main(
            [
                "spice",
                "netlist",
                "fig6-period3-ideal",
                "--periods",
                "0",
                "--out",
                str(tmp_path / "z.cir"),
            ]
        )
        == 2
    )
    assert "periods" in capsys.readouterr().err and not (tmp_path / "z.cir").exists()
    argv = ["spice", "score", str(path), "--x-node", "s", "--v-node", "q", "--forcing-node", "v3"]
    assert main(argv + ["--scene", "fig6-period3-ideal", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    (run,) = d["runs"]
    assert run["scores"]["sliced_wasserstein"] < 1e-2


# ---------------------------------------------------------------- review 24 items 5, 8, 10 (netfix)
def test_compression_warning_says_its_cost_is_measured_on_an_emulation(tmp_path):
    """The cost quoted is that of compress_like_ltspice (an emulation of LTspice's documented
    rule), not of LTspice output: the warning and the result say so."""
    t = np.linspace(0, 1e-2, 2001)
    ys = {"V(s)": np.sin(740 * t), "V(q)": np.cos(740 * t)}
    comp = lt_compression(read_raw(_lt_raw(tmp_path / "c.raw", t, ys, "real forward")))
    assert "emulation" in comp["warning"] and "not LTspice output" in comp["warning"]
    assert "compress_like_ltspice" in comp["cost"]["measured_on"]
    assert len(comp["warning"].splitlines()) == 1


@needs_ngspice
def test_components_mapping_is_circuit_scales(raws, monkeypatch):
    """The components-mode volts -> (x, v, tau) scales come from circuit_scales (the one home),
    bit for bit the numbers of the hand-written formulas they replace."""
    import precise_impact.lab.netlist as nl
    from precise_impact.models.circuit.components import circuit_scales

    calls = []

    def spy(design):
        calls.append(design)
        return circuit_scales(design)

    monkeypatch.setattr(nl, "circuit_scales", spy)
    r = score_netlist(raws / "b.raw", "s", "q", "v3", scene=SCENE, progress=False)
    design = load_scene(SCENE).design()
    cs = circuit_scales(design)
    m = r.mapping
    assert calls and m["mode"] == "components"
    assert (m["omega"], m["seconds_per_tau"], m["volts_per_x"], m["volts_per_v"]) == (
        cs.omega,
        cs.seconds_per_tau,
        cs.volts_per_x,
        cs.volts_per_v,
    )
    # the formulas the mapping had by hand before (bit-identical numbers)
    omega, vu = float(design.omega()), float(design.V_unit)
    assert m["volts_per_v"] == omega * float(design.R8 * design.C1) * vu
    assert m["volts_per_x"] == -vu


def _never_run(*a, **k):
    raise AssertionError("ngspice was run")


def test_spice_score_refuses_an_oversized_tran_before_running(tmp_path, monkeypatch, capsys):
    """`.tran 1e-05 1000` is 1e8 time points: refused from its estimate (one line, exit 3)
    before ngspice starts, instead of running into the 600 s timeout."""
    import precise_impact.lab.netlist as nl

    monkeypatch.setattr(nl.subprocess, "run", _never_run)
    net = tmp_path / "long.cir"
    net.write_text(own_netlist(3).replace(".tran", ".tran 1e-05 1000 *", 1))
    assert nl.tran_cost(net.read_text()).seconds == pytest.approx(
        1e8 * nl.NGSPICE_SECONDS_PER_POINT
    )
    argv = ["spice", "score", str(net), "--x-node", "s", "--v-node", "q", "--scene", SCENE]
    assert main([*argv, "--max-time", "60"]) == 3
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "1e+08 time points" in err and "max_time" in err


@needs_ngspice
def test_ngspice_timeout_is_a_budget(tmp_path):
    """ngspice stopped by its time limit is a budget exceeded (the CLI's exit 3), not a
    failure of the netlist."""
    from precise_impact.errors import BudgetExceededError

    net = tmp_path / "slow.cir"
    net.write_text(own_netlist(20, 1e-6))  # ~4.7 s of ngspice
    with pytest.raises(BudgetExceededError, match="did not finish"):
        run_netlist(net, timeout=0.2)


@pytest.mark.parametrize(
    ("extra", "word"),
    [
        (["--x-node", "nosuch", "--v-node", "q"], "x-node"),
        (["--x-node", "s", "--v-node", "q", "--forcing-node", "v(nosuch)"], "forcing-node"),
        (["--x-node", "s", "--v-node", "q", "--step", "5"], "step"),
    ],
)
def test_spice_score_refuses_missing_nodes_and_steps_before_running(
    extra, word, tmp_path, monkeypatch, capsys
):
    import precise_impact.lab.netlist as nl

    monkeypatch.setattr(nl.subprocess, "run", _never_run)
    net = tmp_path / "own.cir"
    net.write_text(own_netlist(3))
    assert main(["spice", "score", str(net), *extra, "--scene", SCENE]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and word in err


def test_periods_have_one_range_in_the_cli_and_the_api(tmp_path, capsys):
    net = tmp_path / "own.cir"
    net.write_text(own_netlist(3))
    argv = ["spice", "score", str(net), "--x-node", "s", "--v-node", "q", "--scene", SCENE]
    assert main([*argv, "--periods", "1"]) == 2
    cli = capsys.readouterr().err.strip()
    with pytest.raises(ParameterError) as e:
        score_netlist(net, "s", "q", scene=SCENE, periods=1, progress=False)
    assert str(e.value) in cli and "2 <= periods <= 1000000" in cli


def test_zero_gain_is_refused_as_such(tmp_path):
    (tmp_path / "m.toml").write_text('[nodes]\nx = "s"\nv = "q"\n[gains]\nx = 0\n')
    with pytest.raises(ParameterError, match="gain must be non-zero"):
        load_map(tmp_path / "m.toml")


def test_spice_score_refuses_a_tran_too_large_for_memory_naming_it(tmp_path, monkeypatch):
    """Under the default budget the 1e8-point run is refused by its memory estimate: the
    line names the file and its .tran, not 'periods'."""
    import precise_impact.core.budget as cb
    import precise_impact.lab.netlist as nl
    from precise_impact.errors import OverBudgetError

    monkeypatch.setattr(nl.subprocess, "run", _never_run)
    monkeypatch.setattr(cb, "_memory", lambda: 8e9)  # an 8 GB machine
    net = tmp_path / "long.cir"
    net.write_text(own_netlist(3).replace(".tran", ".tran 1e-05 1000 *", 1))
    with pytest.raises(OverBudgetError) as e:
        run_netlist(net, max_time=3600)
    assert e.value.name == "file" and "1e+08 time points" in str(e.value)


def test_node_check_reads_element_terminals_only_where_decidable():
    from precise_impact.lab.netlist import check_nodes

    text = "* t\nV1 in 0 SIN(0 1 1k)\nR1 in out 1k\n+ \nXU1 out mid opamp\nC1 mid 0 1n\n"
    text += ".tran 1u 1m\n"
    check_nodes(text, {"x": "out", "v": "V(MID)", "forcing": "in", "impact": None})
    check_nodes(text, {"x": "xu1.inner"})  # inside a subcircuit: ngspice decides
    check_nodes(text + ".include models.lib\n", {"x": "elsewhere"})  # nodes may be there
    with pytest.raises(ParameterError, match="none of its element lines") as e:
        check_nodes(text, {"v": "t"})  # the title line is not an element
    assert e.value.name == "v-node"
