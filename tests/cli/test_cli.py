"""The command-line contract other tools script against."""

from __future__ import annotations

import json
import subprocess
import sys
from fractions import Fraction

import numpy as np
import pytest

from helpers import check_accuracy_outputs
from precise_impact import Params, Precision, simulate
from precise_impact.cli.main import main


def run(*args):
    return subprocess.run(
        [sys.executable, "-m", "precise_impact", *args], capture_output=True, text=True, timeout=300
    )


def test_simulate_json_contract():
    r = run("simulate", "--eta", "0.74", "--periods", "12", "--precision", "float128", "--json")
    assert r.returncode == 0, r.stderr
    obj = json.loads(r.stdout)  # exactly one JSON object
    assert set(obj) == {
        "params",
        "model",
        "precision",
        "tol",
        "digits",
        "samples",
        "impacts",
        "elapsed_s",
    }
    assert obj["digits"]["basis"] == "estimated" and obj["digits"]["max_possible"] == 33
    assert all(0 <= s["x_digits"] <= 33 and 0 <= s["v_digits"] <= 33 for s in obj["samples"])
    assert obj["params"] == {
        "zeta": "0.05",
        "a": "1",
        "eta": "0.74",
        "x_w": "2",
        "R": "1",
        "x0": "0",
        "v0": "0",
        "t0": "0",
    }
    assert obj["model"] == "heyoka" and obj["precision"] == "float128"
    assert [s["period"] for s in obj["samples"]] == list(range(13))
    assert isinstance(obj["elapsed_s"], float)
    P = Precision.parse("float128")
    # full digits: the strings round-trip to the float128 values of the Python API
    tr = simulate(Params.make(eta="0.74"), 12, precision="float128")
    assert [s["x"] for s in obj["samples"]] == [P.to_str(x) for x in tr.x]
    assert len(obj["samples"][5]["x"].lstrip("-").replace(".", "").lstrip("0").split("e")[0]) >= 33
    assert len(obj["impacts"]) == tr.n_impacts > 0
    imp = obj["impacts"][0]
    assert Fraction(imp["v_after"]) == -Fraction(imp["v_before"])


@pytest.mark.parametrize("model", ["analytical", "analytical-paper"])
def test_simulate_analytical_models(model):
    r = run("simulate", "--eta", "0.74", "--periods", "5", "--model", model, "--json")
    assert r.returncode == 0, r.stderr
    obj = json.loads(r.stdout)
    assert obj["model"] == model and obj["tol"] is None and len(obj["samples"]) == 6


@pytest.mark.parametrize(
    "args, name",
    [
        (["--eta", "-1"], "eta"),
        (["--zeta", "nan"], "zeta"),
        (["--R", "2"], "R"),
        (["--x0", "5"], "x0"),
        (["--periods", "-3"], "periods"),
        (["--periods", "ten"], "periods"),
        (["--precision", "mp:8"], "precision"),
        (["--model", "euler"], "model"),
        (["--tol", "-1e-9"], "tol"),
        (["--out", "x.txt"], "out"),
    ],
)
def test_bad_input_exit_2_no_traceback(args, name):
    r = run("simulate", *args)
    assert r.returncode == 2
    assert "Traceback" not in r.stderr
    assert r.stderr.startswith(f"precise-impact: error: {name} = ")
    assert r.stdout == ""


def test_out_files(tmp_path, capsys):
    npz, csv = tmp_path / "a.npz", tmp_path / "a.csv"
    assert (
        main(
            [
                "simulate",
                "--eta",
                "0.74",
                "--periods",
                "6",
                "--precision",
                "mp:128",
                "--dense",
                "10",
                "--out",
                str(npz),
            ]
        )
        == 0
    )
    assert main(["simulate", "--eta", "0.74", "--periods", "6", "--out", str(csv)]) == 0
    d = np.load(npz)
    tr = simulate(Params.make(eta="0.74"), 6, precision="mp:128")
    P = tr.precision
    assert list(d["x_str"]) == [P.to_str(x) for x in tr.x]
    assert d["dense_t"].shape == (61,)
    lines = csv.read_text().splitlines()
    assert lines[0] == "kind,index,t,x,v_or_v_before,v_after,x_digits,v_digits"
    assert sum(1 for ln in lines if ln.startswith("sample,")) == 7
    claim = simulate(Params.make(eta="0.74"), 6).claimed_digits()
    last = lines[7].split(",")  # sample 6: its claimed digits in the last two columns
    assert last[0] == "sample" and (int(last[6]), int(last[7])) == (claim.x[6], claim.v[6])
    assert all(len(ln.split(",")) == 8 for ln in lines)
    assert not list(tmp_path.glob(".*.tmp"))  # atomic writes leave no temporaries


