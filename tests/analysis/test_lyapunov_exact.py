"""Lyapunov exponents against exact values where the answer is known in closed form.

* A non-impacting oscillator (``x_w`` far away): the tangent flow is ``exp(A t)`` of the
  linear oscillator, so the exponents are the real parts of the eigenvalues of ``A``,
  ``-zeta +- sqrt(zeta^2 - 1)`` (both ``-zeta`` when underdamped), at any forcing frequency.
* The sum ``lambda1 + lambda2 = -2 zeta + (impacts / time) ln R^2`` of any run
  (``det Phi = exp(-2 zeta t)``, ``det S = R^2``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import precise_impact as pi
from precise_impact.analysis.lyapunov.batch import batch_lle
from precise_impact.analysis.lyapunov.fast import fast_batch
from precise_impact.core.linalg import gram_schmidt2

FAR = "1000000"  # a wall the orbit never reaches


def _finite_time_bound(zeta: float, t: float) -> float:
    """|lambda_i(t) - lambda_i| of the linear flow over time ``t``: ``exp(A t) = V e^{D t} V^-1``
    stretches any vector within a factor ``cond(V)`` of ``e^{Re(d) t}``, and the measured logs
    are a difference of two such (after the transient, at the end): ``2 ln cond(V) / t``, doubled
    for safety, plus rounding (1e-12)."""
    A = np.array([[0.0, 1.0], [-1.0, -2.0 * zeta]])
    cond = np.linalg.cond(np.linalg.eig(A)[1])
    return 4 * math.log(cond) / t + 1e-12


@pytest.mark.parametrize("eta", ["0.001", "0.005", "0.0039"])
def test_heyoka_variational_low_eta_non_impacting_is_minus_zeta(eta):
    # before: LLE ~ -4.54 eta (-0.0045 at eta = 0.001) with error bars of 1e-8: the tangents
    # shrank far below (x, v) between QRs and heyoka's error control (relative to the whole
    # state) integrated noise
    periods = 8
    r = pi.lyapunov(pi.Params.make(eta=eta, x_w=FAR), periods=periods, transient=2)
    t = periods / 4 * 2 * math.pi / float(eta)  # per start
    bound = _finite_time_bound(0.05, t)
    assert abs(r.spectrum[0] + 0.05) < bound
    assert abs(r.spectrum[1] + 0.05) < bound
    # the sum is exact up to the rounding of the logs (~eps per QR, ~1e3 QRs)
    assert abs(sum(r.spectrum) + 0.1) < 1e-9


@pytest.mark.parametrize("engine", [fast_batch, batch_lle])
@pytest.mark.parametrize("eta", ["0.001", "0.005"])
def test_sweep_engines_low_eta_non_impacting_is_minus_zeta(engine, eta):
    # before: both engines -0.0045 (eta = 0.001) and -0.0229 (eta = 0.005), stderr 1e-7
    periods = 20
    row = engine([pi.Params.make(eta=eta, x_w=FAR)], periods=periods, transient=5)[0]
    bound = _finite_time_bound(0.05, periods * 2 * math.pi / float(eta))
    assert abs(row["lle"] + 0.05) < bound
    assert abs(row["lambda2"] + 0.05) < bound
    assert abs(row["lle"] + row["lambda2"] + 0.1) < 1e-9
    if engine is fast_batch:
        assert row["engine"] == "fast"  # before: non-finite state, handed to heyoka


@pytest.mark.parametrize("zeta", ["1.5", "3"])
@pytest.mark.parametrize("eta", ["0.712", "0.005"])
def test_overdamped_non_impacting_exponents_are_the_eigenvalues(eta, zeta):
    # before: zeta = 1.5 gave lambda2 = -1.02 for -2.618 (the columns aligned by e^157 between
    # two QRs); at zeta >= 1 the orbit finder refused the run
    z = float(zeta)
    d = math.sqrt(z * z - 1)
    periods = 8
    r = pi.lyapunov(pi.Params.make(eta=eta, zeta=zeta, x_w=FAR), periods=periods, transient=2)
    t = periods / 4 * 2 * math.pi / float(eta)
    bound = _finite_time_bound(z, t)
    assert abs(r.spectrum[0] - (-z + d)) < bound
    assert abs(r.spectrum[1] - (-z - d)) < bound
    # exact sum; relative rounding ~eps per log of size up to 8 e-folds, ~1e3 QRs
    assert abs(sum(r.spectrum) + 2 * z) < 1e-9 * z


def test_gram_schmidt_survives_tiny_and_huge_columns():
    # before: entries of 1e-173 squared to 0: r11 = 0 and ZeroDivisionError (core/linalg.py)
    for s in (1e-173, 1e-300, 1e170):
        q0, q1, u0, u1, r11, r22 = gram_schmidt2(3 * s, 4 * s, 1 * s, 2 * s)
        assert (q0, q1) == pytest.approx((0.6, 0.8), rel=4e-16)
        assert r11 == pytest.approx(5 * s, rel=4e-16)
        assert r11 * r22 == pytest.approx(2 * s * s, rel=1e-15) if s > 1e-160 else r22 > 0
        lanes = gram_schmidt2(*(np.array([1.0, s]) * c for c in (3, 4, 1, 2)), np.sqrt)
        assert lanes[4][1] == pytest.approx(5 * s, rel=4e-16)
        assert lanes[4][0] == 5.0


def test_bifurcation_low_eta_gives_minus_zeta():
    # before: ZeroDivisionError (hypothesis: eta_min = 0.00390625)
    b = pi.bifurcation(
        pi.Params.make(x_w=FAR),
        ("eta", "0.00390625", "0.005", 2),
        periods=6,
        transient=2,
        workers=1,
        progress=False,
    )
    assert np.all(np.abs(b.lle + 0.05) < _finite_time_bound(0.05, 6 * 2 * math.pi / 0.005))


@pytest.mark.parametrize("model", ["heyoka", "fast"])
def test_overdamped_runs_with_attractors_and_in_sync_scan(model):
    # before: 'zeta = 3/2 is not allowed: 0 <= zeta < 1 for the orbit finder' once the tails
    # were long enough for the attractor step's Newton refinement (>= 3 * 32 periods per start)
    z = 1.5
    p = pi.Params.make(zeta="1.5")  # overdamped: the orbit stays off the wall x_w = 2
    r = pi.lyapunov(p, model=model, periods=4 * 100, transient=10)
    assert r.stats["lle_source"] == "finite-time"  # no orbit finder: the finite-time value
    bound = _finite_time_bound(z, 100 * 2 * math.pi / 0.712)
    assert abs(r.spectrum[0] - (-z + math.sqrt(z * z - 1))) < bound
    assert abs(r.spectrum[1] - (-z - math.sqrt(z * z - 1))) < bound
    from precise_impact.analysis.sync import sync_scan

    s = sync_scan(p, "first-order", ["0.02"], periods=20, ensemble=2, lle_periods=400, model=model)
    assert abs(s.lle - r.spectrum[0]) < bound


def test_reversed_ranges_run_in_the_order_given(tmp_path):
    # before: sweep / bifurcation --eta 0.8 0.7 3 refused ('eta_max must be > eta_min')
    p = pi.Params.make()
    kw = dict(periods=20, transient=10)
    b = pi.bifurcation(p, ("eta", "0.8", "0.7", 3), workers=1, progress=False, **kw)
    f = pi.bifurcation(p, ("eta", "0.7", "0.8", 3), workers=1, progress=False, **kw)
    assert [str(e) for e in b.eta] == ["4/5", "3/4", "7/10"]
    assert list(b.lle) == list(f.lle[::-1])  # each point alone: the same numbers
    spec = pi.SweepSpec.make(p, [("eta", "0.8", "0.7", 3)], **kw)
    res = pi.run_sweep(spec, tmp_path, workers=1, progress=False)
    assert [float(v) for v in spec.axes[0][1]] == [0.8, 0.75, 0.7]
    assert list(res.lle) == list(f.lle[::-1])
    assert (tmp_path / "sweep.csv").read_text().splitlines()[1].startswith("0.8,")
