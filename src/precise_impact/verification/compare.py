"""Compare models of one scene against a demonstrated reference; Markdown report + figures.

Runs the reference (and a perturbed one for chaotic scenes), its LLE and every model, scored
by :func:`precise_impact.verification.scores.score` (``docs/numerics.rst``).
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from collections.abc import Sequence
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from precise_impact.analysis.lyapunov import lyapunov
from precise_impact.core.params import check_count, decimal_str
from precise_impact.core.result import ResultMixin, flat, record_columns
from precise_impact.core.trajectory import Trajectory
from precise_impact.errors import ParameterError
from precise_impact.io.atomic import atomic_write
from precise_impact.io.figures import (
    figure,
    finish,
    legend_outside,
    phase_portrait_panels,
    plot_units,
    save_figure,
    series_styles,
    wrap_title,
)
from precise_impact.io.jsonout import write_json
from precise_impact.io.markdown import table
from precise_impact.io.progress import say as _progress
from precise_impact.models.circuit.spice import find_ngspice
from precise_impact.scenes.run import run_scene
from precise_impact.scenes.scene import Scene, load_scene
from precise_impact.solvers.base import MODEL_ALIASES, MODELS, model_capabilities
from precise_impact.solvers.simulate import make_solver
from precise_impact.verification.metrics import reference_bits, sample_errors, scene_for_model
from precise_impact.verification.points import mechanical_points, point_scores
from precise_impact.verification.scores import detected_period, divergence_rate, score, separation

__all__ = [
    "compare",
    "CompareResult",
    "check_models",
    "format_scores",
    "report_markdown",
    "REF_PERTURBATION",
    "MODEL_PERTURBATION",
    "demonstrated_reference",
    "reference_lle",
    "score_line",
]

#: x0 offset of the second reference (chaotic scenes): decorrelates within ~30 periods.
REF_PERTURBATION = Fraction(1, 1000)
#: x0 offset of each model's second run (its finite-time divergence rate).
MODEL_PERTURBATION = Fraction(1, 10**9)


def check_models(models: str | Sequence[str]) -> list[str]:
    """``'a,b'`` or ``['a', 'b']`` -> validated list; :class:`ParameterError` naming ``models``."""
    if isinstance(models, str):
        models = [m.strip() for m in models.split(",")]
    models = [MODEL_ALIASES.get(m, m) for m in models]
    if not models or any(not m for m in models):
        raise ParameterError(
            "models", ",".join(models), "a comma-separated list of " + ", ".join(MODELS)
        )
    for m in models:
        if m not in MODELS:
            raise ParameterError("models", m, "each one of " + ", ".join(MODELS))
    if len(set(models)) != len(models):
        raise ParameterError("models", ",".join(models), "no model twice")
    return models


def _run_model(scene: Scene, model: str, periods: int, per_period: int, params=None) -> Trajectory:

    if not model_capabilities(model).dense:
        per_period = 0  # e.g. certified: stroboscopic samples and impacts only
    sc = dataclasses.replace(
        scene_for_model(scene, model, periods)[0], periods=periods, per_period=per_period
    )
    if params is not None:
        sc = dataclasses.replace(sc, params=params)
    tr = run_scene(sc)
    if not isinstance(tr, Trajectory):
        raise ParameterError("scene", scene.name, "a single-oscillator scene")
    return tr


def compare(
    scene_name_or_path: str | Path,
    models: Sequence[str] | str,
    out: str | Path | None = None,
    periods: int | None = None,
    progress: bool | None = None,
    transient: int | None = None,
    points: bool = False,
    units: str = "dimensionless",
) -> CompareResult:
    """Score ``models`` on a scene against a demonstrated heyoka reference.

    Parameters
    ----------
    scene_name_or_path : str or Path
        A built-in scene (:func:`~precise_impact.scenes.builtin_scenes`) or a ``.toml`` file.
    models : sequence of str or str
        Names from :data:`precise_impact.solvers.base.MODELS`, every registered model (or
        one string ``'a,b'``); a model that does not take the scene's precision runs in one
        it takes (:func:`~precise_impact.verification.metrics.scene_for_model`).
    out : directory or None, default ``None``
        Writes ``report.md``, ``scores.json``, ``phase_portraits.png``,
        ``separation.png``; ``None`` writes nothing.
    periods : int or None, default ``None``
        Forcing periods; ``None`` is the scene's duration.
    progress : bool or None, default ``None``
        One line per finished run on stderr (``None``: only when stderr is a terminal).
    transient : int or None, default ``None``
        Periods discarded before scoring; ``None`` is ``periods // 5``.
    points : bool, default ``False``
        Also score where each model puts the grazing point of the non-impacting orbit and
        the period-doubling point of the 1:1 orbit along eta, against the mechanics
        (:func:`~precise_impact.verification.points.point_scores`; ~1-10 s per model):
        ``models[m]["points"]`` and ``reference["points"]``.
    units : {'dimensionless', 'circuit'}, default ``'dimensionless'``
        Axes of the figures: ``'circuit'`` in seconds and the volts of the scene's design
        (:func:`precise_impact.io.figures.plot_units`).

    Returns
    -------
    CompareResult
        The scene, parameters, regime, how the reference was made (with its
        demonstrated accuracy), the reference LLE and every model's scores
        (:func:`~precise_impact.verification.scores.score`).

    Raises
    ------
    ParameterError
        Unknown scene or model, or bad counts, before any work.
    OptionalDependencyError
        A model needs a component that is not installed (e.g. ngspice).

    See Also
    --------
    precise_impact.verification.scores.score : the scores of one trajectory against another.
    precise_impact.scenes.scene.load_scene : the scenes by name.
    precise_impact.verification.compare.CompareResult : the result's fields.

    Examples
    --------
    >>> import precise_impact as pi
    >>> r = pi.compare("fig6-period3-ideal", ["circuit"], periods=10, progress=False)
    >>> r.scene, r.periods
    ('fig6-period3-ideal', 10)
    """
    models = check_models(models)
    scene = load_scene(scene_name_or_path)
    if scene.kind != "single":
        raise ParameterError("scene", scene.name, "a single-oscillator scene (kind = 'single')")
    periods = scene.periods if periods is None else check_count(periods, "periods", 10**6)
    if periods < 10:
        raise ParameterError("periods", periods, ">= 10")
    plot_units(units, components=scene.design() if units == "circuit" else None)  # before work
    per_period = scene.per_period or 50
    k = periods // 5 if transient is None else int(transient)
    params = scene.params
    dropped = {
        m: scene_for_model(scene, m, periods)[1] for m in models
    }  # validates every model before any work
    if points:
        for m in models:
            if not model_capabilities(m).dense:  # the grazing point needs the steady state's max x
                raise ParameterError(
                    "models", m, "models with dense output for the points (certified has none)"
                )
    if "spice" in models:
        find_ngspice()  # a missing ngspice is refused before the reference runs, not after

    bits = reference_bits(periods)
    ref, check, ref_info = demonstrated_reference(params, periods, per_period, bits, progress)
    period = detected_period(ref, k)
    regime = "periodic" if period > 0 else "chaotic"
    lle = reference_lle(params, progress)
    ref2 = None
    if regime == "chaotic":
        p2 = params.replace(x0=params.x0 + REF_PERTURBATION)
        ref2 = make_solver("heyoka", f"mp:{bits}").solve(p2, periods)
        ref_info["second_reference_x0"] = decimal_str(p2.x0)
    mech = _mechanical_points(params, ref_info) if points else None
    results: dict[str, Any] = {}
    trajs: dict[str, Trajectory] = {}
    for m in models:
        tr = _run_model(scene, m, periods, per_period)
        trajs[m] = tr
        sc = _score_model(scene, m, tr, periods, regime, ref, ref2, lle, k)
        sc["effects_dropped"] = dropped[m]
        sc["effects"] = sorted(scene_for_model(scene, m, periods)[0].effects)
        if mech is not None:
            sc["points"] = point_scores(scene, m, mech)
        results[m] = sc
        _progress(f"{m}: " + score_line(sc), progress)

    result = {
        "scene": scene.name,
        "description": scene.description,
        "params": params.decimal(),
        "periods": periods,
        "transient_periods": k,
        "regime": regime,
        "reference_period": period,
        "reference": ref_info,
        "lle": lle,
        "models": results,
    }
    if out is not None:
        _write_outputs(Path(out), result, scene, ref, check, trajs, units)
    return CompareResult(**result)


def demonstrated_reference(
    params: Any, periods: int, per_period: int, bits: int, progress: bool | None
):
    """The heyoka reference at ``bits``, its check at ``bits + 64``, and how they agree:
    ``(ref, check, info)`` (the one reference routine of :func:`compare` and of
    :func:`precise_impact.lab.netlist.score_netlist`)."""

    t0 = time.perf_counter()
    ref = make_solver("heyoka", f"mp:{bits}").solve(params, periods, per_period=per_period)
    check = make_solver("heyoka", f"mp:{bits + 64}").solve(params, periods)
    agree = sample_errors(ref, check)
    ref_info = {
        "model": "heyoka (mechanical)",
        "precision": f"mp:{bits}",
        "check_precision": f"mp:{bits + 64}",
        "agreement_max": float(max(agree)),
        "agreement_final": float(agree[-1]),
        "impacts": ref.n_impacts,
        "elapsed_s": time.perf_counter() - t0,
    }
    _progress(
        f"reference heyoka mp:{bits} vs mp:{bits + 64}: agree to {max(agree):.1e} "
        f"({ref_info['elapsed_s']:.1f} s)",
        progress,
    )
    return ref, check, ref_info


def reference_lle(params: Any, progress: bool | None) -> dict[str, Any]:
    """The reference LLE (variational, default run) with its error bar and cost."""

    t0 = time.perf_counter()
    ly = lyapunov(params, "variational")
    lle = {
        "lle": float(ly.lle),
        "stderr": float(ly.lle_stderr),
        "periods": ly.periods,
        "transient": ly.transient,
        "method": "variational (saltation), default run",
        "elapsed_s": time.perf_counter() - t0,
    }
    _progress(f"LLE (variational): {ly.lle:.4f} +- {ly.lle_stderr:.4f}", progress)
    return lle


def _mechanical_points(params: Any, ref_info: dict[str, Any]) -> dict[str, Any]:
    """The mechanics' grazing and period-doubling points, also recorded in ``ref_info``."""
    mech = mechanical_points(params)
    ref_info["points"] = {
        "grazing": mech["grazing"],
        "period-doubling": mech["period-doubling"],
        "method": "grazing: closed form; period-doubling of the stable 1:1 orbit: "
        "continuation from eta = 1 (multiplier -1 located to rounding)",
    }
    return mech


