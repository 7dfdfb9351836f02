"""Fuzzing the Python API and the scene files: hostile values for every argument.

The invariant (issue 12, item 7): a public function given any value for one argument
either does its (small, bounded) job or raises :class:`ParameterError` (a ``ValueError``)
whose ``name`` is that argument; never another exception, never a hang.  Numpy scalars and
plain mappings are accepted where a user would pass them.  Scene files: any value of any
key is refused in one ``ParameterError`` naming the key, or the scene runs.

Examples per test: ``PRECISE_IMPACT_FUZZ_EXAMPLES`` (default 25; the ``slow`` run below
uses 20x as many).
"""

from __future__ import annotations

import functools
import math
import os
import time
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from precise_impact import (
    BudgetExceededError,
    IntegrationError,
    OptionalDependencyError,
    ParameterError,
    Params,
    SweepSpec,
    bifurcation,
    grazing_frequencies,
    load_scene,
    lyapunov,
    make_solver,
    nominal_components,
    run_scene,
    simulate,
    simulate_coupled,
    steady_state,
    sync_scan,
)

EXAMPLES = int(os.environ.get("PRECISE_IMPACT_FUZZ_EXAMPLES", "25"))
TIME_BOUND = 60.0

#: Values a careless or hostile caller passes.  Legal ones must run (small jobs only:
#: counts are either illegal or tiny), illegal ones must be refused by name.
HOSTILE = st.one_of(
    st.text(max_size=30),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from(
        [
            None,
            [],
            {},
            (),
            object(),
            b"1",
            True,
            False,
            -1,
            0,
            10**30,
            2**64,
            -(10**400),
            "1e400",
            "1e-400",
            "nan",
            "inf",
            "-0",
            "9" * 700,
            "1e999999999",
            "mp:0",
            "mp:100000",
            Fraction(1, 3),
            Fraction(-7, 2),
            np.float64("nan"),
            np.float64(1e308),
            np.int64(-5),
            np.float32(0.5),
            complex(1, 1),
            "0x10",
            " 0.7 ",
            "1_000",
            "٣",
        ]
    ),
)

ETA = dict(params=Params.make())


def _call_simulate(**kw):
    base = dict(periods=2)
    base.update(kw)
    return simulate(**base)


def _call_lyapunov(**kw):
    base = dict(periods=20, transient=5)
    base.update(kw)
    return lyapunov(base.pop("params", Params.make()), base.pop("method", "variational"), **base)


def _call_bifurcation(**kw):
    base = dict(
        eta_min="0.7", eta_max="0.72", n=2, periods=5, transient=5, workers=1, progress=False
    )
    base.update(kw)
    return bifurcation(base.pop("params", Params.make()), **base)


def _call_sync(**kw):
    base = dict(
        form="first-order",
        k_values=["0.05"],
        periods=5,
        ensemble=1,
        lle_periods=10,
        lle_transient=5,
        per_period=2,
    )
    base.update(kw)
    return sync_scan(base.pop("params", Params.make()), **base)


def _call_sweep_spec(**kw):
    base = dict(axes=[("eta", "0.7", "0.72", 2)], periods=5, transient=5)
    base.update(kw)
    return SweepSpec.make(base.pop("base", Params.make()), **base)


def _call_coupled(**kw):
    base = dict(k="0.05", periods=3)
    base.update(kw)
    return simulate_coupled(base.pop("params", Params.make()), **base)


def _call_solver(**kw):
    base = dict(model="heyoka", precision="float64", tol=None)
    base.update(kw)
    return make_solver(base.pop("model"), base.pop("precision"), base.pop("tol")).solve(
        Params.make(), 2
    )


def _call_orbit(**kw):
    from precise_impact import find_orbit

    base = dict(period=3, transient=200)
    base.update(kw)
    return find_orbit(base.pop("params", Params.make(eta="0.74")), **base)


