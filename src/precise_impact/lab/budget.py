"""Tolerance budget: how the paper's landmarks (:data:`LANDMARKS`) move with every component of a
circuit design: derivatives by the implicit-function theorem on each branch point's augmented
system, chained with the components' parameter map (:func:`effective_parameters`) in exact dual
numbers; then Monte Carlo, Sobol indices (SALib), worst-case corners and the existence limits of
the Fig. 6 orbit.  Method and checks: docs/guide/tolerance.rst.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Mapping, Sequence
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from precise_impact.analysis.lyapunov.fast import fast_batch_rows
from precise_impact.analysis.orbits.landmarks import (
    BranchPoint,
    end_point,
    interval_ends,
    landmark_from_continuation,
    seed_landmark,
)
from precise_impact.core.budget import Cost, Deadline, check_cost, parse_max_time
from precise_impact.core.dual import Dual, seed
from precise_impact.core.params import exact
from precise_impact.core.result import ResultMixin, columns
from precise_impact.errors import ConvergenceError, OptionalDependencyError, ParameterError
from precise_impact.io.figures import finish, new_figure
from precise_impact.io.markdown import table as md_table
from precise_impact.models.circuit.components import Components
from precise_impact.models.circuit.effects import switch
from precise_impact.models.circuit.network import OpAmp, network_rhs
from precise_impact.models.circuit.opamp import design_omega
from precise_impact.scenes.scene import Scene, load_scene

__all__ = [
    "tolerance_budget",
    "landmark_at",
    "drawing",
    "ToleranceBudget",
    "effective_parameters",
    "LANDMARKS",
    "PARTS",
    "parse_tolerances",
    "max_ron",
    "check_ron",
]

PARTS = ("R1", "R2", "R3", "R4", "R5", "R6", "R7", "R8", "C1", "C2")
SOURCES = ("V_A", "V_wall")
#: The inputs of the parameter map a budget differentiates in (``Omega``, the generator, is
#: the reference the landmarks are compared with, not a part).
INPUTS = PARTS + SOURCES
#: The landmarks a budget can compute.
LANDMARKS = ("grazing", "pd_1_1", "p3_low", "p3_high", "lle_0712")
BRANCH_LANDMARKS = ("grazing", "pd_1_1", "p3_low", "p3_high")
_DESCRIPTION = {
    "grazing": "grazing frequency (non-impacting orbit touches the wall)",
    "pd_1_1": "period doubling of the 1:1 orbit",
    "p3_low": "lower end of the Fig. 6 period-3 orbit",
    "p3_high": "upper end of the Fig. 6 period-3 orbit",
    "lle_0712": "largest Lyapunov exponent at eta = 0.712",
}
#: The paper's mechanical system (Fig. 6: zeta = 0.05, a = 1, x_w = 2, R = 1) and where the
#: continuation finds each landmark there: (kind, start, stop, period, impacts).
_PAPER_THETA = (0.05, 1.0, 2.0)
_SEARCH = {
    "grazing": ("graze_free", 0.70, 0.72, 1, 0),
    "pd_1_1": ("period-doubling", 1.0, 0.9, 1, 1),
    "p3_low": ("graze", 0.74, 0.70, 3, None),
    "p3_high": ("graze", 0.74, 0.80, 3, None),
}
FIG6_ETA = 0.74
LLE_ETA = 0.712


# ------------------------------------------------------------------------ the parameter map
def effective_parameters(
    values: Mapping[str, Any], ron: Any = 0, gbw: Any = None, V_unit: Any = 1
) -> dict:
    """``{zeta, eta, a, x_w, omega}`` the circuit with component ``values`` realises.

    Written for any number type with ``+ - * /`` and :func:`math.sqrt`-like ``** 0.5``
    (floats, :class:`~precise_impact.core.dual.Dual` for exact derivatives).  Without ``gbw``:
    the switched-capacitor circuit between switchings with the switches' ``ron`` in series
    with C2 (the KCL of :func:`~precise_impact.models.circuit.switched.effective_system`,
    :func:`~precise_impact.models.circuit.effects.switch.vq`); with ``gbw`` (Hz): the op-amp
    network's quasi-static single-pole model with the default open-loop gain 2e5
    (:func:`~precise_impact.models.circuit.network.network_rhs`).  ``omega^2 = det A``,
    ``2 zeta omega = -tr A``, ``eta = Omega / omega``; ``a`` is the forcing whose mechanical
    response has the circuit's amplitude of ``-V_s / V_unit`` at ``Omega``.
    """
    c = dict(values)
    W = c["Omega"]
    if gbw is None:
        A, bc, bs = _switched_matrix(c, ron)
    else:
        A, bc, bs = _network_matrix(c, gbw)
    (a11, a12), (a21, a22) = A
    w2 = a11 * a22 - a12 * a21
    omega = w2**0.5
    zeta = -(a11 + a22) / (2 * omega)
    eta = W / omega
    # X = (i W - A)^-1 (bc - i bs): the V_s component, in real arithmetic
    d_re = a11 * a22 - a12 * a21 - W * W
    d_im = -W * (a11 + a22)
    r0 = (bc[0], -bs[0])
    r1 = (bc[1], -bs[1])
    # first row of the adjugate of (iW - A): (iW - a22, a12)
    n_re = -a22 * r0[0] - W * r0[1] + a12 * r1[0]
    n_im = W * r0[0] - a22 * r0[1] + a12 * r1[1]
    amp2 = (n_re * n_re + n_im * n_im) / (d_re * d_re + d_im * d_im)
    m = 1 - eta * eta
    D = m * m + (2 * zeta * eta) ** 2
    a = (amp2 * D) ** 0.5 * c["V_A"] / V_unit
    return {"zeta": zeta, "eta": eta, "a": a, "x_w": -c["V_wall"] / V_unit, "omega": omega}


def _switched_matrix(c: dict, ron: Any):
    rho = c["R5"] / c["R4"]
    k = switch.coupling(ron, c["R2"], c["R3"])

    def rhs(V_s, V_C, V3):
        V_q = switch.vq(1, V_C, V3, V_s, k, c["R1"], c["R6"], c["R7"], rho)
        V_p = -c["R2"] * (V3 / c["R1"] - rho * V_q / c["R6"] + V_s / c["R7"])
        return -V_q / (c["R8"] * c["C1"]), V_p / (c["R3"] * c["C2"])

    col1, col2, b = rhs(1.0, 0.0, 0.0), rhs(0.0, 1.0, 0.0), rhs(0.0, 0.0, 1.0)
    A = ((col1[0], col2[0]), (col1[1], col2[1]))
    return A, b, (0.0, 0.0)


class _LinearHy:
    """A stand-in for heyoka's expression namespace that evaluates the network's right-hand
    side on numbers, with the source's ``cos`` and ``sin`` set to chosen values (the network
    is linear in the states and the source, so columns of ones give its matrices)."""

    time = 0.0

    def __init__(self, cos_value: float, sin_value: float) -> None:
        self._c, self._s = cos_value, sin_value

    def cos(self, _x: Any) -> float:
        return self._c

    def sin(self, _x: Any) -> float:
        return self._s

    @staticmethod
    def sum(terms: Sequence[Any]) -> Any:
        out = terms[0]
        for t in terms[1:]:
            out = out + t
        return out


def _network_matrix(c: dict, gbw: Any):
    op = OpAmp(gbw=Fraction(float(gbw)), gbw_mode="quasi-static")  # the effect takes floats

    def rhs(V_s, V_q, cos_v, sin_v):
        dVs, dVq, _ = network_rhs(_LinearHy(cos_v, sin_v), c, V_s, V_q, op)
        return dVs, dVq

    col1, col2 = rhs(1.0, 0.0, 0.0, 0.0), rhs(0.0, 1.0, 0.0, 0.0)
    bc = rhs(0.0, 0.0, 1.0, 0.0)
    bs = rhs(0.0, 0.0, 0.0, 1.0)
    A = ((col1[0] - 0.0, col2[0]), (col1[1], col2[1]))
    return A, bc, bs


# ------------------------------------------------------------------------ tolerances
def parse_tolerances(spec: Any, defaults: Mapping[str, float] | None = None) -> dict[str, float]:
    """Relative tolerances (fractions) of every input from ``spec``.

    ``spec``: ``None`` (the defaults), a number or ``'1%'`` (every part), or a mapping /
    ``'R=1%,C=5%,R6=0.1%'`` string whose keys are a part name, ``R`` (all resistors), ``C``
    (both capacitors), ``V_A`` or ``V_wall``.  Percent signs mark percent; bare numbers in a
    string are percent too; numbers in a mapping are fractions.
    """
    out = {n: 0.0 for n in INPUTS}
    out.update({n: float(v) for n, v in (defaults or {}).items() if n in out})
    if spec is None:
        return out
    if isinstance(spec, (int, float, Fraction)) and not isinstance(spec, bool):
        items: list[tuple[str, Any]] = [("*", _frac(spec, "tolerance"))]
    elif isinstance(spec, str):
        items = []
        for part in [s.strip() for s in spec.split(",") if s.strip()]:
            key, _, val = part.rpartition("=")
            items.append((key.strip() or "*", _pct(val, part)))
    elif isinstance(spec, Mapping):
        items = [(str(k), _frac(v, str(k))) for k, v in spec.items()]
    else:
        raise ParameterError("tolerances", repr(spec), "a percentage, 'R=1%,C=5%' or a mapping")
    for key, v in items:
        names = {
            "*": PARTS,
            "R": PARTS[:8],
            "C": PARTS[8:],
        }.get(key, (key,))
        for n in names:
            if n not in out:
                raise ParameterError(
                    "tolerances", key, "keys: R, C, " + ", ".join(INPUTS) + " (or one value)"
                )
            out[n] = v
    return out


def _pct(text: str, whole: str) -> float:
    t = text.strip()
    try:
        v = float(t[:-1]) / 100 if t.endswith("%") else float(t) / 100
    except ValueError:
        raise ParameterError("tolerance", whole, "a percentage such as 1% or R=1%,C=5%") from None
    return _frac(v, whole)


def _frac(v: Any, name: str) -> float:
    try:
        f = float(v)
    except (TypeError, ValueError):
        raise ParameterError("tolerance", name, "a number") from None
    if not (0 <= f <= 0.2):
        raise ParameterError(
            "tolerance", f"{f:g}", "0 .. 20 % (the budget linearises about the design)"
        )
    return f


# ------------------------------------------------------------------------ the result
@dataclasses.dataclass
class ToleranceBudget(ResultMixin):
    """A tolerance budget (see :func:`tolerance_budget`).

    Attributes
    ----------
    design : dict
        The design's component values (decimal strings) and switch ``ron``.
    tolerances : dict
        Relative tolerance of each input (fractions; uniform within the band).
    nominal : dict
        The effective system at the design (``zeta, eta, a, x_w, omega``) and the generator
        frequency ``f_design`` [Hz].
    landmarks : dict
        Per landmark: ``eta``, ``frequency_hz``, ``dfreq_dlnc`` (Hz per unit relative change of
        each input), ``deta_dtheta`` (IFT), the FD check, Monte Carlo and Sobol figures.
    table : list of dict
        The ranked rows: landmark, component, tolerance, shift in Hz and ppm at +tolerance.
    existence : dict
        The Fig. 6 period-3 orbit at the design: margins, probability over the draws, the
        largest ``R_on / R3`` and the smallest GBW for which it exists, required tolerances.
    seed, mc, sobol : int
        The Monte Carlo seed and sample sizes.
    elapsed_s : float
        Wall time.

    See Also
    --------
    tolerance_budget : makes it.
    """

    design: dict
    tolerances: dict
    nominal: dict
    landmarks: dict
    table: list
    existence: dict
    seed: int
    mc: int
    sobol: int
    elapsed_s: float
    scans: dict = dataclasses.field(default_factory=dict, repr=False)

    def _tables(self):
        return {"ranked": self._ranked_columns}

    def _ranked_columns(self) -> dict:
        t = self.table
        return columns(
            ("rank", None, [r["rank"] for r in t]),
            ("landmark", None, [r["landmark"] for r in t]),
            ("component", None, [r["component"] for r in t]),
            ("tolerance", "%", [r["tolerance_pct"] for r in t]),
            ("shift", "Hz", [r["shift_hz"] for r in t]),
            ("shift", "ppm", [r["shift_ppm"] for r in t]),
        )

    def ranked(self, n: int | None = None) -> list[str]:
        """The table's sentences, largest first ("R6 at 1 % moves ... by ... Hz")."""
        rows = self.table if n is None else self.table[:n]
        return [
            f"{r['component']} at {r['tolerance_pct']:g} % moves the "
            f"{_DESCRIPTION[r['landmark']]} by {r['shift_hz']:+.4g} Hz ({r['shift_ppm']:+.0f} ppm)"
            for r in rows
        ]

    def markdown(self) -> str:
        """The budget as a Markdown report."""
        lines = ["# Tolerance budget", ""]
        lines += self._md_design()
        lines += self._md_landmarks()
        lines += self._md_lle()
        lines += ["", "## Largest effects", ""]
        lines += [f"- {t}" for t in self.ranked(8)]
        lines += self._md_ranked()
        lines += self._md_existence()
        lines += self._md_sobol()
        return "\n".join(lines) + "\n"

    def _md_design(self) -> list[str]:
        """The design's line: omega, the mechanical parameters, the generator, R_on."""
        nom = self.nominal
        return [
            f"Design: omega = {nom['omega']:.6g} rad/s, zeta = {nom['zeta']:.6g}, "
            f"a = {nom['a']:.6g}, x_w = {nom['x_w']:.6g}; generator at eta = {nom['eta']:.6g} "
            f"({nom['f_design']:.6g} Hz); R_on = {self.design.get('ron', '0')} ohm.",
            "",
        ]

    def _md_landmarks(self) -> list[str]:
        """The landmarks' table: where, the FD check, the Monte Carlo and linear spreads."""
        rows = []
        for name, L in self.landmarks.items():
            if "eta" not in L:
                continue
            mc = L.get("monte_carlo")
            wc = L.get("worst_case")
            fd = L.get("fd_check")
            rows.append(
                [
                    name,
                    L["type"],
                    f"{L['eta']:.10g}",
                    f"{L['frequency_hz']:.8g}",
                    f"{fd['max_rel_error']:.2e}" if fd else "not run",
                    f"{mc['std_hz']:.4g} +- {mc['std_stderr_hz']:.2g}"
                    if mc and mc["n"] > 1
                    else ("not run" if not mc else f"{mc['n']} draws converged"),
                    f"{L['linear_std_hz']:.4g}",
                    str(mc["failed"]) if mc else "-",
                    f"{wc['low_hz']:.6g} .. {wc['high_hz']:.6g}" if wc else "not run",
                ]
            )
        return md_table(
            [
                "landmark",
                "type",
                "eta",
                "f [Hz]",
                "IFT vs FD (max rel, per component)",
                "MC spread [Hz]",
                "linear spread [Hz]",
                "MC failed",
                "worst corners [Hz]",
            ],
            rows,
            align="ll",
        )

    def _md_lle(self) -> list[str]:
        """The LLE Monte Carlo's line (none when it did not run)."""
        lle = self.landmarks.get("lle_0712")
        if not (lle and "monte_carlo" in lle):
            return []
        m = lle["monte_carlo"]
        return [
            "",
            f"LLE at eta = 0.712: nominal {lle['nominal']:.5g} +- {lle['nominal_stderr']:.2g}; "
            f"over {m['n']} draws mean {m['mean']:.5g} +- {m['mean_stderr']:.2g}, "
            f"std {m['std']:.4g}, range {m['min']:.4g} .. {m['max']:.4g}, "
            f"{m['chaotic_fraction'] * 100:.0f} % of draws chaotic (LLE > 0).",
        ]

    def _md_ranked(self) -> list[str]:
        """The ranked table: each landmark's shift at + each part's tolerance."""
        lines = ["", "## Ranked (shift of each landmark at + the part's tolerance)", ""]
        return lines + md_table(
            ["rank", "landmark", "component", "tol [%]", "shift [Hz]", "shift [ppm]"],
            [
                [
                    r["rank"],
                    r["landmark"],
                    r["component"],
                    f"{r['tolerance_pct']:g}",
                    f"{r['shift_hz']:+.4g}",
                    f"{r['shift_ppm']:+.0f}",
                ]
                for r in self.table
            ],
            align="rll",
        )

    def _md_existence(self) -> list[str]:
        """Where the Fig. 6 orbit holds, its Sobol indices, and the absent landmarks."""
        ex = self.existence
        lines = ["", "## The Fig. 6 period-3 orbit", ""]
        for k, v in ex.items():
            if isinstance(v, (dict, list)):
                continue
            lines.append(f"- {k}: {v}")
        se = ex.get("sobol_indices_of_existence")
        if se:
            top = sorted(se["ST"].items(), key=lambda kv: -kv[1])[:6]
            lines.append(
                f"- Sobol indices of the orbit's existence (S1/ST, N = {se['N']}, holds in "
                f"{se['fraction'] * 100:.0f} % of the sample): "
                + ", ".join(f"{k} {se['S1'][k]:.3f}/{v:.3f}" for k, v in top)
            )
        for name, L in self.landmarks.items():
            if "absent" in L:
                lines.append(f"- {name}: absent ({L['absent']})")
        return lines

    def _md_sobol(self) -> list[str]:
        """Each landmark's largest Sobol indices (first order / total)."""
        lines = ["", "## Sobol indices (first order S1 / total ST)", ""]
        for name, L in self.landmarks.items():
            s = L.get("sobol")
            if not s or "ST" not in s:
                if s:
                    lines.append(f"- {name}: not computed ({s.get('failed')} evaluations failed)")
                continue
            top = sorted(s["ST"].items(), key=lambda kv: -kv[1])[:5]
            lines.append(
                f"- {name}: "
                + ", ".join(f"{k} {s['S1'][k]:.3f}/{v:.3f}" for k, v in top)
                + f" (N = {s['N']})"
            )
        return lines

    def plot(self, path: str | Path | None = None, what: str = "existence", n: int = 12):
        """A figure of the budget, saved to ``path`` if given.

        Parameters
        ----------
        path : str, Path or None
            Where to save it (PNG).
        what : {'existence', 'ranked'}
            ``'existence'``: the period-3 interval in eta against ``R_on / R3`` and against
            the op-amps' GBW, with the design's forcing (needs the scans); ``'ranked'``: the
            ``n`` largest shifts of the ranked table, in ppm of each landmark's frequency, at
            + each part's tolerance.
        n : int, default 12
            Rows of the ``'ranked'`` figure.
        """
        if what not in ("existence", "ranked"):
            raise ParameterError("what", what, "'existence' or 'ranked'")

        if what == "ranked":
            rows = self.table[:n][::-1]
            fig, grid = new_figure(1, 1, figsize=(8, 0.35 * len(rows) + 1.4))
            ax = grid[0, 0]
            colors = {k: f"C{i}" for i, k in enumerate(LANDMARKS)}
            ax.barh(
                range(len(rows)),
                [r["shift_ppm"] for r in rows],
                color=[colors[r["landmark"]] for r in rows],
            )
            ax.set_yticks(
                range(len(rows)),
                [f"{r['component']} {r['tolerance_pct']:g} %: {r['landmark']}" for r in rows],
            )
            ax.axvline(0, color="k", lw=0.8)
            ax.set_xlabel("shift of the landmark's frequency at + the part's tolerance [ppm]")
            ax.set_title(f"Largest effects ({self.design.get('source', 'design')})")
            return finish(fig, path, dpi=110)
        fig, grid = new_figure(1, 2, figsize=(11, 4.2), layout=None)
        axes = grid[0]
        for ax, key, xlabel, logx in (
            (axes[0], "ron", "R_on / R3", False),
            (axes[1], "gbw", "op-amp gain-bandwidth [Hz]", True),
        ):
            s = self.scans.get(key)
            if not s:
                ax.set_visible(False)
                continue
            x = np.asarray(s["x"], dtype=float)
            lo, hi, d = (np.asarray(s[k], dtype=float) for k in ("eta_low", "eta_high", "eta"))
            ok = np.asarray(s.get("exists", np.isfinite(lo)), dtype=bool)
            ax.fill_between(
                x,
                lo,
                hi,
                where=ok,
                color="tab:green",
                alpha=0.25,
                label="period-3 interval in eta, computed only while it\ncontains the "
                "design's eta (not drawn beyond)",
            )
            ax.plot(x, lo, color="tab:green")
            ax.plot(x, hi, color="tab:green")
            ax.plot(x, d, color="k", lw=1.5, label="the design's forcing eta")
            lim = s.get("limit")
            if lim is not None:
                ax.axvline(
                    lim,
                    color="tab:red",
                    ls="--",
                    label=f"{lim:.4g}: the design's eta leaves the interval\n(the orbit may "
                    "exist at other eta)",
                )
            for xv, lab in s.get("marks", []):
                ax.axvline(xv, color="tab:blue", ls=":", label=lab)
            if logx:
                ax.set_xscale("log")
            ax.set_xlabel(xlabel)
            ax.set_ylabel("eta = Omega / omega_eff")
            ax.legend(fontsize=8, loc="best")
        fig.suptitle(
            "Fig. 6 period-3 orbit at the design's forcing: its existence interval in eta, "
            "scanned until the design's eta leaves it"
        )
        fig.tight_layout()
        return finish(fig, path, dpi=110)


