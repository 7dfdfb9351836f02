"""``precise-impact capture {synth,score,bifurcation}``: oscilloscope captures of the circuit.

``synth`` writes a synthetic capture of a scene's model through a measurement model; ``score``
reads a capture (vendor CSV, generic CSV, NPZ, binary waveform file) and scores it against a
model at the level of the attractor; ``bifurcation`` lays the captures of several forcing
frequencies over the computed bifurcation diagram.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from precise_impact.cli.args import (
    Parser,
    add_capture_reading,
    add_json,
    add_max_time,
    add_out,
    max_time,
)
from precise_impact.errors import ParameterError
from precise_impact.io.atomic import atomic_write
from precise_impact.io.figures import check_plot_path
from precise_impact.io.jsonout import print_json
from precise_impact.lab.scope_files import READ_FORMATS, WRITE_FORMATS, read_capture
from precise_impact.scenes.scene import load_scene

__all__ = ["register", "run"]


def _float(name: str, text: str, lo: float = -math.inf, hi: float = math.inf) -> float:
    try:
        v = float(text)
    except (TypeError, ValueError):
        raise ParameterError(name, text, "a number") from None
    if not (math.isfinite(v) and lo <= v <= hi):
        raise ParameterError(name, text, f"{lo:g} <= value <= {hi:g}")
    return v


def _int(name: str, text: str, lo: int, hi: int) -> int:
    try:
        v = int(text)
    except (TypeError, ValueError):
        raise ParameterError(name, text, f"an integer {lo}..{hi}") from None
    if not lo <= v <= hi:
        raise ParameterError(name, text, f"an integer {lo}..{hi}")
    return v


def _per_channel(name: str, text: str | None, lo: float, hi: float):
    """``'0.01'`` (every channel) or ``'V_s=0.01,V_q=-0.02'``."""
    if text is None:
        return None
    if "=" not in text:
        return _float(name, text, lo, hi)
    out = {}
    for part in text.split(","):
        k, _, v = part.partition("=")
        if k.strip() not in ("V_s", "V_q", "V_3"):
            raise ParameterError(name, text, "a number or V_s=..,V_q=..,V_3=..")
        if k.strip() in out:
            raise ParameterError(name, text, f"each channel once ({k.strip()} given twice)")
        out[k.strip()] = _float(name, v, lo, hi)
    return out


def register(sub) -> argparse.ArgumentParser:
    """Add ``capture`` (with its sub-commands) to ``sub``."""
    c = sub.add_parser("capture", help="oscilloscope captures: synthesise, score, bifurcation")
    cs = c.add_subparsers(dest="capture_command", required=True, parser_class=Parser)

    s = cs.add_parser("synth", help="write a synthetic capture of a model through a scope model")
    s.add_argument(
        "--scene", default="fig6-period3-ideal", help="scene (default fig6-period3-ideal)"
    )
    s.add_argument(
        "--model", default=None, help="circuit, switched-capacitor or spice (default: the scene's)"
    )
    s.add_argument("--eta", default=None, help="another forcing ratio (exact decimal)")
    s.add_argument("--bits", default="8", help="ADC bits 0..24, 0 unquantised (default 8)")
    s.add_argument(
        "--full-scale", default=None, help="vertical range in V, or V_s=..,V_q=.. (default: fit)"
    )
    s.add_argument("--noise", default="0.01", help="white noise RMS / full scale (default 0.01)")
    s.add_argument("--flicker", default="0", help="1/f noise RMS / full scale (default 0)")
    s.add_argument("--sample-rate", default=None, help="Sa/s (default >= 100 per period, 1-2-5)")
    s.add_argument(
        "--periods", default="200", help="record length in forcing periods (default 200)"
    )
    s.add_argument("--transient", default="100", help="periods run before the record (default 100)")
    s.add_argument("--trigger-offset", default="0", help="file time of the first sample, s")
    s.add_argument("--gain-error", default="0", help="relative gain error, or V_s=..,V_q=..")
    s.add_argument("--offset-error", default="0", help="offset error in V, or V_s=..,V_q=..")
    s.add_argument("--timebase-ppm", default="0", help="time-base error in ppm (default 0)")
    s.add_argument("--seed", default="0", help="noise and record-start seed (default 0)")
    s.add_argument("--channels", default="V_s,V_q,V_3", help="V_s,V_q or V_s,V_q,V_3 (default)")
    s.add_argument(
        "--format",
        default=None,
        choices=WRITE_FORMATS,
        help="file layout (default by suffix: .npz, .bin keysight-bin, else csv)",
    )
    add_max_time(s)
    add_json(s, "print the capture's summary as one JSON object")
    add_out(s, "file", "the capture file to write", required=True)
    s.set_defaults(capture_run=run_synth)

    sc = cs.add_parser("score", help="score a capture against a model's attractor")
    sc.add_argument("file", help="capture file (or a Tektronix ALLnnnn directory)")
    _scene_flags(sc)
    add_capture_reading(sc, READ_FORMATS)
    sc.add_argument("--phase", default="0", help="forcing phase of the Poincare section, rad")
    sc.add_argument("--floor-captures", default="3", help="model captures for the floor (2..8)")
    sc.add_argument("--seed", default="0", help="seed of the model captures (default 0)")
    sc.add_argument(
        "--no-lle", action="store_true", help="skip the time-series LLE (a few seconds)"
    )
    add_max_time(sc)
    add_json(sc)
    add_out(
        sc,
        "dir",
        "write capture_score.json, capture_score.md (the report) and capture_score.png here",
        writes=("capture_score.json", "capture_score.md", "capture_score.png"),
    )
    sc.set_defaults(capture_run=run_score)

    b = cs.add_parser(
        "bifurcation", help="captures at several frequencies over the computed diagram"
    )
    b.add_argument("files", nargs="+", help="capture files, one per forcing frequency")
    b.add_argument("--scene", default="fig6-period3-ideal", help="the design (default fig6-...)")
    b.add_argument("--channels", default=None, help="as for score")
    b.add_argument("--computed", default="80", help="computed eta values (default 80, 0: none)")
    add_max_time(b)
    add_json(b)
    add_out(b, "file", "write the figure (.png/.pdf/.svg) here")
    b.set_defaults(capture_run=run_bifurcation)
    c.set_defaults(run=run)
    return c


def _scene_flags(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scene", default="fig6-period3-ideal", help="the model's scene (design)")
    p.add_argument("--model", default=None, help="circuit, switched-capacitor or spice")
    p.add_argument("--eta", default=None, help="the model's eta: a decimal or 'measured'")


def run(ns: argparse.Namespace) -> int:
    """Run ``capture SUB``; returns the exit status."""
    return int(ns.capture_run(ns))


def run_synth(ns: argparse.Namespace) -> int:
    from precise_impact.lab.synth import Measurement, synth_capture  # noqa: PLC0415 -- heavy: the measurement model loaded when the command runs, not at --help

    meas = Measurement(
        bits=_int("bits", ns.bits, 0, 24),
        full_scale=_per_channel("full-scale", ns.full_scale, 1e-12, 1e6),
        noise=_float("noise", ns.noise, 0, 1),
        flicker=_float("flicker", ns.flicker, 0, 1),
        sample_rate=None
        if ns.sample_rate is None
        else _float("sample-rate", ns.sample_rate, 1e-6, 1e12),
        periods=_float("periods", ns.periods, 2, 1e5),
        trigger_offset=_float("trigger-offset", ns.trigger_offset, -1e6, 1e6),
        gain_error=_per_channel("gain-error", ns.gain_error, -0.49, 0.49),
        offset_error=_per_channel("offset-error", ns.offset_error, -1e6, 1e6),
        timebase_ppm=_float("timebase-ppm", ns.timebase_ppm, -1e4, 1e4),
        seed=_int("seed", ns.seed, 0, 2**63 - 1),
    ).check()
    cap = synth_capture(
        ns.scene,
        ns.model,
        eta=ns.eta,
        measurement=meas,
        channels=ns.channels,
        transient=_int("transient", ns.transient, 0, 100000),
        max_time=max_time(ns),
    )
    path = cap.save(ns.out, ns.format)
    if ns.json:
        print_json({"file": str(path), **cap.to_dict()})
    else:
        tr = cap.source["truth"]
        print(
            f"{path}: {cap.n_samples} samples at {cap.sample_rate:.6g} Sa/s, "
            f"{', '.join(cap.channels)}; truth: f = {tr['forcing_frequency_hz']:.9g} Hz, "
            f"{len(tr['impacts_t'])} impacts"
        )
    return 0


def run_score(ns: argparse.Namespace) -> int:
    from precise_impact.lab.attractor import score_capture  # noqa: PLC0415 -- heavy: lab scoring loaded when the command runs, not at --help

    budget = max_time(ns)
    phase = _float("phase", ns.phase, -1e3, 1e3)
    k = _int("floor-captures", ns.floor_captures, 2, 8)
    seed = _int("seed", ns.seed, 0, 2**63 - 1)
    scene = load_scene(ns.scene)  # a bad scene is refused before the file is read
    cap = read_capture(ns.file, ns.channels, ns.format)
    res = score_capture(
        cap,
        scene,
        ns.model,
        section_phase=phase,
        floor_captures=k,
        eta=ns.eta,
        seed=seed,
        lle=not ns.no_lle,
        max_time=budget,
    )
    written = []
    if ns.out is not None:
        out = Path(ns.out)
        res.save(out / "capture_score.json")
        res.plot(out / "capture_score.png")
        text = res.markdown("capture_score.png")
        atomic_write(out / "capture_score.md", lambda fh: fh.write(text), binary=False)
        written = [
            str(out / n) for n in ("capture_score.json", "capture_score.md", "capture_score.png")
        ]
    if ns.json:
        print_json(res.to_dict())
        return 0
    for line in res.summary_lines():
        print(line)
    if written:
        print("written: " + ", ".join(written))
    return 0


def run_bifurcation(ns: argparse.Namespace) -> int:
    from precise_impact.lab.attractor import measured_bifurcation  # noqa: PLC0415 -- heavy: lab scoring loaded when the command runs, not at --help

    budget = max_time(ns)
    if ns.out is not None:
        check_plot_path(ns.out)
    computed = _int("computed", ns.computed, 0, 2000)
    res = measured_bifurcation(ns.files, ns.scene, ns.channels, computed=computed, max_time=budget)
    if ns.out is not None:
        res.plot(ns.out)
    if ns.json:
        print_json(res.to_dict())
        return 0
    for e, p, s in zip(res.eta, res.period, res.sources, strict=True):
        print(f"eta {e:.6f}: period {p}  ({s})")
    if ns.out is not None:
        print(f"written: {ns.out}")
    return 0