@pytest.mark.covered_by("tests/test_readme_sequence.py::test_readme_sequence")
def test_accuracy_job(tmp_path):
    """The README's ``accuracy`` job: a table, a JSON file and a plot; references demonstrated
    (the slow README sequence checks the same on the README's own run of 100 periods)."""
    r = run("accuracy", "--periods", "30", "--out", str(tmp_path))
    assert r.returncode == 0, r.stderr
    check_accuracy_outputs(tmp_path, r.stdout)


def test_lle_json_contract():
    r = run("lle", "--eta", "0.70", "--periods", "300", "--transient", "3000", "--json")
    assert r.returncode == 0, r.stderr
    obj = json.loads(r.stdout)
    assert set(obj) == {
        "params",
        "method",
        "lle",
        "spectrum",
        "lle_stderr",
        "periods",
        "n_impacts",
        "elapsed_s",
        "stats",
        "stderr",  # the 0.2 names, kept for one release beside the new ones
        "impacts",
    }
    assert obj["method"] == "variational" and obj["periods"] == 300 and obj["n_impacts"] == 0
    assert obj["stderr"] == obj["lle_stderr"] and obj["impacts"] == obj["n_impacts"]
    assert abs(obj["lle"] + 0.05) < 1e-3 and abs(sum(obj["spectrum"]) + 0.1) < 1e-12


@pytest.mark.parametrize(
    "args, name",
    [
        (["--method", "qr"], "method"),
        (["--transient", "-1"], "transient"),
        (["--periods", "0"], "periods"),
    ],
)
def test_lle_bad_input(args, name):
    r = run("lle", *args)
    assert r.returncode == 2 and r.stderr.startswith(f"precise-impact: error: {name} = ")


def test_orbit_json_contract():
    """The issue's contract: one object with params, period, impacts, state {t, x, v},
    multipliers [[re, im], ...], stable, lle, residual; the period-3 orbit at eta = 0.74."""
    r = run("orbit", "--eta", "0.74", "--period", "3", "--json")
    assert r.returncode == 0, r.stderr
    obj = json.loads(r.stdout)
    assert {
        "params",
        "period",
        "impacts",
        "state",
        "multipliers",
        "stable",
        "lle",
        "residual",
    } <= set(obj)
    assert obj["period"] == 3 and obj["impacts"] == 2 and obj["stable"] is True
    assert set(obj["state"]) == {"t", "x", "v"} and all(len(m) == 2 for m in obj["multipliers"])
    assert obj["residual"] < 1e-13


@pytest.mark.parametrize(
    "args, name, code",
    [
        (["--period", "0"], "period", 2),
        (["--impacts", "-2"], "impacts", 2),
        (["--guess", "9", "0"], "guess[0]", 2),
    ],
)
def test_orbit_bad_input(args, name, code):
    r = run("orbit", "--eta", "0.74", *args)
    assert r.returncode == code and r.stderr.startswith(f"precise-impact: error: {name} = "), (
        r.stderr
    )


def test_orbit_newton_failure_is_one_line_exit_3():
    r = run("orbit", "--eta", "0.74", "--period", "3", "--impacts", "5")
    assert r.returncode == 3 and "not 5" in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_bifurcation_cli(tmp_path):
    r = run(
        "bifurcation",
        "--eta",
        "0.70",
        "0.72",
        "3",
        "--periods",
        "100",
        "--transient",
        "200",
        "--out",
        str(tmp_path),
    )
    assert r.returncode == 0, r.stderr
    assert "grazing eta (closed form): 0.710687" in r.stdout
    assert (tmp_path / "bifurcation.png").exists() and (tmp_path / "bifurcation.npz").exists()
    assert "3/3" in r.stderr  # progress bar
    bad = run("bifurcation", "--eta", "0.7", "0.7", "3", "--out", str(tmp_path / "new"))
    assert bad.returncode == 2 and bad.stderr.startswith("precise-impact: error: eta_max = ")