# ------------------------------------------------------------------------ the budget
def drawing(scene_or_components: Any) -> tuple[Components, Fraction, dict, str]:
    """``(design, ron, default tolerances, label)`` from a scene, a scene name/path or
    components."""
    if isinstance(scene_or_components, Components):
        return scene_or_components, Fraction(0), {}, "components"
    sc = scene_or_components
    if not isinstance(sc, Scene):
        sc = load_scene(sc)
    if sc.kind != "single":
        raise ParameterError(
            "scene", sc.name, "a single-oscillator scene (a coupled pair has two circuits)"
        )
    # a mechanical scene's design is the nominal circuit realising its parameters
    design = sc.design()
    ron = Fraction(sc.effects.get("switch", {}).get("ron", 0))
    tol = sc.effects.get("tolerance")
    defaults = {}
    if tol is not None:
        defaults = {n: float(tol.get("resistor_pct", 1)) / 100 for n in PARTS[:8]}
        defaults.update({n: float(tol.get("capacitor_pct", 5)) / 100 for n in PARTS[8:]})
    return design, ron, defaults, sc.name


def _theta(p: dict) -> np.ndarray:
    return np.array([float(p[k]) for k in ("zeta", "a", "x_w")])


def _paper_orbit() -> BranchPoint:
    """The Fig. 6 period-3 orbit (two impacts) at the paper's parameters, eta = 0.74."""
    return seed_landmark("orbit", _PAPER_THETA, FIG6_ETA, 3, None)


