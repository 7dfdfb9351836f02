"""``precise-impact run``: run a scene (built-in name or FILE.toml) on its model or another."""

from __future__ import annotations

import argparse
import sys

import mpmath

from precise_impact.cli.args import add_json, add_max_time, add_out, add_units, max_time
from precise_impact.core.mpcontext import mp_context
from precise_impact.errors import ParameterError
from precise_impact.io.jsonout import print_json
from precise_impact.scenes.run import run_scene, save_scene_outputs, scene_json
from precise_impact.scenes.scene import load_scene
from precise_impact.solvers.base import MODEL_ALIASES, MODELS
from precise_impact.verification.metrics import reference_bits


def register(sub) -> argparse.ArgumentParser:
    """Add ``run`` to ``sub``."""
    rn = sub.add_parser("run", help="run a scene (built-in name or FILE.toml)")
    rn.add_argument(
        "scene", help="built-in scene name (see: precise-impact scenes) or a .toml file"
    )
    rn.add_argument(
        "--model", default=None, help="override the scene's model: one of " + ", ".join(MODELS)
    )
    add_json(rn)
    add_out(rn, "dir", "write <scene>_<model>.json and .png here", writes=_scene_files)
    add_max_time(rn)
    add_units(rn)
    rn.set_defaults(run=run)
    return rn


def _scene_files(ns: argparse.Namespace) -> tuple[str, ...]:
    """The files ``run`` writes into ``--out``: ``<scene>_<model>.json`` and ``.png``."""
    scene = load_scene(ns.scene)  # a bad name is refused here, before any work, as in run()
    model = scene.model if ns.model is None else ns.model if ns.model in MODELS else "*"
    return (f"{scene.name}_{model}.json", f"{scene.name}_{model}.png")


def claimed(sample: dict, name: str) -> str:
    """``'x = 1.2345'``: a sample's value to its claimed digits (``name + '_digits'``), or
    3 digits marked unclaimed; the full string where no claim is given."""
    text = sample[name]
    n = sample.get(name + "_digits")
    if n is None or text is None:
        return f"{name} = {text}"
    # parsed in a context of its own (mpmath's global precision is shared by every thread),
    # with bits enough for every digit of the text
    value = mp_context(4 * len(text) + 16).mpf(text)
    shown = (
        mpmath.nstr(value, n, strip_zeros=False)
        if n > 0
        else mpmath.nstr(value, 3, strip_zeros=False) + " (no digit claimed)"
    )
    return f"{name} = {shown}"


def run(ns: argparse.Namespace) -> int:
    """Run ``run``; returns the exit status."""
    scene = load_scene(ns.scene)
    if ns.model is not None and MODEL_ALIASES.get(ns.model, ns.model) not in MODELS:
        raise ParameterError("model", ns.model, "one of " + ", ".join(MODELS))
    if ns.model is not None:
        # validated before any work; a multiprecision-only model (certified) at the bits a
        # chaotic reference of the scene's length needs
        scene = scene.with_model(ns.model, mp_bits=reference_bits(scene.periods))
    result = run_scene(scene, max_time=max_time(ns))
    obj = scene_json(scene, result)
    files = save_scene_outputs(scene, result, ns.out, units=ns.units) if ns.out is not None else []
    if ns.json:
        print_json(obj)
        return 0
    last = obj["samples"][-1]
    n_imp = (
        len(obj["impacts"])
        if isinstance(obj["impacts"], list)
        else sum(map(len, obj["impacts"].values()))
    )
    print(
        f"{scene.name}: model {obj['model']}, effects {', '.join(obj['effects']) or 'none'}, "
        f"{len(obj['samples']) - 1} periods, {n_imp} impacts, {obj['elapsed_s']:.3f} s"
    )
    print("last sample: " + ", ".join(claimed(last, n) for n in ("x", "v", "y") if n in last))
    if "digits" in obj:
        d = obj["digits"]
        print(
            f"digits: {d['final']} of {d['max_possible']} significant digits claimed ({d['basis']})"
        )
        if d["final"] <= 0:
            print(
                f"warning: no significant digit of the last sample can be claimed "
                f"({d['basis']}): its values are shown to 3 digits, marked unclaimed",
                file=sys.stderr,
            )
    for f in files:
        print(f"written: {f}")
    return 0