def _score_model(
    scene: Scene,
    m: str,
    tr: Trajectory,
    periods: int,
    regime: str,
    ref: Trajectory,
    ref2: Trajectory | None,
    lle: dict[str, Any],
    k: int,
) -> dict[str, Any]:
    """The scores of model ``m``'s run ``tr``, with its own divergence rate when chaotic."""
    params = scene.params
    model_lle = None
    extra = {}
    if regime == "chaotic":
        pm = params.replace(x0=params.x0 + MODEL_PERTURBATION)
        tr2 = _run_model(scene, m, periods, 0, params=pm)
        div = divergence_rate(*separation(tr2, tr))
        model_lle = div["rate"] if math.isfinite(div["rate"]) else None
        extra = {
            "model_lle_method": (
                "finite-time divergence rate of the model against itself from x0 + "
                f"{decimal_str(MODEL_PERTURBATION)}"
            ),
            "model_lle_fit": div,
        }
    sc = score(tr, ref, regime=regime, lle=lle["lle"], model_lle=model_lle, ref2=ref2, transient=k)
    sc.update(extra)
    return sc


def _write_outputs(
    out: Path,
    result: dict[str, Any],
    scene: Scene,
    ref: Trajectory,
    check: Trajectory,
    trajs: dict[str, Trajectory],
    units: str = "dimensionless",
) -> None:
    """``scores.json``, the two figures and ``report.md`` in ``out``; their paths in ``result``."""
    k, lle, results = result["transient_periods"], result["lle"], result["models"]
    write_json(out / "scores.json", result, indent=2, default=_json_default)
    u = plot_units(units, components=scene.design() if units == "circuit" else None)
    save_figure(portraits_figure(scene, ref, trajs, k, results, u), out / "phase_portraits.png")
    save_figure(
        separation_figure(scene, ref, check, trajs, lle["lle"], results, u),
        out / "separation.png",
    )
    md = report_markdown(result)
    atomic_write(out / "report.md", lambda fh: fh.write(md), binary=False)
    result["files"] = [
        str(out / n) for n in ("report.md", "scores.json", "phase_portraits.png", "separation.png")
    ]