def _carry_orbit(orbit: BranchPoint, theta: np.ndarray, eta: float) -> BranchPoint:
    """The orbit carried to ``(theta, eta)`` by Newton along the straight path (step halving),
    staying admissible; :class:`ConvergenceError` if it cannot be."""
    t0, e0 = orbit.theta.copy(), orbit.eta
    s, ds, cur = 0.0, 0.25, orbit
    while s < 1.0:
        t = min(1.0, s + ds)
        try:
            nxt = dataclasses.replace(cur, eta_fixed=e0 + t * (eta - e0)).solve(
                t0 + t * (theta - t0)
            )
            if not nxt.admissible():
                raise ConvergenceError("the orbit stopped being admissible")
            cur, s, ds = nxt, t, min(2 * ds, 1.0)
        except (ConvergenceError, np.linalg.LinAlgError, ValueError, ZeroDivisionError):
            ds /= 2
            if ds < 1e-4:
                raise ConvergenceError(
                    f"the period-3 orbit cannot be carried to eta = {eta:.8g}, "
                    f"theta = {np.round(theta, 8).tolist()}"
                ) from None
    return cur


def _move(bp: BranchPoint, theta: np.ndarray, steps: int = 8) -> BranchPoint:
    """The landmark carried from its parameters to ``theta`` by Newton on a straight path
    (natural-parameter continuation in theta), halving steps that fail."""
    start = bp.theta.copy()
    s, ds = 0.0, 1.0 / steps
    cur = bp
    while s < 1.0:
        t = min(1.0, s + ds)
        try:
            nxt = cur.solve(start + t * (theta - start))
            if not nxt.admissible():
                raise ConvergenceError(f"the {bp.kind} landmark's orbit is no longer admissible")
            cur = nxt
            s = t
            ds = min(ds * 2, 1.0)
        except (ConvergenceError, np.linalg.LinAlgError, ValueError, ZeroDivisionError):
            ds /= 2
            if ds < 1e-4:
                raise ConvergenceError(
                    f"the {bp.kind} landmark could not be carried to theta = {theta.tolist()}"
                ) from None
    return cur


