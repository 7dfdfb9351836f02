"""Scores of a model against the reference (_scores.py) and the compare report (_compare.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from precise_impact.core.params import Params
from precise_impact.errors import ParameterError
from precise_impact.solvers.simulate import simulate
from precise_impact.verification.scores import (
    divergence_rate,
    predictability_horizon,
    score,
    sliced_wasserstein,
    wasserstein_1d,
)


def test_sliced_wasserstein_of_a_cloud_with_itself_is_zero():
    rng = np.random.default_rng(1)
    p = rng.normal(size=(500, 2))
    assert sliced_wasserstein(p, p) == 0.0
    assert sliced_wasserstein(p, p[::-1]) == pytest.approx(0.0, abs=1e-15)  # order does not matter


def test_wasserstein_of_shifted_clouds_equals_the_shift():
    rng = np.random.default_rng(2)
    a = rng.normal(size=400)
    assert wasserstein_1d(a, a + 0.37) == pytest.approx(0.37, rel=1e-12)
    assert sliced_wasserstein(a, a - 0.37) == pytest.approx(0.37, rel=1e-12)
    # unequal sizes: exact quantile integral
    assert wasserstein_1d([0.0, 1.0], [0.0, 0.5, 1.0]) == pytest.approx(1 / 6, rel=1e-12)
    # 2-D: a shift s gives mean |s . theta| = (2 / pi) |s| over directions
    p = rng.normal(size=(300, 2))
    s = np.array([0.3, -0.4])
    assert sliced_wasserstein(p, p + s) == pytest.approx(2 / math.pi * 0.5, rel=1e-4)


def test_predictability_horizon_of_an_exponential_separation():
    lam, s0 = 0.03, 1e-16
    t = np.arange(0, 2000, 8.8)
    sep = s0 * np.exp(lam * t)
    for delta in (1e-6, 1e-3, 1e-1):
        assert predictability_horizon(t, sep, delta) == pytest.approx(
            math.log(delta / s0) / lam, rel=1e-12
        )
    assert predictability_horizon(t, sep, 1e300) == math.inf


def test_divergence_rate_of_a_synthetic_exponential():
    t = np.linspace(0, 2000, 401)
    sep = np.minimum(1e-15 * np.exp(0.03 * t), 1.0)  # saturates like a real separation
    d = divergence_rate(t, sep)
    assert abs(d["rate"] - 0.03) < 1e-6
    assert d["points"] > 10


def test_periodic_score_ideal_circuit_at_period_3():
    from precise_impact.scenes.run import run_scene
    from precise_impact.scenes.scene import load_scene

    scene = load_scene("fig6-period3-ideal")
    ref = simulate(scene.params, scene.periods, precision="mp:128")
    tr = run_scene(scene, "circuit")
    sc = score(tr, ref)
    assert sc["regime"] == "periodic"
    assert sc["max_state_error"] < 1e-10
    assert sc["period_model"] == 3 and sc["period_reference"] == 3
    im = sc["impacts"]
    assert im["unmatched_model"] == 0 and im["unmatched_reference"] == 0
    assert im["max_dt"] < 1e-10 and im["max_dv"] < 1e-10


def test_chaotic_score_float64_vs_mp_reference():
    p = Params.make(eta="0.712")
    ref = simulate(p, 200, precision="mp:256")
    m = simulate(p, 200, precision="float64")
    sc = score(m, ref, regime="auto", lle=0.0305)
    assert sc["regime"] == "chaotic"
    assert abs(sc["divergence"]["rate"] - 0.0305) < 0.3 * 0.0305
    h = sc["horizons"]
    assert h["1e-06"] < h["0.001"] < h["0.1"] < math.inf
    # same model and precision on the same attractor: distance within a few noise floors
    assert sc["sliced_wasserstein"] < 3 * sc["sw_floor"] + 0.05


def test_score_refuses_unknown_regime():
    p = Params.make(eta="0.74")
    tr = simulate(p, 20)
    with pytest.raises(ParameterError, match="regime"):
        score(tr, tr, regime="quasi")


def test_compare_writes_report_and_figures(tmp_path):
    from precise_impact.verification.compare import compare

    res = compare(
        "fig6-period3-ideal", ["circuit", "switched-capacitor"], out=tmp_path, progress=False
    )
    assert res["regime"] == "periodic"
    for name in ("report.md", "scores.json", "phase_portraits.png", "separation.png"):
        assert (tmp_path / name).stat().st_size > 0
    assert (tmp_path / "phase_portraits.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    text = (tmp_path / "report.md").read_text()
    assert "circuit" in text and "switched-capacitor" in text and "How obtained" in text
    for m in ("circuit", "switched-capacitor"):
        assert res["models"][m]["max_state_error"] < 1e-10
        assert res["models"][m]["period_model"] == 3


def test_compare_and_cli_refuse_bad_models():
    import argparse

    from precise_impact.cli.commands.compare import register, run
    from precise_impact.verification.compare import compare

    with pytest.raises(ParameterError, match="models"):
        compare("fig6-period3-ideal", ["circuit", "nonsense"])
    parser = argparse.ArgumentParser()
    register(parser.add_subparsers(dest="command"))
    ns = parser.parse_args(["compare", "fig6-period3-ideal", "--models", "circuit,,spicy"])
    with pytest.raises(ParameterError, match="models"):
        run(ns)
