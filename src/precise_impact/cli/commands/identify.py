"""``precise-impact identify``: the impact oscillator a capture realises, with standard errors
(:func:`~precise_impact.lab.identify.identify`); ``--predict``: what it does (``lab.predict``)."""

from __future__ import annotations

import argparse
from pathlib import Path

from precise_impact.cli.args import (
    add_capture_reading,
    add_json,
    add_max_time,
    add_out,
    max_time,
)
from precise_impact.core.budget import check_work
from precise_impact.core.params import check_count
from precise_impact.io.jsonout import print_json, write_json
from precise_impact.io.progress import say
from precise_impact.lab.diagnose import diagnose
from precise_impact.lab.identify import SECONDS_PER_SAMPLE, check_impact_law, identify
from precise_impact.lab.predict import SECONDS_PER_DIAGRAM_VALUE, SECONDS_PER_SAMPLE_RUN, predict
from precise_impact.lab.scope_files import READ_FORMATS, read_capture


def register(sub) -> argparse.ArgumentParser:
    """Add ``identify`` to ``sub``."""
    p = sub.add_parser(
        "identify",
        help="the oscillator a capture realises: eta, zeta, a, x_w, R with standard errors",
    )
    p.add_argument("file", help="capture file (or a Tektronix ALLnnnn directory)")
    add_capture_reading(p, READ_FORMATS)
    p.add_argument(
        "--scene",
        default="fig5-chaotic-ideal",
        help="the design whose volts and seconds per unit map the channels (default: the paper's)",
    )
    p.add_argument(
        "--impact-law",
        default="restitution",
        help="restitution: v+ = -R v- (default); affine: plus kappa (a cos(eta t) - x_w), fitted "
        "(a switched-capacitor circuit whose switches have an on-resistance)",
    )
    p.add_argument("--bootstrap", default="0", help="parametric bootstrap refits (default 0)")
    p.add_argument("--seed", default="0", help="the bootstrap's and the samples' seed (default 0)")
    p.add_argument(
        "--predict",
        action="store_true",
        help="also what the identified system does: its attractor, LLE and landmarks, with the "
        "identification's uncertainty carried through",
    )
    p.add_argument(
        "--diagram",
        default="200",
        help="with --predict: eta values of the identified system's bifurcation diagram, the "
        "capture drawn over it (default 200; 0: none)",
    )
    p.add_argument(
        "--diagnose",
        action="store_true",
        help="also which drawn part (of --scene's circuit) most likely differs from what was "
        "measured, within its tolerance",
    )
    p.add_argument(
        "--samples",
        default="48",
        help="with --predict: parameter sets drawn from the fit's covariance (default 48)",
    )
    add_out(
        p,
        "dir",
        "write identify.json and identify.png here (with --predict also predict.json and "
        "predict.png)",
        writes=_writes,
    )
    add_max_time(p)
    add_json(p)
    p.set_defaults(run=run)
    return p


def _writes(ns: argparse.Namespace) -> tuple[str, ...]:
    extra = ("predict.json", "predict.png") if ns.predict else ()
    extra += ("diagnose.json",) if ns.diagnose else ()
    return ("identify.json", "identify.png", *extra)


def run(ns: argparse.Namespace) -> int:
    """Run ``identify``; returns the exit status."""
    boot = check_count(ns.bootstrap, "bootstrap", 1000, minimum=0)
    seed = check_count(ns.seed, "seed", 2**31 - 1, minimum=0)
    samples = check_count(ns.samples, "samples", 10_000, minimum=2)
    diagram = check_count(ns.diagram, "diagram", 2000, minimum=0)
    law = check_impact_law(ns.impact_law, "impact-law")
    cap = read_capture(ns.file, ns.channels, ns.format)
    check_work(
        f"identify: {len(cap.t)} samples x {1 + boot} fits"
        + (f" and {samples} + 1 predicted systems" if ns.predict else ""),
        # a predicted system priced in samples' worth of fitting
        len(cap.t) * (1 + boot)
        + ((samples + 4) * SECONDS_PER_SAMPLE_RUN + diagram * SECONDS_PER_DIAGRAM_VALUE)
        / SECONDS_PER_SAMPLE
        * ns.predict,
        SECONDS_PER_SAMPLE,
        400.0,
        max_time(ns),
        "bootstrap",
    )
    tell = None if ns.json else (lambda line: say(line, True))
    r = identify(cap, ns.scene, bootstrap=boot, seed=seed, say=tell, impact_law=law)
    d = diagnose(r, ns.scene) if ns.diagnose else None
    if ns.out is not None:  # kept if the prediction is refused (an identified R above 1)
        _write(Path(ns.out), r, None)
        if d is not None:
            write_json(Path(ns.out) / "diagnose.json", d.to_dict(), indent=1)
    p = None
    if ns.predict:
        p = predict(r, samples=samples, seed=seed, say=tell, diagram=diagram, capture=cap)
    if ns.out is not None and p is not None:
        _write(Path(ns.out), None, p)
    if ns.json:
        extra = {"prediction": p.to_dict()} if p else {}
        extra.update({"diagnosis": d.to_dict()} if d else {})
        print_json({**r.to_dict(), **extra})
        return 0
    print(r.summary())
    if d is not None:
        print(d.summary())
    if p is not None:
        print(p.summary())
    if r.bootstrap:
        ratios = ", ".join(f"{k} {v:.2f}" for k, v in r.bootstrap["ratio"].items() if v)
        print(
            f"bootstrap / Jacobian standard errors ({r.bootstrap['replicates']} refits): {ratios}"
        )
    if ns.out is not None:
        print("written: " + ", ".join(str(Path(ns.out) / f) for f in _writes(ns)))
    return 0


def _write(out: Path, r, p) -> None:
    if r is not None:
        write_json(out / "identify.json", r.to_dict(), indent=1)
        r.plot(out / "identify.png")
    if p is not None:
        write_json(out / "predict.json", p.to_dict(), indent=1)
        p.plot(out / "predict.png")
