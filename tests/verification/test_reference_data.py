"""The shipped reference datasets: integrity, tamper detection, and the public testing API."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from precise_impact import Params, simulate
from precise_impact.cli.main import main as cli_main
from precise_impact.testing import assert_stroboscopic_close, load_reference, score_solver
from precise_impact.verification.reference import CASES, default_root, verify

ROOT = default_root()


def heyoka_float64(params: dict, periods: int):
    """A user solver: heyoka in float64 (params are exact decimal strings)."""
    traj = simulate(Params.make(**params), periods, precision="float64")
    return traj.x, traj.v


def test_shipped_data_verifies():
    assert verify(ROOT) == []


def test_shipped_data_is_small_and_complete():
    total = 0
    for case in CASES:
        manifest = json.loads((ROOT / case / "manifest.json").read_text())
        assert {
            "params",
            "model",
            "precision",
            "tolerance",
            "versions",
            "accuracy",
            "files",
        } <= manifest.keys()
        assert {"heyoka", "numpy", "mpmath", "python"} <= manifest["versions"].keys()
        total += sum(f["bytes"] for f in manifest["files"].values())
    assert total < 5 * 2**20


def test_tampered_copy_is_detected(tmp_path):
    copy = tmp_path / "ref"
    shutil.copytree(ROOT, copy)
    assert verify(copy, cases=["single-0.74"]) == []
    p = copy / "single-0.74" / "samples.json"
    data = json.loads(p.read_text())
    x = data["samples"][5]["x"]
    data["samples"][5]["x"] = (
        x[:-3] + ("1" if x[-3] != "1" else "2") + x[-2:]
    )  # one digit, far below float64
    p.write_text(json.dumps(data, indent=1) + "\n")
    problems = verify(copy, cases=["single-0.74"])
    assert problems and "checksum" in problems[0]
    assert cli_main(["reference", "verify", "--root", str(copy), "--case", "single-0.74"]) == 1
    # A missing case is a problem too.
    shutil.rmtree(copy / "lle")
    assert any("lle" in q for q in verify(copy, cases=["lle"]))


def test_recomputation_catches_a_consistent_forgery(tmp_path):
    """Data changed *and* re-checksummed still fails the float128 recomputation."""
    from precise_impact.verification.reference import read_manifest, write_manifest

    copy = tmp_path / "ref"
    shutil.copytree(ROOT / "single-0.712", copy / "single-0.712")
    p = copy / "single-0.712" / "samples.json"
    data = json.loads(p.read_text())
    data["samples"][3]["v"] = "0.5"
    p.write_text(json.dumps(data, indent=1) + "\n")
    m = read_manifest(copy / "single-0.712")
    write_manifest(
        copy / "single-0.712", list(m["files"]), {k: v for k, v in m.items() if k != "files"}
    )
    problems = verify(copy, cases=["single-0.712"])
    assert problems and "period 3" in problems[0]


def test_heyoka_float64_passes_at_1e6():
    r = assert_stroboscopic_close(heyoka_float64, "single-0.74", periods=30, atol=1e-6, rtol=1e-6)
    assert r["passed"] and r["max_error"] < 1e-3


def test_wrong_solver_fails_with_a_clear_message():
    def wrong(params, periods):  # eta off by 1e-4
        traj = simulate(Params.make(**{**params, "eta": "0.7401"}), periods)
        return traj.x, traj.v

    with pytest.raises(AssertionError, match=r"first failure at period \d+"):
        assert_stroboscopic_close(wrong, "single-0.74", periods=30, atol=1e-6, rtol=1e-6)
    with pytest.raises(AssertionError, match="31 samples each"):
        assert_stroboscopic_close(lambda p, n: ([0.0] * n, [0.0] * n), "single-0.74", periods=30)
    assert score_solver(wrong, "single-0.74", periods=30)["passed"] is False


def test_load_reference():
    ref = load_reference("single-0.712")
    assert ref.params["eta"] == "0.712" and ref.periods == 300 and ref.precision.startswith("mp:")
    assert ref.accuracy < 1e-40 and len(ref.impacts) > 100
    f = load_reference("single-0.712", as_float=True)
    assert isinstance(f.x[10], float) and abs(f.x[10] - float(ref.x[10])) == 0


def test_readme_example():
    # --- README example: test your own solver against the reference -----------------
    from precise_impact import Params, simulate
    from precise_impact.testing import assert_stroboscopic_close, load_reference, score_solver

    def my_solver(params, periods):
        # params: exact decimal strings {"zeta": "0.05", "a": "1", "eta": "0.74", ...};
        # return x and v at t0 + k 2 pi / eta, k = 0..periods.
        traj = simulate(Params.make(**params), periods, precision="float64")
        return traj.x, traj.v

    # Passes silently, or raises AssertionError naming the first bad period.
    assert_stroboscopic_close(my_solver, "single-0.74", periods=30, atol=1e-6, rtol=1e-6)

    # The errors themselves: |y - y_ref| / (atol + rtol |y_ref|) at every sample.
    scores = score_solver(my_solver, "single-0.712", periods=60, atol=1e-9, rtol=1e-9)
    print(f"worst scaled error {scores['max_error']:.2e} at period {scores['worst_period']}")

    ref = load_reference("single-0.712")  # mpmath values, demonstrated to ref.accuracy
    print(ref.precision, ref.accuracy, ref.x[300])
    # ---------------------------------------------------------------------------------
    assert np.isfinite(scores["max_error"])


def test_environment_override_is_honoured_by_the_cli(tmp_path):
    """$PRECISE_IMPACT_REFERENCE points `reference verify` (and every other entry point) at a copy:
    a tampered copy must fail there, while the shipped data still passes."""
    import os
    import subprocess
    import sys

    copy = tmp_path / "ref"
    shutil.copytree(ROOT / "single-0.74", copy / "single-0.74")
    p = copy / "single-0.74" / "samples.json"
    p.write_text(p.read_text().replace('"x": "0', '"x": "1', 1))
    env = dict(os.environ, PRECISE_IMPACT_REFERENCE=str(copy))
    cmd = [sys.executable, "-m", "precise_impact", "reference", "verify", "--case", "single-0.74"]
    bad = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
    assert bad.returncode == 1 and "checksum mismatch" in bad.stdout + bad.stderr
    env.pop("PRECISE_IMPACT_REFERENCE")
    good = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
    assert good.returncode == 0, good.stdout + good.stderr


def test_a_damaged_reference_is_an_error_not_a_verdict(tmp_path):
    """0.1.0 scored against a corrupted copy, blamed the correct solver and reported the reference
    as accurate.  Now the checksums are checked first: the error names the file, for the
    testing API with root= and through $PRECISE_IMPACT_REFERENCE alike."""
    import os

    from precise_impact import ReferenceDataError

    copy = tmp_path / "ref"
    shutil.copytree(ROOT / "single-0.74", copy / "single-0.74")
    p = copy / "single-0.74" / "samples.json"
    p.write_text(p.read_text().replace('"x": "0', '"x": "1', 1))
    with pytest.raises(ReferenceDataError, match=r"samples\.json"):
        assert_stroboscopic_close(
            heyoka_float64, "single-0.74", periods=30, atol=1e-6, rtol=1e-6, root=copy
        )
    os.environ["PRECISE_IMPACT_REFERENCE"] = str(copy)
    try:
        with pytest.raises(ReferenceDataError, match="checksum mismatch"):
            load_reference("single-0.74")
    finally:
        del os.environ["PRECISE_IMPACT_REFERENCE"]
    assert load_reference("single-0.74").name == "single-0.74"  # the shipped data still loads


@pytest.mark.parametrize(
    "samples,where",
    [
        (lambda n: (["abc"] * n, ["1"] * n), "x[0] = 'abc'"),
        (lambda n: (np.zeros((n, 2)), np.zeros((n, 2))), "x[0] = array([0., 0.])"),
        (lambda n: ([0.5] * n, [0.1] * (n - 1) + ["1e"]), "v[30] = '1e'"),
        (lambda n: ([True] * n, [0.0] * n), "x[0] = True"),
    ],
    ids=["strings", "2-D", "bad-decimal", "bools"],
)
def test_a_solver_returning_non_numbers_is_one_refusal_naming_solver(samples, where):
    """Strings or rows of a 2-D array as samples: one ParameterError naming ``solver`` and
    the sample (before: ValueError "invalid literal for int() with base 10: 'abc'")."""
    from precise_impact.errors import ParameterError

    with pytest.raises(ParameterError) as e:
        score_solver(lambda p, n: samples(n + 1), "single-0.74", periods=30)
    assert e.value.name == "solver" and where in str(e.value) and "\n" not in str(e.value)


@pytest.mark.parametrize(
    "kw,name",
    [
        ({"case": np.zeros((2, 2))}, "case"),
        ({"case": "nope"}, "case"),
        ({"periods": "3"}, "periods"),
        ({"periods": np.zeros((3, 3))}, "periods"),
        ({"atol": "1e-6"}, "atol"),
        ({"rtol": True}, "rtol"),
        ({"atol": 0, "rtol": 0}, "atol"),
    ],
)
def test_bad_score_options_are_one_line_refusals_naming_them(kw, name):
    from precise_impact.errors import ParameterError

    with pytest.raises(ParameterError) as e:
        score_solver(lambda p, n: ([0.0] * (n + 1), [0.0] * (n + 1)), **kw)
    assert e.value.name == name and "\n" not in str(e.value), str(e.value)