def tolerance_budget(
    scene_or_components: Any = "fig6-period2-datasheet",
    tolerances: Any = None,
    landmarks: Sequence[str] = LANDMARKS,
    seed: int = 0,
    *,
    mc: int = 400,
    sobol: int = 256,
    lle_mc: int = 32,
    lle_periods: int = 2000,
    ron: Any = None,
    scans: bool = True,
    fd_check: bool = True,
    progress: Any = None,
    max_time: Any = None,
) -> ToleranceBudget:
    """The tolerance budget of a circuit design for the paper's landmarks.

    Parameters
    ----------
    scene_or_components : str, Path, Scene or Components, default ``'fig6-period2-datasheet'``
        The design: a scene (its components, its switches' ``R_on``, its tolerance effect's
        percentages as the default tolerances) or component values (``R_on = 0``).
    tolerances : None, number, str or mapping
        Relative tolerances (:func:`parse_tolerances`); default the scene's (1 % resistors,
        5 % capacitors for the datasheet scenes) or 1 % / 5 %.
    landmarks : sequence of str
        Which of :data:`LANDMARKS`.
    seed : int
        Seed of the Monte Carlo draws (``numpy.random.default_rng``) and the Sobol sample.
    mc : int, default 400
        Monte Carlo draws for the branch-point landmarks (``0``: none).
    sobol : int, default 256
        Sobol base sample ``N``, a power of 2 (SALib; ``N (2 D + 2)`` evaluations); ``0``:
        none (no Sobol indices, SALib not needed).
    lle_mc : int, default 32
        Draws for the LLE at 0.712 (each a ``lle_periods``-period run of the fast engine).
    lle_periods : int, default 2000
        Forcing periods of each LLE run.
    ron : decimal or None
        The switches' on-resistance in ohms replacing the scene's: ``0 <= ron <``
        :func:`max_ron` of the design (where the effective damping reaches ``zeta = 1``).
    scans : bool, default ``True``
        The ``R_on / R3`` and GBW scans of the period-3 orbit's existence (the limits).
    fd_check : bool, default ``True``
        Finite differences of re-continued landmarks against the IFT derivatives.
    progress : callable or None
        ``progress(message)`` on long steps.
    max_time : decimal or None
        Seconds the run may take, enforced while it works (between landmarks, draws,
        Sobol evaluations, LLE batches and scan points): past it
        :class:`~precise_impact.errors.BudgetExceededError` and no result.

    Returns
    -------
    ToleranceBudget
        The landmarks at the design with their derivatives by every component, the ranked
        table (``ranked()``), Monte Carlo spreads, Sobol indices, worst-case corners, the
        existence limits of the Fig. 6 orbit; ``markdown()``, ``plot()``.

    Raises
    ------
    ParameterError
        Bad input, before any work.
    OptionalDependencyError
        SALib missing while ``sobol > 0``.
    BudgetExceededError
        ``max_time`` ran out (nothing returned).

    See Also
    --------
    effective_parameters : the components-to-parameters map it differentiates.
    precise_impact.analysis.orbits.landmarks : the branch points as augmented systems.

    Examples
    --------
    >>> from precise_impact import tolerance_budget
    >>> b = tolerance_budget("fig6-period2-datasheet", landmarks=("grazing",), mc=0, sobol=0,
    ...                      lle_mc=0, scans=False, fd_check=False)
    >>> b.ranked()[0].split(" moves ")[0], b.ranked()[0].split(" by ")[1]
    ('C2 at 5 %', '-2.861 Hz (-25246 ppm)')
    """
    t_start = time.perf_counter()
    design, ron0, defaults, label = drawing(scene_or_components)
    tol, ron0 = _check_arguments(
        design, ron0, defaults, tolerances, landmarks, mc, sobol, lle_mc, seed, ron
    )
    deadline = Deadline(None if max_time is None else parse_max_time(max_time), "budget")
    say = progress or (lambda _m: None)
    lin = _linearise(design, ron0)
    sig = np.array([tol[n] for n in INPUTS])
    result_lm: dict = {}
    points: dict[str, BranchPoint] = {}
    orbit_d, p3_why, ends = _fig6_orbit(landmarks, lin, say)
    for name in [n for n in landmarks if n in BRANCH_LANDMARKS]:
        deadline.check(f"before landmark {name}")
        say(f"landmark {name}: located by continuation, polished on its augmented system")
        try:
            bp = _locate(name, orbit_d, ends, p3_why, lin.theta0)
        except (ConvergenceError, ValueError) as e:
            result_lm[name] = {"absent": str(e)}
            continue
        points[name] = bp
        result_lm[name] = _derivatives(name, bp, lin, sig, fd_check, deadline, say)
    table = _ranked(result_lm, tol)

    rng = np.random.default_rng(seed)
    active = [i for i, n in enumerate(INPUTS) if sig[i] > 0]
    if mc and points:
        say(f"Monte Carlo: {mc} draws (seed {seed})")
        _monte_carlo(points, orbit_d, result_lm, rng, mc, lin, sig, deadline)
    if sobol and points and active:
        say(f"Sobol indices: N = {sobol}, {len(active)} inputs")
        _sobol(
            points, result_lm, lin.x0, sig, active, lin.c0, lin.ronf, lin.vu, sobol, seed,
            orbit_d, deadline,
        )  # fmt: skip
    for name in points:
        result_lm[name]["worst_case"] = _corners(
            points[name], result_lm[name], lin.x0, sig, lin.c0, lin.ronf, lin.vu
        )
    if "lle_0712" in landmarks:
        say(f"LLE at eta = 0.712: {lle_mc} draws")
        result_lm["lle_0712"] = _lle_mc(
            design, lin.x0, sig, lin.c0, lin.ronf, lin.vu, lle_mc, lle_periods, seed, deadline
        )
    existence, scan_data = _limits(points, lin, result_lm, sig, orbit_d, scans, deadline, say)
    return ToleranceBudget(
        design={**design.decimal(), "ron": str(float(ron0)), "source": label},
        tolerances={n: tol[n] for n in INPUTS},
        nominal=_plain(lin.nominal),
        landmarks=result_lm,
        table=table,
        existence=existence,
        seed=seed,
        mc=mc,
        sobol=sobol,
        elapsed_s=time.perf_counter() - t_start,
        scans=scan_data,
    )


