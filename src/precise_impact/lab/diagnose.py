"""Back to the components: which drawn part most likely differs, given what an identification
measured (Bayesian evidence of one-part changes, linearised).  ``docs/guide/identify.rst``."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from precise_impact.core.dual import seed
from precise_impact.core.result import ResultMixin, unit_column
from precise_impact.lab.budget import INPUTS, drawing, effective_parameters, parse_tolerances
from precise_impact.lab.identify import Identification, derived

__all__ = ["Diagnosis", "diagnose", "MEASURED"]

#: What the identification measures of the circuit: its natural frequency (the forcing's
#: ``Omega`` over ``eta``), damping, forcing amplitude and wall, in the design's units.
MEASURED = ("omega", "zeta", "a", "x_w")
#: "Part k differs": its change drawn from ``N(0, (OUTLIER t_k)^2)`` instead of its tolerance's
#: ``N(0, t_k^2)``, every other part within its tolerance.
OUTLIER = 3.0
#: Parts whose effects on ``(omega, zeta, a, x_w)`` are parallel to this cosine are named as
#: indistinguishable twins (R8 and C1 both set ``omega`` and ``zeta`` alike).
TWIN_COSINE = 0.999
#: The switches' on-resistance's relative tolerance when the scene gives none (datasheets
#: state a typical and a maximum value: a factor of ~2).
RON_TOLERANCE = 0.5


@dataclasses.dataclass
class Diagnosis(ResultMixin):
    """Which component most likely differs from the drawing.

    Attributes
    ----------
    measured, drawn : dict
        ``omega`` [rad/s], ``zeta``, ``a``, ``x_w``: identified (with standard errors) and the
        drawing's (its effective system, switches' on-resistance included).
    consistent : dict
        ``chi2`` of the difference against the measurement's covariance and the parts'
        tolerances, its degrees of freedom and p-value, and ``p_all_within_tolerance``
        (posterior, prior odds 1:1 against "one part is out of tolerance").
    ranked : list of dict
        One entry per part, the largest share of the explanation first: ``joint_change`` and
        ``joint_stderr`` (the part's relative change given the measurement, every part a priori
        within its tolerance), ``probability`` (posterior of "this part is the one out of
        tolerance", given that one is) with that hypothesis's ``change`` and ``stderr``,
        ``tolerance``, and ``twins``: the parts the measurement cannot tell apart from it.
    notes : list
        What was assumed.

    See Also
    --------
    diagnose : makes one.
    """

    measured: dict
    drawn: dict
    consistent: dict
    ranked: list
    notes: list = dataclasses.field(default_factory=list)

    def _tables(self) -> dict:
        """``to_dataframe()`` table ``ranked``: one row per part, most probable first."""

        def ranked() -> dict:
            r = self.ranked
            return {
                "part": [e["part"] for e in r],
                unit_column("joint_change", "1"): np.array([e["joint_change"] for e in r]),
                unit_column("joint_stderr", "1"): np.array([e["joint_stderr"] for e in r]),
                unit_column("probability", "1"): np.array([e["probability"] for e in r]),
                unit_column("change", "1"): np.array([e["change"] for e in r]),
                unit_column("stderr", "1"): np.array([e["stderr"] for e in r]),
                unit_column("tolerance", "1"): np.array([e["tolerance"] for e in r]),
            }

        return {"ranked": ranked}

    def summary(self, n: int = 5) -> str:
        """Whether the drawing explains the measurement, the ``n`` parts that explain it most,
        and the part likeliest to be out of tolerance."""
        c = self.consistent
        rows = [
            f"as drawn: chi2 {c['chi2']:.1f} on {c['dof']} degrees of freedom (p = "
            f"{c['p_value']:.2g}); every part within tolerance: {c['p_all_within_tolerance']:.0%}",
            "what explains the measurement (every part within its tolerance a priori):",
        ]
        for e in self.ranked[:n]:
            twins = f"  (indistinguishable from {', '.join(e['twins'])})" if e["twins"] else ""
            rows.append(
                f"  {e['part']:6s} {e['joint_change']:+.2%} +- {e['joint_stderr']:.2%} "
                f"(tolerance {e['tolerance']:.1%}){twins}"
            )
        top = max(self.ranked, key=lambda e: e["probability"])
        rows.append(
            f"if one part is out of tolerance: {top['part']} ({top['probability']:.0%}), "
            f"{top['change']:+.2%} +- {top['stderr']:.2%}"
        )
        return "\n".join(rows)


def diagnose(identified: Identification, design: Any = None, tolerances: Any = None) -> Diagnosis:
    """Which drawn component most likely differs from the circuit that was measured.

    Parameters
    ----------
    identified : Identification
        From :func:`~precise_impact.lab.identify.identify`.
    design : scene name, Scene or Components, default the identification's design
        The drawing: its components, the switches' on-resistance (a ``switch`` effect) and
        the parts' tolerances (a ``tolerance`` effect).
    tolerances : see :func:`~precise_impact.lab.budget.parse_tolerances`
        Relative tolerances (default: the scene's, else 1 % resistors, 5 % capacitors, 1 %
        sources); the on-resistance's is :data:`RON_TOLERANCE`.

    Returns
    -------
    Diagnosis

    See Also
    --------
    precise_impact.lab.identify.identify : the identification diagnosed.
    precise_impact.lab.budget.tolerance_budget : the same parameter map, forwards.

    Examples
    --------
    >>> from precise_impact import diagnose, identify, synth_capture
    >>> cap = synth_capture("fig6-period2-datasheet", periods=30, seed=3)
    >>> d = diagnose(identify(cap, "fig6-period2-datasheet"))
    >>> d.consistent["p_value"] > 0.05, d.ranked[0]["part"] in ("C1", "C2")
    (True, True)

    Notes
    -----
    The map from the parts to ``(omega, zeta, a, x_w)`` is the tolerance budget's
    (:func:`~precise_impact.lab.budget.effective_parameters`), linearised at the drawing by
    dual numbers: ``y = y0 + J u`` with ``u`` the parts' relative changes.  Every part within
    its tolerance (``u_j ~ N(0, t_j^2)``) predicts ``r = y_measured - y0 ~ N(0, B)`` with
    ``B = S + sum_j t_j^2 J_j J_j^T``; hypothesis ``k``, "part ``k`` differs" (its change
    ``N(0, v_k)``, ``v_k = (OUTLIER t_k)^2``, the others within tolerance), predicts
    ``N(0, C_k)``, ``C_k = B + (v_k - t_k^2) J_k J_k^T``.  Each hypothesis's posterior is its
    evidence over their sum (equal prior odds; MacKay 1992, "Bayesian interpolation"), the
    change its posterior mean ``v_k J_k^T C_k^-1 r``.  The other parts' tolerances stay in the
    noise: a part is not blamed for what the spread of all of them explains.  The joint
    explanation is the Gaussian posterior of all changes, ``T^2 J^T B^-1 r``.
    """
    design = identified.design if design is None else design
    comp, ron, defaults, _ = drawing(design)
    tol = parse_tolerances(tolerances, {**_DEFAULTS, **defaults})
    names = [*INPUTS, "ron"]
    t = np.array([tol[n] for n in INPUTS] + [RON_TOLERANCE])
    y0, J = _linear(comp, float(ron))
    y, S = _measured(identified)
    r = y - y0
    notes = [] if ron else ["no switch effect in the design: the on-resistance is 0, not ranked"]
    keep = [i for i, n in enumerate(names) if t[i] > 0 and (n != "ron" or ron)]
    chi2_0 = float(r @ np.linalg.solve(S + (J * t**2) @ J.T, r))
    ranked, p_within = _ranked([names[i] for i in keep], J[:, keep], t[keep], r, S)
    return Diagnosis(
        measured={
            k: {"value": float(y[i]), "stderr": math.sqrt(S[i, i])} for i, k in enumerate(MEASURED)
        },  # fmt: skip
        drawn={k: float(y0[i]) for i, k in enumerate(MEASURED)},
        consistent={
            "chi2": chi2_0,
            "dof": len(MEASURED),
            "p_value": chi2_sf(chi2_0, 4),
            "p_all_within_tolerance": p_within,
        },  # fmt: skip
        ranked=ranked,
        notes=notes,
    )


#: Tolerances of the sources when the scene states none.
_DEFAULTS = {**{n: 0.01 for n in INPUTS[:8]}, "C1": 0.05, "C2": 0.05, "V_A": 0.01, "V_wall": 0.01}


def _linear(comp: Any, ron: float) -> tuple[np.ndarray, np.ndarray]:
    """The drawing's ``(omega, zeta, a, x_w)`` and their derivatives by each part's relative
    change (dual numbers through the parameter map, the on-resistance last)."""
    x0 = np.array([float(getattr(comp, n)) for n in INPUTS] + [ron])
    duals = seed(x0)
    values = dict(zip(INPUTS, duals[:-1], strict=True))
    values["Omega"] = float(comp.Omega)
    ep = effective_parameters(values, duals[-1], V_unit=float(comp.V_unit))
    y0 = np.array([ep[k].v for k in MEASURED])
    J = np.array([ep[k].g for k in MEASURED]) * x0  # d y / d ln c
    return y0, J


def _measured(identified: Identification) -> tuple[np.ndarray, np.ndarray]:
    """``(omega, zeta, a, x_w)`` and their covariance from the fit's (``omega = Omega / eta``;
    the scope's timebase error, ppm, is left out)."""
    c = identified.covariance
    values, grads = derived(dict(zip(c["names"], c["values"], strict=True)))
    Om, eta = float(identified.record["Omega_rad_s"]), values["eta"]
    # d (omega, zeta, a, x_w) / d globals, omega = Omega / eta
    D = np.array([-Om / eta**2 * grads["eta"], grads["zeta"], grads["a"], grads["x_w"]])
    y = np.array([Om / eta, values["zeta"], values["a"], values["x_w"]])
    return y, D @ np.asarray(c["matrix"]) @ D.T


def _ranked(names: list, J: np.ndarray, t: np.ndarray, r: np.ndarray, S: np.ndarray) -> tuple:
    """``(ranked parts, probability that every part is within tolerance)``."""
    B = S + (J * t**2) @ J.T  # every part within its tolerance: the baseline's covariance
    logev, out = [], []
    for k, name in enumerate(names):
        jk, v = J[:, k], (OUTLIER * t[k]) ** 2
        C = B + (v - t[k] ** 2) * np.outer(jk, jk)  # part k's change drawn wider
        Ci_r = np.linalg.solve(C, r)
        logev.append(_log_evidence(C, r))
        var = v - v**2 * jk @ np.linalg.solve(C, jk)
        out.append({"part": name, "change": float(v * jk @ Ci_r),
                    "stderr": math.sqrt(max(var, 0.0)), "tolerance": float(t[k])})  # fmt: skip
    ev = np.asarray(logev)
    base = _log_evidence(B, r)
    top = max(ev.max(), base)
    w = np.exp(ev - top)
    p_within = float(np.exp(base - top) / (np.exp(base - top) + w.mean()))  # prior odds 1:1
    white = np.linalg.solve(np.linalg.cholesky(S), J)  # in units of the measurement's errors
    unit = white / np.maximum(np.linalg.norm(white, axis=0), 1e-300)
    tw = J * t**2
    joint = tw.T @ np.linalg.solve(B, r)  # the parts' changes given r, each within tolerance
    joint_var = t**2 - np.einsum("ij,ij->j", tw, np.linalg.solve(B, tw))
    for k, (e, p) in enumerate(zip(out, w / w.sum(), strict=True)):
        e["probability"] = float(p)
        e["joint_change"] = float(joint[k])
        e["joint_stderr"] = math.sqrt(max(float(joint_var[k]), 0.0))
        # parts this measurement cannot tell apart from this one (parallel columns of J)
        e["twins"] = [names[j] for j in range(len(names)) if j != k and
                      abs(unit[:, j] @ unit[:, k]) > TWIN_COSINE]  # fmt: skip
    return sorted(out, key=lambda e: -abs(e["joint_change"]) / e["tolerance"]), p_within


def _log_evidence(C: np.ndarray, r: np.ndarray) -> float:
    _, logdet = np.linalg.slogdet(C)
    return float(-0.5 * (r @ np.linalg.solve(C, r)) - 0.5 * logdet)


def chi2_sf(x: float, k: int) -> float:
    """Upper tail of chi^2 with ``k`` (even) degrees of freedom: ``exp(-x/2) sum (x/2)^i / i!``."""
    h = x / 2
    return float(math.exp(-h) * sum(h**i / math.factorial(i) for i in range(k // 2)))
