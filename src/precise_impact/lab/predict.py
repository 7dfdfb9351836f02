"""What an identified oscillator does (attractor, LLE, landmarks), the fit's uncertainty carried
through by sampling and implicit-function derivatives.  Method: ``docs/guide/identify.rst``."""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from fractions import Fraction
from typing import Any

import numpy as np

from precise_impact.analysis.bifurcation import bifurcation
from precise_impact.analysis.lyapunov import lyapunov
from precise_impact.core.flight import (
    NUMPY,
    homogeneous_start,
    state_from_coefficients,
    steady_coefficients,
    trig_coefficients,
)
from precise_impact.core.params import Params, check_count
from precise_impact.core.result import ResultMixin, unit_column
from precise_impact.errors import ConvergenceError, ParameterError
from precise_impact.io.figures import check_plot_path, finish, new_figure
from precise_impact.lab.budget import landmark_at
from precise_impact.lab.identify import (
    Z95,
    Identification,
    derived,
    record_of,
    reset_velocity,
)

__all__ = [
    "Prediction",
    "predict",
    "capture_strobe",
    "PREDICTED_LANDMARKS",
    "SECONDS_PER_SAMPLE_RUN",
    "SECONDS_PER_DIAGRAM_VALUE",
    "affine_runner",
    "circuit_runner",
    "period3_window",
    "strobe_period",
]

#: The landmarks predicted (``lab.budget``'s: R = 1 systems only).
PREDICTED_LANDMARKS = ("grazing", "p3_low", "p3_high")
#: Seconds per predicted system at the defaults (one sample's 6,000 periods and its three
#: landmarks; the central system counts as 4): 48 samples took 8.0 s at 0.712 and 7.8 s at
#: 0.74 (0.16 s each, landmarks included), taken x2.
SECONDS_PER_SAMPLE_RUN = 0.35
#: Seconds per eta value of the diagram (200 periods after 500): 60 values took 5.8 s, x2.
SECONDS_PER_DIAGRAM_VALUE = 0.2
#: The sampled parameters, in the order of :func:`draws`' columns.
SAMPLED = ("eta", "zeta", "x_w/a", "R")


