"""Plots for people: every figure is inspected as a Figure object (axis labels with units,
the lines drawn, legends outside the data, discrete period colours, distinct styles, verdicts
in titles), not just "a file exists"."""

from __future__ import annotations

import dataclasses
import math
from fractions import Fraction as F

import matplotlib
import numpy as np
import pytest
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure

import precise_impact as pi
from precise_impact.analysis.bifurcation import BifurcationResult
from precise_impact.analysis.orbits.branch import Branch, ContinuationResult
from precise_impact.analysis.sweep import SweepResult, SweepSpec
from precise_impact.analysis.sync import SyncResult, fig7_figure, sync_fraction_figure
from precise_impact.errors import ParameterError
from precise_impact.io.figures import (
    impact_path,
    period_colormap,
    plot_units,
    series_styles,
    wrap_title,
)
from precise_impact.models.circuit.components import circuit_scales, to_circuit
from precise_impact.models.circuit.spice import SpiceResult
from precise_impact.verification.workprecision import wp_figure


@pytest.fixture(scope="session")
def traj():
    """Period 3 with impacts, dense output (0.1 s)."""
    return pi.simulate(pi.Params.make(eta="0.74"), 30, per_period=40)


def _outside(fig: Figure, legend) -> bool:
    """The legend's box overlaps none of the figure's data axes (drawn first)."""
    fig.canvas.draw()
    box = legend.get_window_extent()
    axes = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
    return not any(box.overlaps(ax.get_window_extent()) for ax in axes)


def _legends(fig: Figure) -> list:
    return [lg for lg in [*fig.legends, *(ax.get_legend() for ax in fig.axes)] if lg is not None]


def _labels(fig: Figure) -> set[str]:
    return {t.get_text() for lg in _legends(fig) for t in lg.get_texts()}


# ---------------------------------------------------------------- the circuit's units
def test_circuit_scales_are_the_exact_mapping():
    # 20 kOhm, 47 nF, 2 V per unit: omega = 1/(R C); every factor agrees with to_circuit
    comp = pi.nominal_components(pi.Params.make(), R="20e3", C="47e-9", V_unit=2)
    s = circuit_scales(comp)
    w = float(comp.omega())
    t, vs, vq = to_circuit(comp, 3.0, 0.5, -1.25, w)
    assert s.omega == w == pytest.approx(1 / (20e3 * 47e-9), rel=1e-15)
    # one multiplication each: equal to to_circuit's float64 result within 1 ulp
    assert s.seconds_per_tau * 3.0 == pytest.approx(t, rel=2**-52)
    assert s.volts_per_x * 0.5 == vs == -1.0
    assert s.volts_per_v * -1.25 == pytest.approx(vq, rel=2**-51)


def test_plot_units_labels_and_bad_input():
    d = plot_units("dimensionless")
    assert "dimensionless" in d.x_label and d.x_scale == 1.0
    c = plot_units("circuit", params=pi.Params.make())
    assert c.t_label == "t (s)" and c.x_label.startswith("V_s (V)")
    assert c.v_label.startswith("V_q (V)") and c.t_scale == 1e-3 and c.x_scale == -1.0
    with pytest.raises(ParameterError, match="units"):
        plot_units("volts")
    with pytest.raises(ParameterError, match="units"):
        plot_units("circuit")


# ---------------------------------------------------------------- impacts as jumps
def test_impact_path_draws_the_jump_at_the_wall():
    t = np.array([0.0, 1.0, 2.0, 3.0])
    x = np.array([1.0, 1.9, 1.8, 1.0])
    v = np.array([1.0, 0.5, -0.5, -1.0])
    px, pv = impact_path(t, x, v, [1.5, 2.5], [0.6, np.nan], [-0.6, np.nan], 2.0)
    # the known impact: to the wall, straight down, on; the unrecorded one: a gap, no chord
    assert px.tolist()[:5] == [1.0, 1.9, 2.0, 2.0, 1.8]
    assert pv.tolist()[:5] == [1.0, 0.5, 0.6, -0.6, -0.5]
    assert np.isnan(px[5]) and np.isnan(pv[6]) and px[-1] == 1.0
    assert len(px) == len(t) + 4


