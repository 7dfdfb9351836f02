"""Honest Lyapunov exponents: periodic attractors get their exact Floquet LLE, starts on
different attractors are reported separately, never averaged.

The references are exact: the 1:1 orbit's LLE ``ln R / T - zeta`` (complex multipliers), and
``-zeta`` for the non-impacting steady state.
"""

from __future__ import annotations

import math

import pytest

from precise_impact import Params, lyapunov

EXACT_1_1 = math.log(0.8) / (2 * math.pi) - 0.05  # -0.0855144: R = 0.8, eta = 1, zeta = 0.05


@pytest.mark.parametrize("method", ["variational", "fast"])
def test_periodic_attractor_reports_the_floquet_lle(method):
    """The issue's case: the finite-time estimate was -0.0854322 +- 1.8e-5 (4.5 sigma off);
    now the orbit is found by Newton and its exact LLE reported (to float64 rounding of the
    multipliers), with the finite-time estimate kept beside it."""
    r = lyapunov(Params.make(R="0.8", eta="1"), method, periods=4000, transient=1000)
    assert r.stats["lle_source"] == "floquet"
    (g,) = r.stats["attractors"]
    assert g["kind"] == "periodic" and g["period"] == 1 and g["impacts"] == 1 and g["starts"] == [0, 1, 2, 3]
    assert abs(r.lle - EXACT_1_1) <= 1e-12 and abs(r.lle - EXACT_1_1) <= 10 * r.stderr
    assert abs(sum(r.spectrum) - (2 * math.log(0.8) / (2 * math.pi) - 0.1)) <= 1e-12
    ft = r.stats["finite_time"]
    assert abs(ft["lle"] - EXACT_1_1) > 1e-7  # the finite-time value is not the answer


def test_starts_on_different_attractors_are_not_averaged():
    """eta = 0.7100: of 8 starts, some stay on the chaotic attractor and some fall onto the
    non-impacting steady state (LLE exactly -zeta).  Both attractors are reported with their
    starts; lle is the first start's attractor's, and a warning says the starts split."""
    r = lyapunov(Params.make(eta="0.7100"), "fast", periods=8 * 1500, transient=3000, initial_conditions=8)
    groups = r.stats["attractors"]
    assert {g["kind"] for g in groups} == {"periodic", "not periodic"}, groups
    assert sorted(j for g in groups for j in g["starts"]) == list(range(8))
    (per,) = [g for g in groups if g["kind"] == "periodic"]
    (cha,) = [g for g in groups if g["kind"] == "not periodic"]
    assert abs(per["floquet_lle"] + 0.05) <= 1e-12 and cha["lle"] > 0.02
    first = next(g for g in groups if 0 in g["starts"])
    assert r.lle == (first["floquet_lle"] if first["kind"] == "periodic" else first["lle"])
    assert "attractors" in r.stats["warning"]


def test_chaotic_estimate_is_untouched():
    """One chaotic attractor: the finite-time estimate stands (the same number)."""
    r = lyapunov(Params.make(eta="0.712"), "fast", periods=4000, transient=1000)
    assert r.stats["lle_source"] == "finite-time" and r.lle == r.stats["finite_time"]["lle"]
    assert [g["kind"] for g in r.stats["attractors"]] == ["not periodic"]