def test_sync_cli(tmp_path):
    """Coarse scan: k = 0 never synchronises, k = 0.08 always does; plots and JSON written."""
    r = run(
        "sync",
        "--form",
        "reduced",
        "--k",
        "0",
        "0.08",
        "2",
        "--periods",
        "300",
        "--ensemble",
        "3",
        "--out",
        str(tmp_path),
        "--json",
    )
    assert r.returncode == 0, r.stderr
    obj = json.loads(r.stdout)
    assert obj["form"] == "reduced" and obj["k_values"] == ["0", "0.08"]
    assert obj["fraction_synchronised"] == [0.0, 1.0]
    assert 0 < obj["k_star"] < 0.08 and obj["lle"] > 0
    for name in ("sync_reduced.json", "sync_reduced_fraction.png", "sync_reduced_fig7.png"):
        assert (tmp_path / name).stat().st_size > 1000
    bad = run("sync", "--form", "diagonal", "--out", str(tmp_path / "new"))
    assert bad.returncode == 2 and bad.stderr.startswith("precise-impact: error: form = ")
    # a reversed range is run, not refused (issue 28); the k grid is stored ascending, the
    # order in which the threshold k* is read off
    rev = run("sync", "--k", "0.05", "0.01", "3", "--periods", "50", "--out", str(tmp_path / "rev"))
    assert rev.returncode == 0, rev.stderr
    assert json.loads((tmp_path / "rev" / "sync_first-order.json").read_text())["k_values"] == [
        "0.01",
        "0.03",
        "0.05",
    ]


def test_sweep_cli_resumes(tmp_path):
    args = (
        "sweep",
        "--axis",
        "eta",
        "0.70",
        "0.74",
        "6",
        "--periods",
        "100",
        "--transient",
        "50",
        "--tile",
        "3",
        "--out",
        str(tmp_path),
        "--json",
    )
    r = run(*args)
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    assert s["tiles_computed"] == 2 and s["complete"]
    again = json.loads(run(*args).stdout)
    assert again["tiles_reused"] == 2 and again["tiles_computed"] == 0
    assert (
        (tmp_path / "sweep.csv")
        .read_text()
        .startswith("eta,lle,stderr,lambda2,period,impacts_per_period")
    )
    bad = run("sweep", "--axis", "R", "0", "2", "3", "--out", str(tmp_path / "b"))
    assert bad.returncode == 2 and bad.stderr.startswith("precise-impact: error: R_max = ")


def test_bench_work_precision_without_json_prints_the_table(capsys, monkeypatch):
    """``bench work-precision --quick --out DIR`` without ``--json`` (a README line) ended in
    ``AttributeError: 'WorkPrecisionResult' object has no attribute 'get'`` after its run, the
    table lost.  Through the CLI on a tiny configuration, without ``--out`` (the plots take
    seconds; the README's line with ``--out`` runs in the slow ``test_readme_sequence``)."""
    from precise_impact.cli.commands import bench
    from precise_impact.verification.workprecision import work_precision

    tiny = {  # a configuration that runs in a second (work_precision's config=)
        "cases": {
            "periodic": {"eta": "0.74", "periods": 10},
            "chaotic": {"eta": "0.712", "periods": 10},
        },
        "heyoka": {"float64": ["1e-9", None]},
        "heyoka_mp": [],
        "analytical_paper": [],
        "analytical_robust": True,
        "analytical_mp_dps": [],
        "scipy": {},
        "spice_tmax": [],
        "chaos_N": [10],
        "certify_N": 10,
        "budget_s": 0.5,
        "circuit": True,
    }
    monkeypatch.setattr(
        bench,
        "work_precision",
        lambda quick, out, progress: work_precision(
            quick=quick, out=out, progress=progress, config=tiny
        ),
    )
    assert main(["bench", "work-precision", "--quick"]) == 0
    text = capsys.readouterr().out
    assert "Headlines:" in text and "heyoka float64" in text and "What chaos costs" in text
    assert "one 10-period solve each, set-up included" in text


