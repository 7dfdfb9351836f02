"""The public API: every model behind one Solver protocol, results that serialise, names
documented."""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import json
import os
import shutil
import subprocess
import sys
from collections.abc import Mapping, MutableMapping
from pathlib import Path

import numpy as np
import pytest

import precise_impact as pi
from precise_impact.solvers.base import model_capabilities

SUBPACKAGES = (
    "core",
    "solvers",
    "models",
    "models.circuit",
    "analysis",
    "scenes",
    "verification",
    "lab",
    "io",
    "cli",
)


def test_every_public_name_resolves_and_is_documented():
    missing = [n for n in pi.__all__ if not hasattr(pi, n)]
    assert not missing
    undocumented = [
        n
        for n in pi.__all__
        if not n.isupper()
        and n != "__version__"
        and callable(getattr(pi, n))
        and not (inspect.getdoc(getattr(pi, n)) or "").strip()
    ]
    assert not undocumented, undocumented


@pytest.mark.parametrize("sub", SUBPACKAGES)
def test_subpackages_have_a_docstring_and_all(sub):
    mod = importlib.import_module(f"precise_impact.{sub}")
    assert (mod.__doc__ or "").strip(), sub
    assert isinstance(getattr(mod, "__all__", None), (list, tuple)), sub
    for name in mod.__all__:
        assert hasattr(mod, name) or importlib.util.find_spec(f"precise_impact.{sub}.{name}"), (
            sub,
            name,
        )


def test_models_is_read_only_and_aliases_resolve():
    assert isinstance(pi.MODELS, Mapping) and not isinstance(pi.MODELS, MutableMapping)
    with pytest.raises(TypeError):
        pi.MODELS["mine"] = "no"  # type: ignore[index]
    assert set(pi.MODELS) == {
        "heyoka",
        "analytical",
        "analytical-paper",
        "fast",
        "certified",
        "circuit",
        "switched-capacitor",
        "spice",
    }
    assert isinstance(pi.make_solver("mechanical"), pi.HeyokaSolver)
    with pytest.raises(pi.ParameterError) as e:
        pi.make_solver("nonsense")
    assert e.value.name == "model" and "mechanical (= heyoka)" in str(e.value)


@pytest.mark.parametrize("model", sorted(pi.MODELS))
def test_every_model_is_a_solver_and_simulates(model):
    """Each model of the registry behind the one protocol, in its first declared precision
    (float64, or mp:128 for 'certified'), on the period-3 orbit (eta = 0.74): every model
    stays within 1e-3 of the mechanical reference over 3 periods (the ideal circuit models
    are exact to round-off, ngspice at TMAX = 10 us to ~1e-3, measured 2e-4).  The full
    contract in every declared precision: tests/solvers/test_contract.py."""
    if model == "spice" and shutil.which("ngspice") is None:
        pytest.skip("ngspice is not installed (apt-get install ngspice); CI installs it")
    kind = model_capabilities(model).precisions[0]
    prec = "mp:128" if kind == "mp" else kind
    solver = pi.make_solver(model, prec)
    assert isinstance(solver, pi.Solver)
    p = pi.Params.make(eta="0.74")
    tr = pi.simulate(p, 3, model=model, precision=prec)
    ref = pi.simulate(p, 3)
    assert isinstance(tr, pi.Trajectory) and len(tr.t) == 4
    x = np.asarray(tr.x, dtype=float)
    xr = np.asarray(ref.x, dtype=float)
    assert np.max(np.abs(x - xr)) < 1e-3


def _roundtrip(result, tmp_path):
    """``to_dict()`` is plain JSON, and ``save(.json)`` writes exactly that, which loads back."""
    d = result.to_dict()
    text = json.dumps(d, allow_nan=False)  # must not raise: plain JSON types, no NaN
    path = result.save(tmp_path / f"{type(result).__name__}.json")
    assert path.exists() and json.loads(path.read_text()) == json.loads(text)
    return d


#: Result types not built here, each with the test that round-trips it instead.
ROUND_TRIPPED_ELSEWHERE = {
    # 24 s for the quick main job: test_cli.test_reproduce_quick_main_job reads report.json,
    # which reproduce() writes with ReproduceResult.save (= to_dict()).
    "ReproduceResult": "tests/test_cli.py::test_reproduce_quick_main_job",
}