def _check_arguments(
    design, ron0, defaults, tolerances, landmarks, mc, sobol, lle_mc, seed, ron
) -> tuple[dict[str, float], Fraction]:
    """The tolerances and ``R_on`` of a budget, every argument checked (before any work)."""
    if not defaults:
        defaults = {n: 0.01 for n in PARTS[:8]} | {n: 0.05 for n in PARTS[8:]}
    tol = parse_tolerances(tolerances, defaults)
    bad = [n for n in landmarks if n not in LANDMARKS]
    if bad or not landmarks:
        raise ParameterError(
            "landmarks", ",".join(bad) or "(none)", "any of " + ", ".join(LANDMARKS)
        )
    for name, v, hi in (("mc", mc, 100000), ("sobol", sobol, 65536), ("lle_mc", lle_mc, 10000)):
        if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v <= hi:
            raise ParameterError(name, repr(v), f"an integer 0 .. {hi}")
    if sobol and sobol & (sobol - 1):
        raise ParameterError("sobol", str(sobol), "a power of 2 (Sobol sequences)")
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise ParameterError("seed", repr(seed), "an integer >= 0")
    if ron is not None:
        ron0 = exact("ron", ron)
        if ron0 < 0:
            raise ParameterError("ron", str(ron), ">= 0 ohm")
    check_ron(design, ron0, ron)
    if sobol:
        _require_salib()
    return tol, ron0


@dataclasses.dataclass
class _Linear:
    """The design's inputs, mechanical parameters and their exact first derivatives."""

    c0: dict
    vu: float
    ronf: float
    x0: np.ndarray
    theta0: np.ndarray
    dtheta: np.ndarray
    omega0: float
    domega: np.ndarray
    nominal: dict


def _linearise(design: Components, ron0: Fraction) -> _Linear:
    """The derivative pass of the parameter map: dual numbers through the KCL at the design."""
    c0 = {n: float(getattr(design, n)) for n in INPUTS + ("Omega",)}
    vu = float(design.V_unit)
    ronf = float(ron0)
    x0 = np.array([c0[n] for n in INPUTS])
    duals = dict(zip(INPUTS, seed_inputs(x0), strict=True))
    duals["Omega"] = c0["Omega"]
    ep = effective_parameters(duals, ronf, V_unit=vu)
    theta0 = np.array([ep[k].v for k in ("zeta", "a", "x_w")])
    dtheta = np.array([ep[k].g for k in ("zeta", "a", "x_w")])  # 3 x len(INPUTS)
    omega0, domega = ep["omega"].v, ep["omega"].g
    eta_d = ep["eta"].v
    f_design = c0["Omega"] / (2 * math.pi)
    nominal = {
        "zeta": theta0[0],
        "a": theta0[1],
        "x_w": theta0[2],
        "eta": eta_d,
        "omega": omega0,
        "f_design": f_design,
        "ron_damping": 2 * ronf / c0["R3"],
    }
    return _Linear(c0, vu, ronf, x0, theta0, dtheta, omega0, domega, nominal)


def _fig6_orbit(landmarks, lin: _Linear, say) -> tuple[BranchPoint | None, str, dict]:
    """``(orbit, why not, its interval's ends)``: the Fig. 6 period-3 orbit at the design."""
    orbit_d: BranchPoint | None = None
    p3_why = ""
    ends: dict = {}
    if {"p3_low", "p3_high"} & set(landmarks):
        say("the Fig. 6 period-3 orbit carried to the design; its interval by continuation")
        try:
            orbit_d = _carry_orbit(_paper_orbit(), lin.theta0, lin.nominal["eta"])
            if not orbit_d.stable():
                p3_why = "the period-3 orbit carried to the design's eta is unstable"
                orbit_d = None
        except ConvergenceError as e:
            p3_why = f"no period-3 orbit at the design's eta ({e})"
        ends = interval_ends(orbit_d) if orbit_d is not None else {}
    return orbit_d, p3_why, ends


def _locate(name: str, orbit_d, ends: dict, p3_why: str, theta0: np.ndarray) -> BranchPoint:
    """Landmark ``name`` at the design (raises ConvergenceError / ValueError when absent)."""
    if name in ("p3_low", "p3_high"):
        end = ends.get(name[3:]) if orbit_d is not None else None
        if end is None:
            raise ConvergenceError(p3_why or f"the branch's {name[3:]} end is not in eta +- 0.06")
        bp0 = end_point(orbit_d, end)
        if bp0 is None:
            raise ConvergenceError(
                f"the {name[3:]} end is a {end[0]} at eta = {end[1]:.10g} (no augmented "
                "system for it here)"
            )
        return bp0
    kind, start, stop, period, impacts = _SEARCH[name]
    bp, _ = landmark_from_continuation(kind, _PAPER_THETA, start, stop, period, impacts)
    return _move(bp, theta0)


def landmark_at(name: str, theta: Any, eta_near: float = FIG6_ETA) -> BranchPoint:
    """Landmark ``name`` (one of :data:`BRANCH_LANDMARKS`) of the system ``theta = (zeta, a,
    x_w)`` with R = 1, found as the budget finds it at a design: the period-3 window's ends
    from the Fig. 6 orbit carried to ``(theta, eta_near)``.  ``bp.eta`` is its frequency,
    ``bp.sensitivity()`` its ``d eta / d theta``; :class:`ConvergenceError` when it is absent.
    """
    theta = np.asarray(theta, dtype=float)
    if name not in BRANCH_LANDMARKS:
        raise ParameterError("landmark", name, "one of " + ", ".join(BRANCH_LANDMARKS))
    if name not in ("p3_low", "p3_high"):
        return _locate(name, None, {}, "", theta)
    orbit = _carry_orbit(_paper_orbit(), theta, eta_near)
    if not orbit.stable():
        raise ConvergenceError(f"the period-3 orbit is unstable at eta = {eta_near}")
    return _locate(name, orbit, interval_ends(orbit), "", theta)


def _derivatives(name, bp, lin: _Linear, sig, fd_check, deadline, say) -> dict:
    """A located landmark's frequency and its derivatives by every input (IFT, chained)."""
    g = bp.sensitivity()  # d eta_L / d theta
    deta_dc = g @ lin.dtheta  # d eta_L / d c
    f = bp.eta * lin.omega0 / (2 * math.pi)
    df_dc = (deta_dc * lin.omega0 + bp.eta * lin.domega) / (2 * math.pi)
    dlnc = df_dc * lin.x0  # Hz per unit relative change
    entry = {
        "description": _DESCRIPTION[name],
        "type": {"graze_free": "grazing", "graze": "grazing"}.get(bp.kind, bp.kind),
        "eta": bp.eta,
        "frequency_hz": f,
        "deta_dtheta": dict(zip(("zeta", "a", "x_w"), g.tolist(), strict=True)),
        "dfreq_dlnc": dict(zip(INPUTS, dlnc.tolist(), strict=True)),
        "linear_std_hz": float(np.sqrt(np.sum((dlnc * sig) ** 2) / 3)),
        "worst_case_linear_hz": float(np.sum(np.abs(dlnc * sig))),
        "multipliers": [abs(complex(m)) for m in bp.multipliers()],
    }
    if fd_check:
        deadline.check(f"before the finite differences of {name}")
        say(f"landmark {name}: finite differences of re-continued landmarks")
        entry["fd_check"] = _fd_check(name, bp, g, lin.theta0)
    return entry


def _monte_carlo(points, orbit_d, result_lm, rng, mc, lin: _Linear, sig, deadline) -> None:
    """The Monte Carlo pass: each landmark's spread over ``mc`` uniform draws of the parts,
    and how often the Fig. 6 orbit survives (into ``result_lm``)."""
    x0, c0, ronf, vu = lin.x0, lin.c0, lin.ronf, lin.vu
    u = rng.uniform(-1.0, 1.0, size=(mc, len(INPUTS)))
    draws = x0 * (1 + u * sig)
    vals = _evaluate(points, draws, c0, ronf, vu, deadline)
    if orbit_d is not None:
        vals["_orbit"] = _evaluate({"_orbit": orbit_d}, draws, c0, ronf, vu, deadline)["_orbit"]
    for name in points:
        fs = vals[name]
        ok = fs[np.isfinite(fs)]
        n = len(ok)
        std = float(np.std(ok, ddof=1)) if n > 1 else math.nan
        result_lm[name]["monte_carlo"] = {
            "n": int(n),
            "failed": int(mc - n),
            "mean_hz": float(np.mean(ok)) if n else math.nan,
            "std_hz": std,
            # std of a std of n draws: ~ std / sqrt(2 (n - 1)) (near-normal sums)
            "std_stderr_hz": std / math.sqrt(2 * (n - 1)) if n > 1 else math.nan,
            "min_hz": float(np.min(ok)) if n else math.nan,
            "max_hz": float(np.max(ok)) if n else math.nan,
        }
    result_lm["_p3_draws"] = _p3_fraction(vals, lin.nominal["f_design"])
    if "_orbit" in vals:
        e = vals["_orbit"]
        result_lm["_p3_draws"] = dict(
            result_lm["_p3_draws"] or {},
            orbit_fraction=float(np.mean(np.isfinite(e))),
            orbit_fraction_stderr=float(
                math.sqrt(np.mean(np.isfinite(e)) * (1 - np.mean(np.isfinite(e))) / len(e))
            ),
            orbit_n=len(e),
        )


