"""An oscilloscope capture of the circuit: time in seconds, V_s, V_q (and the forcing V_3) in volts.

A :class:`Capture` is what every reader of :mod:`precise_impact.lab.scope_files` returns and what
:func:`precise_impact.lab.synth.synth_capture` writes: uniformly sampled channels named by their
role (``V_s`` the position integrator's output, ``V_q`` the velocity integrator's, ``V_3`` the
forcing), SI units, the sample interval and where it came from.  :meth:`Capture.to_mechanical`
maps it to ``(tau, x, x')`` through :func:`precise_impact.models.circuit.components.circuit_scales`
(``tau = omega t``, ``x = -V_s / V_unit``, ``x' = V_q / (omega R8 C1 V_unit)``).  Also here: the
checks of a capture's channels and the noise measures of a sampled channel.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from precise_impact.core.params import Params
from precise_impact.core.result import ResultMixin, to_jsonable, unit_column
from precise_impact.errors import ParameterError
from precise_impact.io.atomic import atomic_write
from precise_impact.io.figures import check_plot_path, finish, new_figure
from precise_impact.lab.scope_writers import write_layout
from precise_impact.models.circuit.components import (
    Components,
    circuit_scales,
    dimensionless,
    nominal_components,
)
from precise_impact.scenes.scene import Scene, load_scene

__all__ = [
    "Capture",
    "MechanicalSeries",
    "CHANNELS",
    "MIN_SAMPLES",
    "design_of",
    "check_channels",
    "integrator_pair_fit",
]

#: The channels a capture may carry, by their role in the circuit (paper Fig. 2).
CHANNELS = ("V_s", "V_q", "V_3")
#: Fewest samples a capture may have (a few forcing periods at a few samples each).
MIN_SAMPLES = 16
#: Largest relative deviation of a sample step from the median step for a capture to count as
#: uniformly sampled.  Scope exports round times to 4-7 significant digits; 1e-3 of a step
#: accepts that rounding (<= 5e-5 relative of a time value, i.e. of a step for records of up
#: to 1e4 steps between printed digits) and refuses a missing or doubled sample (deviation 1).
UNIFORM_RTOL = 1e-3


@dataclasses.dataclass
class Capture(ResultMixin):
    """A capture of the circuit's voltages.

    Attributes
    ----------
    t : numpy.ndarray
        Sample times [s] (float64, uniformly spaced; the trigger is at ``t = 0`` for scope files).
    V_s, V_q : numpy.ndarray
        Position and velocity integrator outputs [V].
    V_3 : numpy.ndarray or None
        The forcing source [V], when it was recorded.
    sample_interval : float
        Time between samples [s] (the file's own value where it states one).
    units : dict
        ``{'t': 's', 'V_s': 'V', ...}`` (always SI after reading: readers convert).
    source : dict
        Where it came from: ``format``, ``path``, ``instrument``, the file's channel names for
        each role (``channel_map``), header fields; for a synthetic capture also ``truth`` (the
        forcing frequency and phase as the scope's time base sees them, the model, ...) and the
        ``measurement`` model.

    See Also
    --------
    precise_impact.lab.scope_files.read_capture : read one from a file.
    precise_impact.lab.synth.synth_capture : a synthetic one from a model.
    precise_impact.lab.attractor.score_capture : score it against a model.
    """

    t: np.ndarray
    V_s: np.ndarray
    V_q: np.ndarray
    V_3: np.ndarray | None = None
    sample_interval: float = math.nan
    units: dict = dataclasses.field(default_factory=dict)
    source: dict = dataclasses.field(default_factory=dict)

    # ------------------------------------------------------------------ construction
    @classmethod
    def make(
        cls,
        t: Any,
        V_s: Any,
        V_q: Any,
        V_3: Any = None,
        sample_interval: float | None = None,
        source: dict | None = None,
        what: str = "capture",
    ) -> Capture:
        """A validated capture (SI units): ``t`` strictly increasing and uniform to
        :data:`UNIFORM_RTOL`, channels of ``t``'s length, finite, at least :data:`MIN_SAMPLES`.

        ``what`` names the input in the one-line refusal (a reader passes the file's path).
        """
        t = np.asarray(t, dtype=float).ravel()
        chans = {"V_s": V_s, "V_q": V_q, "V_3": V_3}
        arr: dict[str, np.ndarray | None] = {}
        for name, v in chans.items():
            if v is None:
                arr[name] = None
                continue
            a = np.asarray(v, dtype=float).ravel()
            if a.shape != t.shape:
                raise ParameterError(
                    what,
                    f"{name}: {a.size} samples",
                    f"as many samples as the time axis ({t.size})",
                )
            if not np.all(np.isfinite(a)):
                bad = int(np.argmin(np.isfinite(a)))
                raise ParameterError(
                    what,
                    f"{name}[{bad}] = {a[bad]}",
                    "finite voltages (a damaged or clipped file?)",
                )
            arr[name] = a
        if t.size < MIN_SAMPLES:
            raise ParameterError(what, f"{t.size} samples", f">= {MIN_SAMPLES} samples")
        if not np.all(np.isfinite(t)):
            raise ParameterError(what, "non-finite time", "finite sample times")
        steps = np.diff(t)
        dt_med = float(np.median(steps))
        if not dt_med > 0:
            raise ParameterError(what, f"median step {dt_med:g} s", "increasing sample times")
        dev = np.abs(steps - dt_med) / dt_med
        if float(dev.max()) > UNIFORM_RTOL:
            k = int(np.argmax(dev))
            raise ParameterError(
                what,
                f"step {k}: {steps[k]:.6g} s vs median {dt_med:.6g} s",
                f"uniformly sampled times (each step within {UNIFORM_RTOL:g} of the median; "
                "missing or repeated samples?)",
            )
        dt = dt_med if sample_interval is None else float(sample_interval)
        if not (dt > 0 and abs(dt - dt_med) <= 1e-3 * dt_med):
            raise ParameterError(
                what,
                f"sample interval {dt:g} s",
                f"the time axis's own step ({dt_med:.6g} s) to 1e-3 (a header that disagrees "
                "with the data: wrong unit?)",
            )
        units = {"t": "s", "V_s": "V", "V_q": "V"}
        if arr["V_3"] is not None:
            units["V_3"] = "V"
        return cls(
            t=t,
            V_s=arr["V_s"],  # type: ignore[arg-type]
            V_q=arr["V_q"],  # type: ignore[arg-type]
            V_3=arr["V_3"],
            sample_interval=dt,
            units=units,
            source=dict(source or {}),
        )

    # ------------------------------------------------------------------ views
    @property
    def channels(self) -> dict[str, np.ndarray]:
        """``{'V_s': ..., 'V_q': ..., ['V_3': ...]}``."""
        out = {"V_s": self.V_s, "V_q": self.V_q}
        if self.V_3 is not None:
            out["V_3"] = self.V_3
        return out

    @property
    def n_samples(self) -> int:
        return int(self.t.size)

    @property
    def duration(self) -> float:
        """Record length [s] (``n_samples * sample_interval``)."""
        return float(self.n_samples * self.sample_interval)

    @property
    def sample_rate(self) -> float:
        """Samples per second."""
        return 1.0 / self.sample_interval

    def _tables(self) -> dict:
        """``to_dataframe()`` table ``samples``: time [s] and each recorded channel [V]."""

        def samples() -> dict:
            cols = {unit_column("t", "s"): np.asarray(self.t, dtype=float)}
            for name in ("V_s", "V_q", "V_3"):
                values = getattr(self, name)
                if values is not None:
                    cols[unit_column(name, "V")] = np.asarray(values, dtype=float)
            return cols

        return {"samples": samples}

    def to_dict(self, arrays: bool = False) -> dict[str, Any]:
        """A summary (sizes, sample interval, each channel's range, units, source); with
        ``arrays=True`` the samples too."""
        out: dict[str, Any] = {
            "n_samples": self.n_samples,
            "sample_interval": self.sample_interval,
            "duration": self.duration,
            "t_first": float(self.t[0]),
            "channels": {
                k: {"min": float(v.min()), "max": float(v.max()), "mean": float(v.mean())}
                for k, v in self.channels.items()
            },
            "units": self.units,
            "source": self.source,
        }
        if arrays:
            out["t"] = self.t
            out.update(self.channels)
        return out

    # ------------------------------------------------------------------ files
    def save(self, path: str | os.PathLike, fmt: str | None = None) -> Path:
        """Write the capture: ``.npz`` (arrays + JSON metadata), ``.csv`` (generic time-first
        CSV), ``.json`` (the summary), or a vendor layout by ``fmt``
        (:data:`precise_impact.lab.scope_writers.WRITE_FORMATS`)."""
        path = Path(path)
        if fmt is None and path.suffix.lower() == ".json":
            return super().save(path)
        return write_layout(self, path, fmt, UNIFORM_RTOL)

    def npz_arrays(self) -> dict[str, np.ndarray]:
        """The arrays :meth:`save` puts in an ``.npz`` file (``meta`` is JSON text)."""
        arrays: dict[str, np.ndarray] = {"t": self.t, **self.channels}
        meta = {"sample_interval": self.sample_interval, "units": self.units, "source": self.source}
        arrays["meta"] = np.asarray(json.dumps(ResultMixin_jsonable(meta), allow_nan=False))
        return arrays

    def write_npz(self, path: str | os.PathLike) -> Path:
        """The ``.npz`` form (read back by :func:`precise_impact.lab.scope_files.read_capture`)."""
        path = Path(path)
        arrays = self.npz_arrays()
        atomic_write(path, lambda fh: np.savez_compressed(fh, **arrays), binary=True)
        return path

    # ------------------------------------------------------------------ mapping
    def to_mechanical(
        self,
        design: Any,
        forcing_omega: float | None = None,
        forcing_phase0: float | None = None,
    ) -> MechanicalSeries:
        """The capture in the oscillator's dimensionless variables.

        Parameters
        ----------
        design : Components, Params, Scene or scene name
            The circuit's component values (:func:`design_of`); its ``omega``, ``R8 C1`` and
            ``V_unit`` give the scales
            (:func:`~precise_impact.models.circuit.components.circuit_scales`).
        forcing_omega : float or None
            The forcing's angular frequency [rad/s] in the capture's time base (estimated, e.g.
            :func:`precise_impact.lab.attractor.estimate_forcing`); ``None`` takes the design's
            ``Omega``.
        forcing_phase0 : float or None
            The forcing phase at ``t = 0`` [rad] (``V_3 = V_A cos(Omega t + phase0)``); ``None``
            leaves :attr:`MechanicalSeries.phase` out.
        """

        comp = design_of(design)
        sc = circuit_scales(comp)
        mech = dimensionless(comp)  # the one home of x_w = -V_wall/V_unit, a = V_A R7/(R1 V_unit)
        Om = float(comp.Omega) if forcing_omega is None else float(forcing_omega)
        tau = self.t / sc.seconds_per_tau
        x = self.V_s / sc.volts_per_x
        v = self.V_q / sc.volts_per_v
        phase = None
        if forcing_phase0 is not None:
            phase = np.mod(Om * self.t + float(forcing_phase0), 2 * math.pi)
        return MechanicalSeries(
            tau=tau,
            x=x,
            v=v,
            phase=phase,
            eta=Om / sc.omega,
            omega=sc.omega,
            x_w=float(mech.x_w),
            a=float(mech.a),
        )

    # ------------------------------------------------------------------ plot
    def plot(self, path: Any = None, periods: float | None = None, title: str | None = None):
        """The channels against time (the first ``periods`` forcing periods of the design's
        nominal forcing if the capture carries a synthetic truth, else the first 2000 samples);
        written to ``path`` if given."""

        check_plot_path(path)
        n = min(self.n_samples, 2000)
        f = (self.source.get("truth") or {}).get("forcing_frequency_hz")
        if periods is not None and f:
            n = min(self.n_samples, max(2, int(periods / f / self.sample_interval)))
        chans = self.channels
        fig, axes = new_figure(len(chans), 1, figsize=(8.0, 1.8 * len(chans) + 0.8), sharex=True)
        scale, unit = _time_unit(float(self.t[n - 1] - self.t[0]))
        for ax, (name, v) in zip(axes[:, 0], chans.items(), strict=True):
            ax.plot(self.t[:n] * scale, v[:n], lw=0.8)
            ax.set_ylabel(f"{name} [V]")
            ax.grid(alpha=0.3)
        axes[-1, 0].set_xlabel(f"time [{unit}]")
        src = self.source.get("instrument") or self.source.get("format") or "capture"
        fig.suptitle(
            title or f"{src}: {self.n_samples} samples at {self.sample_rate:.4g} Sa/s", fontsize=10
        )
        return finish(fig, path)


def ResultMixin_jsonable(obj: Any) -> Any:  # noqa: N802 - local alias of to_jsonable

    return to_jsonable(obj)


def _time_unit(span: float) -> tuple[float, str]:
    for scale, unit in ((1.0, "s"), (1e3, "ms"), (1e6, "us"), (1e9, "ns")):
        if span * scale >= 1:
            return scale, unit
    return 1e9, "ns"


@dataclasses.dataclass
class MechanicalSeries(ResultMixin):
    """A capture in the oscillator's dimensionless variables.

    Attributes
    ----------
    tau, x, v : numpy.ndarray
        ``tau = omega t``, ``x``, ``x'``.
    phase : numpy.ndarray or None
        The forcing phase ``Omega t + phase0`` mod 2 pi at each sample (``None``: not given).
    eta : float
        ``Omega / omega`` (the forcing used for ``phase``).
    omega : float
        The design's natural angular frequency [rad/s].
    x_w, a : float
        The wall and the forcing amplitude the design realises.
    """

    tau: np.ndarray
    x: np.ndarray
    v: np.ndarray
    phase: np.ndarray | None
    eta: float
    omega: float
    x_w: float
    a: float


def design_of(design: Any):
    """Component values from a :class:`~precise_impact.models.circuit.components.Components`,
    a :class:`~precise_impact.core.params.Params` (the nominal design), a
    :class:`~precise_impact.scenes.scene.Scene` or a scene name / path.  A system with
    ``R < 1`` (the mechanics; no circuit realises it) gets the ``R = 1`` design's volts and
    seconds, which do not depend on ``R``."""

    if isinstance(design, Components):
        return design
    if isinstance(design, Params):
        return nominal_components(design.replace(R=1))
    if isinstance(design, (str, Path)):
        design = load_scene(design)
    if isinstance(design, Scene):
        return dataclasses.replace(design, params=design.params.replace(R=1)).design()
    raise ParameterError(
        "design", type(design).__name__, "Components, Params, a Scene or a scene name"
    )


# ============================================================== wrong channels, clipping
#: Smallest share of ``V_s``'s variance (its white noise taken out) that ``-integral V_q dt /
#: (R8 C1)`` must explain, segment by segment, for the two channels to be taken as the
#: integrator pair.  Measured on synthetic captures (100-200 periods): the right pair 0.9875 to
#: 1.000 (8 and 4 bits, 10 % white + 1 % 1/f noise with 0.3 V offsets, fig4/5/6 scenes, ideal
#: and datasheet); wrong pairs up to 0.95 but those above 0.886 have a negative R8 C1 (V_s and
#: V_q swapped: the sign check refuses them), those with the design's sign at most 0.879 (V_q
#: as V_s, V_3 as V_q on the near-harmonic fig4 orbit).  0.95 lies between the groups.
INTEGRATOR_MIN_R2 = 0.95
#: The integrator's fitted ``R8 C1`` may differ from the design's by this factor at most
#: (probe gain errors of +-49 % give at most 1.49 / 0.51 = 2.9; a 10x probe set to 1x gives 10).
INTEGRATOR_MAX_RATIO = 3.0
#: Largest share of a channel's samples at one of its extreme values (the ADC's rail) before
#: the capture is refused as clipped (an 8-bit sinusoid fitted to the screen puts ~4 % of its
#: samples on its top code; noise spreads them).
CLIP_MAX_FRACTION = 0.2


def integrator_pair_fit(
    t: np.ndarray,
    vs: np.ndarray,
    vq: np.ndarray,
    segment: int | None = None,
    noise_vs: float = 0.0,
) -> tuple[float, float]:
    """``(R8 C1, R^2)`` of ``V_s = c - integral V_q dt / (R8 C1)``.

    The one home of the integrator-pair relation of the circuit's position and velocity
    channels.  ``segment`` samples per independent constant (``None``: one constant for the
    whole record, as a simulator's noise-free run allows); a capture uses segments of about a
    forcing period, so that neither the random walk of the integrated noise (``sigma dt
    sqrt(n)``) nor a probe offset on ``V_q`` (a drift ``offset t``) accumulates over more than
    one segment (with segments, ``V_q``'s record mean, its offset, is removed first).
    ``R^2`` is the share of ``V_s``'s within-segment variance explained; a
    negative ``R8 C1`` means the two channels are swapped or one is inverted.  ``noise_vs``:
    ``V_s``'s white-noise RMS [V], whose variance (which no relation can explain) is taken out
    of both the residual and the total before the share is formed (a capture passes its white
    noise and ADC step together, ``sqrt(white^2 + q^2/12)``).
    """
    rc, r2, _ = integrator_pair_fit_se(t, vs, vq, segment, noise_vs)
    return rc, r2


def integrator_pair_fit_se(
    t: np.ndarray,
    vs: np.ndarray,
    vq: np.ndarray,
    segment: int | None = None,
    noise_vs: float = 0.0,
) -> tuple[float, float, float]:
    """``(R8 C1, R^2, standard error of R8 C1)``: :func:`integrator_pair_fit` with the fit's
    standard error (residual scatter only, ``n - 2`` degrees of freedom per segment; not the
    trapezoid rule's error, O(h^2) per unit time)."""
    t = np.asarray(t, float)
    vs = np.asarray(vs, float)
    vq = np.asarray(vq, float)
    n = len(t)
    seg = n if segment is None else max(2, min(int(segment), n))
    if segment is not None:
        # V_s is bounded, so V_q's mean over a record of many segments is its probe offset
        # (the true mean is (V_s(end) - V_s(0)) R8 C1 / T ~ 0): removed before integrating
        vq = vq - float(np.mean(vq))
    q = np.concatenate(([0.0], np.cumsum(0.5 * (vq[1:] + vq[:-1]) * np.diff(t))))
    m = (n // seg) * seg
    if m < seg or m < 4:
        return math.nan, 0.0, math.nan
    qs = q[:m].reshape(-1, seg)
    ys = vs[:m].reshape(-1, seg)
    qs = qs - qs.mean(axis=1, keepdims=True)
    ys = ys - ys.mean(axis=1, keepdims=True)
    qq, yy = float(np.sum(qs * qs)), float(np.sum(ys * ys))
    if not (qq > 0 and yy > 0):
        return math.nan, 0.0, math.nan
    k = float(np.sum(qs * ys)) / qq  # = -1 / (R8 C1)
    r = ys - k * qs
    white = m * (1 - 1 / seg) * float(noise_vs) ** 2  # expected within-segment noise sum
    rr = float(np.sum(r * r))
    r2 = 1.0 - max(rr - white, 0.0) / max(yy - white, 1e-300 * yy)
    se = math.sqrt(rr / max(m - 2 * (m // seg), 1) / qq)  # of k
    return (-1.0 / k if k else math.inf), r2, (se / k**2 if k else math.inf)


def noise_sigma(y: np.ndarray) -> float:
    """White-noise standard deviation of a sampled signal: ``1.4826 MAD(second differences)
    / sqrt(6)`` (a second difference of white noise has variance ``6 sigma^2``; the median
    ignores the impacts' jumps; the signal's own curvature adds ``y'' dt^2``, negligible at
    tens of samples per period)."""
    d2 = np.diff(np.asarray(y, float), 2)
    mad = float(np.median(np.abs(d2 - np.median(d2))))
    return 1.4826 * mad / math.sqrt(6)


def adc_step(y: np.ndarray) -> float:
    """The ADC's code step of a quantised record (the median gap between its distinct
    values when they are fewer than half the samples), else 0."""
    u = np.unique(np.asarray(y, float))
    if len(u) < 2 or len(u) > 0.5 * len(y):
        return 0.0
    return float(np.median(np.diff(u)))


def channel_noise(y: np.ndarray) -> dict[str, float]:
    """``{'white', 'step', 'sigma'}`` of a channel: the white noise (:func:`noise_sigma`), the
    ADC step (:func:`adc_step`) and their total ``sqrt(white^2 + step^2 / 12)`` (a coarse ADC
    on a quiet signal repeats codes, so the second differences alone miss its error)."""
    w, q = noise_sigma(y), adc_step(y)
    return {"white": w, "step": q, "sigma": math.sqrt(w * w + q * q / 12.0)}


def check_channels(capture: Capture, design: Any, names: dict | None = None) -> dict:
    """Refuse a capture whose channels are not the circuit's ``V_s``, ``V_q`` (swapped, wrong or
    inverted probes, another node) or that is clipped, with one line naming the channels.

    ``V_s`` must be the integral of ``V_q``: ``V_s' = -V_q / (R8 C1)`` with ``R8 C1`` of the
    design's sign and within :data:`INTEGRATOR_MAX_RATIO` of its value
    (:func:`integrator_pair_fit`, segments of one design period); no channel may have more
    than :data:`CLIP_MAX_FRACTION` of its samples at one extreme value (or twice the share a
    sinusoid spends on the extreme code of a coarse ADC, when larger).  Returns
    ``{'R8C1', 'R8C1_design', 'r2', 'clipped', 'clip_limit'}`` (``clipped``: each channel's
    largest share of samples at one rail; ``clip_limit``: the share refused).
    """

    names = dict(names or capture.source.get("channel_map") or {})
    label = {k: f"{k} ({names[k]})" if names.get(k) and names[k] != k else k for k in CHANNELS}
    what = str(capture.source.get("path") or "capture")

    clipped, limits = {}, {}
    for k, y in capture.channels.items():
        n = len(y)
        share = max(int(np.sum(y == y.max())), int(np.sum(y == y.min()))) / n
        # a coarse ADC's extreme code holds a sinusoid's peak for a share arccos(1 - 2/K)/pi
        # of the time (K codes spanned: 0.18 for the 13 codes of 4 bits): twice that, or
        # CLIP_MAX_FRACTION, whichever is larger, is clipping
        q = adc_step(y)
        codes = float(np.ptp(y)) / q + 1 if q > 0 else math.inf
        natural = math.acos(1 - 2 / codes) / math.pi if codes > 2 else 0.5
        limit = max(CLIP_MAX_FRACTION, 2 * natural)
        clipped[k], limits[k] = share, limit
        if share > limit:
            raise ParameterError(
                what,
                f"channel {label[k]}: {share:.0%} of its samples at one rail",
                f"an unclipped capture (<= {limit:.0%} at the ADC's rails: widen "
                "the vertical range or fix the offset)",
            )
    comp = design_of(design)
    sc = circuit_scales(comp)
    rc_design = sc.volts_per_v / (sc.omega * -sc.volts_per_x)  # R8 C1 with V_unit's sign
    seg = max(8, round(2 * math.pi / (sc.omega * capture.sample_interval)))
    rc, r2 = integrator_pair_fit(
        capture.t, capture.V_s, capture.V_q, seg, channel_noise(capture.V_s)["sigma"]
    )
    pair = f"{label['V_s']} and {label['V_q']}"
    if not (r2 >= INTEGRATOR_MIN_R2 and math.isfinite(rc)):
        raise ParameterError(
            what,
            f"channels {pair}: -integral V_q dt/(R8 C1) explains {max(r2, 0.0):.0%} of V_s",
            f">= {INTEGRATOR_MIN_R2:.0%} (V_s the integral of V_q): a wrong channel? give "
            "--channels V_s=..,V_q=..[,V_3=..]",
        )
    ratio = rc / rc_design
    if ratio < 0:
        raise ParameterError(
            what,
            f"channels {pair}: V_s' = -V_q/(R8 C1) with R8 C1 = {rc:.3g} s (design "
            f"{rc_design:.3g} s)",
            "the design's sign: V_s and V_q swapped or one probe inverted (--channels)",
        )
    if not 1 / INTEGRATOR_MAX_RATIO <= ratio <= INTEGRATOR_MAX_RATIO:
        raise ParameterError(
            what,
            f"channels {pair}: R8 C1 = {rc:.3g} s from the capture, {ratio:.3g} x the design's "
            f"{rc_design:.3g} s",
            f"within {INTEGRATOR_MAX_RATIO:g}x of the design (a probe's attenuation, or another "
            "scene's design?)",
        )
    return {
        "R8C1": rc,
        "R8C1_design": rc_design,
        "r2": r2,
        "clipped": clipped,
        "clip_limit": limits,
    }