def test_trajectory_plot_units_and_vertical_jumps(traj):
    f = traj.as_float64()
    for units, xw, tl, xl, vl in (
        ("dimensionless", 2.0, "tau = omega t (dimensionless)", "x (dim", "x' = dx/dtau (dim"),
        ("circuit", -2.0, "t (s)", "V_s (V)", "V_q (V)"),
    ):
        fig = traj.plot(units=units)
        ax1, ax2 = fig.axes
        assert ax1.get_xlabel().startswith(xl) and ax1.get_ylabel().startswith(vl)
        assert ax2.get_xlabel() == tl and ax2.get_ylabel().startswith(xl)
        curve = ax1.get_lines()[0]
        px, pv = curve.get_xdata(), curve.get_ydata()
        # two points per impact at the wall, exactly: the jump is vertical
        at_wall = np.flatnonzero(px == xw)
        assert len(at_wall) == 2 * traj.n_impacts > 0
        first = at_wall[0]
        assert px[first + 1] == xw and pv[first] * pv[first + 1] < 0  # velocity reversal
        assert any(lab.startswith("wall") and str(abs(xw))[0] in lab for lab in _labels(fig))
        assert len(f["impacts_t"]) == traj.n_impacts
        assert all(_outside(fig, lg) for lg in _legends(fig))


def test_plot_returns_the_figure_and_writes_on_request(traj, tmp_path):
    backend, rc = matplotlib.get_backend(), dict(matplotlib.rcParams)
    fig = traj.plot()
    assert isinstance(fig, Figure) and not list(tmp_path.iterdir())
    for suffix in ("png", "svg"):
        out = traj.plot(tmp_path / f"t.{suffix}")
        assert isinstance(out, Figure) and (tmp_path / f"t.{suffix}").stat().st_size > 1000
    with pytest.raises(ParameterError, match="path"):
        traj.plot(tmp_path / "t.txt")
    assert matplotlib.get_backend() == backend and dict(matplotlib.rcParams) == rc


def test_every_result_type_with_samples_or_rows_plots():
    have = [
        pi.Trajectory,
        pi.CoupledTrajectory,
        pi.CertifiedTrajectory,
        pi.CertifiedCoupledTrajectory,
        pi.CoupledCircuitTrajectory,
        pi.SyncResult,
        Branch,
        ContinuationResult,
        BifurcationResult,
        pi.LyapunovResult,
        SweepResult,
        pi.WorkPrecisionResult,
        pi.CompareResult,
        pi.AccuracyResult,
        pi.ReproduceResult,
        SpiceResult,
    ]
    missing = [c.__name__ for c in have if not callable(getattr(c, "plot", None))]
    assert not missing


# ---------------------------------------------------------------- coupled runs
def test_fig7_titles_give_the_verdict_and_units():
    p = pi.Params.make()
    y0 = (F(-1, 2), F(1, 2))
    runs = [
        pi.simulate_coupled(p, k, "first-order", 100, y0=y0, per_period=10) for k in ("0", "0.08")
    ]
    fig = fig7_figure(runs, 1e-8, units="circuit")
    a, b = fig.axes
    assert a.get_title(loc="left").endswith("k = 0: not synchronised")
    assert "k = 0.08: synchronised" in b.get_title(loc="left")
    assert "a) does not synchronise, b) synchronises" in fig.get_suptitle()
    assert a.get_ylabel() == "|V_s1 - V_s2| (V)" and b.get_xlabel() == "t (s)"
    assert all(_outside(fig, lg) for lg in _legends(fig))