def _limits(points, lin: _Linear, result_lm, sig, orbit_d, scans, deadline, say):
    """``(existence, scans)``: where the Fig. 6 orbit holds (draws, Sobol, the scans' limits)."""
    p3_draws = result_lm.pop("_p3_draws", None)
    sobol_existence = result_lm.pop("_sobol_existence", None)
    existence = _plain(_existence(points, lin.nominal, result_lm, sig, p3_draws))
    if sobol_existence is not None:
        existence["sobol_indices_of_existence"] = sobol_existence
    scan_data: dict = {}
    if scans and orbit_d is not None:
        say("scans: R_on / R3 and GBW limits of the period-3 orbit")
        scan_data, limits = _scans(orbit_d, lin.c0, lin.vu, lin.ronf, deadline)
        existence.update(_plain(limits))
    return existence, scan_data


def _plain(d: dict) -> dict:
    """``d`` with numpy scalars as Python ``float`` / ``bool`` / ``int`` (they print as
    numbers, not ``np.float64(...)``)."""
    out: dict = {}
    for k, v in d.items():
        if isinstance(v, np.bool_):
            v = bool(v)
        elif isinstance(v, np.integer):
            v = int(v)
        elif isinstance(v, np.floating):
            v = float(v)
        out[k] = v
    return out


def max_ron(design: Components) -> float:
    """The largest switch ``R_on`` [ohm] the budget accepts for ``design``: where the
    effective damping of :func:`effective_parameters` reaches ``zeta = 1`` (the switch's
    ``R_on`` adds about ``2 R_on / R3`` to ``2 zeta``; past critical damping the circuit
    is no longer an oscillator, and no landmark exists).  Bisection to 1e-9 relative."""
    c = {n: float(getattr(design, n)) for n in INPUTS + ("Omega",)}
    vu = float(design.V_unit)

    def zeta(r: float) -> float:
        return float(effective_parameters(c, r, V_unit=vu)["zeta"])

    if zeta(0.0) >= 1:
        return 0.0
    lo, hi = 0.0, c["R3"]
    while zeta(hi) < 1:
        lo, hi = hi, 2 * hi
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if zeta(mid) < 1:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-9 * hi:
            break
    return lo


def check_ron(design: Components, ron: Any, given: Any = None) -> None:
    """One line naming ``ron`` unless ``0 <= ron <`` :func:`max_ron` of ``design``."""
    bound = max_ron(design)
    if not 0 <= float(ron) < bound:
        raise ParameterError(
            "ron",
            str(ron if given is None else given),
            f"0 <= ron < {bound:.6g} ohm (zeta reaches 1 there: an overdamped circuit has "
            "none of the landmarks)",
        )


def _require_salib() -> None:
    try:
        import SALib  # noqa: F401, PLC0415 -- optional: loaded on first use
    except ImportError:
        raise OptionalDependencyError(
            "SALib", "pip install 'precise_impact[lab]'", "Sobol indices (or sobol=0)"
        ) from None


def seed_inputs(x0: np.ndarray) -> list[Dual]:
    return seed(x0)


def _fd_check(name: str, bp: BranchPoint, g: np.ndarray, theta0: np.ndarray) -> dict:
    """Finite differences of the landmark re-located (Newton on its augmented system from the
    design's solution) at ``theta0 +- h e_k``, Richardson-extrapolated:
    ``(4 D(h/2) - D(h)) / 3`` with ``D`` the central difference and ``h = eps^(1/3)
    |theta_k|``.  The extrapolation removes the ``h^2 eta''' / 6`` term, which is not small
    near a codimension-two point (a fold born at a grazing has ``|eta'''| ~ 1e7``: plain
    central differences were 4e-6 off there); what remains is ``O(h^4)`` and the rounding
    ``~ eps |eta| / h ~ 1e-11``."""

    def central(k: int, h: float) -> float:
        vals = []
        for s in (1, -1):
            th = theta0.copy()
            th[k] += s * h
            vals.append(_move(bp, th, steps=1).eta)
        return (vals[0] - vals[1]) / (2 * h)

    fd = []
    for k in range(3):
        h = 6.0554544523933395e-06 * abs(theta0[k])  # eps^(1/3)
        fd.append((4 * central(k, h / 2) - central(k, h)) / 3)
    fd_arr = np.array(fd)
    # per component: |FD_k - IFT_k| / |IFT_k| (a zero component against the largest one)
    scale = np.where(g != 0, np.abs(g), np.max(np.abs(g)))
    rel = np.abs(fd_arr - g) / scale
    return {
        "fd": fd_arr.tolist(),
        "ift": g.tolist(),
        "rel_error": rel.tolist(),
        "max_rel_error": float(np.max(rel)),
        "rel_error_meaning": "per component, |FD_k - IFT_k| / |IFT_k|",
        "step_rule": "Richardson (4 D(h/2) - D(h)) / 3, h = eps^(1/3) |theta_k|",
    }


def _evaluate(
    points: dict,
    draws: np.ndarray,
    c0: dict,
    ron: float,
    vu: float,
    deadline: Deadline | None = None,
) -> dict:
    """Landmark frequencies [Hz] at component draws (rows over :data:`INPUTS`): the parameter
    map in float64, then each landmark by chord Newton from the design's solution (its exact
    ``F_y`` fixed), full Newton when the chord fails; NaN where neither converges."""
    chords = {n: bp.jacobian()[1] for n, bp in points.items()}
    out = {n: np.full(len(draws), math.nan) for n in points}
    for i, row in enumerate(draws):
        if deadline is not None:
            deadline.check(f"evaluation {i + 1} of {len(draws)}")
        vals = dict(zip(INPUTS, row.tolist(), strict=True))
        vals["Omega"] = c0["Omega"]
        ep = effective_parameters(vals, ron, V_unit=vu)
        th = _theta(ep)
        for n, bp in points.items():
            if bp.kind == "orbit":  # the orbit at this draw's eta: exists if stable, admissible
                bp = dataclasses.replace(bp, eta_fixed=ep["eta"])
            # a draw where the landmark changed nature makes Newton diverge: its iterates run
            # to eta ~ 1e300, the closed-form flight overflows (cos_sin(eta t)) and divides
            # inf / inf; solve() then reports no convergence and the draw counts as failed.
            # Those NaN are the expected signal, not an error: no RuntimeWarning for them.
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                try:  # chord Newton: converges at the rate |theta - theta_0| (~0.05 at 5 %)
                    q = bp.solve(th, chord=chords[n], iterations=30)
                except (ConvergenceError, np.linalg.LinAlgError, ValueError, ZeroDivisionError):
                    try:  # one full Newton from the design's solution
                        q = bp.solve(th, iterations=20)
                    except (
                        ConvergenceError,
                        np.linalg.LinAlgError,
                        ValueError,
                        ZeroDivisionError,
                    ):
                        continue
            if not q.admissible() or (q.kind == "orbit" and not q.stable()):
                continue  # the landmark changed nature (another flight grazes first ...)
            out[n][i] = q.eta * ep["omega"] / (2 * math.pi)
    return out


