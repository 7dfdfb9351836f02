"""Bifurcation diagram: grazing frequency from its closed form, LLE curve, parallel = serial."""

from __future__ import annotations

from fractions import Fraction

import mpmath
import numpy as np
import pytest

from precise_impact import ParameterError, Params, grazing_frequencies
from precise_impact.analysis.bifurcation import bifurcation, eta_grid


def test_grazing_frequency_closed_form_matches_amplitude_condition():
    """Independent check: the steady-state amplitude a / sqrt((1-eta^2)^2 + (2 zeta eta)^2)
    equals x_w at the closed-form grazing eta (mpmath findroot at 40 digits)."""
    p = Params.make()
    g = grazing_frequencies(p, dps=40)
    assert len(g) == 2
    with mpmath.workdps(40):
        amp = lambda e: 1 / mpmath.sqrt((1 - e**2) ** 2 + (mpmath.mpf("0.1") * e) ** 2) - 2  # noqa: E731
        root = mpmath.findroot(amp, mpmath.mpf("0.71"))
        assert abs(root - g[0]) < mpmath.mpf("1e-35")
        assert abs(amp(g[1])) < mpmath.mpf("1e-35")
    assert abs(float(g[0]) - 0.71069) < 1e-5  # the paper's "about 0.71069"


def test_grid_is_exact_and_validated():
    # a reversed range runs in the order given (before: refused, 'eta_max must be > eta_min')
    assert eta_grid("0.8", "0.7", 3) == [Fraction(4, 5), Fraction(3, 4), Fraction(7, 10)]
    grid = eta_grid("0.70", "0.74", 5)
    assert grid == [
        Fraction(7, 10),
        Fraction(71, 100),
        Fraction(72, 100),
        Fraction(73, 100),
        Fraction(74, 100),
    ]
    for args, name in [
        (("0", "1", 3), "eta_min"),
        (("0.8", "0.8", 3), "eta_max"),
        (("0.8", "0", 3), "eta_max"),
        (("0.7", "0.8", 0), "n"),
    ]:
        with pytest.raises(ParameterError) as e:
            eta_grid(*args)
        assert e.value.name == name


def test_bifurcation_parallel_equals_serial_and_files(tmp_path):
    """Same numbers from 1 and 2 workers (deterministic); LLE = -zeta below grazing
    (no impacts after the transient: bound ln(1 + 2 zeta / omega_d) / t, see
    test_variational), positive in the chaotic band; PNG and NPZ written."""
    p = Params.make()
    kw = dict(periods=300, transient=1500, progress=False)
    a = bifurcation(p, ("eta", "0.70", "0.72", 3), workers=1, **kw)
    b = bifurcation(p, ("eta", "0.70", "0.72", 3), workers=2, **kw)
    assert np.array_equal(a.x, b.x) and np.array_equal(a.lle, b.lle)
    t = 300 * 2 * np.pi / 0.70
    assert abs(a.lle[0] + 0.05) <= np.log(1 + 0.1 / np.sqrt(1 - 0.0025)) / t
    assert a.impacts_per_period[0] == 0
    assert a.lle[1] > 0 and a.lle[2] > 0  # 0.71, 0.72: chaotic
    assert a.grazing and 0.70 < a.grazing[0] < 0.72
    files = a.save_all(tmp_path)
    d = np.load(files["npz"])
    assert list(d["eta_str"]) == ["0.7", "0.71", "0.72"] and d["x"].shape == (3, 300)
    assert files["png"].stat().st_size > 20_000


def test_axis_tuple_model_and_progress():
    """The eta axis tuple and model= give the numbers of the old (eta_min, eta_max, n)
    and engine= forms bit for bit (those warn); a callable progress counts the values."""
    p = Params.make()
    seen = []
    kw = dict(periods=60, transient=60, workers=1)
    new = bifurcation(
        p,
        ("eta", "0.73", "0.75", 3),
        model="heyoka",
        progress=lambda d, n: seen.append((d, n)),
        **kw,
    )
    assert seen == [(1, 3), (2, 3), (3, 3)] and new.eta == eta_grid("0.73", "0.75", 3)
    with pytest.warns(DeprecationWarning) as w:
        old = bifurcation(p, "0.73", "0.75", 3, engine="heyoka", progress=False, **kw)
    assert {str(m.message).split(" (the old spelling")[0] for m in w} == {
        "bifurcation: engine= is deprecated, use model=",
        "bifurcation: (eta_min, eta_max, n) is deprecated, "
        "use an axis tuple ('eta', start, stop, n)",
    }
    with pytest.warns(DeprecationWarning):
        by_keyword = bifurcation(
            p, eta_min="0.73", eta_max="0.75", n=3, model="heyoka", progress=False, **kw
        )
    for r in (old, by_keyword):
        assert np.array_equal(r.x, new.x) and np.array_equal(r.lle, new.lle)
    for args, extra, name in [
        ((("x_w", "1", "2", 3),), {}, "axis"),
        ((("eta", "0.7", "0.8", 3), "0.9"), {}, "eta_max"),
        ((("eta", "0.7", "0.8", 3),), {"model": "gpu"}, "model"),
        ((("eta", "0.7", "0.8", 3),), {"progress": "yes"}, "progress"),
    ]:
        with pytest.raises(ParameterError) as e:
            bifurcation(p, *args, **extra)
        assert e.value.name == name