@dataclasses.dataclass
class Prediction(ResultMixin):
    """What the identified system does, with the identification's uncertainty.

    Attributes
    ----------
    system : dict
        The central system used: ``eta, zeta, x_w/a, R`` (``a = 1``: the motion scales with
        ``a``, so only ``x_w / a`` enters the dynamics).
    attractor : dict
        The central system's attractor: ``kind`` (``'periodic'`` or ``'not periodic'``),
        ``period`` and ``impacts`` per period (periodic), ``impact_rate``, and the fraction of
        the samples whose attractor is of the same kind (and period).
    lle : dict
        ``value`` and ``stderr`` of the central system (finite-time; the Floquet value on a
        periodic attractor, ``source``), ``sampled`` (median and 2.5 / 97.5 % quantiles of the
        samples' exponents, the fraction positive) and ``ci95``: the union of the central
        value's +-1.96 standard errors and the samples' quantiles.
    landmarks : dict
        ``name -> {eta, stderr, ci95, deta_dtheta, sampled_stderr, from_identified}``: the
        landmark's frequency ratio, its standard error by the implicit-function derivatives
        (``d eta_L / d (zeta, a, x_w)``) and the fit's covariance, the same from the samples,
        and the identified ``eta`` minus the landmark in standard errors of that difference;
        ``{'absent': why}`` where the landmark was not found.
    samples : dict
        Each sample's ``eta, zeta, x_w/a, R``, exponent and attractor kind.
    seconds : float
        Wall time.
    notes : list
        What was assumed (``R`` at 1, samples rejected as unphysical, ...).
    diagram : dict
        With ``diagram=N``: the central system's bifurcation diagram (``eta``, stroboscopic
        ``x`` per value, ``lle``) over the identified eta and its landmarks, and with a
        ``capture`` the capture's own stroboscopic ``x`` (``capture_x``, the same phase and
        units: ``(x - o_x) / a``) to draw at the identified eta.

    See Also
    --------
    predict : makes one.
    """

    system: dict
    attractor: dict
    lle: dict
    landmarks: dict
    samples: dict
    seconds: float
    notes: list = dataclasses.field(default_factory=list)
    diagram: dict = dataclasses.field(default_factory=dict)

    def _tables(self) -> dict:
        """``to_dataframe()`` tables ``samples`` (one row per sampled system: its parameters,
        exponent and attractor) and ``landmarks`` (one row per landmark found)."""

        def samples() -> dict:
            cols = {unit_column(k, "1"): self.samples[k] for k in (*SAMPLED, "lle")}
            out = {k: np.asarray(v, dtype=float) for k, v in cols.items()}
            return {**out, "attractor": list(self.samples["kind"])}

        def landmarks() -> dict:
            rows = {k: m for k, m in self.landmarks.items() if "absent" not in m}
            return {
                "name": list(rows),
                unit_column("eta", "1"): np.array([m["eta"] for m in rows.values()], float),
                unit_column("stderr", "1"): np.array([m["stderr"] for m in rows.values()], float),
            }

        return {"samples": samples, "landmarks": landmarks}

    def covers(self, name: str, truth: float) -> bool:
        """Whether the 95 % interval of ``'lle'`` or of a landmark holds ``truth``."""
        entry = self.lle if name == "lle" else self.landmarks[name]
        lo, hi = entry["ci95"]
        return lo <= truth <= hi

    def summary(self) -> str:
        """The attractor, the exponent and the landmarks, one line each."""
        a, e = self.attractor, self.lle
        kind = a["kind"] if a["kind"] != "periodic" else f"period {a['period']}, {a['impacts']} "
        kind += "impacts per period" if a["kind"] == "periodic" else ""
        rows = [
            f"attractor: {kind} ({a['same_kind']:.0%} of {len(self.samples['lle'])} samples alike)",
            f"LLE {e['value']:.5f} +- {e['stderr']:.2g} per unit time ({e['source']}); 95 %: "
            f"{e['ci95'][0]:.5f} .. {e['ci95'][1]:.5f}; positive in "
            f"{e['sampled']['positive']:.0%} of the samples",
        ]
        for name, m in self.landmarks.items():
            if "absent" in m:
                rows.append(f"{name}: not found ({m['absent']})")
            else:
                rows.append(
                    f"{name}: eta {m['eta']:.6f} +- {m['stderr']:.2g} (95 %: {m['ci95'][0]:.6f} "
                    f".. {m['ci95'][1]:.6f}); identified eta is {m['from_identified']:+.1f} "
                    "standard errors from it"
                )
        return "\n".join(rows)

    def plot(self, path: Any = None):
        """The samples' exponents (histogram, the central value and its interval) and the
        identified eta beside the landmarks with their 95 % intervals."""
        check_plot_path(path)
        cols = 3 if self.diagram else 2
        fig, axes = new_figure(1, cols, figsize=(5.5 * cols, 4))
        ax1, ax2 = axes[0][:2]
        if self.diagram:
            self._plot_diagram(axes[0][2])
        lle = np.asarray(self.samples["lle"], dtype=float)
        ax1.hist(lle, bins=max(8, len(lle) // 3), color="0.7")
        ax1.axvline(self.lle["value"], color="C0", label="central system")
        ax1.axvspan(*self.lle["ci95"], color="C0", alpha=0.15, label="95 % interval")
        ax1.set(xlabel="largest Lyapunov exponent", ylabel="samples", title="LLE")
        ax1.legend(fontsize=8)
        ax1.locator_params(axis="x", nbins=5)
        rows = [(k, m) for k, m in self.landmarks.items() if "absent" not in m]
        s = self.system
        half = Z95 * s["eta_stderr"]
        ax2.axvspan(s["eta"] - half, s["eta"] + half, color="C0", alpha=0.3)
        ax2.axvline(s["eta"], color="C0", label=f"identified eta {s['eta']:.5f}")
        for i, (name, m) in enumerate(rows):
            ax2.errorbar(m["eta"], i, xerr=Z95 * m["stderr"], fmt="o", color="C1", capsize=4)
            label = f"{name} {m['eta']:.5f} +- {Z95 * m['stderr']:.5f}"
            ax2.annotate(label, (m["eta"], i), textcoords="offset points", xytext=(0, 8),
                         ha="center", fontsize=8)  # fmt: skip
        ax2.set(xlabel="eta", yticks=[], title="landmarks and the identified eta (95 %)")
        ax2.set_ylim(-0.7, len(rows) - 0.3)
        ax2.legend(fontsize=8, loc="lower right")
        return finish(fig, path)

    def _plot_diagram(self, ax) -> None:
        d, s = self.diagram, self.system
        eta = np.repeat(np.asarray(d["eta"], float), len(d["x"][0]))
        ax.plot(eta, np.ravel(d["x"]), ",", color="0.3")
        if d.get("capture_x"):
            xs = np.asarray(d["capture_x"], float)
            ax.plot(np.full(len(xs), s["eta"]), xs, ".", color="C3", ms=3, label="the capture")
            ax.legend(fontsize=8, loc="lower right")
        ax.axvline(s["eta"], color="C0", lw=0.8)
        ax.set(xlabel="eta", ylabel="x at the forcing's phase 0 (a = 1)",
               title="the identified system's diagram")  # fmt: skip


def predict(
    identified: Identification,
    samples: Any = 48,
    periods: Any = 20000,
    sample_periods: Any = 5000,
    transient: Any = 1000,
    seed: Any = 0,
    say: Any = None,
    diagram: Any = 0,
    capture: Any = None,
) -> Prediction:
    """The attractor, the largest Lyapunov exponent and the landmarks of an identified system.

    Parameters
    ----------
    identified : Identification
        From :func:`~precise_impact.lab.identify.identify`.
    samples : int, default 48
        Parameter sets drawn from the fit's normal distribution (its covariance; sets with
        ``R > 1`` or ``zeta < 0`` are redrawn: the truncated normal, a flat prior on the
        physical region), each run for its exponent and attractor.
    periods : int, default 20000
        Forcing periods of the central system's exponent (the compiled engine).
    sample_periods : int, default 5000
        Forcing periods of each sample's exponent.
    transient : int, default 1000
        Periods dropped before each exponent.
    seed : int, default 0
        The draws' seed.
    say : callable or None
        Called with a line at each stage.
    diagram : int, default 0
        Values of eta in the central system's bifurcation diagram (0: none), over the
        identified eta and its landmarks (200 periods each after a 500-period transient).
    capture : Capture or None
        The identified capture: its stroboscopic samples are drawn over the diagram.

    Returns
    -------
    Prediction

    See Also
    --------
    precise_impact.lab.identify.identify : the identification predicted from.
    precise_impact.analysis.lyapunov.lyapunov : the exponents (``model='fast'``).
    precise_impact.lab.budget.landmark_at : the landmarks.

    Examples
    --------
    >>> from precise_impact import identify, predict, synth_capture
    >>> cap = synth_capture("fig6-period3-ideal", periods=30, seed=2)
    >>> p = predict(identify(cap, "fig6-period3-ideal"), samples=8, periods=2000,
    ...             sample_periods=1000)
    >>> p.attractor["period"], p.attractor["impacts"], p.lle["source"]
    (3, 2, 'floquet')

    Notes
    -----
    The exponent is not a smooth function of the parameters where windows of periodic motion
    are dense, so its uncertainty is sampled; the landmarks are smooth (an augmented Newton
    system each), so theirs is linear: ``var = g^T C g`` with ``g`` the implicit-function
    derivative and ``C`` the covariance of ``(zeta, x_w / a)``; the samples check it.  The
    landmark machinery is written for ``R = 1``: landmarks are predicted when the identified
    ``R``'s interval holds 1.
    """
    t0 = time.perf_counter()
    tell = say or (lambda _line: None)
    n = check_count(samples, "samples", 10_000, minimum=2)
    names, mean, cov = fit_law(identified)
    _check_restitution(identified)
    central, notes = central_system(mean, names)
    drawn = draws(mean, cov, names, n, check_count(seed, "seed", 2**31 - 1, minimum=0))
    tell(f"the central system's exponent over {periods} periods ...")
    main = _exponent(central, periods, transient)
    tell(f"{n} sampled systems, {sample_periods} periods each ...")
    runs = [_exponent(_system(row), sample_periods, transient) for row in drawn]
    landmarks = {}
    if identified.covers("R", 1.0):
        tell("landmarks: grazing and the period-3 window's ends ...")
        landmarks = {k: _landmark(k, central, drawn, mean, cov, names) for k in PREDICTED_LANDMARKS}
    else:
        notes.append("landmarks not predicted: the identified R excludes 1 (they are R = 1's)")
    shown = {}
    if check_count(diagram, "diagram", 2000, minimum=0):
        tell(f"the identified system's bifurcation diagram, {diagram} values ...")
        shown = _diagram(central, landmarks, int(diagram), identified, capture)
    return Prediction(
        diagram=shown,
        system={**central, "eta_stderr": identified.stderr("eta")},
        attractor=_attractor(main, runs),
        lle=_lle(main, runs),
        landmarks=landmarks,
        samples={
            **{k: drawn[:, i].tolist() for i, k in enumerate(SAMPLED)},
            "lle": [r["lle"] for r in runs],
            "kind": [r["label"] for r in runs],
        },
        seconds=time.perf_counter() - t0,
        notes=notes,
    )


def fit_law(identified: Identification) -> tuple[list, np.ndarray, np.ndarray]:
    c = identified.covariance
    if not c:
        raise ParameterError(
            "identified", "an Identification without its covariance", "one from identify()"
        )
    return list(c["names"]), np.asarray(c["values"], float), np.asarray(c["matrix"], float)


def _check_restitution(identified: Identification) -> None:
    """Refuse an identified ``R`` above 1 beyond its interval: energy gained at each impact."""
    lo = identified.parameters["R"]["ci95"][0]
    if lo > 1:
        R, se = identified.value("R"), identified.stderr("R")
        raise ParameterError(
            "R",
            f"{R:.5f} +- {se:.2g} (identified; 95 % from {lo:.5f})",
            "an interval that holds R <= 1: above 1 each impact adds energy, which no impact "
            "oscillator does (a non-ideality of the circuit that the model lacks); no prediction",
        )


def reduced(g: np.ndarray, names: list) -> np.ndarray:
    """``(eta, zeta, x_w / a, R)`` of globals ``g`` (rows)."""
    ix = {k: i for i, k in enumerate(names)}
    a = np.hypot(g[..., ix["a_c"]], g[..., ix["a_s"]])
    return np.stack([g[..., ix["eta"]], g[..., ix["zeta"]], g[..., ix["x_w"]] / a,
                     g[..., ix["R"]]], axis=-1)  # fmt: skip


def central_system(mean: np.ndarray, names: list) -> tuple[dict, list]:
    eta, zeta, xwa, R = reduced(mean, names).tolist()
    notes = []
    if R > 1:  # the constrained estimate under R <= 1 sits on the boundary
        notes.append(f"the identified R = {R:.6f} > 1: the central system uses R = 1")
        R = 1.0
    kappa = float(mean[names.index("kappa")]) if "kappa" in names else 0.0
    if kappa:  # the mechanics has no feed-through: predicted for its eta, zeta, x_w / a, R
        notes.append(f"the identified impact feed-through kappa = {kappa:.4g} is not in these "
                     "predictions (they use v+ = -R v-); the affine law's period-3 window: "
                     "period3_window(affine_runner(...))")  # fmt: skip
    return {"eta": eta, "zeta": zeta, "x_w/a": xwa, "R": R}, notes


def draws(mean, cov, names, n: int, seed: int) -> np.ndarray:
    """``n`` rows of ``(eta, zeta, x_w / a, R)`` from the fit's normal law, truncated to the
    physical region (``R <= 1``, ``zeta >= 0``, ``eta > 0``) by redrawing."""
    rng = np.random.default_rng(seed)
    rows: list = []
    for _ in range(100):
        g = rng.multivariate_normal(mean, cov, size=2 * n, method="eigh")
        red = reduced(g, names)
        ok = (red[:, 3] <= 1) & (red[:, 1] >= 0) & (red[:, 0] > 0)
        rows.extend(red[ok].tolist())
        if len(rows) >= n:
            return np.asarray(rows[:n])
    raise ParameterError("identified", "a covariance with most of its mass at R > 1", "R <= 1")


def _system(row: Any) -> dict:
    eta, zeta, xwa, R = (float(v) for v in row)
    return {"eta": eta, "zeta": zeta, "x_w/a": xwa, "R": R}


def _params(s: dict) -> Params:
    xw = s["x_w/a"]
    return Params.make(eta=repr(s["eta"]), zeta=repr(s["zeta"]), a="1", x_w=repr(xw),
                       R=repr(s["R"]), x0=repr(min(0.0, xw - 1.0)))  # fmt: skip


def _exponent(s: dict, periods: Any, transient: Any) -> dict:
    r = lyapunov(_params(s), model="fast", periods=periods, transient=transient)
    head = r.stats["attractors"][r.stats.get("headline_attractor", 0) or 0]
    label = head["kind"] if head["kind"] != "periodic" else f"period {head['period']}"
    return {
        "lle": float(r.lle),
        "stderr": float(r.lle_stderr),
        "source": r.stats.get("lle_source", ""),
        "head": head,
        "label": label,
    }


def _attractor(main: dict, runs: list) -> dict:
    h = main["head"]
    out = {"kind": h["kind"], "impact_rate": float(h.get("impact_rate", math.nan))}
    if h["kind"] == "periodic":
        out.update(period=int(h["period"]), impacts=int(h["impacts"]))
    out["same_kind"] = sum(r["label"] == main["label"] for r in runs) / len(runs)
    return out


def _lle(main: dict, runs: list) -> dict:
    v = np.asarray([r["lle"] for r in runs])
    lo, med, hi = np.quantile(v, [0.025, 0.5, 0.975]).tolist()
    half = Z95 * main["stderr"]
    return {
        "value": main["lle"],
        "stderr": main["stderr"],
        "source": main["source"],
        "sampled": {"median": med, "q025": lo, "q975": hi, "positive": float(np.mean(v > 0))},
        "ci95": [min(lo, main["lle"] - half), max(hi, main["lle"] + half)],
    }


def _landmark(name: str, central: dict, drawn, mean, cov, names) -> dict:
    theta = (central["zeta"], 1.0, central["x_w/a"])
    try:
        bp = landmark_at(name, theta)
    except (ConvergenceError, ValueError, np.linalg.LinAlgError) as e:
        return {"absent": str(e)}
    g = bp.sensitivity()  # d eta_L / d (zeta, a, x_w) at a = 1
    d = landmark_gradient(mean, names, g)
    se = math.sqrt(max(float(d @ cov @ d), 0.0))
    moved = [_moved(name, bp, row) for row in drawn]
    moved = [m for m in moved if m is not None]
    eta_ix = names.index("eta")
    e = np.zeros(len(names))
    e[eta_ix] = 1.0
    gap_se = math.sqrt(max(float((e - d) @ cov @ (e - d)), 0.0))
    return {
        "eta": float(bp.eta),
        "stderr": se,
        "ci95": [bp.eta - Z95 * se, bp.eta + Z95 * se],
        "deta_dtheta": dict(zip(("zeta", "a", "x_w"), g.tolist(), strict=True)),
        "sampled_stderr": float(np.std(moved, ddof=1)) if len(moved) > 1 else math.nan,
        "from_identified": (central["eta"] - bp.eta) / gap_se if gap_se > 0 else math.nan,
    }


def landmark_gradient(mean: np.ndarray, names: list, g: np.ndarray) -> np.ndarray:
    """``d eta_L / d globals``: through ``zeta`` and ``x_w / a`` (``a`` held at 1)."""
    _, grads = derived(dict(zip(names, mean, strict=True)))
    return g[0] * grads["zeta"] + g[2] * grads["x_w/a"]


def _diagram(central: dict, landmarks: dict, n: int, identified, capture) -> dict:
    """The central system's diagram over its eta and landmarks (+-0.01), at most +-0.08."""
    etas = [central["eta"], *(m["eta"] for m in landmarks.values() if "eta" in m)]
    lo = max(min(etas) - 0.01, central["eta"] - 0.08)
    hi = min(max(etas) + 0.01, central["eta"] + 0.08)
    b = bifurcation(_params(central), ("eta", repr(lo), repr(hi), n), periods=200,
                    transient=500, progress=False)  # fmt: skip
    out = {"eta": [float(e) for e in b.eta], "x": np.asarray(b.x, float).tolist(),
           "lle": np.asarray(b.lle, float).tolist()}  # fmt: skip
    if capture is not None:
        out["capture_x"] = capture_strobe(identified, capture).tolist()
    return out


def capture_strobe(identified: Identification, capture: Any) -> np.ndarray:
    """The capture's ``x`` at the forcing's phase 0 (``Omega t - phase = 2 pi k``), in the
    identified system's units with ``a = 1``: ``(x - o_x) / a`` (linear interpolation)."""
    rec = record_of(capture, identified.design)
    Om, ph = float(identified.record["Omega_rad_s"]), identified.value("phase")
    k = np.arange(math.ceil((Om * rec.t[0] - ph) / (2 * math.pi)),
                  math.floor((Om * rec.t[-1] - ph) / (2 * math.pi)) + 1)  # fmt: skip
    tk = (ph + 2 * math.pi * k) / Om
    return (np.interp(tk, rec.t, rec.x) - identified.value("o_x")) / identified.value("a")


def _moved(name: str, bp: Any, row: Any) -> float | None:
    """The landmark of a sampled system (its eta is not an input: theta only)."""
    _, zeta, xwa, _ = (float(v) for v in row)
    try:
        return float(landmark_at(name, (zeta, 1.0, xwa)).eta)
    except (ConvergenceError, ValueError, np.linalg.LinAlgError):
        return None


# ============================================================================ the window by runs
#: Strobe points compared to call an attractor period 3 (the last ``WINDOW_COMPARED``), and
#: their tolerance (unit of ``x``): a period-3 orbit inside the window repeats to ~1e-9.
WINDOW_COMPARED = 30
WINDOW_TOL = 1e-4


def affine_runner(system: dict) -> Any:
    """``run(eta, state, periods) -> (strobe x, state)`` of the oscillator with the affine
    impact law ``v+ = -R v- + kappa (a cos(eta t) - x_w)`` (``lab.identify.IMPACT_LAWS``):
    the closed-form flights of :mod:`precise_impact.core.flight`, each impact found on a grid
    of 64 points per flight (and at every apex above the wall) and refined to 1e-12."""
    zeta, a, x_w = float(system["zeta"]), float(system["a"]), float(system["x_w"])
    R, kappa = float(system["R"]), float(system.get("kappa", 0.0))
    wd = math.sqrt(1 - zeta * zeta)

    def run(eta: float, state: tuple, periods: int) -> tuple[np.ndarray, tuple]:
        P, Q = steady_coefficients(eta, zeta, a)
        T = 2 * math.pi / eta
        x, v, out = float(state[0]), float(state[1]), np.empty(periods)
        for k in range(periods):
            s, end = k * T, (k + 1) * T
            while True:
                c = trig_coefficients(*homogeneous_start(s, x, v, P, Q, eta, NUMPY), zeta, wd)
                flight = functools.partial(_at, s=s, c=c, P=P, Q=Q, eta=eta, zeta=zeta, wd=wd)
                hit = _first_hit(flight, s, end, x_w)
                if hit is None:
                    x, v = _at(end, s, c, P, Q, eta, zeta, wd)
                    break
                _, vb = _at(hit, s, c, P, Q, eta, zeta, wd)
                s, x, v = hit, x_w, float(reset_velocity(vb, hit, eta, R, kappa, a, 0.0, x_w))
            out[k] = x
        return out, (x, v)

    return run


def circuit_runner(solver: Any, design: Any, drawn_eta: Any) -> tuple[Any, float]:
    """``(run, omega)``: ``run(eta, state, periods) -> (strobe x, state)`` of a circuit model
    (a solver of ``models.circuit``: switched-capacitor, ngspice, ...) at the drawn ``eta``:
    the forcing's frequency ``eta omega`` with the parts unchanged, ``omega`` the design's
    ``Omega / drawn_eta`` [rad/s]; the same sweep as :func:`affine_runner` for
    :func:`period3_window`."""
    omega = Fraction(design.Omega) / Fraction(drawn_eta)

    def run(eta: float, state: tuple, periods: int) -> tuple[np.ndarray, tuple]:
        d = dataclasses.replace(design, Omega=omega * Fraction(repr(float(eta))))
        x0, v0 = (repr(float(u)) for u in state)
        tr = solver.solve(d, periods, x0=x0, v0=v0, t0="0")
        return np.asarray(tr.x, float), (float(tr.x[-1]), float(tr.v[-1]))

    return run, float(omega)


def _at(t: Any, s: float, c: tuple, P, Q, eta, zeta, wd) -> tuple:
    x, v, _ = state_from_coefficients(t, s, c, P, Q, eta, zeta, wd, NUMPY)
    return x, v


def _first_hit(at: Any, s: float, end: float, x_w: float) -> float | None:
    """The first time in ``(s, end]`` where the flight ``at`` reaches ``x_w`` moving up."""
    t = np.linspace(s, end, 65)
    x, v = at(t)
    for j in range(1, len(t)):
        if x[j] >= x_w > x[j - 1]:
            return _refine(at, t[j - 1], t[j], lambda xx, vv: xx - x_w)
        if v[j - 1] > 0 >= v[j]:  # an apex between samples: above the wall?
            tm = _refine(at, t[j - 1], t[j], lambda xx, vv: vv, sign=-1)
            if float(at(np.array([tm]))[0][0]) >= x_w:
                return _refine(at, t[j - 1], tm, lambda xx, vv: xx - x_w)
    return None


def _refine(at: Any, lo: float, hi: float, f: Any, sign: int = 1) -> float:
    """The root of ``f(x, v)`` in ``[lo, hi]`` (``sign * f`` rises through it): three rounds
    of 33 points, then bisection to 1e-12."""
    for _ in range(3):
        t = np.linspace(lo, hi, 33)
        g = sign * f(*at(t))
        j = int(np.argmax(g >= 0)) if np.any(g >= 0) else len(t) - 1
        lo, hi = float(t[max(j - 1, 0)]), float(t[j])
    while hi - lo > 1e-12 * max(1.0, abs(hi)):
        mid = 0.5 * (lo + hi)
        if sign * float(f(*at(np.array([mid])))[0]) >= 0:
            hi = mid
        else:
            lo = mid
    return hi


def period3_window(
    run: Any, eta_range: tuple = (0.70, 0.80), coarse: float = 0.002, step: float = 0.0002
) -> dict | None:
    """The interval of ``eta`` over which ``run``'s attractor is a period-3 orbit, as a sweep
    finds it: a coarse scan from rest (400 periods each), then continuation from the middle of
    its longest run of period-3 values, down and up in steps of ``step`` (each run from the
    last one's state, 150 periods) until the orbit is lost; each end the midpoint of the last
    period-3 value and the first other.  (Continuation from the first period-3 value of the
    scan, at the window's edge, lost the orbit at once in one record of three.)  ``run`` is
    :func:`affine_runner`'s or a circuit model's (the same sweep for both); ``None`` if no
    period-3 value is found.  ``{'low', 'high', 'step'}``."""
    found = []
    for eta in np.arange(eta_range[0], eta_range[1] + 1e-12, coarse):
        xs, state = run(float(eta), (0.0, 0.0), 400)
        found.append((float(eta), state) if strobe_period(xs) == 3 else None)
    inside = _middle_of_longest(found)
    if inside is None:
        return None
    ends = [_continued(run, *inside, sign * step) for sign in (-1, 1)]
    return {"low": ends[0], "high": ends[1], "step": step}


def _middle_of_longest(found: list) -> Any:
    """The middle entry of the longest run of consecutive non-``None`` entries, or ``None``."""
    best, start = (0, 0), None
    for k, item in enumerate([*found, None]):
        if item is not None and start is None:
            start = k
        elif item is None and start is not None:
            best, start = max(best, (k - start, start)), None
    return found[best[1] + best[0] // 2] if best[0] else None


def _continued(run: Any, eta: float, state: tuple, step: float) -> float:
    for _ in range(int(0.2 / abs(step))):
        xs, state = run(eta + step, state, 150)
        if strobe_period(xs) != 3:
            return eta + step / 2
        eta += step
    return eta


def strobe_period(xs: np.ndarray) -> int:
    """The period (1, 2 or 3 forcing periods) of the last :data:`WINDOW_COMPARED` strobe
    points to :data:`WINDOW_TOL`, else 0."""
    x = np.asarray(xs[-WINDOW_COMPARED:], float)
    for p in (1, 2, 3):
        if np.max(np.abs(x[p:] - x[:-p])) < WINDOW_TOL:
            return p
    return 0