@pytest.fixture(scope="session")
def results(tmp_path_factory):
    """One small instance of every public result type, keyed by class name (about 6 s)."""
    tiny = {  # work precision on 10 periods, three heyoka tolerances and the closed form (~3 s)
        "cases": {
            "periodic": {"eta": "0.74", "periods": 10},
            "chaotic": {"eta": "0.712", "periods": 10},
        },
        "heyoka": {"float64": ["1e-5", "1e-9", None]},
        "heyoka_mp": [],
        "analytical_paper": [],
        "analytical_robust": True,
        "analytical_mp_dps": [],
        "scipy": {},
        "spice_tmax": [],
        "chaos_N": [10, 40, 80],
        "certify_N": 40,
        "budget_s": 0.5,
        "circuit": False,
    }
    p = pi.Params.make(eta="0.74")
    spec = pi.SweepSpec.make(
        pi.Params.make(), [("eta", "0.70", "0.72", 2)], periods=20, transient=5, tile_size=2
    )
    made = [
        pi.simulate(p, 2, precision="mp:128"),
        pi.lyapunov(p, periods=40, transient=10, initial_conditions=1, segments=2),
        pi.simulate_coupled(p, "0.05", "first-order", 5, y0=("0.5", "0")),
        pi.simulate_coupled_circuit(pi.nominal_components(p), "0.05", 3),
        pi.sync_scan(
            p, "first-order", ["0.05"], periods=20, ensemble=2, lle_periods=0, per_period=4
        ),
        pi.bifurcation(
            p, ("eta", "0.70", "0.72", 2), periods=20, transient=5, workers=1, progress=False
        ),
        pi.run_sweep(spec, tmp_path_factory.mktemp("sweep"), workers=1, progress=False),
        pi.accuracy_table(periods=3, etas=("0.74",), progress=False),
        pi.compare("fig6-period3-ideal", ["circuit"], periods=10, progress=False),
        pi.work_precision(quick=True, progress=False, config=tiny),
        pi.find_orbit(pi.Params.make(eta="0.74"), 3),
    ]
    cont = pi.continue_orbit(pi.Params.make(R="0.8", eta="1"), "eta", "1", "0.95", 1, max_points=40)
    made += [
        cont,
        cont.branches[0],
        cont.bifurcations[0],
        pi.certify(p, 3, precision="mp:128"),
        pi.certify_coupled(p, "0.1", "reduced", 3, y0=("0.5", "0.1"), precision="mp:128"),
        pi.prove_orbit(pi.Params.make(eta="0.70"), 1, guess=("102/53", "49/265"), impacts=0),
        pi.prove_landmark(pi.locate_landmark("grazing"), "1e-40"),  # 0.1 s
    ]
    # the bench (issue 24): a short synthetic capture, its score, two captures as a measured
    # diagram, the time-series LLE of a model run, the grazing-only budget, a netlist (~4 s)
    cap = pi.synth_capture("fig6-period3-ideal", periods=20, transient=10, seed=1)
    caps = [
        pi.synth_capture("fig6-period3-ideal", eta=e, periods=20, transient=10)
        for e in ("0.73", "0.74")
    ]
    dense = pi.simulate(pi.Params.make(eta="0.712"), 60, per_period=40)
    dx, dv = (np.asarray(a, dtype=float) for a in (dense.dense_x, dense.dense_v))
    dt = float(dense.dense_t[1]) - float(dense.dense_t[0])
    made += [
        cap,
        pi.score_capture(cap, "fig6-period3-ideal", lle=False, floor_captures=2, transient=10),
        pi.measured_bifurcation(caps, "fig6-period3-ideal", computed=4, computed_periods=20),
        # identification (issue 38): 30 periods of the period-3 orbit (~1 s)
        ident := pi.identify(
            pi.synth_capture("fig6-period3-ideal", periods=30, seed=2), "fig6-period3-ideal"
        ),
        pi.predict(ident, samples=4, periods=1000, sample_periods=500, transient=100),
        pi.diagnose(ident),
        pi.timeseries_lle(np.column_stack([dx, dv]), dt, period=40 * dt),
        pi.tolerance_budget(
            "fig6-period2-datasheet",
            landmarks=("grazing",),
            mc=0,
            sobol=0,
            lle_mc=0,
            scans=False,
            fd_check=False,
            progress=False,
        ),
    ]
    # the impact surface (issue 25): a short impact-map orbit, the singularity set of a
    # coarse continuation, a 4 x 3 domain map, a (1,1) response curve (~3 s)
    made += [
        pi.impact_map_orbit(pi.Params.make(eta="0.74"), "0.1", "0.5", 3),
        pi.singularity_set(pi.Params.make(eta="0.74"), v_max=1.0, step=0.05),
        pi.basins(
            pi.Params.make(eta="0.74"),
            ((0, 1, 4), (0.5, 2.5, 3)),
            transient=60,
            refine=False,
            progress=False,
        ),  # fmt: skip
        pi.response_curve(
            pi.Params.make(zeta="0", R="0.8", eta="2.8"),
            1,
            "x_w",
            "-2",
            "0.5",
            at="-1",
            max_points=60,
        ),  # fmt: skip
    ]
    if shutil.which("ngspice") is not None:  # CI installs it; the count test names it if not
        made.append(
            pi.score_netlist(
                Path(__file__).parent / "lab/data/fig6_period3_ideal.cir",
                "s",
                "q",
                "v3",
                scene="fig6-period3-ideal",
                periods=5,
                progress=False,
            )
        )
    return {type(r).__name__: r for r in made}