def _call_one_impact(**kw):
    from precise_impact import one_impact_orbits

    base = dict(dps=20, grid=50)
    base.update(kw)
    return one_impact_orbits(base.pop("params", Params.make(R="0.8", eta="1")), **base)


def _call_continue(**kw):
    from precise_impact import continue_orbit

    base = dict(
        parameter="eta", start="1", stop="0.99", period=1, max_points=4, doublings=0, transient=200
    )
    base.update(kw)
    return continue_orbit(base.pop("params", Params.make(R="0.8")), **base)


def _call_certify(**kw):
    from precise_impact import certify

    # a budget: a hostile value that is a valid large count ("1_000" is periods=1000) ends
    # within ~2 s (refused before work when estimated over it, else BudgetExceededError: both
    # accepted answers) instead of certifying for up to a minute; the base call takes 0.04 s,
    # so every small legal value still runs to its end
    base = dict(periods=2, precision="mp:128", max_time=2)
    if "bits" in kw:  # the deprecated spelling of precision
        del base["precision"]
    base.update(kw)
    return certify(base.pop("params", Params.make()), **base)


def _call_certify_coupled(**kw):
    from precise_impact import certify_coupled

    # a budget, as for certify: certify_coupled(periods="1_000") ran 30-45 s (refused at once
    # now, estimated over max_time); the base call takes 0.04 s
    base = dict(
        k="0.1", form="reduced", periods=2, y0=("0.5", "0.1"), precision="mp:128", max_time=2
    )
    if "bits" in kw:  # the deprecated spelling of precision
        del base["precision"]
    base.update(kw)
    return certify_coupled(base.pop("params", Params.make()), **base)


def _call_prove(**kw):
    from precise_impact import prove_orbit

    base = dict(period=1, bits=128, guess=("102/53", "49/265"), impacts=0)
    base.update(kw)
    return prove_orbit(base.pop("params", Params.make(eta="0.70")), **base)


def _call_lyapunov_fast(**kw):
    base = dict(model="fast", periods=20, transient=5)
    base.update(kw)
    return lyapunov(base.pop("params", Params.make()), base.pop("method", "variational"), **base)


def _call_run_sweep(**kw):
    """A two-point fast-engine sweep into a fresh directory (a text ``out`` is put under it)."""
    import tempfile

    from precise_impact import run_sweep

    with tempfile.TemporaryDirectory() as tmp:
        base = dict(out=os.path.join(tmp, "s"), workers=1, progress=False)
        if isinstance(kw.get("out"), str):
            kw["out"] = os.path.join(tmp, kw["out"].replace("/", "_").replace("\x00", ""))
        base.update(kw)
        spec = base.pop("spec", None)
        if spec is None:
            spec = SweepSpec.make(
                Params.make(), [("eta", "0.7", "0.72", 2)], periods=5, transient=5, model="fast"
            )
        return run_sweep(spec, **base)


def _zeros(p, n):
    return [0.0] * (n + 1), [0.0] * (n + 1)


def _call_score_solver(**kw):
    from precise_impact.testing import score_solver

    base = dict(solver=_zeros, case="single-0.74", periods=3)
    base.update(kw)
    return score_solver(base.pop("solver"), **base)


def _call_score_solver_output(solver):
    """The fuzzed value is what the solver returns."""
    return _call_score_solver(solver=lambda p, n: solver)


def _call_score_solver_samples(solver):
    """The fuzzed value is every sample the solver returns."""
    return _call_score_solver(solver=lambda p, n: ([solver] * (n + 1), [solver] * (n + 1)))


_BUDD_DUX = Params.make(eta="4.85", zeta=0, R="0.5", x_w="-0.3", x0="-0.5")


def _call_prove_landmark(**kw):
    from precise_impact import locate_landmark, prove_landmark

    base = dict(width="1e-10")
    base.update(kw)
    bp = base.pop("bp", None) if "bp" in base else locate_landmark("grazing")
    return prove_landmark(bp, **base)


def _call_locate_landmark(**kw):
    from precise_impact import locate_landmark

    base = dict(point="grazing")
    base.update(kw)
    return locate_landmark(base.pop("point"), **base)


