"""Bad input everywhere (API and CLI), property-based invariants, and undamped resonance."""

from __future__ import annotations

from fractions import Fraction

import mpmath
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from precise_impact import HeyokaSolver, ParameterError, Params, Precision, simulate
from precise_impact.cli.main import main
from precise_impact.core.params import PARAM_NAMES

BAD_NUMBERS = ["nan", "NaN", "inf", "-inf", "Infinity", "abc", "", "1e", "0x10", "1/0"]


# ------------------------------------------------------------------ API validators
@settings(max_examples=200, deadline=None)
@given(
    name=st.sampled_from(PARAM_NAMES),
    bad=st.one_of(
        st.sampled_from(BAD_NUMBERS),
        st.sampled_from([float("nan"), float("inf"), -float("inf")]),
        st.booleans(),
        st.lists(st.integers(), max_size=2),
        st.none().map(lambda _: object()),
    ),
)
def test_every_parameter_refuses_non_numbers(name, bad):
    with pytest.raises(ParameterError) as e:
        Params.make(**{name: bad})
    assert e.value.name == name and name in str(e.value)


@settings(max_examples=300, deadline=None)
@given(
    zeta=st.fractions(min_value=-2, max_value=2, max_denominator=1000),
    eta=st.fractions(min_value=-2, max_value=2, max_denominator=1000),
    R=st.fractions(min_value=-1, max_value=2, max_denominator=1000),
    x0=st.fractions(min_value=-5, max_value=5, max_denominator=1000),
    x_w=st.fractions(min_value=-5, max_value=5, max_denominator=1000),
)
def test_validator_accepts_exactly_the_documented_ranges(zeta, eta, R, x0, x_w):
    ok = zeta >= 0 and eta > 0 and 0 <= R <= 1 and x0 <= x_w
    if ok:
        p = Params.make(zeta=zeta, eta=eta, R=R, x0=x0, x_w=x_w)
        # decimal strings round-trip exactly
        assert Params.make(**p.decimal()) == p
    else:
        with pytest.raises(ParameterError) as e:
            Params.make(zeta=zeta, eta=eta, R=R, x0=x0, x_w=x_w)
        # the first violated rule, in the documented order, is the one named
        first = [
            n
            for n, bad in (
                ("zeta", zeta < 0),
                ("eta", eta <= 0),
                ("R", not 0 <= R <= 1),
                ("x0", x0 > x_w),
            )
            if bad
        ][0]
        assert e.value.name == first


@pytest.mark.parametrize(
    "spec", ["float32", "mp", "mp:", "mp:63", "mp:-5", "mp:1e3", "quad128", "", "FLOAT", None, 64]
)
def test_unknown_precisions(spec):
    with pytest.raises(ParameterError) as e:
        Precision.parse(spec)
    assert e.value.name == "precision"


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"periods": "x"}, "periods"),
        ({"periods": True}, "periods"),
        ({"periods": -1}, "periods"),
        ({"periods": 10**9}, "periods"),
        ({"per_period": -2}, "per_period"),
        ({"tol": "nan"}, "tol"),
        ({"tol": float("inf")}, "tol"),
        ({"tol": "-1e-3"}, "tol"),
        ({"model": None}, "model"),
        ({"precision": "mp:10"}, "precision"),
    ],
)
def test_simulate_refuses_before_work(kwargs, name):
    with pytest.raises(ParameterError) as e:
        simulate(Params.make(), **{"periods": 1, **kwargs})
    assert e.value.name == name


