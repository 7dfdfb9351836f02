"""The one fallback rule (:func:`~precise_impact.solvers.base.with_fallback`) and its users.

A primary that gives up hands the same call to the fallback, whose result says why; without a
fallback the refusal is an :class:`IntegrationError`; a batch falls back only for the items
the primary left unresolved.  Then each engine that falls back does so through it, as its
result states: the fast model, the fast pair and the fast Lyapunov spectrum (zeta >= 1 or an
overdamped error equation are outside their closed forms).
"""

from __future__ import annotations

import pytest

from precise_impact import IntegrationError, Params, lyapunov, simulate
from precise_impact.solvers.base import Unresolved, note_fallback, with_fallback
from precise_impact.solvers.fast.single import FastSolver
from precise_impact.solvers.simulate import simulate_coupled


class _Result:
    def __init__(self, value):
        self.value, self.stats = value, {"engine": "slow"}


def _primary(x, scale=1):
    if x < 0:
        raise Unresolved("quick", f"x = {x} < 0")
    r = _Result(scale * x)
    r.stats["engine"] = "quick"
    return r


def _fallback(x, scale=1):
    return _Result(-scale * x)


def test_the_primary_result_when_it_resolves():
    r = with_fallback(_primary, _fallback, note_fallback("slow"))(3, scale=2)
    assert (r.value, r.stats["engine"]) == (6, "quick")


def test_the_fallback_gets_the_same_call_and_says_why():
    r = with_fallback(_primary, _fallback, note_fallback("slow"))(-3, scale=2)
    assert (r.value, r.stats["engine"]) == (6, "slow (fallback: x = -3 < 0)")


def test_no_fallback_is_an_integration_error_naming_the_engine():
    with pytest.raises(
        IntegrationError, match="the quick engine does not resolve this orbit: x = -3"
    ):
        with_fallback(_primary, None)(-3)


def test_a_batch_falls_back_only_for_the_unresolved_items():
    calls = []

    def primary(xs):
        out = [x if x >= 0 else None for x in xs]
        if None in out:
            raise Unresolved("quick", "negative", out)
        return out

    def fallback(xs, indices):
        calls.append(indices)
        return [10 * xs[i] for i in indices]

    run = with_fallback(primary, fallback, lambda r, why: (r, why))
    assert run([1, -2, 3, -4]) == [1, (-20, "negative"), 3, (-40, "negative")]
    assert calls == [[1, 3]] and run([5, 6]) == [5, 6] and calls == [[1, 3]]


def test_the_engines_fall_back_through_it():
    over = Params.make(eta="0.712", zeta="1.2")  # overdamped: outside the fast closed form
    tr = simulate(over, 3, model="fast")
    assert tr.model == "fast" and tr.stats["engine"].startswith("heyoka (fallback: zeta >= 1")
    with pytest.raises(IntegrationError, match="fast engine does not resolve"):
        FastSolver(fallback=False).solve(over, 3)
    r = lyapunov(over, method="variational", model="fast", periods=40, transient=10)
    assert r.stats["engine"] == "heyoka variational (fallback: zeta >= 1)"
    pair = simulate_coupled(Params.make(eta="0.712"), "10", "paper", 3, y0=("1", "0"), model="fast")
    assert (
        pair.stats["engine"].startswith("heyoka (fallback: ")
        and "underdamped" in pair.stats["engine"]
    )