def _call_impact_map(**kw):
    from precise_impact import impact_map

    base = dict(params=Params.make(), phase=0.3, v=1.0, n=1, engine="heyoka")
    base.update(kw)
    return impact_map(base.pop("params"), base.pop("phase"), base.pop("v"), **base)


def _call_impact_map_orbit(**kw):
    from precise_impact import impact_map_orbit

    base = dict(params=Params.make(), phase=0.3, v=1.0, n=2, engine="heyoka")
    base.update(kw)
    args = [base.pop(k) for k in ("params", "phase", "v", "n")]
    return impact_map_orbit(*args, **base)


def _call_singularity_set(**kw):
    from precise_impact import singularity_set

    base = dict(params=Params.make(), max_points=20, seed_phases=4, seed_speeds=8)
    base.update(kw)
    return singularity_set(base.pop("params"), **base)


def _call_basins(**kw):
    from precise_impact import basins

    base = dict(params=_BUDD_DUX, grid=((0, 1, 1), (0.1, 0.5, 1)), transient=5, progress=False)
    base.update(kw)
    return basins(base.pop("params"), base.pop("grid"), **base)


def _call_point_attractor(**kw):
    from precise_impact.analysis.impact_surface.basins import point_attractor

    base = dict(params=_BUDD_DUX, section="impact", u=0.3, v=0.2, transient=20)
    base.update(kw)
    args = [base.pop(k) for k in ("params", "section", "u", "v")]
    return point_attractor(*args, **base)


def _call_response_curve(**kw):
    from precise_impact import response_curve

    base = dict(params=Params.make(eta="2.8", zeta=0, R="0.8"), n=1, parameter="x_w")
    base.update(start=-2, stop=0.5, at=-1, max_points=5)
    base.update(kw)
    return response_curve(**base)


def _call_budd_dux_orbit(**kw):
    from precise_impact.analysis.impact_surface.response import budd_dux_orbit

    base = dict(theta=2.0, eta=2.8, R=0.8)
    base.update(kw)
    return budd_dux_orbit(**base)


def _call_budd_dux_points(**kw):
    from precise_impact.analysis.impact_surface.response import budd_dux_points

    base = dict(eta="2.8", R="0.8", samples=50, dps=15)
    base.update(kw)
    return budd_dux_points(**base)


def _call_budd_dux_locate(**kw):
    from precise_impact.analysis.impact_surface.response import budd_dux_locate

    base = dict(kind="fold", eta=2.8, x_w="-1.7802356013215904924", V=4.08, R="0.8", dps=30)
    base.update(kw)
    return budd_dux_locate(**base)


def _call_timeseries_lle(**kw):
    from precise_impact import timeseries_lle

    base = dict(states=np.sin(0.1 * np.arange(2000)), dt=0.1)
    base.update(kw)
    return timeseries_lle(base.pop("states"), base.pop("dt"), **base)


@functools.cache
def _capture():
    from precise_impact import synth_capture

    return synth_capture("fig6-period3-ideal", periods=8, transient=5)


def _capture_file(tmp):
    from precise_impact import write_capture

    path = os.path.join(tmp, "cap.csv")
    write_capture(_capture(), path, "rigol")
    return path


def _call_read_capture(**kw):
    import tempfile

    from precise_impact import read_capture

    with tempfile.TemporaryDirectory() as tmp:
        base = dict(path=_capture_file(tmp))
        base.update(kw)
        return read_capture(base.pop("path"), **base)


def _call_write_capture(**kw):
    import tempfile

    from precise_impact import write_capture

    with tempfile.TemporaryDirectory() as tmp:
        base = dict(path=os.path.join(tmp, "out.csv"))
        if isinstance(kw.get("path"), str):
            name = kw["path"].replace("/", "_").replace("\x00", "")[:40]
            kw["path"] = os.path.join(tmp, name + "x")
        base.update(kw)
        cap = base.pop("capture") if "capture" in base else _capture()
        return write_capture(cap, base.pop("path"), **base)