def _p3_fraction(vals: dict, f_design: float) -> dict | None:
    if "p3_low" not in vals or "p3_high" not in vals:
        return None
    lo, hi = vals["p3_low"], vals["p3_high"]
    ok = np.isfinite(lo) & np.isfinite(hi)
    inside = ok & (lo < f_design) & (f_design < hi)
    n = int(np.sum(ok))
    p = float(np.sum(inside)) / n if n else math.nan
    return {
        "fraction": p,
        "stderr": math.sqrt(p * (1 - p) / n) if n else math.nan,
        "n": n,
    }


def _sobol(
    points, result_lm, x0, sig, active, c0, ron, vu, N, seed_, orbit=None, deadline=None
) -> None:
    """SALib's Sobol indices of each landmark frequency over the tolerance box (uniform
    parts), and of the Fig. 6 orbit's existence at the design's eta (an indicator: which
    parts decide whether it holds) when ``orbit`` is given."""
    from SALib.analyze import sobol as sobol_analyze  # noqa: PLC0415 -- optional: loaded on first use
    from SALib.sample import sobol as sobol_sample  # noqa: PLC0415 -- optional: loaded on first use

    names = [INPUTS[i] for i in active]
    problem = {
        "num_vars": len(active),
        "names": names,
        "bounds": [[-1.0, 1.0]] * len(active),
    }
    U = sobol_sample.sample(problem, N, calc_second_order=False, seed=seed_)
    full = np.zeros((len(U), len(INPUTS)))
    full[:, active] = U
    pts = dict(points)
    if orbit is not None:
        pts["_orbit"] = orbit
    vals = _evaluate(pts, x0 * (1 + full * sig), c0, ron, vu, deadline)
    if orbit is not None:
        Y = np.isfinite(vals["_orbit"]).astype(float)
        if 0 < Y.mean() < 1:
            Si = sobol_analyze.analyze(problem, Y, calc_second_order=False, seed=seed_)
            result_lm["_sobol_existence"] = {
                "N": N,
                "fraction": float(Y.mean()),
                "S1": dict(zip(names, np.asarray(Si["S1"]).tolist(), strict=True)),
                "ST": dict(zip(names, np.asarray(Si["ST"]).tolist(), strict=True)),
            }
    for name in points:
        Y = vals[name]
        if not np.all(np.isfinite(Y)):
            result_lm[name]["sobol"] = {"N": N, "failed": int(np.sum(~np.isfinite(Y)))}
            continue
        Si = sobol_analyze.analyze(problem, Y, calc_second_order=False, seed=seed_)
        result_lm[name]["sobol"] = {
            "N": N,
            "evaluations": len(U),
            "S1": dict(zip(names, np.asarray(Si["S1"]).tolist(), strict=True)),
            "ST": dict(zip(names, np.asarray(Si["ST"]).tolist(), strict=True)),
            "S1_conf": dict(zip(names, np.asarray(Si["S1_conf"]).tolist(), strict=True)),
        }


def _corners(bp, L, x0, sig, c0, ron, vu) -> dict:
    """The two corners of the tolerance box along the signs of the landmark's gradient,
    evaluated nonlinearly (the extreme corners of a near-linear landmark)."""
    s = np.sign(np.array([L["dfreq_dlnc"][n] for n in INPUTS]))
    rows = np.array([x0 * (1 + s * sig), x0 * (1 - s * sig)])
    v = _evaluate({"x": bp}, rows, c0, ron, vu)["x"]
    return {
        "high_hz": float(v[0]),
        "low_hz": float(v[1]),
        "high_corner": {n: int(s[i] * (sig[i] > 0)) for i, n in enumerate(INPUTS)},
    }


def _lle_mc(design, x0, sig, c0, ron, vu, n, periods, seed_, deadline=None) -> dict:
    """The LLE with the generator at ``eta = 0.712`` of the ideal design, over ``n`` draws:
    each draw's effective system run by the fast engine (its variational LLE, batch-means
    standard error)."""
    omega_design = float(design_omega(design))
    W = LLE_ETA * omega_design
    rng = np.random.default_rng([seed_, 712])
    u = rng.uniform(-1.0, 1.0, size=(n, len(INPUTS)))
    rows = [x0] + [x0 * (1 + ui * sig) for ui in u]
    pts = []
    for row in rows:
        vals = dict(zip(INPUTS, row.tolist(), strict=True))
        vals["Omega"] = W
        ep = effective_parameters(vals, ron, V_unit=vu)
        pts.append([ep["eta"], ep["zeta"], ep["a"], ep["x_w"], 1.0, 0.0, 0.0, 0.0])

    def fallback(idx):
        raise ConvergenceError("the fast engine did not resolve an LLE point")

    res: list = []
    chunk = 8  # rows are independent: the same numbers in chunks, the deadline between them
    for i in range(0, len(pts), chunk):
        if deadline is not None:
            deadline.check(f"LLE draw {i} of {len(pts) - 1}")
        res += fast_batch_rows(
            np.array(pts[i : i + chunk]), fallback, periods=periods, transient=1000
        )
    lle = np.array([r["lle"] for r in res], dtype=float)
    err = np.array([r["stderr"] for r in res], dtype=float)
    d = lle[1:]
    return {
        "description": _DESCRIPTION["lle_0712"],
        "nominal": float(lle[0]),
        "nominal_stderr": float(err[0]),
        "nominal_eta": pts[0][0],
        "monte_carlo": {
            "n": int(n),
            "seed": [seed_, 712],
            "mean": float(np.mean(d)) if n else math.nan,
            "mean_stderr": float(np.std(d, ddof=1) / math.sqrt(n)) if n > 1 else math.nan,
            "std": float(np.std(d, ddof=1)) if n > 1 else math.nan,
            "min": float(np.min(d)) if n else math.nan,
            "max": float(np.max(d)) if n else math.nan,
            "chaotic_fraction": float(np.mean(d > 0)) if n else math.nan,
            "median_run_stderr": float(np.median(err[1:])) if n else math.nan,
        },
    }


def _ranked(result_lm: dict, tol: dict) -> list:
    rows = []
    for name, L in result_lm.items():
        if "dfreq_dlnc" not in L:
            continue
        f = L["frequency_hz"]
        for n, d in L["dfreq_dlnc"].items():
            if tol[n] <= 0 and d == 0:
                continue
            t = tol[n]
            shift = d * t
            rows.append(
                {
                    "landmark": name,
                    "component": n,
                    "tolerance_pct": t * 100,
                    "shift_hz": shift,
                    "shift_ppm": shift / f * 1e6,
                    "per_percent_ppm": d * 0.01 / f * 1e6,
                }
            )
    rows = [r for r in rows if r["tolerance_pct"] > 0]
    rows.sort(key=lambda r: -abs(r["shift_ppm"]))
    for i, r in enumerate(rows, 1):
        r["rank"] = i
    return rows


def _existence(points, nominal, result_lm, sig, p3_draws) -> dict:
    """The Fig. 6 orbit at the design's generator frequency: margins to both ends, the
    tolerances that keep it in the worst case (linear corners), the fraction of draws."""
    out: dict = {
        "meaning": (
            "a stable admissible period-3 orbit (two impacts) at the design's forcing: "
            "f_low < f_design < f_high, the ends being the first grazing, fold or period doubling "
            "along the Fig. 6 branch each way"
        )
    }
    if "p3_low" not in points or "p3_high" not in points:
        out["exists"] = False
        out["why"] = result_lm.get("p3_low", {}).get("absent") or result_lm.get("p3_high", {}).get(
            "absent"
        )
        return out
    f = nominal["f_design"]
    lo, hi = result_lm["p3_low"], result_lm["p3_high"]
    m_lo, m_hi = f - lo["frequency_hz"], hi["frequency_hz"] - f
    out["exists"] = bool(m_lo > 0 and m_hi > 0)
    out["margin_low_hz"] = m_lo
    out["margin_high_hz"] = m_hi
    out.update(_worst_case_tolerances(lo, hi, m_lo, m_hi, sig))
    out.update(_draw_fractions(p3_draws))
    return out


