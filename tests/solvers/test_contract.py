"""The solver contract, derived from the registries: every model of :data:`MODELS` and of
:data:`COUPLED_MODELS`, in every precision it declares, keeps the same basic promises.

Shape of the result (one sample per period boundary), times increasing from ``t0`` to
``t0 + periods T``, the mass never beyond the wall and every impact at it moving into it, and
a precision (or tolerance) the model does not declare refused with :class:`ParameterError`
before any work.  A model added to a registry is tested here without a line changed.
"""

from __future__ import annotations

import math
import shutil
import time

import numpy as np
import pytest

import precise_impact as pi
from precise_impact import ParameterError, Params, Precision, simulate
from precise_impact.solvers.base import (
    COUPLED_MODELS,
    MODELS,
    PRECISION_KINDS,
    CoupledSolver,
    Solver,
    coupled_model_capabilities,
    make_coupled_solver,
    make_solver,
    model_capabilities,
)
from precise_impact.solvers.simulate import simulate_coupled

#: One precision of each kind.
PRECISION_OF = {
    "float64": "float64",
    "longdouble": "longdouble",
    "float128": "float128",
    "mp": "mp:128",
}
#: The period-3 orbit (two impacts in three periods from rest).
ETA = "0.74"
PERIODS = 3


def _single():
    return [(m, k) for m in sorted(MODELS) for k in model_capabilities(m).precisions]


def _coupled():
    return [
        (m, k) for m in sorted(COUPLED_MODELS) for k in coupled_model_capabilities(m).precisions
    ]


def _refused(caps):
    return [k for k in PRECISION_KINDS if k not in caps.precisions]


def _f(a) -> np.ndarray:
    return np.array([math.nan if v is None else float(v) for v in a], dtype=float)


def _skip_without_ngspice(model):
    if model == "spice" and shutil.which("ngspice") is None:
        pytest.skip("ngspice is not installed (apt-get install ngspice); CI installs it")


def _check_times(t, p: Params, periods: int):
    T = 2 * math.pi / float(p.eta)
    assert len(t) == periods + 1
    assert np.all(np.diff(t) > 0), t
    assert t[0] == float(p.t0) and math.isclose(t[-1], float(p.t0) + periods * T, rel_tol=1e-12)


def _check_impacts(times, t_end, n_min=1):
    times = _f(times)
    assert len(times) >= n_min
    assert np.all(np.diff(times) > 0) and np.all((times > 0) & (times <= t_end)), times


def test_the_registries_cover_the_models_the_docs_promise():
    """Both registries are filled (the circuit models register from models/); every entry
    declares at least one precision."""
    assert {"heyoka", "fast", "certified", "circuit"} <= set(MODELS)
    assert {"heyoka", "fast", "certified", "circuit"} <= set(COUPLED_MODELS)
    assert model_capabilities("certified").precisions == ("mp",)
    assert all(_single()) and all(_coupled())


@pytest.mark.parametrize(("model", "kind"), _single(), ids=lambda v: str(v))
def test_every_model_in_every_declared_precision_keeps_the_contract(model, kind):
    _skip_without_ngspice(model)
    prec = PRECISION_OF[kind]
    assert isinstance(make_solver(model, prec), Solver)
    p = Params.make(eta=ETA)
    tr = simulate(p, PERIODS, model=model, precision=prec)
    assert tr.precision.kind == kind
    t, x = _f(tr.t), _f(tr.x)
    _check_times(t, p, PERIODS)
    assert np.all(np.isfinite(x)) and np.all(np.isfinite(_f(tr.v)))
    # never beyond the wall (ngspice's x is a node voltage read out at TMAX = 10 us: 1e-3)
    assert x.max() <= float(p.x_w) + (1e-3 if model == "spice" else 1e-9)
    _check_impacts(tr.impacts_t, t[-1], n_min=2)
    vb, va = _f(tr.impacts_v_before), _f(tr.impacts_v_after)
    if np.all(np.isnan(vb) & np.isnan(va)):  # the switched-capacitor circuit records no speeds
        assert model == "switched-capacitor"
        return
    assert np.all(vb > 0) and np.all(va < 0)  # into the wall, and away from it (R = 1)
    if model != "spice":
        assert np.allclose(va, -float(p.R) * vb, rtol=1e-9, atol=0)


