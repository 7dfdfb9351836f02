"""Score an oscilloscope capture against a model at the level of the attractor.

A capture has no known initial condition, so :func:`score_capture` compares what does not depend
on it: the forcing (:func:`estimate_forcing`), the Poincare section at a forcing phase
(:func:`poincare_section`) and its detected period, the impacts (:func:`detect_impacts`), the
sliced Wasserstein distances to the model against their noise floors (the model captured through
the same measurement model), and the time-series LLE.  Several captures at several forcing
frequencies give a measured bifurcation diagram (:func:`measured_bifurcation`).  Each step, its
method and why: :doc:`/guide/captures`, "Scoring a capture in detail".
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Sequence
from fractions import Fraction
from typing import Any

import numpy as np

from precise_impact.analysis.orbits.branch import brute_force_diagram
from precise_impact.analysis.periodicity import detect_period_noisy
from precise_impact.core.budget import Deadline, check_work, parse_max_time, run_cost
from precise_impact.core.impact import reset_velocity
from precise_impact.core.precision import Precision
from precise_impact.core.result import ResultMixin, unit_column
from precise_impact.errors import ParameterError, check_type
from precise_impact.io.figures import check_plot_path, finish, new_figure
from precise_impact.io.markdown import table as md_table
from precise_impact.lab.capture import (
    Capture,
    adc_step,
    channel_noise,
    check_channels,
    design_of,
    noise_sigma,
)
from precise_impact.lab.scope_files import read_capture
from precise_impact.lab.synth import Measurement, synth_capture
from precise_impact.models.circuit.components import circuit_scales
from precise_impact.scenes.scene import Scene, load_scene
from precise_impact.verification.scores import sliced_wasserstein, wasserstein_1d

#: What a capture argument may be.
_CAPTURE_ARG = "a Capture or a capture file's path (str or os.PathLike)"

__all__ = [
    "ForcingEstimate",
    "CaptureScore",
    "MeasuredBifurcation",
    "estimate_forcing",
    "fit_sinusoid",
    "noise_sigma",
    "adc_step",
    "channel_noise",
    "poincare_section",
    "detect_impacts",
    "analyse_capture",
    "score_capture",
    "measured_bifurcation",
    "SECTION_HALF_WINDOW",
    "IMPACT_SIGMAS",
    "SEPARATION_THRESHOLD",
]

#: Samples on each side of a section time in its local fit (capped at a tenth of a period).
SECTION_HALF_WINDOW = 8
#: Impact threshold, in standard deviations of a one-sample difference of x'.
IMPACT_SIGMAS = 8.0
#: ``separated`` when the section distance exceeds this many times ``sw_floor_max``.  Derived
#: from the verdict's false positives (``benchmarks/bench_capture_separation.py``,
#: ``benchmarks/results/capture_separation.md``): an ideal capture scored against the ideal
#: model (30 independent records per condition, the default measurement: 8 bits, 1 % noise,
#: 200 periods) gives ratios SW / sw_floor_max of median 0.85, max 1.85 at eta = 0.74 and
#: median 0.31, max 0.49 at 0.712: 0 of 60 above 3, a false-positive rate below 5 % at 95 %
#: confidence (the rule of three, 3/60) and ~3e-7 under a log-normal fit of the 0.74 ratios
#: (log-mean -0.17, log-sd 0.25; 1.85 is the fit's 3-sigma point).  The datasheet
#: switched-capacitor capture stays separated: 177..231 at 0.74, 5.9..7.0 at 0.712.
SEPARATION_THRESHOLD = 3.0


# ============================================================================ forcing
@dataclasses.dataclass
class ForcingEstimate(ResultMixin):
    """The forcing as the capture's time base sees it: ``V_3 = A cos(omega t + phase0)``.

    Attributes
    ----------
    omega : float
        Angular frequency [rad/s].
    frequency_hz : float
        ``omega / 2 pi``.
    phase0 : float
        Forcing phase at ``t = 0`` [rad], in ``[0, 2 pi)``.
    amplitude : float
        ``A`` [V] (of ``V_3``; of ``V_s``'s fundamental when estimated from ``V_s``).
    omega_stderr : float
        Standard error of ``omega`` from the fit's covariance and residual [rad/s].
    source : str
        ``'V_3'`` or ``'V_s'``.
    phase_source : str
        How ``phase0`` was referred to the forcing.
    """

    omega: float
    frequency_hz: float
    phase0: float
    amplitude: float
    omega_stderr: float
    source: str
    phase_source: str
    iterations: int = 0


def _spectral_peak(t: np.ndarray, y: np.ndarray, lo: float | None, hi: float | None) -> float:
    """Angular frequency of the largest peak of ``y``'s Hann-windowed spectrum (zero-padded
    4x, parabolic interpolation of the log magnitude) within ``[lo, hi]`` rad/s."""
    n = len(y)
    dt = float(t[1] - t[0])
    m = 1 << int(math.ceil(math.log2(4 * n)))
    spec = np.abs(np.fft.rfft((y - y.mean()) * np.hanning(n), m))
    w = 2 * math.pi * np.fft.rfftfreq(m, dt)
    mask = np.ones_like(w, dtype=bool)
    mask[0] = False
    if lo is not None:
        mask &= w >= lo
    if hi is not None:
        mask &= w <= hi
    if not mask.any():
        raise ParameterError("omega_hint", (lo, hi), "a band the capture's spectrum covers")
    k = int(np.flatnonzero(mask)[np.argmax(spec[mask])])
    if 0 < k < len(spec) - 1:
        a, b, c = np.log(spec[k - 1 : k + 2] + 1e-300)
        den = a - 2 * b + c
        d = 0.5 * (a - c) / den if den != 0 else 0.0
        return float(w[k] + d * (w[1] - w[0]))
    return float(w[k])


def fit_sinusoid(
    t: np.ndarray,
    y: np.ndarray,
    omega0: float,
    harmonics: int = 1,
    max_iter: int = 30,
    weights: np.ndarray | None = None,
) -> dict[str, Any]:
    """Least-squares fit of ``c + sum_h a_h cos(h w t) + b_h sin(h w t)`` with the frequency
    ``w`` refined by Gauss-Newton on all parameters from ``omega0``.

    The one forcing-sinusoid fitter of the package (the captures' :func:`estimate_forcing`
    and the netlists' :func:`precise_impact.lab.netlist.fit_forcing` use it).

    Parameters
    ----------
    t, y : numpy.ndarray
        Times and values.
    omega0 : float
        Starting angular frequency.
    harmonics : int, default 1
        Harmonics fitted.
    max_iter : int, default 30
        Gauss-Newton iterations at most (stops when a step is below ``1e-13 w``).
    weights : numpy.ndarray or None, default ``None``
        Per-point weights (e.g. the time each point stands for on a simulator's non-uniform
        grid); ``None``: equal.  They are normalised to a mean of 1.

    Returns
    -------
    dict
        ``{'omega', 'a', 'b', 'c', 'omega_stderr', 'sigma', 'iterations'}`` (``a``, ``b`` per
        harmonic, referred to ``t = 0``), and for error propagation ``'tm'`` (the centre time
        the fit is parametrised about), ``'a_centred'``, ``'b_centred'`` (referred to ``tm``),
        ``'cov'`` (covariance of ``[c, a_centred..., b_centred..., w]``: ``sigma^2 (J^T W
        J)^-1``) and ``'rms'`` (the weighted rms residual, ``sqrt(sum W r^2 / n)``).
    """
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    if weights is None:
        sq = None
    else:
        wts = np.maximum(np.asarray(weights, float), 0.0)
        sq = np.sqrt(wts * (len(t) / max(float(wts.sum()), 1e-300)))
    tm = 0.5 * (t[0] + t[-1])
    tc = t - tm  # centred: the frequency and the phase decouple
    w = float(omega0)
    H = int(harmonics)
    hs = np.arange(1, H + 1)
    it = 0
    coef = np.zeros(2 * H + 1)
    J = np.empty((len(t), 2 * H + 2))

    def solve(A: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        if sq is None:
            return np.linalg.lstsq(A, rhs, rcond=None)[0]
        return np.linalg.lstsq(A * sq[:, None], rhs * sq, rcond=None)[0]

    for it in range(1, max_iter + 1):  # noqa: B007 - the count is reported
        ph = np.outer(tc, hs * w)
        C, S = np.cos(ph), np.sin(ph)
        B = np.column_stack([np.ones_like(tc), C, S])
        coef = solve(B, y)
        a, b = coef[1 : H + 1], coef[H + 1 :]
        dw = (-S * a + C * b) * (tc[:, None] * hs)
        J[:, :-1] = B
        J[:, -1] = dw.sum(axis=1)
        r = y - B @ coef
        step = solve(J, r)
        w += float(step[-1])
        if abs(step[-1]) <= 1e-13 * abs(w):
            break
    ph = np.outer(tc, hs * w)
    B = np.column_stack([np.ones_like(tc), np.cos(ph), np.sin(ph)])
    coef = solve(B, y)
    r = y - B @ coef
    if sq is not None:
        r = r * sq
    dof = max(1, len(t) - (2 * H + 2))
    sigma = float(np.sqrt(r @ r / dof))
    a, b = coef[1 : H + 1], coef[H + 1 :]
    J[:, :-1] = B
    J[:, -1] = ((-np.sin(ph) * a + np.cos(ph) * b) * (tc[:, None] * hs)).sum(axis=1)
    Jw = J if sq is None else J * sq[:, None]
    try:
        cov = np.linalg.inv(Jw.T @ Jw) * sigma**2
        stderr = float(math.sqrt(max(cov[-1, -1], 0.0)))
    except np.linalg.LinAlgError:
        cov = np.full((2 * H + 2, 2 * H + 2), math.nan)
        stderr = math.nan
    # refer the harmonics to t = 0: cos(h w (t - tm)) = cos(h w t - h w tm)
    shift = hs * w * tm
    A0 = a * np.cos(shift) - b * np.sin(shift)
    B0 = a * np.sin(shift) + b * np.cos(shift)
    return {
        "omega": w,
        "a": A0,
        "b": B0,
        "c": float(coef[0]),
        "omega_stderr": stderr,
        "sigma": sigma,
        "iterations": it,
        "tm": tm,
        "a_centred": a,
        "b_centred": b,
        "cov": cov,
        "rms": float(np.sqrt(r @ r / len(t))),
    }


def _phase(a: float, b: float) -> float:
    """``phi`` of ``a cos(wt) + b sin(wt) = A cos(wt + phi)``, in ``[0, 2 pi)``."""
    return float(np.mod(math.atan2(-b, a), 2 * math.pi))


def estimate_forcing(
    capture: Capture,
    omega_hint: float | None = None,
    source: str = "auto",
    lag: float | None = None,
) -> ForcingEstimate:
    """The forcing's frequency and phase from ``V_3`` (or ``V_s``).

    Parameters
    ----------
    capture : Capture
    omega_hint : float or None
        The design's ``Omega`` [rad/s]: the spectral search is limited to +-20 % of it
        (needed for ``V_s``, whose subharmonics can be stronger than its line at ``Omega``).
    source : {'auto', 'V_3', 'V_s'}
        ``'auto'``: ``V_3`` if the capture has it.
    lag : float or None
        For ``V_s``: the phase of ``V_s``'s fundamental minus the forcing's (the model's; see
        :func:`score_capture`); ``None`` leaves ``phase0`` as ``V_s``'s own phase.
    """
    if source not in ("auto", "V_3", "V_s"):
        raise ParameterError("source", source, "'auto', 'V_3' or 'V_s'")
    if source == "auto":
        source = "V_3" if capture.V_3 is not None else "V_s"
    if source == "V_3" and capture.V_3 is None:
        raise ParameterError("source", "V_3", "a capture with a V_3 channel")
    y = capture.V_3 if source == "V_3" else capture.V_s
    assert y is not None
    band = (0.8 * omega_hint, 1.2 * omega_hint) if omega_hint else (None, None)
    if source == "V_s" and omega_hint is None:
        raise ParameterError("omega_hint", None, "the design's Omega to find the forcing in V_s")
    w0 = _spectral_peak(capture.t, y, *band)
    fit = fit_sinusoid(capture.t, y, w0, harmonics=1 if source == "V_3" else 3)
    phi = _phase(fit["a"][0], fit["b"][0])
    phase_source = "V_3 fit"
    if source == "V_s":
        if lag is None:
            phase_source = "V_s fundamental (not referred to the forcing)"
        else:
            phi = float(np.mod(phi - lag, 2 * math.pi))
            phase_source = "V_s fundamental minus the model's lag of V_s behind V_3"
    return ForcingEstimate(
        omega=fit["omega"],
        frequency_hz=fit["omega"] / (2 * math.pi),
        phase0=phi,
        amplitude=float(math.hypot(fit["a"][0], fit["b"][0])),
        omega_stderr=fit["omega_stderr"],
        source=source,
        phase_source=phase_source,
        iterations=fit["iterations"],
    )


# ================================================================ noise, section, impacts
def detect_impacts(
    x: np.ndarray,
    v: np.ndarray,
    x_w: float,
    sigma_x: float,
    sigma_v: float,
    dt_tau: float,
    half_window: int = SECTION_HALF_WINDOW,
    R: float = 1.0,
) -> dict[str, Any]:
    """Impacts in a sampled ``(x, x')``: a one-sample drop of ``x'`` by more than
    :data:`IMPACT_SIGMAS` ``sqrt(2) sigma_v`` with ``x`` within reach of the wall on both sides.

    Returns ``{'index', 'v', 'at', 'threshold'}``: the sample before each impact, its velocity
    before the impact, the impact instant (fractional sample index) and the jump threshold in
    units of ``x'``.  The velocity is the least-squares ``v-`` of the two one-sided fits at the
    impact instant, ``v_l = v-`` and ``v_r = v+ = k v-`` with ``k = -R`` from the reset law
    (:func:`precise_impact.core.impact.reset_velocity`): ``v- = (v_l + k v_r) / (1 + k^2)``
    (``(v_l - v_r) / 2`` for ``R = 1``; that half-jump was ``(1 + R) / 2 v-`` for ``R < 1``).
    """

    k_reset = float(reset_velocity(1.0, R))
    dv = np.diff(v)
    thr = IMPACT_SIGMAS * math.sqrt(2) * sigma_v
    reach = 0.5 * np.abs(dv) * dt_tau + 6 * sigma_x + 1e-12
    near = (x[:-1] > x_w - reach) & (x[1:] > x_w - reach)
    idx = np.flatnonzero((dv < -thr) & near)
    # one impact per jump: a jump spread over two samples (an impact at a sample instant)
    if len(idx) > 1:
        keep = np.concatenate(([True], np.diff(idx) > 1))
        idx = idx[keep]
    vel = np.empty(len(idx))
    bounds = np.concatenate(([-1], idx, [len(v) - 1]))
    at = np.empty(len(idx))
    for k, j in enumerate(idx):
        lo = max(bounds[k] + 1, j - half_window + 1)
        hi = min(bounds[k + 2], j + 1 + half_window)
        il, ir = np.arange(lo, j + 1), np.arange(j + 1, hi)
        # the impact instant: where the left-side quadratic of x reaches the wall inside the
        # interval (its middle if it does not); both sides' quadratics of x' evaluated there
        # (linear fits at the middle were 0.026 off on noise-free data: x'' over 8 samples)
        s = _wall_crossing(il, x[lo : j + 1], x_w, j)
        vl = _poly_at(il, v[lo : j + 1], s)
        vr = _poly_at(ir, v[j + 1 : hi], s)
        vel[k] = (vl + k_reset * vr) / (1.0 + k_reset * k_reset)
        at[k] = s
    return {"index": idx, "v": vel, "at": at, "threshold": thr}


def _poly_at(i: np.ndarray, y: np.ndarray, at: float) -> float:
    """A least-squares quadratic through ``(i, y)`` (a line below 4 points) at ``at``."""
    if len(i) < 4:
        return _line_at(i, y, at)
    p = np.polyfit(i - at, y, 2)
    return float(p[-1])


def _wall_crossing(i: np.ndarray, x: np.ndarray, x_w: float, j: int) -> float:
    """The sample-index time in ``[j, j + 1]`` where the quadratic through ``(i, x)`` reaches
    ``x_w`` (``j + 0.5`` when it does not, or with fewer than 4 points)."""
    if len(i) < 4:
        return j + 0.5
    c2, c1, c0 = np.polyfit(i - j, x, 2)
    roots = np.roots([c2, c1, c0 - x_w])
    real = [float(r.real) for r in roots if abs(r.imag) < 1e-12 and -0.25 <= r.real <= 1.25]
    return j + min(max(real[0], 0.0), 1.0) if real else j + 0.5


def _line_at(i: np.ndarray, y: np.ndarray, at: float) -> float:
    if len(i) == 0:
        return math.nan
    if len(i) == 1:
        return float(y[0])
    p = np.polyfit(i - at, y, 1)
    return float(p[1])


def poincare_section(
    x: np.ndarray,
    v: np.ndarray,
    t: np.ndarray,
    omega: float,
    phase0: float,
    section_phase: float = 0.0,
    impacts: np.ndarray | None = None,
    half_window: int = SECTION_HALF_WINDOW,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(t_k, x_k, v_k)`` where the forcing phase ``omega t + phase0`` is ``section_phase`` mod
    2 pi: local linear least-squares fits of ``+-half_window`` samples (one side only where an
    impact falls in the window; ``impacts`` are the sample indices before each impact)."""
    dt = float(t[1] - t[0])
    k0 = math.ceil((omega * (t[0] + half_window * dt) + phase0 - section_phase) / (2 * math.pi))
    k1 = math.floor((omega * (t[-1] - half_window * dt) + phase0 - section_phase) / (2 * math.pi))
    if k1 < k0:
        return np.empty(0), np.empty(0), np.empty(0)
    ks = np.arange(k0, k1 + 1)
    tk = (2 * math.pi * ks - phase0 + section_phase) / omega
    fi = (tk - t[0]) / dt
    i0 = np.floor(fi).astype(int)
    offs = np.arange(-half_window + 1, half_window + 1)
    J = np.clip(i0[:, None] + offs, 0, len(t) - 1)
    u = J - fi[:, None]

    def fit(y: np.ndarray) -> np.ndarray:
        Y = y[J]
        um, ym = u.mean(axis=1), Y.mean(axis=1)
        cov = ((u - um[:, None]) * (Y - ym[:, None])).sum(axis=1)
        var = ((u - um[:, None]) ** 2).sum(axis=1)
        return ym - cov / var * um

    xs, vs = fit(x), fit(v)
    if impacts is not None and len(impacts):
        flag = np.zeros(len(t), dtype=int)
        flag[impacts] = 1
        c = np.concatenate(([0], np.cumsum(flag)))
        lo, hi = J[:, 0], J[:, -1]
        hit = np.flatnonzero(c[hi] - c[lo] > 0)  # an impact between lo and hi
        for q in hit:
            js = J[q]
            m = int(impacts[np.searchsorted(impacts, js[0])])  # impact between m and m+1
            side = js[js <= m] if fi[q] <= m + 0.5 else js[js > m]
            if len(side) < 2:
                side = js[js <= m] if len(js[js <= m]) >= len(js[js > m]) else js[js > m]
            xs[q] = _line_at(side.astype(float), x[side], fi[q])
            vs[q] = _line_at(side.astype(float), v[side], fi[q])
    return tk, xs, vs


def _section_noise_excess(
    capture: Capture, forcing: ForcingEstimate, section_phase: float, hw: int, noise: dict
) -> float:
    """How much noisier a section point is than the white noise predicts, measured on ``V_3``
    (a pure sinusoid: its residual is the channel's whole noise, 1/f included): the spread of
    the residual's section points over ``white / sqrt(2 hw)``, at least 1.  1 without ``V_3``.

    The white noise is measured on the highest frequencies (second differences); 1/f noise
    puts most of its power below them, where a section point (a fit of ``2 hw`` samples) does
    not average it away: 0.3 % of full scale of 1/f noise made period 3 fail the chi-square
    test at eta = 0.74 until this factor was applied."""
    if capture.V_3 is None or forcing.source != "V_3":
        return 1.0
    r = capture.V_3 - forcing.amplitude * np.cos(forcing.omega * capture.t + forcing.phase0)
    r = r - float(np.median(r))
    _, pts, _ = poincare_section(
        r, r, capture.t, forcing.omega, forcing.phase0, section_phase, None, hw
    )
    white = noise["V_3"]["sigma"] / math.sqrt(2 * hw)
    if len(pts) < 8 or not white > 0:
        return 1.0
    spread = 1.4826 * float(np.median(np.abs(pts - np.median(pts))))
    return max(1.0, spread / white)


def analyse_capture(
    capture: Capture,
    design: Any,
    forcing: ForcingEstimate | None = None,
    section_phase: float = 0.0,
    max_period: int = 16,
    R: float | None = None,
) -> dict[str, Any]:
    """Forcing, noise, impacts, Poincare section and period of one capture (no model).

    ``R``: the restitution coefficient of the impacts' reset law (``None``: the design's
    when ``design`` is a Params or Scene, else 1: the circuit's reversal is elastic)."""
    if R is None:
        R = float(getattr(getattr(design, "params", design), "R", 1))
    comp = design_of(design)
    if forcing is None:
        forcing = estimate_forcing(capture, float(comp.Omega))
    m = capture.to_mechanical(comp, forcing.omega, forcing.phase0)
    noise = {k: channel_noise(y) for k, y in capture.channels.items()}
    sc = circuit_scales(comp)
    sx = noise["V_s"]["sigma"] / abs(sc.volts_per_x)
    sv = noise["V_q"]["sigma"] / abs(sc.volts_per_v)
    dt_tau = capture.sample_interval * m.omega
    imp = detect_impacts(m.x, m.v, m.x_w, sx, sv, dt_tau, R=R)
    per_period = 2 * math.pi / forcing.omega / capture.sample_interval
    hw = max(1, min(SECTION_HALF_WINDOW, int(0.05 * per_period)))
    tk, xs, vs = poincare_section(
        m.x, m.v, capture.t, forcing.omega, forcing.phase0, section_phase, imp["index"], hw
    )
    # a section point is the intercept of a least-squares line through 2 hw samples at (about)
    # their centre: its noise is sigma / sqrt(2 hw)
    s_x, s_v = sx / math.sqrt(2 * hw), sv / math.sqrt(2 * hw)
    excess = _section_noise_excess(capture, forcing, section_phase, hw, noise)
    s_x, s_v = s_x * excess, s_v * excess
    period = detect_period_noisy(xs, vs, s_x, s_v, max_period) if len(xs) else 0
    periods = capture.duration * forcing.omega / (2 * math.pi)
    return {
        "forcing": forcing,
        "eta": forcing.omega / m.omega,
        "noise": {
            **noise,
            "x": sx,
            "v": sv,
            "section_x": s_x,
            "section_v": s_v,
            "section_excess": excess,
        },
        "section": {"t": tk, "x": xs, "v": vs, "phase": section_phase},
        "half_window": hw,
        "period": period,
        "impacts": {
            "count": len(imp["index"]),
            "per_period": len(imp["index"]) / periods if periods > 0 else math.nan,
            "t": capture.t[0] + imp["at"] * capture.sample_interval,
            "v": imp["v"],
            "threshold_v": imp["threshold"],
        },
        "periods": periods,
    }


# ============================================================================ scoring
@dataclasses.dataclass
class CaptureScore(ResultMixin):
    """A capture scored against a model at the level of the attractor.

    Attributes
    ----------
    forcing : ForcingEstimate
    eta : float
        Measured ``Omega / omega`` (``omega`` of the design).
    period : int
        Detected period of the capture's Poincare section (0: none up to ``max_period``).
    period_model : int
        The same on the model's first synthetic capture.
    impacts : dict
        ``count``, ``per_period``, velocity ``mean``/``std``/``quantiles``, ``threshold_v``,
        the model's ``per_period_model``.
    sliced_wasserstein : float
        Mean SW distance of the capture's section cloud to the model captures' clouds.
    sw_floor : float
        Mean SW distance between the model captures' clouds (the noise floor).
    sw_floor_max : float
        The largest of those pairs and of ``sw_floor_halves``.
    sw_floor_halves : float
        SW distance between the capture's first and second half, divided by ``sqrt 2`` (the
        floor of clouds twice as large): a floor that does not depend on the noise model.
    impact_v_wasserstein, impact_v_floor : float or None
        The same for the impact velocities (1-Wasserstein); ``None`` when the capture or the
        model has no impacts (``impact_v_reason`` says which).
    impact_v_reason : str
        Why the impact-velocity distance is ``None`` (empty when it is not).
    sw_floor_quantisation : float
        An undithered ADC's code error on the distance (``2 q / sqrt(12 n)`` per section point
        of ``n`` samples, in ``(x, x')``; the standard quantisation model), 0 when the
        measured white noise exceeds a code.
    threshold : float
        :data:`SEPARATION_THRESHOLD` (its derivation and false-positive rate are there).
    separated : bool
        ``sliced_wasserstein > threshold * sw_floor_max``: the capture is off the model's
        attractor beyond what the measurement alone explains.
    section, section_model : dict
        The section clouds (``x``, ``v``).
    lle : dict or None
        The time-series LLE (:func:`~precise_impact.analysis.lyapunov.timeseries.timeseries_lle`;
        ``None`` with ``lle=False``).
    notes : list of str
        What the scorer noticed (e.g. a threshold, a missing forcing channel).

    See Also
    --------
    score_capture : makes it.
    precise_impact.analysis.lyapunov.timeseries.timeseries_lle : the LLE estimator.
    """

    scene: str
    model: str
    forcing: ForcingEstimate
    eta: float
    eta_model: float
    periods: float
    noise: dict
    period: int
    period_model: int
    impacts: dict
    sliced_wasserstein: float
    sw_floor: float
    sw_floor_max: float
    sw_floor_halves: float
    sw_floor_quantisation: float
    threshold: float
    impact_v_wasserstein: float | None
    impact_v_floor: float | None
    impact_v_reason: str
    separated: bool
    floor_method: str
    section: dict
    section_model: dict
    source: dict
    lle: dict | None = None
    notes: list = dataclasses.field(default_factory=list)

    def _tables(self) -> dict:
        """``to_dataframe()`` tables ``section`` (the capture's Poincare section, dimensionless)
        and ``section_model`` (the model captures' section)."""

        def cloud(sec: dict) -> dict:
            return {
                unit_column("x", "1"): np.asarray(sec["x"], dtype=float),
                unit_column("v", "1"): np.asarray(sec["v"], dtype=float),
            }

        return {
            "section": lambda: cloud(self.section),
            "section_model": lambda: cloud(self.section_model),
        }

    def to_dict(self, arrays: bool = False) -> dict[str, Any]:
        d = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        if not arrays:
            d["section"] = {"points": len(self.section["x"]), "phase": self.section["phase"]}
            d["section_model"] = {"points": len(self.section_model["x"])}
            d["impacts"] = {k: v for k, v in self.impacts.items() if k not in ("t", "v", "v_model")}
            if self.lle is not None:  # the estimate, not its divergence curves
                d["lle"] = {k: v for k, v in self.lle.items() if not isinstance(v, (list, tuple))}
        return d

    def _w1_text(self) -> str:
        """The impact-velocity distance with its floor, or ``none (why)``."""
        if self.impact_v_wasserstein is None or self.impact_v_floor is None:
            return f"none ({self.impact_v_reason})"
        return f"{self.impact_v_wasserstein:.4g} vs floor {self.impact_v_floor:.4g}"

    def summary_lines(self) -> list[str]:
        """The score in a few lines of text (what ``capture score`` prints)."""
        f = self.forcing
        out = [
            f"forcing: {f.frequency_hz:.9g} Hz (+- {f.omega_stderr / 2 / math.pi:.2g}) from "
            f"{f.source}, phase {f.phase0:.4f} rad; eta measured {self.eta:.6f}",
            f"period {self.period} (model {self.period_model}); impacts/period "
            f"{self.impacts['per_period']:.4f} (model {self.impacts['per_period_model']:.4f})",
            f"sliced Wasserstein {self.sliced_wasserstein:.4g} vs {self.threshold:g} x floor max "
            f"{self.sw_floor_max:.4g} (mean floor {self.sw_floor:.4g}); impact velocities W1 "
            f"{self._w1_text()}: "
            + ("SEPARATED from the model" if self.separated else "within the model's noise floor"),
        ]
        if self.lle is not None and self.lle.get("lle") is not None:
            status = self.lle.get("status", "ok")
            out.append(
                f"LLE (time series, {self.lle.get('method')}): {self.lle['lle']:.4g} +- "
                f"{self.lle.get('lle_stderr') or float('nan'):.2g} per unit tau"
                + ("" if status == "ok" else f" ({status}: {self.lle.get('reason')})")
            )
        elif self.lle is not None:
            out.append(f"LLE: none ({self.lle.get('status')}: {self.lle.get('reason')})")
        return out + ["note: " + n for n in self.notes]

    def markdown(self, figure: str | None = None) -> str:
        """A report of the score (Markdown): the capture, the model, each figure beside the
        model's and its noise floor, the verdict; ``figure``: a figure file to link."""
        f = self.forcing
        src = self.source or {}
        lle = self.lle or {}
        rows = [
            (
                "forcing frequency [Hz]",
                f"{f.frequency_hz:.9g} +- {f.omega_stderr / 2 / math.pi:.2g}",
                f"{f.frequency_hz * self.eta_model / self.eta:.9g}",  # eta_model omega / 2 pi
                f"from {f.source}",
            ),
            ("eta (Omega / omega)", f"{self.eta:.6f}", f"{self.eta_model:g}", ""),
            ("period of the section", str(self.period), str(self.period_model), "0: none <= max"),
            (
                "impacts per period",
                f"{self.impacts['per_period']:.4f}",
                f"{self.impacts['per_period_model']:.4f}",
                "",
            ),
            (
                "section distance (sliced W)",
                f"{self.sliced_wasserstein:.4g}",
                f"floor {self.sw_floor:.4g} (max {self.sw_floor_max:.4g})",
                "floor: below",
            ),
            (
                "impact velocities (W1)",
                "none" if self.impact_v_wasserstein is None else f"{self.impact_v_wasserstein:.4g}",
                "" if self.impact_v_floor is None else f"floor {self.impact_v_floor:.4g}",
                self.impact_v_reason,
            ),
        ]
        if lle.get("lle") is not None:
            rows.append(
                (
                    "LLE, time series [1/tau]",
                    f"{lle['lle']:.4g} +- {lle.get('lle_stderr') or float('nan'):.2g}",
                    "",
                    str(lle.get("method", ""))
                    + (
                        ""
                        if lle.get("status", "ok") == "ok"
                        else f"; {lle.get('status')}: {lle.get('reason')}"
                    ),
                )
            )
        elif lle:
            rows.append(
                ("LLE, time series", "none", "", f"{lle.get('status')}: {lle.get('reason')}")
            )
        lines = [
            f"# Capture score: {src.get('path', src.get('format', 'capture'))}",
            "",
            f"Against scene `{self.scene}` on model `{self.model}`, {self.periods:.1f} forcing "
            f"periods captured ({src.get('format', '?')} layout).",
            "",
        ]
        lines += md_table(("figure", "capture", "model", "note"), rows)
        verdict = (
            "**separated**: the capture is off the model's attractor beyond what the "
            "measurement alone explains (section distance "
            f"{self.sliced_wasserstein:.4g} > {self.threshold:g} x the largest floor "
            f"{self.sw_floor_max:.4g})"
            if self.separated
            else "**within the noise floor**: the measurement cannot tell it from the model "
            f"(section distance {self.sliced_wasserstein:.4g} <= {self.threshold:g} x the "
            f"largest floor {self.sw_floor_max:.4g})"
        )
        lines += ["", "Noise floor: " + self.floor_method + ".", "", "Verdict: " + verdict + "."]
        if self.notes:
            lines += [""] + [f"- {n}" for n in self.notes]
        if figure:
            lines += ["", f"![sections and impact velocities]({figure})"]
        return "\n".join(lines) + "\n"

    def plot(self, path: Any = None, units: str = "dimensionless"):
        """Poincare sections (capture over model), impact-velocity distributions, and the
        figures; written to ``path`` if given."""

        check_plot_path(path)
        fig, axes = new_figure(1, 2, figsize=(10.0, 4.4))
        ax = axes[0, 0]
        sm = self.section_model
        ax.plot(sm["x"], sm["v"], ".", ms=5, color="0.6", label=f"model ({self.model})")
        ax.plot(self.section["x"], self.section["v"], ".", ms=3, color="C3", label="capture")
        ax.set_xlabel("x (section)")
        ax.set_ylabel("x' (section)")
        ax.set_title(
            f"Poincare section at forcing phase {self.section['phase']:.2f}\n"
            f"period {self.period} (model {self.period_model}); SW {self.sliced_wasserstein:.3g}"
            f" vs {self.threshold:g} x floor max {self.sw_floor_max:.3g}",
            fontsize=9,
        )
        ax.legend(fontsize=8, loc="best")
        ax.grid(alpha=0.3)
        ax = axes[0, 1]
        vc = np.asarray(self.impacts.get("v", []), float)
        vm = np.asarray(self.impacts.get("v_model", []), float)
        hi = max([1e-3, *(a.max() for a in (vc, vm) if len(a))])
        bins = np.linspace(0, hi * 1.05, 40)
        if len(vm):
            ax.hist(vm, bins=bins, density=True, color="0.6", alpha=0.7, label="model")
        if len(vc):
            ax.hist(
                vc, bins=bins, density=True, histtype="step", color="C3", lw=1.5, label="capture"
            )
        ax.set_xlabel("impact velocity")
        ax.set_ylabel("density")
        ax.set_title(
            f"impacts/period {self.impacts['per_period']:.3f} (model "
            f"{self.impacts.get('per_period_model', math.nan):.3f}); W1 {self._w1_text()}",
            fontsize=9,
        )
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        fig.suptitle(
            f"capture vs {self.scene} on {self.model}: eta {self.eta:.5f} measured "
            f"(f = {self.forcing.frequency_hz:.6g} Hz from {self.forcing.source}); "
            + ("separated" if self.separated else "within the noise floor"),
            fontsize=10,
        )
        return finish(fig, path)


def _velocity_stats(v: np.ndarray) -> dict[str, Any]:
    v = np.asarray(v, float)
    v = v[np.isfinite(v)]
    if not len(v):
        return {"mean": None, "std": None, "quantiles": None}
    return {
        "mean": float(v.mean()),
        "std": float(v.std()),
        "quantiles": {f"{q:g}": float(np.quantile(v, q)) for q in (0.05, 0.25, 0.5, 0.75, 0.95)},
    }


def _lle_slot(capture: Capture, comp: Any, forcing: ForcingEstimate, notes: list) -> dict | None:
    """The time-series LLE of the capture in ``1/tau`` (the variational LLE's unit):
    :func:`precise_impact.analysis.lyapunov.timeseries.timeseries_lle` on the recorded state
    ``(x, x')`` with neighbours at equal forcing phase, when that module is installed."""
    try:
        from precise_impact.analysis.lyapunov.timeseries import (  # noqa: PLC0415 -- optional module
            timeseries_lle,
        )
    except ImportError:
        notes.append(
            "lle: left out (precise_impact.analysis.lyapunov.timeseries is not installed here)"
        )
        return None
    m = capture.to_mechanical(comp, forcing.omega, forcing.phase0)
    dt_tau = capture.sample_interval * m.omega
    try:
        res = timeseries_lle(
            np.column_stack([m.x, m.v]),
            dt_tau,
            period=2 * math.pi / m.eta,
            phase0=float(m.phase[0]) if m.phase is not None else 0.0,
        )
    except Exception as e:  # the estimator's own refusal is reported; the score stands
        notes.append(f"lle: {type(e).__name__}: {e}")
        return None
    return res.to_dict()


def _noise_surrogate(capture: Capture, forcing: ForcingEstimate, noise: dict) -> Any:
    """The capture's noise as a time series: ``V_3`` minus its fitted sinusoid (``None``
    without ``V_3``, or when its ADC step dominates its white noise: the residual would then
    be the code pattern of the sinusoid, not noise)."""
    if capture.V_3 is None or forcing.source != "V_3":
        return None
    n3 = noise["V_3"]
    if not n3["white"] > 0 or n3["step"] > 2 * n3["white"]:
        return None
    r = capture.V_3 - forcing.amplitude * np.cos(forcing.omega * capture.t + forcing.phase0)
    return r - float(np.median(r))


def _add_surrogate(ref: Capture, r: np.ndarray, noise: dict, rng: np.random.Generator) -> Capture:
    """``ref`` plus the capture's noise series ``r``, circularly shifted by an independent
    random offset per channel (the same spectrum, 1/f and hum included, an independent
    realisation) and scaled by the channel's white noise over ``V_3``'s."""
    chans = {}
    w3 = noise["V_3"]["white"]
    for k, y in ref.channels.items():
        scale = noise.get(k, noise["V_s"])["white"] / w3
        shifted = np.roll(r, int(rng.integers(len(r))))
        chans[k] = y + scale * np.resize(shifted, len(y))
    return Capture.make(
        ref.t, chans["V_s"], chans["V_q"], chans.get("V_3"), ref.sample_interval, ref.source
    )


def _requantised(ref: Capture, capture: Capture, noise: dict) -> Capture:
    """``ref`` on the capture's ADC grid, channel by channel (its step and offset)."""
    chans = {}
    for k, y in ref.channels.items():
        q = noise.get(k, {}).get("step", 0.0)
        src = capture.channels.get(k)
        if q > 0 and src is not None:
            off = float(src.min())
            y = off + q * np.round((y - off) / q)
        chans[k] = y
    return Capture.make(
        ref.t, chans["V_s"], chans["V_q"], chans.get("V_3"), ref.sample_interval, ref.source
    )


def _checked_score_args(
    capture: Any, channels: Any, floor_captures: Any, max_period: Any, section_phase: Any
) -> Capture:
    """The capture (read from its file if a path) after checking score_capture's arguments."""
    if not isinstance(capture, Capture):
        check_type(capture, (str, os.PathLike, list, tuple), "capture", _CAPTURE_ARG)
        capture = read_capture(capture, channels)
    if not isinstance(floor_captures, int) or not 2 <= floor_captures <= 8:
        raise ParameterError("floor_captures", floor_captures, "an integer 2..8")
    if not isinstance(max_period, int) or not 1 <= max_period <= 64:
        raise ParameterError("max_period", max_period, "an integer 1..64")
    if not (isinstance(section_phase, (int, float)) and math.isfinite(section_phase)):
        raise ParameterError("section_phase", section_phase, "a finite phase in rad")
    return capture


def _forcing_from_vs(capture: Capture, comp: Any, refs: list, ref_an: list) -> ForcingEstimate:
    """The forcing from ``V_s``, its phase referred through the model captures' lag of V_s."""
    # the model's lag of V_s's fundamental behind V_3, to refer V_s's phase to the forcing
    lags = []
    for r, a in zip(refs, ref_an, strict=True):
        fit = fit_sinusoid(r.t, r.V_s, a["forcing"].omega, harmonics=3)
        lags.append(_phase(fit["a"][0], fit["b"][0]) - a["forcing"].phase0)
    lag = float(np.angle(np.mean(np.exp(1j * np.asarray(lags)))))
    return estimate_forcing(capture, float(comp.Omega), "V_s", lag=lag)


def _impact_distance(vimp: np.ndarray, vms: list, pairs: list) -> tuple[Any, Any, str]:
    """``(W1, its floor, reason if none)`` of the impact velocities against the model's."""
    # the impact-velocity distance needs impacts on both sides: none, with the reason, else
    w1: float | None = None
    w1_floor: float | None = None
    w1_reason = ""
    if not len(vimp):
        w1_reason = "no impacts detected in the capture"
    elif not all(len(vm) for vm in vms):
        w1_reason = "no impacts in the model's captures"
    else:
        w1 = float(np.mean([wasserstein_1d(vimp, vm) for vm in vms]))
        w1_floor = float(np.mean([wasserstein_1d(vms[i], vms[j]) for i, j in pairs]))
    return w1, w1_floor, w1_reason


def _halves_floor(cloud: np.ndarray, p: int) -> float:
    """The SW distance of the capture's own halves (whole cycles each), over sqrt(2)."""
    # the capture's own halves: a floor that does not rest on the noise model (a 4-bit ADC's
    # undithered codes made the model captures' floor 17x too small); SW between clouds of
    # n/2 points is sqrt(2) that between clouds of n (the distance falls as n^-1/2).  On a
    # period-p orbit each half holds whole cycles (a half with one point of the cycle more than
    # the other differs by ~ spread p / n: 0.08 of the spread for 25 points)
    h = len(cloud) // 2
    if p > 0:
        h -= h % p
    return sliced_wasserstein(cloud[:h], cloud[h : 2 * h]) / math.sqrt(2) if h else 0.0


def _quantisation_floor(noise: dict, comp: Any, half_window: int, notes: list) -> float:
    """The code error of a section point of an undithered ADC (0 if dithered), noted."""
    # an undithered ADC (measured white noise below one code): the model captures' noise is
    # then measured as ~0 (the second differences of a coarse code sequence are mostly 0), so
    # they repeat one deterministic code pattern and their pairs' floor misses the code error
    # the capture's sub-code noise leaves.  Its size under the standard quantisation model (a
    # signal crossing codes within a section window: errors uniform, q^2/12, independent):
    # q / sqrt(12 * 2 hw) per section point and channel; two clouds each perturbed that much
    # differ by up to twice it in SW.  Noted in the report: the verdict rests on that model
    sc_ = circuit_scales(comp)
    n_fit = 2 * half_window
    dq = {
        k: (
            noise[k]["step"] / math.sqrt(12 * n_fit)
            if noise[k]["white"] < noise[k]["step"]
            else 0.0
        )
        for k in ("V_s", "V_q")
    }
    quant = 2 * math.hypot(dq["V_s"] / abs(sc_.volts_per_x), dq["V_q"] / abs(sc_.volts_per_v))
    if quant > 0:
        notes.append(
            "undithered quantisation: the ADC step exceeds the white noise "
            f"({', '.join(k for k in dq if dq[k] > 0)}); the floor includes the code error of "
            f"a section point, {quant:.3g} (2 q / sqrt(12 x {n_fit} samples), the standard "
            "quantisation model: the verdict rests on it)"
        )
    return quant


def _model_captures(
    capture: Capture,
    forcing: ForcingEstimate,
    noise: dict,
    periods: float,
    seed: int,
    run: tuple,
    floor_captures: int,
    max_time: Any,
    deadline: Deadline,
) -> list[Capture]:
    """The model captured ``floor_captures`` times through the capture's measurement model."""
    sc, model, eta_model, transient = run
    # the capture's measurement, measured, is the synthetic captures': its sample rate, its
    # record length, its white noise per channel and its ADC step
    white = {k: n["white"] for k, n in noise.items()}
    white.setdefault("V_3", white["V_s"])
    meas = Measurement(
        bits=0,
        noise=0.0,
        noise_v=white,
        sample_rate=capture.sample_rate,
        periods=max(2.0, periods),
        seed=seed,
    )
    surrogate = _noise_surrogate(capture, forcing, noise)
    if surrogate is not None:  # the scope's own noise, whatever its spectrum, replaces white
        meas = dataclasses.replace(meas, noise_v=0.0)
    rng = np.random.default_rng(seed)
    refs = []
    for i in range(floor_captures):
        r = synth_capture(
            sc,
            model,
            eta=eta_model,
            measurement=dataclasses.replace(meas, seed=seed + 1 + i),
            transient=transient,
            max_time=max_time,
        )
        deadline.check(f"model capture {i + 1} of {floor_captures}")
        if surrogate is not None:
            r = _add_surrogate(r, surrogate, noise, rng)
        refs.append(_requantised(r, capture, noise))
    return refs


def _check_probes(capture: Capture, comp: Any, notes: list) -> None:
    """Refuse wrong, swapped or inverted probes; note channels near clipping."""
    # wrong, swapped or inverted probes and clipped channels are refused before any scoring
    chk = check_channels(capture, comp)
    for k, share in chk["clipped"].items():
        if share > 0.5 * chk["clip_limit"][k]:
            notes.append(f"{k}: {share:.0%} of its samples at one rail (clipping?)")


def _model_eta(eta: Any, eta_meas: float) -> Any:
    """The model's ``eta``: the measured one (as a fraction) or the one given."""
    if eta == "measured":
        eta_model: Any = Fraction(eta_meas).limit_denominator(10**9)
    else:
        eta_model = eta
    return eta_model


def _impacts_record(an: dict, vimp: np.ndarray, vms: list, ref_an: list) -> dict[str, Any]:
    """The score's ``impacts`` field: the capture's impacts beside the model captures'."""
    return {
        "count": an["impacts"]["count"],
        "per_period": an["impacts"]["per_period"],
        "per_period_model": float(np.mean([a["impacts"]["per_period"] for a in ref_an])),
        "threshold_v": an["impacts"]["threshold_v"],
        **_velocity_stats(vimp),
        "t": an["impacts"]["t"],
        "v": vimp,
        "v_model": np.concatenate(vms) if vms else np.empty(0),
    }


def _note_short_record(periods: float, max_period: int, notes: list) -> None:
    """Note a record too short to detect periods up to ``max_period``."""
    if periods < 2 * max_period + max_period + 2:
        notes.append(
            f"record of {periods:.1f} periods: periods up to {max_period} need "
            f">= {3 * max_period + 2}"
        )


def score_capture(
    capture: Capture | str | os.PathLike,
    scene: Any = "fig6-period3-ideal",
    model: str | None = None,
    *,
    channels: Any = None,
    section_phase: float = 0.0,
    max_period: int = 16,
    floor_captures: int = 3,
    transient: int = 100,
    eta: Any = None,
    seed: int = 0,
    lle: bool = True,
    max_time: Any = None,
) -> CaptureScore:
    """Score a capture against ``scene`` on ``model`` at the level of the attractor.

    Parameters
    ----------
    capture : Capture or path
        A capture (or a file :func:`~precise_impact.lab.scope_files.read_capture` reads, with
        ``channels``).
    scene : str, Path or Scene, default ``'fig6-period3-ideal'``
        The design (component values) and parameters the capture is compared with.
    model : str or None
        The circuit model of the reference (``circuit``, ``switched-capacitor``, ``spice``);
        ``None`` is the scene's.
    channels : str, sequence, dict or None, default ``None``
        When ``capture`` is a path: the file's channels for ``V_s``, ``V_q`` (and ``V_3``),
        :func:`~precise_impact.lab.scope_files.parse_channels`.
    section_phase : float, default 0
        Forcing phase of the Poincare section [rad].
    max_period : int, default 16
        Largest period detected.
    floor_captures : int, default 3
        Synthetic captures of the model (2..8): the reference cloud and the noise floor.
    transient : int, default 100
        Model periods discarded before each synthetic capture.
    eta : decimal, ``'measured'`` or None
        The model's forcing ratio: the scene's (``None``) or the capture's measured one.
    seed : int, default 0
        Seed of the model captures.
    lle : bool, default True
        Estimate the LLE from the time series
        (:func:`~precise_impact.analysis.lyapunov.timeseries.timeseries_lle`; a periodic
        capture gives none, with the reason).
    max_time : float or None, default ``None``
        Time budget [s] of the whole score, enforced while it runs (each model capture's
        run is checked against what is left before it starts;
        :class:`~precise_impact.errors.BudgetExceededError` once it has run out).

    Returns
    -------
    CaptureScore
        The forcing estimate, the section's period, impact statistics, the sliced Wasserstein
        distance of the sections with its noise floor and the verdict (``separated``), the
        LLE; ``markdown()`` is the report, ``plot()`` the figure.

    See Also
    --------
    precise_impact.lab.synth.synth_capture : captures with a known truth.
    measured_bifurcation : several captures over the computed diagram.

    Examples
    --------
    >>> from precise_impact import score_capture, synth_capture
    >>> cap = synth_capture("fig6-period2-datasheet", periods=60, transient=50)
    >>> s = score_capture(cap, "fig6-period3-ideal", floor_captures=2, transient=50, lle=False)
    >>> s.period, s.period_model, s.separated
    (2, 3, True)
    """

    deadline = Deadline(None if max_time is None else parse_max_time(max_time), "capture score")
    capture = _checked_score_args(capture, channels, floor_captures, max_period, section_phase)
    sc = scene if isinstance(scene, Scene) else load_scene(scene)
    model = model or sc.model
    comp = sc.design()
    notes: list[str] = []
    _check_probes(capture, comp, notes)
    forcing = estimate_forcing(capture, float(comp.Omega))
    eta_meas = forcing.omega / float(comp.omega())
    eta_model = _model_eta(eta, eta_meas)
    periods = capture.duration * forcing.omega / (2 * math.pi)
    _note_short_record(periods, max_period, notes)
    noise = {k: channel_noise(v) for k, v in capture.channels.items()}
    refs = _model_captures(
        capture,
        forcing,
        noise,
        periods,
        seed,
        (sc, model, eta_model, transient),
        floor_captures,
        deadline if max_time is not None else None,
        deadline,
    )
    R = float(sc.params.R)
    ref_an = [analyse_capture(r, comp, None, section_phase, max_period, R) for r in refs]
    if capture.V_3 is None:
        forcing = _forcing_from_vs(capture, comp, refs, ref_an)
    an = analyse_capture(capture, comp, forcing, section_phase, max_period, R)
    cloud = np.column_stack([an["section"]["x"], an["section"]["v"]])
    clouds = [np.column_stack([a["section"]["x"], a["section"]["v"]]) for a in ref_an]
    sw = float(np.mean([sliced_wasserstein(cloud, c) for c in clouds]))
    pairs = [(i, j) for i in range(len(clouds)) for j in range(i + 1, len(clouds))]
    floors = [sliced_wasserstein(clouds[i], clouds[j]) for i, j in pairs]
    vimp = an["impacts"]["v"]
    vms = [a["impacts"]["v"] for a in ref_an]
    w1, w1_floor, w1_reason = _impact_distance(vimp, vms, pairs)
    impacts = _impacts_record(an, vimp, vms, ref_an)
    lle_res = _lle_slot(capture, comp, forcing, notes) if lle else None
    halves = _halves_floor(cloud, an["period"])
    quant = _quantisation_floor(noise, comp, an["half_window"], notes)
    floor_max = max(max(floors), halves, quant)
    sep = bool(sw > SEPARATION_THRESHOLD * floor_max)
    return CaptureScore(
        scene=sc.name,
        model=model,
        forcing=forcing,
        eta=eta_meas,
        eta_model=float(Fraction(refs[0].source["truth"]["eta"])),
        periods=periods,
        noise=an["noise"],
        period=an["period"],
        period_model=ref_an[0]["period"],
        impacts=impacts,
        sliced_wasserstein=sw,
        sw_floor=float(np.mean(floors)),
        sw_floor_max=float(floor_max),
        sw_floor_halves=float(halves),
        sw_floor_quantisation=float(quant),
        threshold=SEPARATION_THRESHOLD,
        impact_v_wasserstein=w1,
        impact_v_floor=w1_floor,
        impact_v_reason=w1_reason,
        separated=sep,
        floor_method=(
            f"{floor_captures} independent synthetic captures of the model through the capture's "
            "measurement model (sample rate, record length, measured white noise and ADC step "
            "per channel): the floor is the mean distance between them; sw_floor_max the "
            "largest of those, of the capture's own halves (/ sqrt 2) and of the undithered "
            f"quantisation bound; separated: SW > {SEPARATION_THRESHOLD:g} sw_floor_max"
        ),
        section={**an["section"]},
        section_model={"x": clouds[0][:, 0], "v": clouds[0][:, 1]},
        source={k: v for k, v in capture.source.items() if k != "truth"},
        lle=lle_res,
        notes=notes,
    )


# ============================================================================ bifurcation
@dataclasses.dataclass
class MeasuredBifurcation(ResultMixin):
    """Section ``x`` of several captures against their measured ``eta``, with the computed
    diagram of the mechanics.

    Attributes
    ----------
    eta : list of float
        Measured ``eta`` of each capture.
    x : list of arrays
        Each capture's Poincare-section ``x``.
    period : list of int
        Each capture's detected period.
    computed_eta, computed_x : numpy.ndarray
        The computed diagram (:func:`~precise_impact.analysis.orbits.branch.brute_force_diagram`):
        ``computed_x[i]`` the stroboscopic ``x`` at ``computed_eta[i]``.

    See Also
    --------
    measured_bifurcation : makes it.
    """

    scene: str
    eta: list
    x: list
    period: list
    computed_eta: np.ndarray
    computed_x: np.ndarray
    sources: list

    def _tables(self) -> dict:
        """``to_dataframe()`` tables ``points`` (every capture's section points: capture index,
        measured ``eta``, detected period, ``x``) and ``computed`` (the mechanics' diagram)."""

        def points() -> dict:
            n = [len(x) for x in self.x]
            return {
                "capture": np.repeat(np.arange(len(n)), n),
                unit_column("eta", "1"): np.repeat(np.asarray(self.eta, dtype=float), n),
                "period": np.repeat(np.asarray(self.period, dtype=int), n),
                unit_column("x", "1"): np.concatenate([np.asarray(x, dtype=float) for x in self.x])
                if n
                else np.zeros(0),
            }

        def computed() -> dict:
            k = self.computed_x.shape[1] if self.computed_x.ndim == 2 else 1
            return {
                unit_column("eta", "1"): np.repeat(np.asarray(self.computed_eta, dtype=float), k),
                unit_column("x", "1"): np.asarray(self.computed_x, dtype=float).ravel(),
            }

        return {"points": points, "computed": computed}

    def to_dict(self) -> dict[str, Any]:
        return {
            "scene": self.scene,
            "captures": [
                {"eta": e, "period": p, "points": len(x), "source": s}
                for e, p, x, s in zip(self.eta, self.period, self.x, self.sources, strict=True)
            ],
            "computed_eta": self.computed_eta,
            "computed_points": int(self.computed_x.size),
        }

    def plot(self, path: Any = None):
        """Computed diagram (grey dots) with the measured section points (red) on top."""

        check_plot_path(path)
        fig, axes = new_figure(1, 1, figsize=(8.0, 5.0))
        ax = axes[0, 0]
        ce = np.repeat(self.computed_eta, self.computed_x.shape[1])
        ax.plot(ce, self.computed_x.ravel(), ".", ms=2.5, color="0.3", alpha=0.5, mew=0)
        ax.plot([], [], ".", color="0.45", label="computed (mechanics)")
        for i, (e, x) in enumerate(zip(self.eta, self.x, strict=True)):
            ax.plot(
                np.full(len(x), e), x, ".", ms=3, color="C3", label="captures" if i == 0 else None
            )
        ax.set_xlabel("eta (captures: measured Omega / design omega)")
        ax.set_ylabel("x at the forcing phase 0")
        ax.set_title(
            f"measured bifurcation diagram over the computed one ({self.scene})", fontsize=10
        )
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        return finish(fig, path)


#: Seconds per byte of a capture file read and analysed (a 1.5 MB Rigol CSV of 200 periods:
#: 0.73 s on this project's 2-core machine under load, 0.48 us/byte; priced at 1 us) and the
#: bytes held per byte of file (the text becomes float64 columns: priced at 4).
CAPTURE_SECONDS_PER_BYTE, CAPTURE_BYTES_PER_BYTE = 1e-6, 4.0


_FLOAT64 = Precision.parse("float64")


def _capture_bytes(c: Any) -> float:
    """A capture's size as a file would hold it: the file's bytes, or ~40 text bytes per
    sample of a capture already in memory."""
    if isinstance(c, Capture):
        return 40.0 * len(c.t)
    return float(os.path.getsize(c)) if os.path.exists(c) else 0.0


def _price_bifurcation(captures, computed: int, computed_periods: int, max_time: Any) -> None:
    """Refuse a measured bifurcation over budget before reading anything (issue 35 item 6)."""
    size = sum(_capture_bytes(c) for c in captures)
    seconds = size * CAPTURE_SECONDS_PER_BYTE
    # the computed diagram as the run itself admits it (core.budget.run_cost, float64 runs)
    seconds += run_cost(_FLOAT64, computed_periods + 400, runs=computed).seconds if computed else 0
    check_work(
        f"capture bifurcation: {len(captures)} captures ({size / 1e6:.0f} MB) + {computed} "
        "computed eta values",
        1,
        seconds,
        size * CAPTURE_BYTES_PER_BYTE,
        None if max_time is None else parse_max_time(max_time),
        "captures",
    )


def measured_bifurcation(
    captures: Sequence[Capture | str | os.PathLike],
    scene: Any = "fig6-period3-ideal",
    channels: Any = None,
    computed: int = 80,
    computed_periods: int = 100,
    max_period: int = 16,
    max_time: Any = None,
) -> MeasuredBifurcation:
    """A measured bifurcation diagram: each capture's measured ``eta`` and Poincare-section ``x``,
    over the computed diagram of the scene's mechanics across the captures' ``eta`` range.

    Parameters
    ----------
    captures : sequence of Capture or paths
        Captures at several forcing frequencies (files are read with
        :func:`~precise_impact.lab.scope_files.read_capture` and ``channels``).
    scene : str, Path or Scene, default ``'fig6-period3-ideal'``
        The design: its ``omega`` turns each capture's measured frequency into ``eta``, its
        mechanics give the computed diagram.
    channels : str, sequence, dict or None, default ``None``
        The files' channels for ``V_s``, ``V_q`` (and ``V_3``):
        :func:`~precise_impact.lab.scope_files.parse_channels`.
    computed : int, default 80
        ``eta`` values of the computed diagram, spread over the captures' range.
    computed_periods : int, default 100
        Stroboscopic points recorded per computed ``eta`` (after 400 transient periods).
    max_period : int, default 16
        Longest period looked for in each capture's section.
    max_time : float or None, default ``None``
        Time budget [s], enforced between captures and passed to the computed diagram.

    Returns
    -------
    MeasuredBifurcation
        The measured points with their periods, and the computed diagram; ``plot()`` lays
        one over the other.

    See Also
    --------
    score_capture : one capture against the model's attractor.
    precise_impact.analysis.orbits.branch.brute_force_diagram : the computed diagram.

    Examples
    --------
    >>> from precise_impact import measured_bifurcation, synth_capture
    >>> caps = [synth_capture(eta=e, periods=30, transient=20) for e in ("0.712", "0.74")]
    >>> res = measured_bifurcation(caps, computed=4, computed_periods=20)
    >>> [round(e, 3) for e in res.eta], res.period  # chaos: no period; period 3
    ([0.712, 0.74], [0, 3])
    """

    check_type(captures, (list, tuple), "captures", "a list of captures: " + _CAPTURE_ARG)
    if not captures:
        raise ParameterError("captures", [], "at least one capture")
    for c in captures:
        check_type(c, (Capture, str, os.PathLike), "captures", _CAPTURE_ARG)
    if not isinstance(computed, int) or not 0 <= computed <= 2000:
        raise ParameterError("computed", computed, "an integer 0..2000")
    _price_bifurcation(captures, computed, computed_periods, max_time)
    deadline = Deadline(
        None if max_time is None else parse_max_time(max_time), "capture bifurcation"
    )
    sc = scene if isinstance(scene, Scene) else load_scene(scene)
    comp = sc.design()
    w = float(comp.omega())
    etas, xs, pers, srcs = [], [], [], []
    for c in captures:
        deadline.check(f"after {len(etas)} of {len(captures)} captures")
        cap = c if isinstance(c, Capture) else read_capture(c, channels)
        an = analyse_capture(cap, comp, None, 0.0, max_period, float(sc.params.R))
        etas.append(an["forcing"].omega / w)
        xs.append(an["section"]["x"])
        pers.append(an["period"])
        srcs.append(str(cap.source.get("path", cap.source.get("instrument", ""))))
    lo, hi = min(etas), max(etas)
    pad = max(0.01, 0.05 * (hi - lo))
    if computed:
        deadline.admit(
            run_cost(_FLOAT64, computed_periods + 400, runs=computed),
            f"the computed diagram ({computed} eta values)",
        )
        ce, cx = brute_force_diagram(
            sc.params,
            ("eta", lo - pad, hi + pad, computed),
            periods=computed_periods,
            transient=400,
        )
    else:
        ce, cx = np.empty(0), np.empty((0, 0))
    return MeasuredBifurcation(
        scene=sc.name,
        eta=etas,
        x=xs,
        period=pers,
        computed_eta=np.asarray(ce, float),
        computed_x=np.asarray(cx, float),
        sources=srcs,
    )