def _call_score_capture(**kw):
    from precise_impact import score_capture

    return score_capture(kw["capture"])


def _call_measured_bifurcation(**kw):
    from precise_impact import measured_bifurcation

    return measured_bifurcation(kw["captures"], computed=0)


#: (callable, the arguments to fuzz); each call with valid defaults takes milliseconds.
ENTRY_POINTS = {
    "Params.make": (
        lambda **kw: Params.make(**kw),
        ["eta", "zeta", "a", "x_w", "R", "x0", "v0", "t0"],
    ),
    "simulate": (
        _call_simulate,
        [
            "params",
            "periods",
            "per_period",
            "precision",
            "tol",
            "model",
            "eta",
            "zeta",
            "a",
            "x_w",
            "R",
            "x0",
            "v0",
            "t0",
        ],
    ),
    "make_solver": (_call_solver, ["model", "precision", "tol"]),
    "lyapunov": (
        _call_lyapunov,
        ["params", "method", "periods", "transient", "precision", "model", "max_time"],
    ),
    "lyapunov-fast": (
        _call_lyapunov_fast,
        ["params", "method", "periods", "transient", "precision", "max_time"],
    ),
    "bifurcation": (
        _call_bifurcation,
        ["params", "eta_min", "eta_max", "n", "periods", "transient", "workers", "model"]
        + ["max_time"],
    ),
    "run_sweep": (_call_run_sweep, ["spec", "out", "workers", "dask", "max_tiles"]),
    "score_solver": (_call_score_solver, ["solver", "case", "periods", "atol", "rtol"]),
    "score_solver-output": (_call_score_solver_output, ["solver"]),
    "score_solver-samples": (_call_score_solver_samples, ["solver"]),
    "sync_scan": (
        _call_sync,
        [
            "params",
            "form",
            "k_values",
            "periods",
            "ensemble",
            "seed",
            "tail",
            "threshold",
            "per_period",
            "spread",
            "lle_periods",
            "lle_transient",
            "precision",
            "engine",
            "model",
            "max_time",
        ],
    ),
    "SweepSpec.make": (
        _call_sweep_spec,
        ["base", "axes", "periods", "transient", "tile_size", "batch_size", "max_work", "model"],
    ),
    "simulate_coupled": (
        _call_coupled,
        ["params", "k", "form", "periods", "per_period", "precision", "max_impacts", "engine"],
    ),
    "nominal_components": (
        lambda **kw: nominal_components(kw.pop("params", Params.make()), **kw),
        ["params", "R", "C", "V_unit"],
    ),
    "steady_state": (lambda **kw: steady_state(kw.get("params", Params.make())), ["params"]),
    "grazing_frequencies": (
        lambda **kw: grazing_frequencies(kw.pop("params", Params.make()), **kw),
        ["params", "dps"],
    ),
    "find_orbit": (
        _call_orbit,
        ["params", "period", "guess", "transient", "impacts", "max_iterations", "precision"]
        + ["guess_from", "seed"],
    ),
    "one_impact_orbits": (_call_one_impact, ["params", "dps", "grid", "period"]),
    "certify": (
        _call_certify,
        ["params", "periods", "bits", "target_radius", "max_bits", "precision"],
    ),
    "certify_coupled": (
        _call_certify_coupled,
        ["params", "k", "form", "periods", "y0", "bits", "max_bits", "precision"],
    ),
    "prove_orbit": (
        _call_prove,
        ["params", "period", "guess", "impacts", "bits", "radius", "transient"],
    ),
    "continue_orbit": (
        _call_continue,
        [
            "params",
            "parameter",
            "start",
            "stop",
            "period",
            "impacts",
            "guess",
            "transient",
            "max_points",
            "doublings",
            "virtual",
        ],
    ),
    # the newer entry points (issue 35 item 7d): a wrong kind of leading argument is refused
    # by name before any work (it was an AttributeError / TypeError deep inside)
    "prove_landmark": (_call_prove_landmark, ["bp", "width", "bits"]),
    "locate_landmark": (_call_locate_landmark, ["point", "theta", "side"]),
    "impact_map": (_call_impact_map, ["params", "phase", "v", "n", "engine"]),
    "impact_map_orbit": (_call_impact_map_orbit, ["params", "phase", "v", "n"]),
    "singularity_set": (_call_singularity_set, ["params"]),
    "basins": (_call_basins, ["params", "grid", "section"]),
    "point_attractor": (_call_point_attractor, ["params", "section", "u", "v"]),
    "response_curve": (_call_response_curve, ["params", "n", "parameter"]),
    "budd_dux_orbit": (_call_budd_dux_orbit, ["theta", "eta", "R"]),
    "budd_dux_points": (_call_budd_dux_points, ["eta", "R"]),
    "budd_dux_locate": (_call_budd_dux_locate, ["kind"]),
    "timeseries_lle": (_call_timeseries_lle, ["states", "dt", "method"]),
    "read_capture": (_call_read_capture, ["path", "fmt"]),
    "write_capture": (_call_write_capture, ["capture", "path", "fmt"]),
    "score_capture": (_call_score_capture, ["capture"]),
    "measured_bifurcation": (_call_measured_bifurcation, ["captures"]),
}
#: Outcomes that are answers, not failures, for some entry points: Newton may not reach an
#: orbit (ConvergenceError) or meet a tangential contact on the way (IntegrationError).
ANSWERS = {
    "find_orbit": (IntegrationError,),
    "continue_orbit": (IntegrationError,),
    "certify": (IntegrationError,),
    "certify_coupled": (IntegrationError,),
    "prove_orbit": (IntegrationError,),
    "prove_landmark": (IntegrationError,),
    "locate_landmark": (IntegrationError,),
    "response_curve": (IntegrationError,),
    "impact_map": (IntegrationError,),
    "impact_map_orbit": (IntegrationError,),
    # the closed form's documented poles (V = 0, eta = 0 or 1, R = 1, eta = n / k)
    "budd_dux_orbit": (ZeroDivisionError,),
}
#: Failures the fuzz found in another part's code (reported there, not fixed here): xfail, not
#: strict (most values pass), so that the rest of the fuzz keeps running.
KNOWN: dict[tuple[str, str], str] = {}
CASES = [
    pytest.param(name, arg, marks=pytest.mark.xfail(reason=KNOWN[name, arg], strict=False))
    if (name, arg) in KNOWN
    else (name, arg)
    for name, (_, args) in ENTRY_POINTS.items()
    for arg in args
]


