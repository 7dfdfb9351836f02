"""Synthetic scope captures: a model of the circuit seen through an explicit measurement model.

:func:`synth_capture` runs a scene on any model of the circuit (``circuit``,
``switched-capacitor``, ``spice``) as ``compare`` runs each model, samples the trajectory at the
scope's sample times (cubic Hermite on knots that include every impact), maps it to volts with
the design's component values and applies a :class:`Measurement` (time-base error, trigger,
probe gain and offset, white and 1/f noise, ADC).  The truth the scorers are tested against is
kept in ``capture.source['truth']``.  The measurement model, the sampling error and the truth:
:doc:`/guide/captures`, "The measurement model in detail".
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from precise_impact.analysis.lyapunov.finite_time import finite_time_lle
from precise_impact.core.budget import Deadline, parse_max_time
from precise_impact.core.flow import acceleration
from precise_impact.core.params import decimal_str
from precise_impact.errors import ParameterError
from precise_impact.lab.capture import CHANNELS, MIN_SAMPLES, UNIFORM_RTOL, Capture
from precise_impact.models.circuit.components import circuit_scales, to_circuit
from precise_impact.models.circuit.effects.catalogue import CIRCUIT_MODELS
from precise_impact.scenes.run import run_scene
from precise_impact.scenes.scene import Scene, load_scene
from precise_impact.verification.compare import scene_for_model

__all__ = ["Measurement", "synth_capture", "sample_trajectory", "DEFAULT_SAMPLES_PER_PERIOD"]

#: Samples per forcing period when no sample rate is given (rounded up to a 1-2-5 rate in Sa/s).
DEFAULT_SAMPLES_PER_PERIOD = 100
#: The model's dense points per forcing period the scope samples are interpolated from.
DENSE_PER_PERIOD = 256


@dataclasses.dataclass(frozen=True)
class Measurement:
    """How the scope sees the circuit.

    Attributes
    ----------
    bits : int
        ADC resolution (1..24); 0 records the voltages unquantised.
    full_scale : float, dict or None
        Vertical range [V] per channel (``{'V_s': 8.0, ...}`` or one value for all); ``None``
        sets each to 1.25 x the clean signal's peak-to-peak, centred on it (a user fitting the
        trace to the screen).
    noise : float
        White noise RMS as a fraction of the channel's full scale (0.01 = 1 %).
    flicker : float
        1/f noise RMS as a fraction of full scale.
    sample_rate : float or None
        Samples per second; ``None``: the 1-2-5 rate at or above
        :data:`DEFAULT_SAMPLES_PER_PERIOD` samples per forcing period.
    periods : float
        Record length in forcing periods.
    trigger_offset : float
        File time of the first sample [s] (negative: pre-trigger samples).
    gain_error, offset_error : float or dict
        Probe/channel gain error (relative) and offset error [V], one value or per channel.
    noise_v : float, dict or None
        White noise RMS in volts (one value or per channel), overriding ``noise`` where given
        (used to match a measured capture's noise).
    timebase_ppm : float
        Time-base error: the scope's clock runs this many ppm fast.
    seed : int
        Seed of the noise and of the record's start on the attractor.

    See Also
    --------
    synth_capture : a capture of a model through it.
    """

    bits: int = 8
    full_scale: float | dict | None = None
    noise: float = 0.01
    flicker: float = 0.0
    sample_rate: float | None = None
    periods: float = 200
    trigger_offset: float = 0.0
    gain_error: float | dict = 0.0
    offset_error: float | dict = 0.0
    noise_v: float | dict | None = None
    timebase_ppm: float = 0.0
    seed: int = 0

    def check(self) -> Measurement:
        """Validated (one :class:`ParameterError` naming the field and its range)."""
        self._check_record()
        for name in ("gain_error", "offset_error", "full_scale", "noise_v"):
            self._check_per_channel(name)
        if not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise ParameterError("seed", self.seed, "an integer >= 0")
        return self

    def _check_record(self) -> None:
        """Check the ADC, noise, sample-rate, length, trigger and time-base fields."""
        if not (isinstance(self.bits, (int, np.integer)) and 0 <= self.bits <= 24):
            raise ParameterError("bits", self.bits, "an integer 0..24 (0: unquantised)")
        for name in ("noise", "flicker"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and 0 <= v <= 1):
                raise ParameterError(name, v, "0 <= value <= 1 (a fraction of full scale)")
        if self.sample_rate is not None and not (
            math.isfinite(self.sample_rate) and self.sample_rate > 0
        ):
            raise ParameterError("sample_rate", self.sample_rate, "> 0 Sa/s")
        if not (math.isfinite(self.periods) and 2 <= self.periods <= 1e5):
            raise ParameterError("periods", self.periods, "2 <= periods <= 1e5")
        if not math.isfinite(self.trigger_offset):
            raise ParameterError("trigger_offset", self.trigger_offset, "a finite time in s")
        if not (math.isfinite(self.timebase_ppm) and abs(self.timebase_ppm) <= 1e4):
            raise ParameterError("timebase_ppm", self.timebase_ppm, "|ppm| <= 1e4")

    def _check_per_channel(self, name: str) -> None:
        """Check one per-channel field (a number or ``{channel: number}``) and its range."""
        v = getattr(self, name)
        vals = v.values() if isinstance(v, dict) else ([] if v is None else [v])
        if isinstance(v, dict) and set(v) - set(CHANNELS):
            raise ParameterError(name, sorted(set(v) - set(CHANNELS)), "keys of V_s, V_q, V_3")
        for x in vals:
            if not (isinstance(x, (int, float)) and math.isfinite(x)):
                raise ParameterError(name, x, "finite numbers")
            if name == "gain_error" and not -0.5 < x < 0.5:
                raise ParameterError(name, x, "-0.5 < gain error < 0.5")
            if name == "full_scale" and not x > 0:
                raise ParameterError(name, x, "> 0 V")
            if name == "noise_v" and not x >= 0:
                raise ParameterError(name, x, ">= 0 V")

    def per_channel(self, name: str, field: str, default: Any = 0.0) -> Any:
        v = getattr(self, field)
        if isinstance(v, dict):
            return v.get(name, default)
        return default if v is None else v


#: The model that records the mechanics itself (a reference trajectory through the scope).
MECHANICS = "heyoka"


def _rate_125(minimum: float) -> float:
    """The smallest 1-2-5 x 10^k value >= ``minimum`` (a scope's sample-rate ladder)."""
    k = math.floor(math.log10(minimum))
    for m in (1, 2, 5, 10):
        if m * 10.0**k >= minimum * (1 - 1e-12):
            return m * 10.0**k
    return 10.0 ** (k + 1)


def _knots(tr: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The trajectory's dense points and its impacts (before and after, at the wall) as
    Hermite knots, in time order (an impact's 'after' knot follows its 'before' knot)."""
    t = np.asarray(tr.dense_t, dtype=float)
    x = np.asarray(tr.dense_x, dtype=float)
    v = np.asarray(tr.dense_v, dtype=float)
    f = tr.as_float64()
    ti, vb, va = f["impacts_t"], f["impacts_v_before"], f["impacts_v_after"]
    xw = float(tr.params.x_w)
    tt = np.concatenate([t, ti, ti])
    xx = np.concatenate([x, np.full(ti.shape, xw), np.full(ti.shape, xw)])
    vv = np.concatenate([v, vb, va])
    tag = np.concatenate([np.full(t.shape, 1), np.full(ti.shape, 0), np.full(ti.shape, 2)])
    order = np.lexsort((tag, tt))
    return tt[order], xx[order], vv[order]


def sample_trajectory(tr: Any, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(x, x')`` of a trajectory with dense output at dimensionless times ``tau`` (cubic
    Hermite between its dense points and impacts; the acceleration of eq. (2a) as ``x''``)."""

    if tr.dense_t is None or len(tr.dense_t) < 2:
        raise ParameterError("model", tr.model, "a model with dense output")
    kt, kx, kv = _knots(tr)
    p = tr.params
    ka = acceleration(kt, kx, kv, float(p.eta), float(p.zeta), float(p.a), np.cos)
    tau = np.asarray(tau, dtype=float)
    if tau.min() < kt[0] or tau.max() > kt[-1]:
        raise ParameterError("tau", (tau.min(), tau.max()), f"within the run [{kt[0]}, {kt[-1]}]")
    j = np.clip(np.searchsorted(kt, tau, side="right") - 1, 0, len(kt) - 2)
    # a zero-length interval (an impact's before/after pair) is never chosen: side='right'
    # puts tau == t_impact on the 'after' knot, whose successor is the next dense point
    h = kt[j + 1] - kt[j]
    s = (tau - kt[j]) / h
    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
    x = h00 * kx[j] + h10 * h * kv[j] + h01 * kx[j + 1] + h11 * h * kv[j + 1]
    v = h00 * kv[j] + h10 * h * ka[j] + h01 * kv[j + 1] + h11 * h * ka[j + 1]
    return x, v


def _flicker(rng: np.random.Generator, n: int) -> np.ndarray:
    """Unit-RMS 1/f noise of ``n`` samples (white Gaussian noise shaped by 1/sqrt(f), no DC)."""
    if n < 4:
        return np.zeros(n)
    spec = np.fft.rfft(rng.normal(size=n))
    f = np.arange(spec.size, dtype=float)
    spec[0] = 0
    spec[1:] /= np.sqrt(f[1:])
    y = np.fft.irfft(spec, n)
    return y / float(np.std(y))


def _checked_args(
    scene: Any,
    model: str | None,
    measurement: Measurement | None,
    measurement_kw: dict,
    channels: Any,
    transient: Any,
    max_time: Any,
) -> tuple[Measurement, Any, Any, Any, str]:
    """Check synth_capture's arguments: (measurement, max_time, channels, scene, model)."""
    meas = (measurement or Measurement(**measurement_kw)).check()
    if max_time is not None and not isinstance(max_time, Deadline):
        max_time = Deadline(parse_max_time(max_time), "capture synth")
    if measurement is not None and measurement_kw:
        raise ParameterError("measurement", sorted(measurement_kw), "a Measurement or its fields")
    if isinstance(channels, str):
        channels = tuple(c.strip() for c in channels.split(","))
    if not {"V_s", "V_q"} <= set(channels) or set(channels) - set(CHANNELS):
        raise ParameterError("channels", ",".join(channels), "V_s,V_q or V_s,V_q,V_3")
    if not isinstance(transient, (int, np.integer)) or not 0 <= transient <= 10**5:
        raise ParameterError("transient", transient, "an integer 0..1e5")
    sc = scene if isinstance(scene, Scene) else load_scene(scene)
    if sc.kind != "single":
        raise ParameterError("scene", sc.name, "a single-oscillator scene")
    model = model or sc.model
    if model not in (*CIRCUIT_MODELS, MECHANICS):
        allowed = ", ".join((*CIRCUIT_MODELS, MECHANICS))
        raise ParameterError("model", model, "a circuit model or the mechanics: " + allowed)
    return meas, max_time, channels, sc, model


def _record_grid(meas: Measurement, T: float) -> tuple[float, float, int]:
    """The sample rate, interval and count of the record, checked before any work."""
    fs = meas.sample_rate or _rate_125(DEFAULT_SAMPLES_PER_PERIOD / T)
    dt = 1.0 / fs
    n = int(math.ceil(meas.periods * T / dt))
    # the record, checked before any work: enough samples, sampled above Nyquist, not too many
    lo_fs = max(2.0 / T, MIN_SAMPLES / (meas.periods * T))
    if not lo_fs <= fs:
        raise ParameterError(
            "sample_rate",
            fs,
            f">= {lo_fs:.6g} Sa/s for this record (>= 2 samples per forcing period of "
            f"{T:.6g} s and >= {MIN_SAMPLES} samples in {meas.periods:g} periods)",
        )
    if n > 5 * 10**7:
        raise ParameterError("sample_rate", fs, f"a record of <= 5e7 samples (asked {n})")
    # float64 file times trigger_offset + k dt must resolve a step to the reader's uniformity
    # tolerance: an ulp of the largest time <= UNIFORM_RTOL / 10 of dt
    t_max = abs(meas.trigger_offset) + n * dt
    if math.ulp(t_max) > 0.1 * UNIFORM_RTOL * dt:
        lim = 0.1 * UNIFORM_RTOL * dt / math.ulp(1.0) / 2
        raise ParameterError(
            "trigger_offset",
            meas.trigger_offset,
            f"|trigger offset| <~ {lim:.3g} s at this sample interval ({dt:.3g} s): float64 "
            "times further from 0 no longer resolve a sample step",
        )
    return fs, dt, n


def _measured(
    name: str, y: np.ndarray, meas: Measurement, rng: np.random.Generator, n: int
) -> tuple[np.ndarray, dict[str, Any]]:
    """One channel through the probe, the noise and the ADC: ``(samples, range record)``."""
    g = float(meas.per_channel(name, "gain_error"))
    y = (1 + g) * y + float(meas.per_channel(name, "offset_error"))
    fsr = meas.per_channel(name, "full_scale", None)
    if fsr is None:
        pp = float(y.max() - y.min()) or 1.0
        lo, fsr = float(y.min()) - 0.125 * pp, 1.25 * pp
    else:
        lo = 0.5 * float(y.max() + y.min()) - 0.5 * float(fsr)
    sigma = meas.per_channel(name, "noise_v", None)
    sigma = meas.noise * fsr if sigma is None else float(sigma)
    y = y + sigma * rng.normal(size=n)
    if meas.flicker:
        y = y + meas.flicker * fsr * _flicker(rng, n)
    clipped = 0
    if meas.bits:
        lsb = fsr / 2**meas.bits
        code = np.floor((y - lo) / lsb)
        clipped = int(np.sum((code < 0) | (code > 2**meas.bits - 1)))
        y = lo + (np.clip(code, 0, 2**meas.bits - 1) + 0.5) * lsb
    return y, {"low": lo, "full_scale": float(fsr), "clipped": clipped}


def _lle_record(model: str, fitted: Any, params: Any, f: dict, tau: np.ndarray) -> Any:
    """The finite-time LLE of the record's stretch (ideal circuit only), else ``None``."""
    # the finite-time variational exponent of the record's own stretch (per unit of the
    # oscillator's time), along the model's impacts: the mechanics' tangent map, so only for a
    # model without effects (the ideal circuit is the mechanics); a 200-period record's own
    # exponent scatters ~11 % about the asymptotic one at eta = 0.712
    if model == "circuit" and not fitted.effects and 0 <= float(params.zeta) < 1:
        return finite_time_lle(
            params, f["impacts_t"], f["impacts_v_before"], float(tau[0]), float(tau[-1])
        )
    return None


def synth_capture(
    scene: Any = "fig6-period3-ideal",
    model: str | None = None,
    eta: Any = None,
    measurement: Measurement | None = None,
    channels: tuple[str, ...] | str = ("V_s", "V_q", "V_3"),
    transient: int = 100,
    max_time: float | Deadline | None = None,
    **measurement_kw: Any,
) -> Capture:
    """A capture of ``scene`` on ``model`` through ``measurement``.

    Parameters
    ----------
    scene : str, Path or Scene, default ``'fig6-period3-ideal'``
        A single-oscillator scene (its design gives the volts and seconds).
    model : str or None
        ``'circuit'``, ``'switched-capacitor'`` or ``'spice'`` (the scene's effects that fit it
        kept), or ``'heyoka'``: the mechanics itself through the design's volts and seconds
        (any ``R``: the circuits realise ``R = 1`` only); ``None`` is the scene's own model.
    eta : decimal or None
        Another forcing frequency ratio (the design's ``Omega`` follows it).
    measurement : Measurement or None
        The measurement model; ``None`` is ``Measurement(**measurement_kw)``.
    channels : tuple of str or ``'V_s,V_q[,V_3]'``
        The channels recorded (``V_s`` and ``V_q`` always).
    transient : int, default 100
        Forcing periods run before the record may start.
    max_time : float, Deadline or None, default ``None``
        Time budget [s] (or a :class:`~precise_impact.core.budget.Deadline` shared with the
        caller): the model run's estimate is checked against it before any work and the
        synthesis stops once it has run out
        (:class:`~precise_impact.errors.BudgetExceededError`, the CLI's exit 3); ``None``: the
        scene runner's default budget.
    **measurement_kw
        Fields of :class:`Measurement` (``bits``, ``noise``, ``periods``, ``seed`` ...) when
        ``measurement`` is ``None``.

    Returns
    -------
    Capture
        With ``source['truth']`` (forcing ``omega_rad_s`` and ``phase0_rad`` in the file's time
        base, ``forcing_frequency_hz``, impacts in the record, scene, model, parameters,
        ``lle_record`` the record's own finite-time exponent or ``None``) and
        ``source['measurement']``.

    See Also
    --------
    Measurement : the measurement model.
    precise_impact.lab.scope_files.write_capture : write it in an instrument's layout.
    precise_impact.lab.attractor.score_capture : score it.

    Examples
    --------
    >>> from precise_impact import synth_capture
    >>> cap = synth_capture("fig6-period3-ideal", periods=10, transient=5, bits=8, noise=0.01)
    >>> sorted(cap.channels), round(cap.source["truth"]["forcing_frequency_hz"], 3)
    (['V_3', 'V_q', 'V_s'], 117.775)
    """

    meas, max_time, channels, sc, model = _checked_args(
        scene, model, measurement, measurement_kw, channels, transient, max_time
    )
    params = sc.params if eta is None else sc.params.replace(eta=eta)
    # the design realising these parameters (Omega follows eta); the scene itself is kept for
    # the run (its raw table carries the effects), the parameters passed beside it
    # (the mechanics' R may be below 1: the volts and seconds are the R = 1 design's)
    design_params = params.replace(R=1) if model == MECHANICS else params
    comp = dataclasses.replace(sc, params=design_params).design()
    scales = circuit_scales(comp)
    w = scales.omega
    Om = float(comp.Omega)
    T = 2 * math.pi / Om
    fs, dt, n = _record_grid(meas, T)
    deadline = max_time if max_time is not None else Deadline(None, "capture synth")
    e = meas.timebase_ppm * 1e-6
    rng = np.random.default_rng(meas.seed)
    t_true0 = transient * T + rng.random() * T
    dt_true = dt / (1 + e)
    t_true = t_true0 + np.arange(n) * dt_true
    run_periods = int(math.ceil((t_true[-1] + dt_true) / T)) + 1
    # the scene on the model (its effects that fit it kept), as compare runs each model
    fitted = scene_for_model(sc, model, run_periods)[0]
    tr = run_scene(
        dataclasses.replace(
            fitted, periods=run_periods, per_period=DENSE_PER_PERIOD, params=params
        ),
        # the run's estimate against the whole budget (before any work); the deadline after
        max_time=deadline.max_time,
    )
    deadline.check("after the model run")
    tau = w * t_true
    x, v = sample_trajectory(tr, tau)
    _, Vs, Vq = to_circuit(comp, tau, x, v, w)
    clean = {"V_s": np.asarray(Vs, float), "V_q": np.asarray(Vq, float)}
    if "V_3" in channels:
        clean["V_3"] = float(comp.V_A) * np.cos(Om * t_true)
    out: dict[str, np.ndarray] = {}
    ranges: dict[str, Any] = {}
    for name, y in clean.items():
        out[name], ranges[name] = _measured(name, y, meas, rng, n)
    t_file = meas.trigger_offset + np.arange(n) * dt
    f = tr.as_float64()
    inside = (f["impacts_t"] >= tau[0]) & (f["impacts_t"] <= tau[-1])
    imp_t_file = meas.trigger_offset + (f["impacts_t"][inside] / w - t_true0) * (1 + e)
    lle_record = _lle_record(model, fitted, params, f, tau)
    truth = {
        "scene": sc.name,
        "model": model,
        "params": params.decimal(),
        "eta": decimal_str(params.eta),
        "components": comp.decimal(),
        "omega_natural_rad_s": w,
        # V_3 = V_A cos(Omega t_true) with t_true = t_true0 + (t_file - t0_file) / (1 + e)
        "forcing_omega_rad_s": Om / (1 + e),
        "forcing_frequency_hz": Om / (1 + e) / (2 * math.pi),
        "forcing_phase0_rad": float(
            np.mod(Om * (t_true0 - meas.trigger_offset / (1 + e)), 2 * math.pi)
        ),
        "record_start_tau": float(tau[0]),
        "impacts_t": imp_t_file,
        "impacts_v_before": f["impacts_v_before"][inside],
        "impacts_per_period": float(np.sum(inside)) / (n * dt_true / T),
        "lle_record": lle_record,
    }
    mdict = dataclasses.asdict(meas)
    mdict.update(sample_rate=fs, channel_ranges=ranges, transient=transient)
    return Capture.make(
        t_file,
        out["V_s"],
        out["V_q"],
        out.get("V_3"),
        sample_interval=dt,
        source={
            "format": "synthetic",
            "instrument": f"synthetic ({model})",
            "truth": truth,
            "measurement": mdict,
        },
    )
