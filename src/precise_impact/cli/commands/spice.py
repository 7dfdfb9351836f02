"""``precise-impact spice netlist|score``: the project's netlist of a scene as a starting point;
score your own SPICE netlist or raw waveforms against the mechanics."""

from __future__ import annotations

import argparse

import heyoka

from precise_impact.cli.args import (
    add_json,
    add_max_time,
    add_out,
    add_periods,
    add_units,
    max_time,
)
from precise_impact.core.params import check_count
from precise_impact.io.atomic import atomic_write
from precise_impact.io.jsonout import print_json
from precise_impact.models.circuit.spice import spice_netlist
from precise_impact.scenes.scene import load_scene

__all__ = ["register", "run"]


def register(sub) -> argparse.ArgumentParser:
    """Add ``spice`` (with sub-subcommand ``score``) to ``sub``."""
    s = sub.add_parser(
        "spice", help="your own circuit: score an ngspice/LTspice netlist or .raw waveform file"
    )
    ssub = s.add_subparsers(dest="spice_command", required=True)
    nl = ssub.add_parser(
        "netlist",
        help="write a scene's ngspice netlist (the paper's Fig. 2 with the scene's design, "
        "effects and start) to edit and score",
    )
    nl.add_argument(
        "scene", help="built-in scene name (see: precise-impact scenes) or a .toml file"
    )
    add_periods(nl, None, "forcing periods simulated", default_text="default: the scene's")
    nl.add_argument(
        "--tmax",
        default=None,
        help="largest time step of .tran in seconds (default: the scene's, else 1e-5)",
    )
    add_out(nl, "file", "the netlist file to write (.cir)", required=True)
    nl.set_defaults(run=run_netlist)
    sc = ssub.add_parser(
        "score",
        help="run a netlist with ngspice (or read a .raw file) and score it against the "
        "demonstrated mechanical reference from its first sample",
    )
    sc.add_argument("file", help="netlist (.cir, .net, .sp, .spi, .ckt) or waveform file (.raw)")
    sc.add_argument("--x-node", help="node carrying position: V_s = -V_unit x")
    sc.add_argument("--v-node", help="node carrying velocity: V_q = omega R8 C1 V_unit x'")
    sc.add_argument(
        "--forcing-node",
        help="node of the forcing V_3 (its frequency, amplitude and phase are fitted)",
    )
    sc.add_argument("--impact-node", help="optional logic node toggling at each impact (e.g. pol)")
    sc.add_argument(
        "--map",
        metavar="FILE",
        help="TOML mapping: [nodes], [gains], [offsets], "
        "[components], [parameters], scene, [scales] (docs: your own netlist)",
    )
    sc.add_argument("--scene", help="target scene (its parameters and design values)")
    sc.add_argument(
        "--scales",
        choices=("auto", "components", "fitted"),
        default="auto",
        help="volts/seconds from the design values or fitted to the waveform (default auto: the "
        "design's when there is one)",
    )
    sc.add_argument("--step", help="only this run of a stepped or multi-plot file (0-based)")
    add_periods(sc, None, "at most this many forcing periods scored", default_text="default: all")
    sc.add_argument(
        "--ltspice",
        action="store_true",
        default=None,
        help="run the netlist in ngspice's LTspice compatibility mode (default: for "
        ".net files and netlists exported from .asc)",
    )
    add_json(sc, "print one JSON object")
    add_out(
        sc,
        "dir",
        "write scores.json, phase_portraits.png and separation.png here (one pair per run, "
        "_0, _1 ..., for a stepped file)",
        writes=("scores.json", "phase_portraits*.png", "separation*.png"),
    )
    add_units(sc)
    add_max_time(sc)
    s.set_defaults(run=run)
    return s


def run_netlist(ns: argparse.Namespace) -> int:
    """Run ``spice netlist``: the scene's netlist, written atomically; returns the exit status."""
    scene, _dropped = load_scene(ns.scene).fitted_to("spice")
    periods = scene.periods if ns.periods is None else check_count(ns.periods, "periods", 10**6, 1)
    tmax = ns.tmax if ns.tmax is not None else (scene.tmax if scene.tmax is not None else "1e-5")
    p = scene.params
    text = spice_netlist(scene.design(), scene.effects, periods, tmax, p.x0, p.v0, p.t0)
    atomic_write(ns.out, lambda fh: fh.write(text), binary=False)
    print(f"written: {ns.out} ({periods} periods; nodes: x s, v q, forcing v3, impacts pol)")
    return 0


def run(ns: argparse.Namespace) -> int:
    """Run ``spice score``; returns the exit status."""
    from precise_impact.lab.netlist import (  # noqa: PLC0415 -- heavy: loaded when the command runs, not at --help
        check_periods,
        format_result,
        score_netlist,
    )

    step = None if ns.step is None else check_count(ns.step, "step", 10**6)
    periods = None if ns.periods is None else check_periods(ns.periods)
    if ns.json:
        heyoka.set_logger_level_error()
    res = score_netlist(
        ns.file,
        ns.x_node,
        ns.v_node,
        ns.forcing_node,
        impact_node=ns.impact_node,
        map=ns.map,
        scene=ns.scene,
        scales=ns.scales,
        step=step,
        periods=periods,
        ltspice=ns.ltspice,
        out=ns.out,
        units=ns.units,
        progress=not ns.json,
        max_time=max_time(ns),
    )
    if ns.json:
        print_json(res.to_dict())
    else:
        print(format_result(res))
        if ns.out is not None:
            print("written: " + ", ".join(res.files or []))
    return 0