def _names_argument(err: ParameterError, arg: str) -> bool:
    """The refusal names the argument (or, for a parameter set, one of its fields)."""
    n = err.name
    if n == arg or n.startswith(arg + ".") or n.startswith(arg + "[") or arg in n.split(", "):
        return True
    if arg in ("params", "base") and n in Params.__dataclass_fields__:
        return True  # a field of the parameter set
    if (arg in ("path", "capture", "captures") and n == "file") or (arg, n) == ("fmt", "format"):
        return True  # a capture file's refusals name it as the CLI does (FILE, --format)
    if arg == "axes" and (n in ("axis", "n") or n.endswith(("_min", "_max"))):
        return True  # an element of an axis
    if arg.endswith(("_min", "_max")) and n == arg[:-4]:
        return True  # an end of a range outside the parameter's box names the parameter
    return arg in str(err)  # a relation between two arguments (x0 <= x_w, eta_max > eta_min)


@pytest.mark.parametrize(
    "entry,arg", CASES, ids=[f"{e}-{a}" for e, a in (getattr(c, "values", c) for c in CASES)]
)
@settings(
    max_examples=EXAMPLES,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(value=HOSTILE)
def test_fuzz_public_functions(entry, arg, value):
    fn, _ = ENTRY_POINTS[entry]
    t0 = time.perf_counter()
    try:
        fn(**{arg: value})
    except ParameterError as e:
        assert isinstance(e, ValueError)
        assert _names_argument(e, arg), f"{entry}({arg}={value!r}) names {e.name!r}: {e}"
        assert "\n" not in str(e)
    except (BudgetExceededError, OptionalDependencyError):
        pass
    except ANSWERS.get(entry, ()):
        pass
    assert time.perf_counter() - t0 < TIME_BOUND  # a hang guard, not a speed claim


@pytest.mark.parametrize(
    "value",
    [
        np.float64(0.712),
        np.float32(0.75),
        np.int64(1),
        np.int32(2),
        Fraction(89, 125),
        "0.712",
        0.712,
        1,
    ],
)
def test_numpy_scalars_and_exact_values_are_parameters(value):
    """A value a user would pass is taken; a binary float as its shortest round-trip decimal
    (np.float64(0.712) is the 0.712 the user typed, not 0.71199999999999996625...)."""
    p = Params.make(eta=value)
    expect = (
        Fraction(repr(float(value))) if isinstance(value, (float, np.floating)) else Fraction(value)
    )
    assert p.eta == expect
    assert math.isfinite(float(p.eta))


@pytest.mark.parametrize(
    "entry",
    [
        "simulate",
        "lyapunov",
        "bifurcation",
        "sync_scan",
        "simulate_coupled",
        "nominal_components",
        "steady_state",
        "grazing_frequencies",
    ],
)
def test_plain_mappings_are_parameter_sets(entry):
    fn, _ = ENTRY_POINTS[entry]
    fn(params={"eta": "0.712", "x_w": np.float64(2.0)})
    with pytest.raises(ParameterError) as e:
        fn(params={"eta": "-1"})
    assert e.value.name == "eta"


def test_params_are_validated_however_they_were_built():
    import dataclasses

    p = Params.make()
    bad = object.__new__(Params)  # bypasses __init__ and __post_init__
    for f in dataclasses.fields(Params):
        object.__setattr__(bad, f.name, getattr(p, f.name))
    object.__setattr__(bad, "eta", Fraction(-1))
    with pytest.raises(ParameterError) as e:
        simulate(bad, 2)
    assert e.value.name == "eta"
    with pytest.raises(ParameterError):
        dataclasses.replace(p, eta=Fraction(-1))


# --- scene files ------------------------------------------------------------------
SCENE_KEYS = [
    ("parameters", "eta"),
    ("parameters", "zeta"),
    ("parameters", "a"),
    ("parameters", "x_w"),
    ("parameters", "R"),
    ("parameters", "x0"),
    ("model", "precision"),
    ("model", "tol"),
    ("model", "name"),
    ("duration", "periods"),
    ("outputs", "per_period"),
    ("system", "kind"),
    ("components", "R"),
    ("components", "C"),
]


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return {math.inf: "inf", -math.inf: "-inf"}.get(v, "nan" if v != v else repr(v))
    s = str(v).replace("\\", "\\\\").replace('"', '\\"')
    s = "".join(c if c.isprintable() else f"\\u{ord(c):04x}" for c in s if ord(c) < 0x10000)
    return f'"{s}"'


SCENE_VALUES = st.one_of(
    st.text(max_size=30),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(10**20), max_value=10**20),
    st.booleans(),
    st.sampled_from(
        [
            "1e999 ohm",
            "1e-999 ohm",
            "1e400 ohm",
            "1e999 F",
            "1e9999999 ohm",
            "0 ohm",
            "-5 nF",
            "10 kohm",
            "100 nF",
            "mp:99999",
            "float128",
            "1e-300",
            "spice",
        ]
    ),
)