def _public_result_types():
    return {
        n
        for n in pi.__all__
        if isinstance(getattr(pi, n), type)
        and issubclass(getattr(pi, n), pi.ResultMixin)
        and getattr(pi, n) is not pi.ResultMixin
    }


def test_every_public_result_type_is_covered(results):
    assert _public_result_types() == set(results) | set(ROUND_TRIPPED_ELSEWHERE)
    for name in _public_result_types():
        assert dataclasses.is_dataclass(getattr(pi, name)), name


@pytest.mark.parametrize("name", sorted(_public_result_types() - set(ROUND_TRIPPED_ELSEWHERE)))
def test_results_round_trip_through_json(name, results, tmp_path):
    r = results[name]
    assert type(r) is getattr(pi, name)
    d = _roundtrip(r, tmp_path)
    if (
        type(r).to_dict is pi.ResultMixin.to_dict
    ):  # Trajectory-like results lay out their samples themselves
        assert set(d) == {f.name for f in dataclasses.fields(r)}
    if name == "LyapunovResult":
        assert d["method"] == "variational" and d["stats"]["impacts"] > 0
    if name == "Trajectory":
        assert d["precision"] == "mp:128" and len(d["samples"]) == 3
    if name == "CoupledTrajectory":
        assert d["form"] == "first-order"
    if name == "SweepResult":
        assert d["complete"] and d["stats"]["tiles_computed"] == 1 and len(d["lle"]) == 2
        assert d["spec"]["axes"] == [["eta", ["0.7", "0.72"]]]


def test_array_results_save_npz_that_loads_back(results, tmp_path):
    """Results with arrays also save ``.npz``: the arrays come back bit for bit."""
    for name in (
        "Trajectory",
        "BifurcationResult",
        "SweepResult",
        "LyapunovResult",
        "CoupledTrajectory",
    ):
        r = results[name]
        path = r.save(tmp_path / f"{name}.npz")
        with np.load(path) as z:
            arrays = {
                f.name: getattr(r, f.name)
                for f in dataclasses.fields(r)
                if isinstance(getattr(r, f.name), np.ndarray) and getattr(r, f.name).dtype != object
            }
            for key, a in arrays.items():
                if key in z.files:
                    assert np.array_equal(z[key], a, equal_nan=True), (name, key)
            assert arrays.keys() & set(z.files) or name == "Trajectory", name
    sw = results["SweepResult"]
    csv = sw.save(tmp_path / "sweep.csv").read_text().splitlines()
    assert (
        csv[0] == "eta,lle,stderr,lambda2,period,impacts_per_period,status,eta_exact"
        and len(csv) == 3
    )
    assert csv[1].endswith(",ok,0.7")  # a per-point status word (issue 28: refused points say so)
    assert float(csv[1].split(",")[1]) == sw.lle[0]  # repr(float) round-trips exactly
    with pytest.raises(pi.ParameterError):
        sw.save(tmp_path / "sweep.txt")


def _every_result(results):
    """Every result type (30): the public ones, ReproduceResult (24 s to run) built from its
    fields, and SyncRun."""
    out = dict(results)
    out["ReproduceResult"] = pi.ReproduceResult(
        quick=True,
        periods=20,
        ngspice=False,
        figures={
            "4": {
                "eta": "0.70",
                "regime": "periodic",
                "models": {
                    "circuit (ideal)": {
                        "max_error_second_half": 1e-12,
                        "horizon_0.1": None,
                        "impacts": 3,
                        "elapsed_s": 0.1,
                    }
                },
            }
        },
        lle={"variational": [0.03, 0.001, 100]},
        sync={"paper": {"k_star": 0.031, "k_star_err": 0.001, "message": "crossing"}},
        elapsed_s=1.0,
    )
    out["SyncRun"] = results["SyncResult"].runs[0][0]  # reached through SyncResult.runs
    assert set(out) == _public_result_types() | {"SyncRun"}
    return out