@dataclasses.dataclass
class CompareResult(ResultMixin):
    """Scores of models on a scene against a demonstrated reference (:func:`compare`).

    Attributes
    ----------
    scene, description : str
        The scene compared.
    params : dict
        Exact parameters (decimal strings).
    periods, transient_periods : int
        Forcing periods simulated; periods discarded before scoring.
    regime : str
        ``'periodic'`` or ``'chaotic'`` (from the reference's stroboscopic samples).
    reference_period : int or None
        Detected period of the reference.
    reference : dict
        How the reference was made and its demonstrated accuracy.
    lle : dict
        The reference's largest Lyapunov exponent with its error bar.
    models : dict
        Model name -> its scores (see :func:`~precise_impact.verification.scores.score`).
    files : list of str or None
        Files written when ``out`` was given.

    See Also
    --------
    precise_impact.verification.compare.compare : returns it.
    precise_impact.verification.scores.score : the scores in it.
    """

    scene: str
    description: str
    params: dict
    periods: int
    transient_periods: int
    regime: str
    reference_period: Any
    reference: dict
    lle: dict
    models: dict
    files: list | None = None

    def plot(self, path: str | os.PathLike | None = None):
        """Each model against the reference in one bar: the largest state error (periodic
        scenes) or the time ``tau`` it stays within 1e-3 (chaotic), the verdict beside it.

        Parameters
        ----------
        path : str, os.PathLike or None, default ``None``
            Also write the figure there (``.png``, ``.pdf``, ``.svg``, atomically).

        Returns
        -------
        matplotlib.figure.Figure
        """
        names = list(self.models)
        eta = float(Fraction(self.params["eta"]))
        periodic = self.regime == "periodic"
        fig = figure(figsize=(9, 1.6 + 0.5 * len(names)), layout="constrained")
        ax = fig.subplots()
        if periodic:
            vals = [max(float(self.models[m]["max_state_error"]), 1e-40) for m in names]
            ax.set_xscale("log")
            ax.set_xlabel("largest state error after the transient (dimensionless)")
        else:
            span = self.periods * 2 * math.pi / eta
            vals = [
                min(float(self.models[m]["horizons"].get("0.001", math.nan)), span) for m in names
            ]
            ax.set_xlabel("time within 1e-3 of the reference, tau (dimensionless)")
        ax.barh(range(len(names)), vals, color="tab:blue", alpha=0.35)
        ax.set_yticks(range(len(names)), names, fontsize=8)
        ax.invert_yaxis()
        for i, m in enumerate(names):
            ax.annotate(
                _verdict(self.models[m], eta),
                (0, i),
                xycoords=("axes fraction", "data"),
                xytext=(4, 0),
                textcoords="offset points",
                va="center",
                fontsize=7.5,
            )
        ax.grid(True, axis="x", alpha=0.3)
        ax.set_title(
            wrap_title(
                f"{self.scene}: {self.regime}, {self.periods} periods against heyoka "
                f"{self.reference.get('precision', '')}",
                fig,
            ),
            fontsize=10,
        )
        return finish(fig, path, dpi=110)

    def _tables(self) -> dict:
        """``to_dataframe()`` table ``models``: one row per model, its scalar scores (nested
        ones as ``divergence.rate``, ``horizons.0.001`` ...)."""
        return {
            "models": lambda: record_columns(
                [{"model": m, **flat(sc)} for m, sc in self.models.items()]
            )
        }


