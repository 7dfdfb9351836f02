"""The paper's three frequencies: every registered model against a demonstrated reference.

Scores the (model, precision) pairs of :data:`CANDIDATES`: every registered model in the first
precision it takes (heyoka also in long double and float128; ``certified`` in the reference's
multiprecision; ``spice`` when ngspice is installed).

The reference's accuracy is demonstrated by two multiprecision runs (``bits``, ``bits + 64``).
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from precise_impact.core.params import Params, check_count
from precise_impact.core.precision import has_quad
from precise_impact.core.result import ResultMixin, record_columns
from precise_impact.errors import OptionalDependencyError
from precise_impact.io.figures import (
    figure_legend,
    finish,
    new_figure,
    save_figure,
    series_styles,
    wrap_title,
)
from precise_impact.io.jsonout import write_json
from precise_impact.io.progress import say as _progress
from precise_impact.models.circuit.spice import find_ngspice
from precise_impact.solvers.base import MODELS, model_capabilities
from precise_impact.solvers.simulate import simulate
from precise_impact.verification.metrics import reference_bits, sample_errors

__all__ = [
    "PAPER_ETAS",
    "CANDIDATES",
    "candidates",
    "AccuracyResult",
    "reference_bits",
    "sample_errors",
    "accuracy_table",
    "format_table",
]

#: The paper's three regimes: periodic without impacts, chaotic, period-3.
PAPER_ETAS = ("0.70", "0.712", "0.74")

#: The mechanical reference's hardware precisions, each scored (the other models: one each).
_HEYOKA_PRECISIONS = ("float64", "longdouble", "float128")


def candidates(bits: int) -> tuple[tuple[str, str], ...]:
    """The (model, precision) pairs scored: every registered model
    (:data:`~precise_impact.solvers.base.MODELS`) in the first precision it takes
    (``mp:bits``, the reference's, for a multiprecision-only model such as ``certified``),
    and ``heyoka`` also in ``longdouble`` and ``float128``."""
    out: list[tuple[str, str]] = []
    for model in MODELS:
        if model == "heyoka":
            out += [(model, p) for p in _HEYOKA_PRECISIONS]
            continue
        kind = model_capabilities(model).precisions[0]
        out.append((model, f"mp:{bits}" if kind == "mp" else kind))
    return tuple(out)


#: (model, precision) pairs scored against the reference at 100 periods (:func:`candidates`).
CANDIDATES = candidates(reference_bits(100))


def accuracy_table(
    periods: int = 100,
    etas: Sequence[str] = PAPER_ETAS,
    out: str | Path | None = None,
    progress: bool | None = None,
) -> AccuracyResult:
    """Score every candidate at each eta; write ``accuracy.json`` and ``accuracy.png`` to ``out``.

    Parameters
    ----------
    periods : int, default 100
        Forcing periods from rest.
    etas : sequence of decimal strings, default ``PAPER_ETAS``
        Forcing frequencies, the paper's ``('0.70', '0.712', '0.74')``.
    out : directory or None, default ``None``
        Where ``accuracy.json`` and ``accuracy.png`` go; ``None`` writes nothing.
    progress : bool or None, default ``None``
        One line per finished run on stderr (``None``: only when stderr is a terminal).

    Returns
    -------
    AccuracyResult
        One row per (eta, model, precision), the reference's own row first.

    Raises
    ------
    ParameterError
        ``periods`` outside 1..2000, before any work.

    See Also
    --------
    precise_impact.verification.scores.score : one model against one reference.
    precise_impact.verification.workprecision.work_precision : error against wall time.
    precise_impact.verification.accuracy.AccuracyResult : the result's fields.

    Examples
    --------
    >>> import precise_impact as pi
    >>> r = pi.accuracy_table(periods=3, etas=("0.74",), progress=False)
    >>> r.periods, r.rows[0]["model"], r.rows[0]["eta"]
    (3, 'heyoka', '0.74')
    """
    periods = check_count(periods, "periods", 2000, minimum=1)
    bits = reference_bits(periods)
    rows: list[dict[str, Any]] = []
    curves: dict[str, dict[str, list[float]]] = {}
    for eta in etas:
        params = Params.make(eta=eta)
        t0 = time.perf_counter()
        ref = simulate(params, periods, precision=f"mp:{bits}")
        check = simulate(params, periods, precision=f"mp:{bits + 64}")
        agreement = max(sample_errors(ref, check))
        _progress(
            f"eta={eta}: reference mp:{bits} vs mp:{bits + 64} agree to {agreement:.1e} "
            f"({time.perf_counter() - t0:.1f} s)",
            progress,
        )
        rows.append(
            {
                "eta": eta,
                "model": "heyoka",
                "precision": f"mp:{bits}",
                "max_error": agreement,
                "final_error": sample_errors(ref, check)[-1],
                "impacts": ref.n_impacts,
                "elapsed_s": ref.elapsed_s,
                "role": f"reference (error = disagreement with mp:{bits + 64})",
            }
        )
        curves[eta] = {}
        for model, prec in candidates(bits):
            if prec == "float128" and not has_quad():
                continue  # this heyoka build has no quad precision: the row does not exist here
            if model == "spice" and not _have_ngspice():
                _progress(f"eta={eta}: spice skipped (ngspice is not installed)", progress)
                continue  # the row does not exist on this installation
            traj = simulate(params, periods, model=model, precision=prec)
            errs = sample_errors(traj, ref)
            curves[eta][f"{model} {prec}"] = errs
            rows.append(
                {
                    "eta": eta,
                    "model": model,
                    "precision": prec,
                    "max_error": max(errs),
                    "final_error": errs[-1],
                    "impacts": traj.n_impacts,
                    "elapsed_s": traj.elapsed_s,
                    "role": "candidate",
                }
            )
            _progress(f"eta={eta}: {model} {prec}: max error {max(errs):.2e}", progress)
    result = AccuracyResult(periods=periods, reference_bits=bits, rows=rows)
    if out is not None:
        out = Path(out)
        write_json(out / "accuracy.json", result.to_dict(), indent=2)
        _plot(curves, periods, out / "accuracy.png")
    return result


def _have_ngspice() -> bool:
    try:
        find_ngspice()
    except OptionalDependencyError:
        return False
    return True


def _plot(curves: dict[str, dict[str, list[float]]], periods: int, path: Path) -> None:
    """Error against period, one panel per eta, one style per model and precision, the legend
    beneath the panels."""
    labels = list(dict.fromkeys(lab for by_model in curves.values() for lab in by_model))
    style = dict(zip(labels, series_styles(len(labels)), strict=True))
    fig, axes = new_figure(
        1, len(curves), figsize=(5 * len(curves), 4.8), layout="constrained", sharey=True
    )
    for ax, (eta, by_model) in zip(axes[0], curves.items(), strict=True):
        for label, errs in by_model.items():
            st = style[label]
            ax.semilogy(
                range(len(errs)),
                [max(e, 1e-40) for e in errs],
                label=label,
                color=st["color"],
                ls=st["ls"],
                marker=st["marker"],
                markevery=max(1, len(errs) // 8),
                ms=4,
                lw=1,
            )
        ax.set_title(f"eta = {eta}")
        ax.set_xlabel("forcing period k")
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("max(|x - x_ref|, |x' - x'_ref|) at t0 + kT\n(dimensionless)")
    figure_legend(fig, axes[0], ncol=4)
    fig.suptitle(
        wrap_title(
            f"Error against the multiprecision heyoka reference over {periods} periods "
            "(floor 1e-40)",
            fig,
        )
    )
    save_figure(fig, path, fmt="png", dpi=110)


@dataclasses.dataclass
class AccuracyResult(ResultMixin):
    """Every model and precision scored against the demonstrated reference (:func:`accuracy_table`).

    Attributes
    ----------
    periods : int
        Forcing periods of every run.
    reference_bits : int
        Bits of the multiprecision reference (demonstrated by a run 64 bits wider).
    rows : list of dict
        One row per (eta, model, precision): ``eta``, ``model``, ``precision``,
        ``max_error``, ``final_error``, ``impacts``, ``elapsed_s``, ``role``.

    See Also
    --------
    precise_impact.verification.accuracy.accuracy_table : returns it.
    precise_impact.verification.scores.score : one model's scores.
    """

    periods: int
    reference_bits: int
    rows: list

    def plot(self, path: str | os.PathLike | None = None):
        """The largest error of every model and precision, one panel per eta (log scale);
        each bar names its model.

        Parameters
        ----------
        path : str, os.PathLike or None, default ``None``
            Also write the figure there (``.png``, ``.pdf``, ``.svg``, atomically).

        Returns
        -------
        matplotlib.figure.Figure
        """
        etas = list(dict.fromkeys(r["eta"] for r in self.rows))
        fig, axes = new_figure(
            1, len(etas), figsize=(4.5 * len(etas), 5.0), layout="constrained", sharey=True
        )
        for ax, eta in zip(axes[0], etas, strict=True):
            rows = [r for r in self.rows if r["eta"] == eta]
            names = [f"{r['model']} {r['precision']}" for r in rows]
            errs = [max(float(r["max_error"]), 1e-40) for r in rows]
            colours = ["0.6" if r["role"] != "candidate" else "tab:blue" for r in rows]
            ax.barh(range(len(rows)), errs, color=colours)
            ax.set_yticks(range(len(rows)), names, fontsize=8)
            ax.set_xscale("log")
            ax.invert_yaxis()
            ax.set_title(f"eta = {eta}", fontsize=10)
            ax.set_xlabel("max error over the samples (dimensionless)")
            ax.grid(True, axis="x", which="both", alpha=0.3)
        fig.suptitle(
            wrap_title(
                f"Largest error against heyoka mp:{self.reference_bits} over {self.periods} "
                "periods (grey: the reference against +64 bits)",
                fig,
            ),
            fontsize=10,
        )
        return finish(fig, path, dpi=110)

    def _tables(self) -> dict:
        """``to_dataframe()`` table ``rows``: one per (eta, model, precision)."""
        return {"rows": lambda: record_columns(self.rows)}


def format_table(result: AccuracyResult) -> str:
    """The table printed by ``precise-impact accuracy``.

    Parameters
    ----------
    result : AccuracyResult
        From :func:`accuracy_table`.

    Returns
    -------
    str
    """
    lines = [
        f"Errors over {result['periods']} periods from rest against heyoka "
        f"mp:{result['reference_bits']} (max over stroboscopic samples of max(|dx|, |dv|))",
        f"{'eta':>6}  {'model':<18} {'precision':<11} {'max error':>10} {'at end':>10} "
        f"{'impacts':>7} {'time [s]':>9}",
    ]
    for r in result["rows"]:
        tag = "  <- reference: disagreement with +64 bits" if r["role"] != "candidate" else ""
        lines.append(
            f"{r['eta']:>6}  {r['model']:<18} {r['precision']:<11} {r['max_error']:>10.2e} "
            f"{r['final_error']:>10.2e} {r['impacts']:>7d} {r['elapsed_s']:>9.4f}{tag}"
        )
    return "\n".join(lines)