# ------------------------------------------------------------------ CLI: exit status 2, one line
CLI_CASES = [
    (["simulate", "--eta", "nan"], "eta"),
    (["simulate", "--zeta", "-inf"], "zeta"),
    (["simulate", "--a", "inf"], "a"),
    (["simulate", "--xw", "abc"], "x_w"),
    (["simulate", "--R", "1.0001"], "R"),
    (["simulate", "--x0", "2.5"], "x0"),
    (["simulate", "--v0", ""], "v0"),
    (["simulate", "--t0", "NaN"], "t0"),
    (["simulate", "--precision", "float16"], "precision"),
    (["simulate", "--dense", "-1"], "dense"),
    (["lle", "--eta", "0"], "eta"),
    (["lle", "--precision", "mp:2"], "precision"),
    (["lle", "--periods", "1.5"], "periods"),
    (["bifurcation", "--eta", "0.7", "0.7", "5", "--out", "/tmp/x"], "eta_max"),
    (["bifurcation", "--eta", "nan", "0.8", "5", "--out", "/tmp/x"], "eta_min"),
    (["bifurcation", "--eta", "0.7", "0.8", "5", "--workers", "0", "--out", "/tmp/x"], "workers"),
    (["sync", "--k", "-0.1", "0.1", "3"], "k_min"),
    (["sync", "--k", "0.05", "0.05", "3"], "k_max"),
    (["sync", "--ensemble", "many"], "ensemble"),
    (["sweep", "--axis", "eta", "0.8", "0.8", "3", "--out", "/tmp/x"], "eta_max"),
    (["sweep", "--axis", "eta", "0.8", "0", "3", "--out", "/tmp/x"], "eta_max"),
    (["sweep", "--axis", "x0", "0", "1", "3", "--out", "/tmp/x"], "axis"),
    (["sweep", "--axis", "zeta", "-1", "0", "3", "--out", "/tmp/x"], "zeta_min"),
    (["accuracy", "--periods", "-5"], "periods"),
]


@pytest.mark.parametrize("argv, name", CLI_CASES)
def test_cli_bad_input_exit_2_names_the_parameter(argv, name, capsys, tmp_path):
    # each case its own --out: cases sharing one raced for its lock in parallel workers
    argv = [str(tmp_path / "x") if a == "/tmp/x" else a for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"precise-impact: error: {name} = ") and err.count("\n") == 1


# ------------------------------------------------------------------ invariants
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    eta=st.fractions(min_value=Fraction(1, 2), max_value=Fraction(3, 2), max_denominator=200),
    zeta=st.fractions(min_value=Fraction(1, 100), max_value=Fraction(1, 5), max_denominator=200),
    x_w=st.fractions(min_value=Fraction(1, 2), max_value=3, max_denominator=100),
    R=st.fractions(min_value=Fraction(9, 10), max_value=1, max_denominator=100),
)
def test_invariants_wall_and_impact_law(eta, zeta, x_w, R):
    """x <= x_w at every sample and dense point; v_after = -R v_before exactly as one
    rounding of the product (R rounded once, then the product: <= eps relative)."""
    p = Params.make(eta=eta, zeta=zeta, x_w=x_w, R=R)
    tr = HeyokaSolver("float64", max_impacts=10_000).solve(p, 15, per_period=16)
    xw = float(x_w)
    assert np.all(tr.dense_x <= xw) and np.all(tr.x <= xw)
    vb, va = np.asarray(tr.impacts_v_before, float), np.asarray(tr.impacts_v_after, float)
    assert np.all(vb > 0)
    assert np.all(np.abs(va + float(R) * vb) <= 2.3e-16 * np.abs(vb))


# ------------------------------------------------------------------ undamped resonance
def test_undamped_resonance_is_bounded_by_impacts():
    """eta = 1, zeta = 0: from rest x(t) = (t/2) sin t grows until it reaches the wall.

    The first impact is the first root of (t/2) sin t = x_w (mpmath, 50 digits):
    float64 within 1e-13 (eps * t / slope, slope ~3), mp:128 within 1e-30.  After
    that the impacts bound the motion: over 1000 periods x stays in [-10, x_w] and
    |v| < 10 (measured [-4.49, 2], 4.78) instead of growing like t/2 ~ 3000.
    """
    p = Params.make(eta="1", zeta="0")
    with mpmath.workdps(50):
        f = lambda t: t / 2 * mpmath.sin(t) - 2  # noqa: E731
        t1 = mpmath.findroot(f, (2 * mpmath.pi, 2 * mpmath.pi + mpmath.pi / 2), solver="bisect")
        t1 = mpmath.findroot(f, t1)
    tr = simulate(p, 1000, per_period=20)
    assert abs(tr.impacts_t[0] - float(t1)) < 1e-13
    assert tr.dense_x.max() <= 2.0 and tr.dense_x.min() > -10 and np.abs(tr.dense_v).max() < 10
    hp = simulate(p, 2, precision="mp:128")
    with mpmath.workdps(50):
        assert abs(hp.impacts_mpf()[0][0] - t1) < mpmath.mpf("1e-30")
    with pytest.raises(ParameterError) as e:
        simulate(p, 2, model="analytical")
    assert e.value.name == "zeta"
