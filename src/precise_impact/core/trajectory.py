"""Result of one simulation: stroboscopic samples, impacts, optional dense output."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Any

import numpy as np

from precise_impact.core import digits as _digits
from precise_impact.core.params import Params, decimal_str
from precise_impact.core.precision import Precision
from precise_impact.core.result import ResultMixin, columns
from precise_impact.errors import ParameterError
from precise_impact.io.atomic import atomic_write
from precise_impact.io.figures import plot_trajectory
from precise_impact.io.jsonout import dumps, write_json

__all__ = ["Trajectory", "atomic_write"]


@dataclasses.dataclass
class Trajectory(ResultMixin):
    """What a solver returns.

    Attributes
    ----------
    params : Params
        The exact parameters.
    model : str
        ``'heyoka'``, ``'analytical'``, ``'analytical-paper'``, ...
    precision : Precision
        Number type of every state value below.
    tol : Any
        Tolerance the solver was run with (in ``precision``'s type, or ``None``).
    t, x, v : numpy arrays
        Stroboscopic samples at ``t0 + k T``, ``k = 0..periods`` (``T = 2 pi / eta``);
        object arrays for float128 / mp.
    impacts_t, impacts_v_before, impacts_v_after : numpy arrays
        Every impact, in time order.
    dense_t, dense_x, dense_v : numpy arrays or None
        Optional dense output (``per_period`` points per period).
    elapsed_s : float
        Wall time of the integration (compilation excluded).
    stats : dict
        Solver statistics (steps, ...).
    claim : Digits or None
        The significant digits each sample claims (:meth:`claimed_digits`): set by
        ``simulate(..., demonstrate=...)`` (``'demonstrated'``); ``None`` until first asked
        for, then ``'proven'`` (certified model) or ``'estimated'``.

    See Also
    --------
    precise_impact.solvers.simulate.simulate : returns it.
    precise_impact.solvers.certified.single.CertifiedTrajectory : the certified counterpart.
    precise_impact.verification.scores.score : compare two trajectories.
    """

    params: Params
    model: str
    precision: Precision
    tol: Any
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    impacts_t: np.ndarray
    impacts_v_before: np.ndarray
    impacts_v_after: np.ndarray
    dense_t: np.ndarray | None = None
    dense_x: np.ndarray | None = None
    dense_v: np.ndarray | None = None
    elapsed_s: float = 0.0
    stats: dict = dataclasses.field(default_factory=dict)
    claim: _digits.Digits | None = dataclasses.field(default=None, repr=False, compare=False)

    def claimed_digits(self) -> _digits.Digits:
        """The significant digits each sample can claim, and on what basis.

        ``'proven'`` for the certified model (its balls' radii), ``'demonstrated'`` when a
        second run at a higher precision was asked for (``simulate(..., demonstrate=True)``),
        else ``'estimated'``: the precision's rounding amplified along this run by its tangent
        flow (:func:`precise_impact.core.digits.estimate`).  Computed once and kept.

        Returns
        -------
        Digits
            ``x[k]``, ``v[k]``: claimed significant digits of sample ``k``; ``basis``; ``note``.
        """
        if self.claim is None:
            st = self.stats or {}
            if st.get("certified") and "x_rad" in st and len(st["x_rad"]) == len(self.x):
                self.claim = _digits.proven(self, st["x_rad"], st["v_rad"])
            else:
                self.claim = _digits.estimate(self)
        return self.claim

    @property
    def periods(self) -> int:
        return len(self.t) - 1

    @property
    def n_impacts(self) -> int:
        return len(self.impacts_t)

    def _tables(self) -> dict:
        """``to_dataframe()`` tables: ``samples`` (default), ``impacts``, ``dense`` (if kept)."""
        P = self.precision
        tab = {
            "samples": lambda: columns(
                ("period", None, np.arange(len(self.t))),
                *(("t", "1", self.t), ("x", "1", self.x), ("v", "1", self.v)),
                precision=P,
            ),
            "impacts": lambda: columns(
                ("t", "1", self.impacts_t),
                ("v_before", "1", self.impacts_v_before),
                ("v_after", "1", self.impacts_v_after),
                precision=P,
            ),
        }
        if self.dense_t is not None:
            d = (("t", "1", self.dense_t), ("x", "1", self.dense_x), ("v", "1", self.dense_v))
            tab["dense"] = lambda: columns(*d, precision=P)
        return tab

    def state_mpf(self, k: int) -> tuple:
        """Exact mpmath values ``(t, x, v)`` of sample ``k``."""
        P = self.precision
        return P.to_mpf(self.t[k]), P.to_mpf(self.x[k]), P.to_mpf(self.v[k])

    def impacts_mpf(self) -> list[tuple]:
        """Exact mpmath values ``(t, v_before, v_after)`` of every impact."""
        P = self.precision
        return [
            (P.to_mpf(t), P.to_mpf(vb), P.to_mpf(va))
            for t, vb, va in zip(
                self.impacts_t, self.impacts_v_before, self.impacts_v_after, strict=True
            )
        ]

    def as_float64(self) -> dict[str, np.ndarray]:
        """Samples and impacts rounded to float64 (for plotting)."""
        conv = self.precision.floats
        return {
            "t": conv(self.t),
            "x": conv(self.x),
            "v": conv(self.v),
            "impacts_t": conv(self.impacts_t),
            "impacts_v_before": conv(self.impacts_v_before),
            "impacts_v_after": conv(self.impacts_v_after),
        }

    # ------------------------------------------------------------------ output
    def _str(self, x: Any) -> str | None:
        """``x`` as a full-precision decimal string; ``None`` for a value the model did not
        record (``None`` in an object array, NaN in a float array)."""
        if x is None:
            return None
        text = self.precision.to_str(x)
        return None if text == "nan" else text

    #: The reason given beside a JSON object holding ``null`` state numbers (a model may say
    #: more in ``stats["null"]``).
    NULL_REASON = "not recorded by this model"

    def to_dict(self) -> dict:
        """The CLI's ``--json`` object; every state number a full-precision decimal string
        (``null`` where the model recorded none, with the reason under ``"null"``)."""
        s = self._str
        partial = {}
        if self.stats and self.stats.get("partial"):  # an interrupted run: say so in every file
            partial = {"partial": {k: self.stats[k] for k in ("periods_done", "periods_asked")}}
        claim = self.claimed_digits()
        samples = [
            {
                "period": k,
                "t": s(t),
                "x": s(x),
                "v": s(v),
                "x_digits": int(claim.x[k]),
                "v_digits": int(claim.v[k]),
            }
            for k, (t, x, v) in enumerate(zip(self.t, self.x, self.v, strict=True))
        ]
        idig = claim.impacts or {}

        def imp_digits(i: int) -> dict:
            # each impact's claimed digits (null: the basis gives none per impact)
            return {
                f"{n}_digits": (int(idig[n][i]) if n in idig else None)
                for n in ("t", "v_before", "v_after")
            }

        impacts = [
            {"t": s(t), "v_before": s(vb), "v_after": s(va), **imp_digits(i)}
            for i, (t, vb, va) in enumerate(
                zip(self.impacts_t, self.impacts_v_before, self.impacts_v_after, strict=True)
            )
        ]
        has_null = any(
            v is None
            for row in samples + impacts
            for k, v in row.items()
            if not k.endswith("_digits")
        )
        # "x", "v": every binary digit of the run, as decimals; "x_digits", "v_digits": how many
        # leading significant digits of each the run can claim ("digits": on what basis)
        null = {"null": (self.stats or {}).get("null", self.NULL_REASON)} if has_null else {}
        return {
            **partial,
            "params": self.params.decimal(),
            "model": self.model,
            "precision": self.precision.name,
            "tol": s(self.tol) if self.tol is not None else None,
            "digits": claim.summary(),
            "samples": samples,
            "impacts": impacts,
            **null,
            "elapsed_s": self.elapsed_s,
        }

    def save(self, path: str | os.PathLike) -> Path:
        """Write ``.npz`` (decimal strings for every number, plus float64 copies), ``.csv`` or
        ``.json``.

        ``.json`` is :meth:`to_dict` (the CLI's ``--json`` object); ``.csv`` rows give each
        sample's claimed digits (``x_digits``, ``v_digits``, :meth:`claimed_digits`).  The file
        is written atomically (temporary file + rename).
        """
        path = Path(path)
        s = np.vectorize(lambda x: self._str(x) or "nan", otypes=[object])
        if path.suffix == ".npz":
            arrays: dict[str, np.ndarray] = {}
            for name in ("t", "x", "v", "impacts_t", "impacts_v_before", "impacts_v_after"):
                a = getattr(self, name)
                arrays[name + "_str"] = np.asarray(s(a) if len(a) else [], dtype=str)
            for k, a in self.as_float64().items():
                arrays[k] = a
            if self.dense_t is not None:
                f = self.precision.floats
                arrays["dense_t"], arrays["dense_x"], arrays["dense_v"] = (
                    f(self.dense_t),
                    f(self.dense_x),
                    f(self.dense_v),
                )
            meta = {k: v for k, v in self.to_dict().items() if k not in ("samples", "impacts")}
            arrays["meta_json"] = np.asarray(dumps(meta))

            def write(fh):
                np.savez_compressed(fh, **arrays)

            atomic_write(path, write, binary=True)
        elif path.suffix == ".csv":
            # x_digits, v_digits: the significant digits a sample claims (claimed_digits)
            lines = ["kind,index,t,x,v_or_v_before,v_after,x_digits,v_digits"]
            c = lambda x: self._str(x) or "nan"  # noqa: E731 - not recorded
            claim = self.claimed_digits()
            for j, (t, x, v) in enumerate(zip(self.t, self.x, self.v, strict=True)):
                lines.append(f"sample,{j},{c(t)},{c(x)},{c(v)},,{claim.x[j]},{claim.v[j]}")
            xw = decimal_str(self.params.x_w)
            if "/" in xw:  # a ratio is text to a spreadsheet: the wall in the working precision
                xw = c(self.precision.from_fraction(self.params.x_w))
            for i, (t, vb, va) in enumerate(
                zip(self.impacts_t, self.impacts_v_before, self.impacts_v_after, strict=True)
            ):
                lines.append(f"impact,{i},{c(t)},{xw},{c(vb)},{c(va)},,")
            text = "\n".join(lines) + "\n"
            atomic_write(path, lambda fh: fh.write(text), binary=False)
        elif path.suffix == ".json":
            write_json(path, self.to_dict(), indent=None)
        else:
            raise ParameterError("out", str(path), "output file must end in .npz, .csv or .json")
        return path

    def plot(
        self,
        path: str | os.PathLike | None = None,
        units: str = "dimensionless",
        components=None,
        last: int | None = None,
    ):
        """Phase portrait (impacts as vertical jumps at the labelled wall) beside ``x(t)``.

        Parameters
        ----------
        path : str, os.PathLike or None, default ``None``
            Also write the figure there (``.png``, ``.pdf`` or ``.svg``, atomically).
        units : {'dimensionless', 'circuit'}, default ``'dimensionless'``
            ``'circuit'``: seconds and the volts ``V_s``, ``V_q`` of ``components`` (default: the
            nominal design of :attr:`params`); see :func:`precise_impact.io.figures.plot_units`.
        components : Components or None
            The circuit design for ``units='circuit'``.
        last : int or None, default ``None``
            Draw only the last ``last`` forcing periods (``None``: all).

        Returns
        -------
        matplotlib.figure.Figure
        """
        return plot_trajectory(self, path, units=units, components=components, last=last)


# 0.1.0 name, kept for one release.
Trajectory.to_json_dict = Trajectory.to_dict  # type: ignore[attr-defined]