# ------------------------------------------------------------------ claimed digits (issue 27)
def _strict(text):
    def bad(tok):
        raise ValueError(f"non-JSON token {tok}")

    return json.loads(text, parse_constant=bad)


def _main(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_simulate_json_states_claimed_digits_per_sample(capsys):
    """``--json`` says how many digits each sample claims and on what basis; 0.712 in float64
    loses them all by period ~90 (the truth: ~0.13 digits a period, LLE 0.0302 / ln 10 T)."""
    code, out, err = _main(capsys, "simulate", "--periods", "150", "--json")
    assert code == 0, err
    obj = _strict(out)
    d = obj["digits"]
    assert d["basis"] == "estimated" and d["max_possible"] == 15 and d["final"] == 0
    assert 60 <= d["first_unclaimed_period"] <= 110
    claims = [min(s["x_digits"], s["v_digits"]) for s in obj["samples"]]
    assert claims[0] == 15 and claims[10] >= 8 and claims[-1] == 0
    assert "no significant digit" in err and err.count("\n") == 1  # one warning line


def test_simulate_prints_no_more_digits_than_claimed(capsys):
    code, out, err = _main(capsys, "simulate", "--periods", "150")
    assert code == 0, err
    assert err.startswith("warning: no significant digit of the final state")
    xline = next(line for line in out.splitlines() if line.strip().startswith("x = "))
    value, mark = xline.split("=", 1)[1].strip().split(" ", 1)
    assert mark == "(no digit claimed)" and len(value.lstrip("-").replace(".", "")) == 3
    # a periodic run keeps most digits: printed to exactly the claim
    code, out, err = _main(capsys, "simulate", "--eta", "0.74", "--periods", "20", "--json")
    claim = _strict(out)["samples"][-1]["x_digits"]
    code, out, err = _main(capsys, "simulate", "--eta", "0.74", "--periods", "20")
    assert code == 0 and err == ""
    xline = next(line for line in out.splitlines() if line.strip().startswith("x = "))
    digits = xline.split("=", 1)[1].strip().lstrip("-").replace(".", "").lstrip("0")
    assert 9 <= claim <= 14 and len(digits) == claim
    assert f"x {claim}, v " in out and "estimated from the precision" in out


def test_simulate_demonstrate_flag(capsys):
    code, out, err = _main(capsys, "simulate", "--periods", "40", "--demonstrate", "--json")
    assert code == 0, err
    d = _strict(out)["digits"]
    assert d["basis"] == "demonstrated" and d["reference"] == "mp:128"
    code, out, err = _main(capsys, "simulate", "--periods", "4", "--demonstrate", "float64")
    assert code == 2 and "demonstrate" in err and out == ""
    code, out, err = _main(
        capsys, "simulate", "--periods", "4", "--model", "spice", "--demonstrate"
    )
    assert code == 2 and "spice" in err and out == ""
    code, out, err = _main(capsys, "simulate", "--periods", "4", "--demonstrate", "mp:1000000000")
    assert code == 2 and "64 <= BITS <= 8192" in err and out == ""  # the precision's own range


def test_run_prints_the_last_sample_to_its_claimed_digits(capsys):
    code, out, err = _main(capsys, "run", "fig6-period3-ideal", "--json")
    assert code == 0, err
    obj = _strict(out)
    last = obj["samples"][-1]
    assert obj["digits"]["basis"] == "estimated" and 5 <= last["x_digits"] <= 15
    code, out, err = _main(capsys, "run", "fig6-period3-ideal")
    line = next(ln for ln in out.splitlines() if ln.startswith("last sample:"))
    x = line.split("x = ", 1)[1].split(",", 1)[0]
    assert len(x.lstrip("-").replace(".", "").lstrip("0")) == last["x_digits"]
    code, out, err = _main(capsys, "run", "fig5-chaotic-ideal")
    assert "(no digit claimed)" in out and err.startswith("warning: no significant digit")