def _json_default(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    return str(o)


def score_line(sc: dict) -> str:
    """One line of a model's scores (:func:`~precise_impact.verification.scores.score`'s dict):
    periodic -- state error, impact errors, period; chaotic -- horizon, rate, cloud distances."""
    if sc["regime"] == "periodic":
        im = sc["impacts"]
        return (
            f"max state error {sc['max_state_error']:.2e}, impacts dt {im['max_dt']:.1e} dv "
            f"{im['max_dv']:.1e} (unmatched {im['unmatched_model']}/{im['unmatched_reference']}), "
            f"period {sc['period_model']}"
        )
    h = sc["horizons"]
    return (
        f"horizon(1e-3) {h.get('0.001', math.nan):.1f}, rate {sc['divergence']['rate']:.4f}, "
        f"SW {sc['sliced_wasserstein']:.3f} (floor {sc['sw_floor']:.3f}), "
        f"impact-v W1 {sc['impact_v_wasserstein']:.3f} (floor {sc['impact_v_floor']:.3f})"
    )


def format_scores(result: CompareResult) -> str:
    """Plain-text summary printed by ``precise-impact compare``.

    Parameters
    ----------
    result : CompareResult
        From :func:`compare`.

    Returns
    -------
    str
    """
    r = result["reference"]
    lines = [
        f"scene {result['scene']}: {result['regime']} (reference period "
        f"{result['reference_period']}), {result['periods']} periods, transient "
        f"{result['transient_periods']}",
        f"reference heyoka {r['precision']} agrees with {r['check_precision']} to "
        f"{r['agreement_max']:.1e}; LLE {result['lle']['lle']:.4f} +- "
        f"{result['lle']['stderr']:.4f}",
    ]
    for m, sc in result["models"].items():
        lines.append(f"  {m:<20} {score_line(sc)}")
        if "points" in sc:
            g, d = sc["points"]["grazing"], sc["points"]["period-doubling"]
            pd = (
                ""
                if d is None
                else f", period-doubling eta {d['model']:.8g} ({d['shift']:+.2e}, {d['how']})"
            )
            lines.append(f"  {'':<20} grazing eta {g['model']:.8g} ({g['shift']:+.2e}){pd}")
    return "\n".join(lines)


# ----------------------------------------------------------------- figures
def _verdict(sc: dict, eta: float, t0: float = 0.0) -> str:
    """One line per panel: how the model stands against the reference (a horizon is a time
    tau; shown with the forcing periods it spans after the start ``t0``,
    ``(tau - t0) eta / (2 pi)``)."""
    if sc.get("regime") == "periodic":
        return f"max state error {sc['max_state_error']:.1e}, period {sc.get('period_model')}"
    h = sc.get("horizons", {}).get("0.001", math.nan)
    if h == math.inf:
        return "within 1e-3 of the reference throughout"
    return (
        f"within 1e-3 of the reference until tau = {h:.4g} "
        f"({(h - t0) * eta / (2 * math.pi):.1f} periods)"
    )


def portraits_figure(
    scene: Scene, ref: Trajectory, trajs: dict, k: int, results: dict, u: Any = None
):
    """The reference and each model in the phase plane after ``k`` transient periods: impacts
    as vertical jumps at the labelled wall, the reference's samples (red rings) over every
    model's, each model's verdict in its title."""
    u = u or plot_units("dimensionless")
    panels = [("reference: heyoka " + ref.precision.name, ref)] + list(trajs.items())
    t_from = float(ref.as_float64()["t"][k])
    return phase_portrait_panels(
        panels,
        float(scene.params.x_w),
        u,
        f"{scene.name}: phase portraits after {k} transient periods (eta = "
        f"{decimal_str(scene.params.eta)})",
        reference=ref,
        t_from=t_from,
        verdicts={
            m: _verdict(sc, float(scene.params.eta), float(scene.params.t0))
            for m, sc in results.items()
        },
    )


def separation_figure(
    scene: Scene,
    ref: Trajectory,
    check: Trajectory,
    trajs: dict,
    lam: float,
    results: dict,
    u: Any = None,
):
    """Each model's distance from the reference against time (log scale), the reference's own
    check and the growth ``e^(lambda t)``; legend beside the axes, one style per series."""
    u = u or plot_units("dimensionless")
    fig = figure(figsize=(10, 4.8), layout="constrained")
    ax = fig.subplots()
    styles = series_styles(len(trajs))
    floor = 1e-60
    anchor = None
    for (m, tr), st in zip(trajs.items(), styles, strict=True):
        t, sep = separation(tr, ref)
        ax.semilogy(u.t(t), np.maximum(sep, floor), lw=1, color=st["color"], ls=st["ls"], label=m)
        div = results[m].get("divergence")
        if anchor is None and div and math.isfinite(div.get("t_start", math.nan)):
            i = int(np.argmin(np.abs(t - div["t_start"])))
            anchor = (t[i], sep[i])
    tc, sc = separation(check, ref)
    ax.semilogy(
        u.t(tc),
        np.maximum(sc, floor),
        lw=0.8,
        color="0.5",
        label=f"{ref.precision.name} vs {check.precision.name}",
    )
    if anchor is None:
        for tr in trajs.values():
            t, sep = separation(tr, ref)
            pos = np.nonzero(sep > 0)[0]
            if len(pos):
                anchor = (t[pos[0]], sep[pos[0]])
                break
    if anchor is not None:
        tt = tc
        line = anchor[1] * np.exp(lam * (tt - anchor[0]))
        ok = (line > floor) & (line < 1e3)
        ax.semilogy(
            u.t(tt[ok]),
            line[ok],
            "k--",
            lw=1,
            label=f"e^(lambda tau), lambda = {lam:.4f} per unit tau (variational)",
        )
    ax.set_xlabel(u.t_label)
    ax.set_ylabel("max(|x - x_ref|, |x' - x'_ref|) at t0 + kT\n(dimensionless)")
    ax.set_title(
        wrap_title(f"{scene.name}: separation from the heyoka {ref.precision.name} reference", fig),
        fontsize=10,
    )
    ax.grid(True, which="both", alpha=0.3)
    legend_outside(ax, fontsize=7.5)
    return fig


# ----------------------------------------------------------------- report
def _g(x, fmt=".3e") -> str:
    if x is None:
        return "n/a"
    if isinstance(x, float) and not math.isfinite(x):
        return "never" if x == math.inf else "n/a"
    return format(x, fmt)


def _points_report(res: dict) -> list[str]:
    rp = res["reference"]["points"]
    L = [
        "",
        "## Bifurcation points along eta",
        "",
        f"Mechanics: grazing of the non-impacting orbit at eta = {rp['grazing']:.12g} (closed "
        f"form); period-doubling of the 1:1 orbit at eta = {_g(rp['period-doubling'], '.12g')} "
        "(continuation).",
        "",
    ]
    rows = []
    for m, s in res["models"].items():
        g, d = s["points"]["grazing"], s["points"]["period-doubling"]
        dd = (
            ("n/a",) * 4
            if d is None
            else (
                f"{d['model']:.10g}",
                f"{d['shift']:+.3e}",
                f"{d['resolution']:.1e}",
                d["how"]
                + (
                    f" (orbit lost at eta {d['lost'][0]:.8g} .. {d['lost'][1]:.8g} "
                    f"with det(A+I) = {d['test_at_last_valid']:.3g})"
                    if d["how"] == "extrapolated"
                    else ""
                ),
            )
        )
        rows.append((m, f"{g['model']:.10g}", f"{g['shift']:+.3e}", f"{g['resolution']:.1e}", *dd))
    L += table(
        (
            "model",
            "grazing eta",
            "shift",
            "resolution",
            "period-doubling eta",
            "shift",
            "resolution",
            "how",
        ),
        rows,
        "lrrrrrrl",
    )
    L += [
        "",
        "How obtained (`precise_impact.verification.points`): the grazing point is the root of "
        "x_w - max x of the model's own steady state, the period-doubling point the root of det(A "
        "+ I) of the model's stroboscopic map identified from its runs (A fitted, multipliers = "
        "eig A); both approached from the valid side by a safeguarded secant.  *how* = root: the "
        "test function reached zero there; extrapolated: the model's orbit was lost (it escaped) "
        "while the test function was still away from zero -- an imperfect, discontinuity-induced "
        "bifurcation of the switching hardware -- and the eta given extrapolates the smooth test "
        "function (resolution = the extrapolated distance).  The heyoka model itself recovers both "
        "mechanical points to ~1e-9.",
    ]
    return L


def report_markdown(res: dict) -> str:
    """``report.md``: how the reference was made, every model's scores and how they were
    obtained; ``res`` is a :class:`CompareResult`'s fields as a dict (or ``scores.json``).
    Its tables come from :func:`precise_impact.io.markdown.table`."""
    L = _report_header(res)
    L += ["## Scores", ""]
    if res["regime"] == "periodic":
        L += _periodic_scores(res)
    else:
        L += _chaotic_scores(res)
    L += _report_footer(res)
    return "\n".join(L)


def _report_header(res: dict) -> list[str]:
    """The report's title, parameters, reference and LLE sections."""
    r, ly = res["reference"], res["lle"]
    p = ", ".join(f"{k} = {v}" for k, v in res["params"].items())
    L = [
        f"# Model comparison: scene `{res['scene']}`",
        "",
        res.get("description", ""),
        "",
        f"Parameters (exact decimals): {p}.  {res['periods']} forcing periods from the scene's "
        "initial condition; samples at t0 + kT, T = 2 pi / eta.  The first "
        f"{res['transient_periods']} periods are the transient (excluded from state errors, impact "
        "matching, periods and clouds).",
        "",
        "## Reference",
        "",
        f"heyoka Taylor integrator with impact events (the `mechanical` model) in {r['precision']} "
        f"(MPFR); rerun in {r['check_precision']}.  Largest disagreement over all stroboscopic "
        f"samples: **{r['agreement_max']:.2e}** (final sample {r['agreement_final']:.2e}) -- the "
        f"reference's demonstrated accuracy.  Impacts: {r['impacts']}.  "
        f"Time {r['elapsed_s']:.1f} s.",
        "",
        f"Regime: **{res['regime']}** (reference period {res['reference_period']}: smallest p <= "
        "32 with the samples after the transient p-periodic to 1e-6 (1 + |x| + |v|); 0 = none).",
        "",
        f"LLE: **{ly['lle']:.4f} +- {ly['stderr']:.4f}** per unit time ({ly['method']}: "
        f"{ly['periods']} measured periods after {ly['transient']} transient, error bar by batch "
        f"means; {ly['elapsed_s']:.1f} s).",
        "",
    ]
    if "second_reference_x0" in r:
        L += [
            "Second reference (noise floor of the distribution distances): heyoka "
            f"{r['precision']} from x0 = {r['second_reference_x0']}.",
            "",
        ]
    return L


def _periodic_scores(res: dict) -> list[str]:
    """The scores table of a periodic scene and how its columns were obtained."""
    rows = []
    for m, s in res["models"].items():
        im = s["impacts"]
        rows.append(
            (
                m,
                _g(s["max_state_error"]),
                _g(s["final_state_error"]),
                f"{im['model_impacts']}/{im['reference_impacts']}",
                im["matched"],
                f"{im['unmatched_model']}/{im['unmatched_reference']}",
                _g(im["max_dt"]),
                _g(im["max_dv"]),
                s["period_model"] or "none",
                f"{s['elapsed_s']:.3f}",
            )
        )
    header = (
        "model",
        "max state error",
        "final state error",
        "impacts (model/ref)",
        "matched",
        "unmatched model/ref",
        "max impact dt",
        "max impact dv",
        "period",
        "time [s]",
    )
    L = table(header, rows)
    L += [
        "",
        "How obtained:",
        "",
        "* *state error*: max(|x - x_ref|, |v - v_ref|) at every stroboscopic sample after the "
        "transient, the difference taken exactly in mpmath (then rounded to float).",
        "* *impacts*: each model impact after the transient is matched to the nearest reference "
        "impact in time (within T/4; one model impact per reference impact); dt and dv = "
        "|v_before - v_before_ref| are over matched pairs; unmatched counts are the impacts left "
        "over on each side.",
        "* *period*: smallest p <= 32 such that the model's samples after the transient repeat "
        "after p periods to 1e-6 (1 + |x| + |v|) "
        "(`precise_impact.analysis.periodicity.detect_period`).",
    ]
    return L


def _chaotic_scores(res: dict) -> list[str]:
    """The scores table of a chaotic scene and how its columns were obtained."""
    deltas = list(next(iter(res["models"].values()))["horizons"])
    header = (
        "model",
        *(f"horizon d={d}" for d in deltas),
        "fitted rate",
        "rate / LLE",
        "model LLE est.",
        "LLE gap",
        "sliced W (floor)",
        "impact-v W1 (floor)",
        "impacts/period (ref)",
        "period",
        "time [s]",
    )
    rows = []
    for m, s in res["models"].items():
        d = s["divergence"]
        rows.append(
            (
                m,
                *(_g(s["horizons"][x], ".1f") for x in deltas),
                f"{_g(d['rate'], '.4f')} +- {_g(d['stderr'], '.4f')}",
                _g(s["rate_over_lle"], ".3f"),
                _g(s["lle_model"], ".4f"),
                _g(s["lle_gap"], "+.4f"),
                f"{_g(s['sliced_wasserstein'], '.4f')} ({_g(s['sw_floor'], '.4f')})",
                f"{_g(s['impact_v_wasserstein'], '.4f')} ({_g(s['impact_v_floor'], '.4f')})",
                f"{_g(s['impacts_per_period_model'], '.3f')} "
                f"({_g(s['impacts_per_period_reference'], '.3f')})",
                s["period_model"] or "none",
                f"{s['elapsed_s']:.3f}",
            )
        )
    L = table(header, rows)
    L += [
        "",
        "How obtained:",
        "",
        "* *separation* sep(t) = max(|x - x_ref|, |v - v_ref|) at the stroboscopic samples (exact "
        "differences).",
        "* *horizon d*: first time (dimensionless) sep exceeds d, interpolated linearly in ln sep "
        "between the two samples around the crossing; 'never' if it stays below.",
        "* *fitted rate*: least-squares slope of ln sep against t over the samples with 1e-12 < "
        "sep < 1e-2 before sep first reaches 1e-2 (error: standard error of the slope); *rate / "
        "LLE* divides by the variational LLE above.",
        f"* *model LLE est.*: the same fitted rate for the model against itself started from x0 + "
        f"{decimal_str(MODEL_PERTURBATION)} (a finite-time estimate); *LLE gap* = model LLE est. - "
        "reference LLE.",
        "* *sliced W*: sliced 1-Wasserstein distance between the (x, v) stroboscopic clouds after "
        "the transient (256 projection directions, stratified random angles, exact 1-D distance "
        "from sorted samples); *floor*: the same distance between the reference and the second "
        "reference (two samples of the same attractor) -- a model distance near the floor is "
        "indistinguishable from sampling noise.",
        "* *impact-v W1*: 1-D Wasserstein distance between the v_before values of the impacts "
        "after the transient; floor as above.",
    ]
    return L


def _report_footer(res: dict) -> list[str]:
    """The grazing/period-doubling points (if scored), each model's effects and the figures."""
    r, ly = res["reference"], res["lle"]
    L: list[str] = []
    if "points" in r:
        L += _points_report(res)
    L += [
        "",
        "Effects per model (the scene's effects that do not fit a model are dropped for it):",
        "",
    ]
    for m, s in res["models"].items():
        L.append(
            f"* {m}: {', '.join(s['effects']) or 'none'}"
            + (f" (dropped: {', '.join(s['effects_dropped'])})" if s["effects_dropped"] else "")
        )
    L += [
        "",
        "## Figures",
        "",
        "* `phase_portraits.png`: phase portraits (dense output, "
        "after the transient) with the stroboscopic samples, one panel per model, the reference "
        "first.",
        "* `separation.png`: sep(t) on a log scale for each model, the reference's own mp-vs-mp "
        f"disagreement, and the line e^(lambda t) with lambda = {ly['lle']:.4f} (variational LLE).",
        "",
        "Numbers are also in `scores.json`.",
        "",
    ]
    return L