def _worst_case_tolerances(lo: dict, hi: dict, m_lo: float, m_hi: float, sig) -> dict:
    """The tolerances that keep the orbit in the worst case: R's alone, C's alone, every part,
    and the 3-sigma scale of the budget's tolerances (linear in the parts)."""
    out: dict = {}
    # linear worst case per class: shift of each margin per unit tolerance of R's and C's
    dR = {
        s: sum(abs(L["dfreq_dlnc"][INPUTS[i]]) for i in range(8))
        for s, L in (("low", lo), ("high", hi))
    }
    dC = {
        s: sum(abs(L["dfreq_dlnc"][INPUTS[i]]) for i in range(8, 10))
        for s, L in (("low", lo), ("high", hi))
    }
    margin = {"low": m_lo, "high": m_hi}
    tR = min(max(margin[s], 0) / dR[s] if dR[s] else math.inf for s in margin)
    tC = min(max(margin[s], 0) / dC[s] if dC[s] else math.inf for s in margin)
    out["worst_case_resistor_tolerance_pct_alone"] = tR * 100
    out["worst_case_capacitor_tolerance_pct_alone"] = tC * 100
    # equal tolerance on every part
    tall = min(max(margin[s], 0) / (dR[s] + dC[s]) for s in margin)
    out["worst_case_common_tolerance_pct"] = tall * 100
    # 3 sigma (root sum of squares of uniform bands) with the budget's tolerances scaled
    rss = {
        s: math.sqrt(sum((L["dfreq_dlnc"][n] * sig[i]) ** 2 / 3 for i, n in enumerate(INPUTS)))
        for s, L in (("low", lo), ("high", hi))
    }
    out["three_sigma_scale_of_budget"] = min(
        max(margin[s], 0) / (3 * rss[s]) if rss[s] else math.inf for s in margin
    )
    return out


def _draw_fractions(p3_draws: dict | None) -> dict:
    """The Monte Carlo draws' fractions with the orbit / with its whole interval."""
    out: dict = {}
    if p3_draws is not None and "orbit_fraction" in p3_draws:
        out["fraction_of_draws_with_stable_period3_orbit"] = p3_draws["orbit_fraction"]
        out["orbit_fraction_stderr"] = p3_draws["orbit_fraction_stderr"]
    if p3_draws is not None and "fraction" in p3_draws:
        out["fraction_of_draws_with_period3"] = p3_draws["fraction"]
        out["interval_fraction_stderr"] = p3_draws["stderr"]
        out["draws_with_both_ends"] = p3_draws["n"]
    return out


def _scans(
    orbit_d: BranchPoint, c0: dict, vu: float, ron0: float, deadline: Deadline | None = None
) -> tuple[dict, dict]:
    """The Fig. 6 orbit along ``R_on / R3`` (switched-capacitor KCL) and along the op-amps'
    GBW (the network's quasi-static model): at each value the orbit carried to the design's
    eta there (exists: converged, admissible, stable), its interval's ends by continuation
    (for the plot), and the limit by bisection on existence (to 1e-9 relative)."""
    R3 = c0["R3"]

    def system(kw: dict) -> tuple[np.ndarray, float]:
        ep = effective_parameters({**c0}, V_unit=vu, **kw)
        return _theta(ep), float(ep["eta"])

    def exists_at(orbit: BranchPoint, kw: dict) -> BranchPoint | None:
        th, eta = system(kw)
        try:  # past the limit Newton diverges (see _evaluate): its overflow is the signal
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                o = _carry_orbit(orbit, th, eta)
        except ConvergenceError:
            return None
        return o if o.stable() else None

    def scan(xs, kwf) -> tuple[list, float | None]:
        rows: list = []
        orbit: BranchPoint | None = orbit_d
        last_ok = None
        limit = None
        for x in xs:
            if deadline is not None:
                deadline.check(f"existence scan at {float(x):.4g}")
            th, eta = system(kwf(x))
            o = exists_at(orbit, kwf(x)) if orbit is not None else None
            lo = hi = math.nan
            if o is not None:
                try:
                    ends = interval_ends(o)
                    lo = ends["low"][1] if ends["low"] else math.nan
                    hi = ends["high"][1] if ends["high"] else math.nan
                except (ConvergenceError, ValueError):
                    pass
                orbit, last_ok = o, x
            elif orbit is not None and last_ok is not None:
                limit = _bisect(last_ok, x, orbit, kwf, exists_at)
                orbit = None
            rows.append((x, eta, lo, hi, o is not None))
        return rows, limit

    xs = np.linspace(0.0, 0.03, 61)
    ron_rows, ron_lim = scan(xs, lambda x: {"ron": x * R3})
    gs = np.logspace(8, 3.5, 46)  # from an ideal op-amp down
    gbw_rows, gbw_lim = scan(gs, lambda g: {"gbw": g})
    gbw_rows = gbw_rows[::-1]

    def table(rows, lim, marks):
        return {
            "x": [r[0] for r in rows],
            "eta": [r[1] for r in rows],
            "eta_low": [r[2] for r in rows],
            "eta_high": [r[3] for r in rows],
            "exists": [r[4] for r in rows],
            "limit": lim,
            "marks": marks,
        }

    ron_marks = [(ron0 / R3, f"design R_on / R3 = {ron0 / R3:.4g}")] if ron0 else []
    if abs(ron0 - 160.0) > 1e-9 or R3 != 1e4:
        ron_marks.append((160.0 / R3, "ADG5233 160 ohm"))
    limits = {
        "max_ron_over_R3": None if ron_lim is None else float(ron_lim),
        "max_ron_ohm": None if ron_lim is None else float(ron_lim * R3),
        "ron_scan_range": [0.0, 0.03],
        "min_gbw_hz": None if gbw_lim is None else float(gbw_lim),
        "gbw_scan_range_hz": [float(gs[-1]), float(gs[0])],
    }
    return {
        "ron": table(ron_rows, ron_lim, ron_marks),
        "gbw": table(gbw_rows, gbw_lim, [(3e6, "TL072 3 MHz")]),
    }, limits


def _bisect(x_ok: float, x_bad: float, orbit: BranchPoint, kwf, exists_at) -> float:
    """The boundary of existence between ``x_ok`` (the orbit exists, ``orbit`` is it there)
    and ``x_bad``: bisection, the orbit carried from the last good point each time."""
    for _ in range(80):
        xm = 0.5 * (x_ok + x_bad)
        o = exists_at(orbit, kwf(xm))
        if o is not None:
            x_ok, orbit = xm, o
        else:
            x_bad = xm
        if abs(x_bad - x_ok) <= 1e-9 * max(abs(x_ok), abs(x_bad)):
            break
    return 0.5 * (x_ok + x_bad)


def estimate_seconds(
    landmarks: Sequence[str], mc: int, sobol: int, lle_mc: int, lle_periods: int, scans: bool
) -> float:
    """A rough wall-time estimate (measured on one core: ~1 ms a landmark evaluation per
    draw, ~1 ms per 100 LLE periods, ~30 s of scans, ~3 s of continuations)."""
    n = len([x for x in landmarks if x in BRANCH_LANDMARKS])
    evals = n * (mc + sobol * (2 * len(PARTS) + 2))
    lle = lle_mc * (lle_periods + 1000) * 1e-5 if "lle_0712" in landmarks else 0.0
    return 3.0 + 1e-3 * evals + lle + (30.0 if scans else 0.0)


def check_budget(max_time: float | None, **kw: Any) -> None:
    """Refuse a budget whose estimate exceeds ``max_time`` seconds, before any work (the
    shared refusal, :func:`~precise_impact.core.budget.check_cost`: one line, exit 3)."""
    what = f"budget: {kw.get('mc', 0)} Monte Carlo + {kw.get('sobol', 0)} Sobol draws"
    check_cost(Cost(estimate_seconds(**kw), 0.0, what), max_time, size="mc")