def test_sync_fraction_legend_is_outside_the_data_and_k_star():
    r = SyncResult(
        params=pi.Params.make(),
        form="first-order",
        k_values=[F(2, 100), F(3, 100), F(4, 100)],
        periods=100,
        ensemble=4,
        seed=0,
        per_period=20,
        tail=0.1,
        threshold=1e-8,
        fraction_synchronised=np.array([0.0, 0.5, 1.0]),
        fraction_intermittent=np.array([0.5, 0.25, 0.0]),
        fraction_burst=np.zeros(3),
        fraction_collapsed=np.zeros(3),
        mean_rate=np.zeros(3),
        runs=[],
        k_star=0.03,
        k_star_err=0.002,
        message="",
        lle=0.03,
        lle_stderr=0.001,
        lle_periods=100,
        elapsed_s=0.0,
    )
    fig = sync_fraction_figure(r)
    (lg,) = _legends(fig)
    assert _outside(fig, lg) and "k* = 0.0300" in fig.axes[0].get_title()
    assert isinstance(r.plot(), Figure)


# ---------------------------------------------------------------- bifurcation
def _bif(R="1"):
    eta = [F(70, 100), F(71, 100), F(72, 100)]
    rng = np.random.default_rng(0)
    return BifurcationResult(
        params=pi.Params.make(R=R),
        eta=eta,
        x=np.vstack([np.full(50, 1.9), rng.uniform(0.5, 2.0, 50), np.tile([1.2, 1.7], 25)]),
        lle=np.array([-0.05, 0.03, -0.05]),
        lle_stderr=np.array([0.0, 0.002, 0.0]),
        impacts_per_period=np.array([0.0, 0.67, 1.0]),
        grazing=[0.7107],
        periods=50,
        transient=10,
        elapsed_s=0.0,
        workers=1,
        status=["ok"] * 3,
    )


def test_bifurcation_names_the_minus_zeta_line_for_what_it_is():
    r = _bif()
    fig = r.plot()
    labels = _labels(fig)
    assert not any("no impacts" in lab for lab in labels)
    assert any(lab.startswith("-zeta = half the exponent sum (R = 1)") for lab in labels)
    # R = 1: half the exponent sum is -zeta exactly, impacts or not
    assert np.all(r.half_exponent_sum() == -0.05)
    # R = 0.8: -zeta + nu ln R with nu = impacts per period * eta / (2 pi)
    r8 = _bif("0.8")
    nu = r8.impacts_per_period * np.array([0.70, 0.71, 0.72]) / (2 * math.pi)
    assert r8.half_exponent_sum() == pytest.approx(-0.05 + nu * math.log(0.8), rel=1e-15)
    # R = 0 (plastic): -inf where the orbit impacts, -zeta where it does not, one value per eta
    # (a scalar failed the plot: `bifurcation --R 0` exited with a matplotlib traceback)
    r0 = _bif("0")
    assert list(r0.half_exponent_sum()) == [-0.05, -math.inf, -math.inf]
    r0.plot()
    assert all(_outside(fig, lg) for lg in _legends(fig))
    ax1, ax2 = fig.axes[:2]
    assert ax1.get_ylabel() == "x at t0 + kT (dimensionless)" and ax2.get_xlabel().startswith("eta")


def test_bifurcation_draws_a_density_image_not_millions_of_markers():
    r = _bif()
    fig = r.plot()
    (img,) = fig.axes[0].get_images()
    # the chaotic column inks many rows, the period-1 column one row, period-2 two rows
    a = np.ma.getdata(img.get_array())
    inked = (np.ma.getmaskarray(img.get_array()) == 0).sum(axis=0)
    assert inked[0] == 1 and inked[2] == 2 and inked[1] > 20 and a.shape[1] == 3


# ---------------------------------------------------------------- sweep's period map
def test_period_colormap_is_discrete_with_a_none_category():
    per = np.array([[1, 2, 3], [0, 32, -1], [np.nan, 3, 1]])
    index, cmap, norm, labels = period_colormap(per, 32)
    assert isinstance(cmap, ListedColormap) and isinstance(norm, BoundaryNorm)
    assert labels == ["refused", "none <= 32", "1", "2", "3", "32"] and cmap.N == 6
    assert index[1, 1] == 5 and index[0, 0] == 2 and np.isnan(index[2, 0])
    # one colour per category: no interpolation between periods
    assert len({tuple(cmap(norm(i))) for i in range(6)}) == 6