def test_every_result_type_to_dict_loads_with_a_strict_parser(results):
    """All 30 result types (SyncRun and ReproduceResult included): ``to_dict()`` is text a
    strict parser (no NaN / Infinity tokens) loads."""

    def refuse(token):
        raise AssertionError(f"non-strict JSON token {token}")

    for name, r in _every_result(results).items():
        assert isinstance(json.loads(json.dumps(r.to_dict()), parse_constant=refuse), dict), name


#: Result types without samples or rows (one orbit, one point, one run): no to_dataframe.
NO_ROWS = {"Bifurcation", "PeriodicOrbit", "ProvenOrbit", "ProvenLandmark", "SyncRun"}


def test_every_result_type_has_a_short_repr(results):
    """Issue 27: the repr of a 200-period mp:256 Trajectory was 94,429 characters (every
    sample's 78 digits); every result type's repr is now one line, type first, sizes and key
    numbers, at most REPR_LIMIT = 400 characters, whatever it holds."""
    reprs = {name: repr(r) for name, r in _every_result(results).items()}
    reprs["Trajectory-200"] = repr(pi.simulate(pi.Params.make(eta="0.74"), 200, precision="mp:128"))
    for name, text in reprs.items():
        assert len(text) <= 400 and "\n" not in text, (name, len(text))
        assert text.startswith(name.split("-")[0] + "("), name
    assert "periods=200" in reprs["Trajectory-200"] and "n_impacts=133" in reprs["Trajectory-200"]
    assert "t,x,v=<201 object>" in reprs["Trajectory-200"]
    assert "lle=" in reprs["LyapunovResult"] and "regime=" in reprs["CompareResult"]


def test_to_dataframe_on_every_result_type_with_rows(results):
    """Every result type with samples or rows converts to a DataFrame (28 of the 33; the 5
    single-object types say they have none); columns carry units, numbers are float64."""
    pd = pytest.importorskip("pandas")
    everything = _every_result(results)
    assert len(everything) == 33
    covered = 0
    for name, r in everything.items():
        if name in NO_ROWS:
            assert r.tables() == ()
            with pytest.raises(pi.ParameterError, match="no samples or rows"):
                r.to_dataframe()
            continue
        covered += 1
        assert r.tables(), name
        for what in r.tables():
            df = r.to_dataframe(what)
            assert isinstance(df, pd.DataFrame) and len(df) > 0, (name, what)
            for col in df.columns:
                if col.endswith(("[1]", "[1/tau]", "[s]")):
                    assert df[col].dtype == np.float64, (name, what, col)
        pd.testing.assert_frame_equal(r.to_dataframe(), r.to_dataframe(r.tables()[0]))
        with pytest.raises(pi.ParameterError, match="what"):
            r.to_dataframe("no-such-table")
    assert covered == 28
    tr = results["Trajectory"]
    df = tr.to_dataframe()
    assert list(df.columns) == ["period", "t [1]", "x [1]", "v [1]"]
    assert np.array_equal(df["x [1]"].to_numpy(), tr.as_float64()["x"])
    imp = tr.to_dataframe("impacts")
    assert np.array_equal(imp["v_before [1]"].to_numpy(), tr.as_float64()["impacts_v_before"])
    sw = results["SweepResult"].to_dataframe()
    assert sw["eta [1]"].tolist() == [0.7, 0.72] and sw["status"].tolist() == ["ok", "ok"]


def test_to_dataframe_without_pandas_says_how_to_install_it(results, monkeypatch):
    monkeypatch.setitem(sys.modules, "pandas", None)  # import pandas -> ImportError
    with pytest.raises(pi.OptionalDependencyError, match=r"pip install 'precise_impact\[pandas\]'"):
        results["Trajectory"].to_dataframe()


def test_dict_style_access_is_kept_for_one_release():
    ly = pi.lyapunov(
        pi.Params.make(eta="0.74"), periods=20, transient=5, initial_conditions=1, segments=2
    )
    assert ly["lle"] == ly.lle
    with pytest.raises(KeyError):
        ly["no_such_field"]


def _cli(*args, env=None):
    return subprocess.run(
        [sys.executable, "-m", "precise_impact", *args],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )


def test_version_is_written_once():
    from importlib import metadata

    r = _cli("--version")
    assert (
        r.returncode == 0
        and r.stdout.strip() == f"precise-impact {metadata.version('precise_impact')}"
    )
    assert pi.__version__ == metadata.version("precise_impact")


def test_missing_ngspice_is_one_line_and_exit_2(tmp_path):
    env = dict(os.environ, PATH=str(tmp_path))  # a PATH without ngspice
    r = _cli("run", "fig6-period3-ideal", "--model", "spice", "--json", env=env)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and "Traceback" not in r.stderr
    assert "ngspice" in lines[0] and "apt-get install ngspice" in lines[0]


def test_missing_dask_is_one_line_and_exit_2(tmp_path):
    """A Python without the dask extra: hide the package with a sitecustomize-free -c wrapper."""
    code = (
        "import sys; sys.modules['dask'] = None; sys.modules['distributed'] = None; "
        "from precise_impact.cli.main import main; "
        "sys.exit(main(['sweep', '--axis', 'eta', '0.70', '0.72', '2', '--periods', '2', "
        f"'--transient', '1', '--dask', 'local', '--out', {str(tmp_path / 'sw')!r}]))"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert "dask" in lines[0] and "pip install 'precise_impact[dask]'" in lines[0]


@pytest.mark.without_quad
def test_float128_without_quad_precision_is_refused_clearly(monkeypatch):
    """A heyoka build without heyoka.real128: float64 still works, float128 is refused by name."""
    import heyoka

    monkeypatch.delattr(heyoka, "real128", raising=False)
    from precise_impact.core.precision import quad_or_mp

    assert quad_or_mp() == "mp:113"
    tr = pi.HeyokaSolver("float64").solve(pi.Params.make(eta="0.74"), 2)
    assert len(tr.t) == 3
    with pytest.raises(pi.ParameterError) as e:
        pi.simulate(pi.Params.make(), 1, precision="float128")
    assert e.value.name == "precision" and "quad precision" in str(e.value)


def test_plots_never_switch_the_users_backend(tmp_path):
    """A user's backend (here 'svg', set before import) is the same after the package plots."""
    code = f"""
import matplotlib
matplotlib.use("svg")
import precise_impact as pi
from precise_impact.analysis.sync import plot_fig7
plot_fig7(
    pi.Params.make(), "first-order", "0.031", "0.032", 4, {str(tmp_path / "f7.png")!r}, per_period=4
)
pi.accuracy_table
r = pi.BifurcationResult
print(matplotlib.get_backend())
"""
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip().lower() == "svg" and (tmp_path / "f7.png").stat().st_size > 1000


def test_output_files_respect_the_umask(tmp_path):
    old = os.umask(0o027)
    try:
        pi.simulate(pi.Params.make(eta="0.74"), 2).save(tmp_path / "t.npz")
    finally:
        os.umask(old)
    assert (tmp_path / "t.npz").stat().st_mode & 0o777 == 0o640


def test_missing_scipy_is_one_line_and_exit_2_before_any_work(tmp_path):
    code = (
        "import sys; sys.modules['scipy'] = None; sys.modules['scipy.integrate'] = None; "
        "from precise_impact.cli.main import main; "
        f"sys.exit(main(['bench', 'work-precision', '--quick', '--out', {str(tmp_path / 'wp')!r}]))"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert "scipy" in lines[0] and "pip install 'precise_impact[bench]'" in lines[0]
    assert not (tmp_path / "wp").exists()  # refused before any work or output


def test_every_model_is_registered_on_every_import_path():
    """Since the package's names load on first use (issue 35), nothing imported the circuit
    models, which register as they are imported: in a fresh process ``simulate(...,
    model="switched-capacitor")`` was "not allowed" and ``MODELS`` listed 5 of 8 models.  The
    registry now loads its providers at first use."""
    import ast
    import subprocess
    import sys

    program = (
        "import sys; from precise_impact.solvers.base import MODELS, COUPLED_MODELS; "
        "print(sorted(MODELS)); print(sorted(COUPLED_MODELS)); "
        "import precise_impact as pi; "
        "print(type(pi.simulate(pi.Params.make(), 2, model='switched-capacitor')).__name__)"
    )
    r = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, check=True)
    models, coupled, made = r.stdout.splitlines()
    want = {"spice", "circuit", "switched-capacitor", "heyoka", "fast"}
    assert want <= set(ast.literal_eval(models))
    assert len(ast.literal_eval(coupled)) >= 3
    assert made == "Trajectory"