@pytest.mark.parametrize("section,key", SCENE_KEYS, ids=[f"{s}.{k}" for s, k in SCENE_KEYS])
@settings(
    max_examples=EXAMPLES,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(value=SCENE_VALUES)
def test_fuzz_scene_values(tmp_path_factory, section, key, value):
    base = {
        "system": {"kind": '"single"'},
        "model": {"name": '"circuit"', "precision": '"float64"'},
        "parameters": {"eta": '"0.712"'},
        "components": {"R": '"10 kohm"', "C": '"100 nF"'},
        "duration": {"periods": "2"},
        "outputs": {"per_period": "0"},
    }
    base[section][key] = _toml_value(value)
    text = 'name = "fuzz"\n' + "".join(
        f"[{sec}]\n" + "".join(f"{k} = {v}\n" for k, v in kv.items()) for sec, kv in base.items()
    )
    path = tmp_path_factory.mktemp("scene") / "fuzz.toml"
    path.write_text(text, encoding="utf-8")
    t0 = time.perf_counter()
    try:
        scene = load_scene(path)
        run_scene(scene, max_time=60)
    except ParameterError as e:
        # the key, or a relation naming it (x0 <= x_w), or a whole-scene budget
        assert key in e.name or key in str(e) or e.name in ("scene", "max_time", "periods"), (
            section,
            key,
            value,
            str(e),
        )
    except (BudgetExceededError, OptionalDependencyError):
        pass
    assert time.perf_counter() - t0 < TIME_BOUND


@pytest.mark.slow
def test_fuzz_long_run():
    """The same fuzzing with 20x the examples (marked slow; run with -m slow)."""
    import subprocess
    import sys

    env = dict(os.environ, PRECISE_IMPACT_FUZZ_EXAMPLES=str(20 * EXAMPLES))
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "-q",
            "-p",
            "no:cacheprovider",
            __file__,
            os.path.join(os.path.dirname(__file__), "test_reliability.py"),
            "-k",
            "fuzz and not long_run",
        ],
        env=env,
        capture_output=True,
        text=True,
        timeout=5400,
    )
    assert r.returncode == 0, r.stdout[-3000:]