def test_sweep_period_map_colour_bar_names_whole_periods():
    base = pi.Params.make()
    spec = SweepSpec.make(base, [("eta", "0.70", "0.72", 3), ("a", "0.9", "1.1", 2)], periods=60)
    per = np.array([[1.0, 0.0], [3.0, 25.0], [-1.0, 2.0]])
    z = np.zeros((3, 2))
    r = SweepResult(spec, z, z, z, per, z, complete=True)
    fig = r.plot()
    img = fig.axes[1].get_images()[0]
    assert isinstance(img.norm, BoundaryNorm) and img.cmap.N == 6
    cbar = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"][-1]
    ticks = [t.get_text() for t in cbar.get_yticklabels()]
    assert ticks == ["refused", "none <= 32", "1", "2", "3", "25"]


# ---------------------------------------------------------------- styles and titles
def test_eleven_series_get_eleven_distinct_styles():
    st = series_styles(11)
    assert len({(s["color"], s["marker"], s["ls"]) for s in st}) == 11
    assert len({(s["color"], s["marker"]) for s in series_styles(42)}) == 42
    fams = [f"method {i}" for i in range(11)]
    rows = [
        {"case": "periodic", "family": f, "time_s": 0.1 * (i + 1), "error": 10.0**-i}
        for i, f in enumerate(fams)
    ]
    ref = {"eta": "0.74", "periods": 50, "agreement": 1e-50, "precision": "mp:192", "check": "x"}
    fig = wp_figure({"cases": {"periodic": {}}, "rows": rows, "references": {"periodic": ref}})
    lines = [ln for ln in fig.axes[0].get_lines() if ln.get_label() in fams]
    assert len({(ln.get_color(), ln.get_marker(), ln.get_linestyle()) for ln in lines}) == 11
    (lg,) = fig.legends
    assert _outside(fig, lg)


def test_long_titles_are_wrapped_to_fit(traj):
    title = "fig6-period3-datasheet: switched-capacitor, effects: " + ", ".join(["x" * 12] * 12)
    fig = pi.io.figures.plot_trajectory(traj, title=title)
    fig.canvas.draw()
    box = fig._suptitle.get_window_extent()
    assert box.x0 >= 0 and box.x1 <= fig.bbox.width
    assert "\n" in wrap_title(title, fig)


# ---------------------------------------------------------------- other results
def test_branch_and_continuation_plots_keep_the_legend_beside():
    n = 5
    b = Branch(
        parameter="eta",
        period=1,
        impacts=1,
        origin="start",
        values=np.linspace(0.8, 0.9, n),
        x=np.linspace(1.0, 1.5, n)[:, None],
        v=np.zeros((n, 1)),
        multipliers=np.zeros((n, 2, 2)),
        stable=np.array([True] * 3 + [False] * 2),
        admissible=np.ones(n, dtype=bool),
        lle=np.linspace(-0.05, 0.01, n),
        stop_reason="end of range",
    )
    c = ContinuationResult(pi.Params.make(), "eta", F(8, 10), F(9, 10), [b], [], 0.0)
    for fig in (b.plot(), c.plot()):
        assert all(_outside(fig, lg) for lg in _legends(fig))
        assert fig.axes[0].get_ylabel() == "x at t0 + kT (dimensionless)"
    assert "wall x = x_w" in _labels(c.plot())


def test_lyapunov_plot_shows_convergence(traj):
    r = pi.lyapunov(pi.Params.make(eta="0.74"), periods=60, transient=20)
    fig = r.plot()
    run_line = [ln for ln in fig.axes[0].get_lines() if ln.get_label() == "running estimate"]
    assert len(run_line) == 1 and len(run_line[0].get_xdata()) == len(r.running)
    assert fig.axes[0].get_ylabel() == "LLE per unit time tau"


