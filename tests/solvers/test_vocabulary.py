"""One vocabulary (issue 23): ``precision=``, ``model=`` / ``method=``, ``segments``,
``guess_from``; each 0.2 spelling kept one release with a DeprecationWarning, same numbers."""

import json
import subprocess
import sys
import warnings

import pytest

from precise_impact import Params
from precise_impact.errors import ParameterError
from precise_impact.solvers.certified.coupled import certify_coupled
from precise_impact.solvers.certified.single import certify

P = Params.make(eta="0.74")


def test_precision_mp_bits_is_the_old_bits_exactly():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        new = certify(P, 5, precision="mp:128", max_bits=128)
    with pytest.warns(DeprecationWarning, match="certify: bits= is deprecated, use precision="):
        old = certify(P, 5, bits=128, max_bits=128)
    assert new.bits == old.bits == 128
    assert [tuple(map(str, s)) for s in new.samples] == [tuple(map(str, s)) for s in old.samples]


def test_auto_is_the_default_and_chooses_the_bits():
    r = certify(P, 5)
    assert r.bits_choice != "given" and r.bits >= 128


@pytest.mark.parametrize("bad", ["float64", "mp:32", "mp:99999", "auto2", 128])
def test_a_bad_precision_is_refused_before_work_naming_it(bad):
    with pytest.raises(ParameterError, match=r"^precision = .*'auto' or 'mp:BITS' with 64"):
        certify(P, 5, precision=bad)


def test_the_pair_takes_mp_bits_and_auto():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = certify_coupled(P, "0.1", periods=3, precision="mp:192")
    assert r.bits == 192 and r.bits_choice == "given"
    r = certify_coupled(P, "0.1", periods=3, precision="auto")  # the pilot's choice
    assert r.bits_choice.startswith("automatic") and r.max_radius() <= 1e-30
    with pytest.raises(ParameterError, match=r"^precision = 'mp:8' is not allowed: 'auto' or"):
        certify_coupled(P, "0.1", periods=3, precision="mp:8")


def test_cli_precision_flag_and_the_deprecated_bits_flag():
    cmd = [sys.executable, "-m", "precise_impact", "certify", "--eta", "0.74", "--periods", "3"]
    new = subprocess.run([*cmd, "--precision", "mp:128", "--json"], capture_output=True, text=True)
    old = subprocess.run([*cmd, "--bits", "128", "--json"], capture_output=True, text=True)
    assert new.returncode == old.returncode == 0, (new.stderr, old.stderr)
    assert json.loads(new.stdout)["bits"] == json.loads(old.stdout)["bits"] == 128
    assert "--bits is deprecated" in old.stderr and "deprecated" not in new.stderr


def test_closed_form_precision_is_the_old_backend_dps_bits_exactly():
    """AnalyticalSolver(precision='mp:103') is backend='mpmath', dps=30 (mpmath's 103 bits)."""
    from precise_impact.solvers.closed_form import AnalyticalSolver

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        new = AnalyticalSolver(precision="mp:103").solve(P, 20)
        f64 = AnalyticalSolver(precision="float64").solve(P, 20)
    with pytest.warns(DeprecationWarning, match="AnalyticalSolver: backend=/dps= is deprecated"):
        old = AnalyticalSolver(backend="mpmath", dps=30).solve(P, 20)
    with pytest.warns(DeprecationWarning):
        old64 = AnalyticalSolver(backend="float64").solve(P, 20)
    assert new.precision.name == old.precision.name == "mp:103"
    assert [str(x) for x in new.x] == [str(x) for x in old.x]
    assert list(f64.x) == list(old64.x) and list(f64.v) == list(old64.v)
    with pytest.raises(ParameterError, match="^precision = 'float128'"):
        AnalyticalSolver(precision="float128")
    with pytest.raises(ParameterError, match="^backend = .*not with precision="):
        AnalyticalSolver(backend="mpmath", precision="mp:128")


def test_find_orbit_guess_from_and_the_deprecated_seed():
    """``seed`` means an RNG seed elsewhere (score, sync_scan); find_orbit's start strategy is
    ``guess_from``."""
    from precise_impact import find_orbit

    p = Params.make(R="0.8", eta="1")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        new = find_orbit(p, 1, guess_from="closed-form")
    with pytest.warns(DeprecationWarning, match="find_orbit: seed= is deprecated, use guess_from="):
        old = find_orbit(p, 1, seed="closed-form")
    assert (new.x, new.v, new.lle) == (old.x, old.v, old.lle)
    with pytest.raises(ParameterError, match="^guess_from = "):
        find_orbit(p, 1, guess_from="random")


def test_fast_lle_segments_and_the_deprecated_blocks():
    from precise_impact.solvers.fast.lle import fast_lle

    p = Params.make(eta="0.712")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        new = fast_lle(p, periods=400, transient=100, segments=8)
    with pytest.warns(DeprecationWarning, match="fast_lle: blocks= is deprecated, use segments="):
        old = fast_lle(p, periods=400, transient=100, blocks=8)
    assert new["lle"] == old["lle"] and new["stderr"] == old["stderr"]


def test_lyapunov_model_fast_is_the_old_method_fast():
    from precise_impact import lyapunov

    p = Params.make(eta="0.712")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        new = lyapunov(p, "variational", model="fast", periods=400, transient=100)
    with pytest.warns(DeprecationWarning, match="method='fast' is deprecated"):
        old = lyapunov(p, "fast", periods=400, transient=100)
    assert new.lle == old.lle and new.lle_stderr == old.lle_stderr
    with pytest.raises(ParameterError, match="^model = 'fast' .* heyoka with method='two-traj"):
        lyapunov(p, "two-trajectory", model="fast")


def test_cli_lle_model_flag_and_the_deprecated_method_fast():
    cmd = [sys.executable, "-m", "precise_impact", "lle", "--periods", "300", "--transient", "50"]
    new = subprocess.run([*cmd, "--model", "fast", "--json"], capture_output=True, text=True)
    old = subprocess.run([*cmd, "--method", "fast", "--json"], capture_output=True, text=True)
    assert new.returncode == old.returncode == 0, (new.stderr, old.stderr)
    assert json.loads(new.stdout)["lle"] == json.loads(old.stdout)["lle"]
    assert "--method fast is deprecated" in old.stderr