def _wrong_kind_calls():
    from precise_impact import (
        basins,
        impact_map,
        locate_landmark,
        measured_bifurcation,
        prove_landmark,
        read_capture,
        read_raw,
        score_capture,
        score_netlist,
        timeseries_lle,
        write_capture,
    )
    from precise_impact.analysis.impact_surface.basins import point_attractor
    from precise_impact.analysis.impact_surface.response import budd_dux_orbit
    from precise_impact.analysis.orbits.landmarks import seed_landmark

    p = Params.make()
    return {
        "bp": lambda: prove_landmark(p, "grazing"),
        "theta": lambda: locate_landmark("grazing", p),
        "kind": lambda: seed_landmark(p, (0.05, 1.0, 2.0), 0.712),
        "phase": lambda: impact_map(p, p, 1.0),
        "grid": lambda: basins(p, p),
        "section": lambda: point_attractor(p, p, 0.3, 1.0),
        "states": lambda: timeseries_lle(p, 0.1),
        "capture": lambda: write_capture(p, "x.csv"),
        "path": lambda: read_capture(p),
        "captures": lambda: measured_bifurcation(p),
        "R": lambda: budd_dux_orbit(2.0, 2.8, "0.8"),
        "score_capture": lambda: score_capture(p),
        "score_netlist": lambda: score_netlist(p),
        "read_raw": lambda: read_raw(p),
    }


@pytest.mark.parametrize("arg", list(_wrong_kind_calls()))
def test_wrong_kind_of_argument_refused_by_name(arg):
    """A wrong kind of leading argument is one ParameterError naming it and saying what was
    wanted, before any work (issue 35 item 7d: it was an AttributeError, TypeError or a
    plain ValueError deep inside)."""
    name = {"score_capture": "capture", "score_netlist": "path", "read_raw": "path"}.get(arg, arg)
    with pytest.raises(ParameterError) as e:
        _wrong_kind_calls()[arg]()
    assert e.value.name == name and "\n" not in str(e.value)
    assert "Params" in str(e.value) or "str" in str(e.value)