def test_dataclass_results_plot_rows():
    acc = pi.AccuracyResult(
        periods=10,
        reference_bits=128,
        rows=[
            {"eta": e, "model": m, "precision": "float64", "max_error": 1e-12, "role": "candidate"}
            for e in ("0.70", "0.74")
            for m in ("heyoka", "analytical")
        ],
    )
    fig = acc.plot()
    assert [len(ax.patches) for ax in fig.axes] == [2, 2]
    fields = {f.name for f in dataclasses.fields(pi.ReproduceResult)}
    assert {"figures", "sync"} <= fields


# ---------------------------------------------------------------- the commands' figures
def test_compare_portraits_overlay_the_reference_with_verdicts(traj):
    from precise_impact.verification.compare import portraits_figure

    scene = pi.load_scene("fig6-period3-datasheet")
    model = pi.simulate(scene.params, 30, per_period=40)
    results = {"circuit": {"regime": "periodic", "max_state_error": 1.5e-12, "period_model": 3}}
    u = plot_units("circuit", components=scene.design())
    fig = portraits_figure(scene, traj, {"circuit": model}, 10, results, u)
    ref_ax, model_ax = fig.axes
    assert model_ax.get_title().endswith("max state error 1.5e-12, period 3")
    rings = [ln for ln in model_ax.get_lines() if ln.get_label() == "reference samples"]
    assert len(rings) == 1 and len(rings[0].get_xdata()) == 21  # samples 10..30
    assert ref_ax.get_xlabel().startswith("V_s (V)") and ref_ax.get_ylabel().startswith("V_q")
    assert "omega = 1000 rad/s" in fig.get_suptitle().replace("\n", " ")
    (lg,) = fig.legends
    assert _outside(fig, lg)
    # a long verdict wraps inside its panel instead of running into the next one
    long = {"circuit": {**results["circuit"], "period_model": "3 " + "x" * 120}}
    fig = portraits_figure(scene, traj, {"circuit": model}, 10, long, u)
    fig.canvas.draw()
    for ax in fig.axes:
        width = ax.title.get_window_extent().width
        assert width <= 1.05 * ax.get_window_extent().width


def test_scene_figure_titles_fit_and_units(traj):
    from precise_impact.scenes.run import scene_figure

    scene = pi.load_scene("fig6-period3-datasheet")
    obj = {"model": "switched-capacitor", "effects": ["comparator", "flipflop", "switch"]}
    fig = scene_figure(scene, traj, obj, units="circuit")
    fig.canvas.draw()
    assert fig._suptitle.get_window_extent().x1 <= fig.bbox.width
    assert fig.axes[1].get_xlabel() == "t (s)"


def test_units_flag_is_checked_before_any_work(tmp_path):
    import subprocess
    import sys

    r = subprocess.run(
        [sys.executable, "-m", "precise_impact", "run", "fig6-period3-ideal", "--units", "volts"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 2 and "--units" in r.stderr and "circuit" in r.stderr


def test_trajectory_plot_last_periods(traj):
    fig = traj.plot(last=5)
    ax1, ax2 = fig.axes
    strobe = [ln for ln in ax2.get_lines() if ln.get_label() == "samples at t0 + kT"][0]
    assert len(strobe.get_xdata()) == 6  # samples 25..30
    t_from = float(traj.as_float64()["t"][25])
    assert min(ax2.get_lines()[0].get_xdata()) >= t_from and "last 5 periods" in ax1.get_title()
    with pytest.raises(ParameterError, match="last"):
        traj.plot(last=0)


def test_circuit_units_for_a_system_no_circuit_realises():
    """The seconds and volts do not depend on R or zeta: a mechanical run at R = 0.8 (or
    zeta = 0) is drawn in circuit units (was refused: 'R = 1 for the circuits'), and a
    design that is not a Components object is refused by name (was an AttributeError)."""
    from precise_impact import ParameterError, Params
    from precise_impact.io.figures import plot_units

    one = plot_units("circuit", params=Params.make(R="1"))
    for kw in ({"R": "0.8"}, {"zeta": "0"}):
        u = plot_units("circuit", params=Params.make(**kw))
        assert (u.t_scale, u.x_scale, u.v_scale) == (one.t_scale, one.x_scale, one.v_scale)
    with pytest.raises(ParameterError, match="components"):
        plot_units("circuit", components="x")