@pytest.mark.parametrize("model", sorted(MODELS))
def test_every_model_refuses_an_undeclared_precision_before_work(model):
    """10**8 periods would run for hours: the refusal comes first, naming the precision
    (and a tolerance, for the models that take none)."""
    caps = model_capabilities(model)
    p = Params.make(eta=ETA)
    for kind in _refused(caps) + ["float32"]:
        start = time.perf_counter()
        with pytest.raises(ParameterError) as e:
            simulate(p, 10**8, model=model, precision=PRECISION_OF.get(kind, kind))
        assert e.value.name == "precision" and time.perf_counter() - start < 5
    if not caps.tolerance:
        with pytest.raises(ParameterError) as e:
            simulate(p, 10**8, model=model, precision=PRECISION_OF[caps.precisions[0]], tol="1e-10")
        assert e.value.name == "tol"


@pytest.mark.parametrize(("model", "kind"), _coupled(), ids=lambda v: str(v))
def test_every_coupled_model_in_every_declared_precision_keeps_the_contract(model, kind):
    caps = coupled_model_capabilities(model)
    form = caps.forms[0] if caps.forms else "first-order"
    prec = PRECISION_OF[kind]
    assert isinstance(make_coupled_solver(model, prec), CoupledSolver)
    p = Params.make(eta=ETA)
    r = simulate_coupled(p, "0.05", form, PERIODS, y0=("0.5", "0"), precision=prec, model=model)
    assert r.precision.kind == kind
    t = _f(r.t)
    _check_times(t, p, PERIODS)
    for name in ("x", "v", "y", "w"):
        a = _f(getattr(r, name))
        assert len(a) == PERIODS + 1 and np.all(np.isfinite(a)), name
    assert max(_f(r.x).max(), _f(r.y).max()) <= float(p.x_w) + 1e-9
    _check_impacts(r.master_impacts_t, t[-1], n_min=2)
    _check_impacts(r.slave_impacts_t, t[-1], n_min=1)


@pytest.mark.parametrize("model", sorted(COUPLED_MODELS))
def test_every_coupled_model_refuses_what_it_does_not_declare_before_work(model):
    caps = coupled_model_capabilities(model)
    p = Params.make(eta=ETA)
    form = caps.forms[0] if caps.forms else "first-order"
    for kind in _refused(caps) + ["float32"]:
        start = time.perf_counter()
        with pytest.raises(ParameterError) as e:
            simulate_coupled(
                p, "0.05", form, 50_000, precision=PRECISION_OF.get(kind, kind), model=model
            )
        assert e.value.name == "precision" and time.perf_counter() - start < 5
    if caps.forms is not None:
        other = next(f for f in pi.COUPLED_FORMS if f not in caps.forms)
        with pytest.raises(ParameterError) as e:
            simulate_coupled(
                p, "0.05", other, 50_000, precision=PRECISION_OF[caps.precisions[0]], model=model
            )
        assert e.value.name == "form"
    with pytest.raises(ParameterError) as e:
        simulate_coupled(p, "0.05", form, 5, model="gpu")
    assert e.value.name == "model"


def test_the_engine_keyword_is_the_old_spelling_of_model():
    p = Params.make(eta=ETA)
    with pytest.warns(DeprecationWarning, match="model="):
        old = simulate_coupled(p, "0.05", "first-order", 2, y0=("0.5", "0"), engine="fast")
    new = simulate_coupled(p, "0.05", "first-order", 2, y0=("0.5", "0"), model="fast")
    assert np.array_equal(old.y, new.y) and old.stats["engine"] == new.stats["engine"] == "fast"
    assert Precision.parse("float64") == new.precision
