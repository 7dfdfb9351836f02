"""The commands of ``precise-impact``, one module each (asv's layout).

Each module exposes ``register(subparsers) -> ArgumentParser`` (adds its parser, with
``set_defaults(run=run)``) and ``run(ns) -> int`` (the exit status).  :data:`MODULES` is the
one list of them, in the order ``precise-impact --help`` shows: a new command is one new
module here plus one entry in that list.  A module is imported when its command is parsed
(:func:`load`): a run pays for its own command's imports only, not all 24 (0.3-0.9 s less
per run, measured with ``-X importtime``); :data:`COMMANDS` imports them all.
"""

from __future__ import annotations

import importlib
from types import ModuleType

__all__ = ["COMMANDS", "MODULES", "load"]

#: Command name -> its module in this package, in the order of ``precise-impact --help``.
MODULES: dict[str, str] = {
    "simulate": "simulate",
    "lle": "lle",
    "orbit": "orbit",
    "certify": "certify",
    "continue": "continuation",
    "response": "response",
    "bifurcation": "bifurcation",
    "sync": "sync",
    "sweep": "sweep",
    "scenes": "scenes",
    "run": "run",
    "compare": "compare",
    "reference": "reference",
    "bench": "bench",
    "reproduce": "reproduce",
    "accuracy": "accuracy",
    "spice": "spice",
    "budget": "budget",
    "capture": "capture",
    "identify": "identify",
    "impact-map": "impact_map",
    "singularity": "singularity",
    "basins": "basins",
    "explore": "explore",
}


def load(name: str) -> ModuleType:
    """The module of command ``name`` (a key of :data:`MODULES`), imported now."""
    return importlib.import_module(f"{__name__}.{MODULES[name]}")


def __getattr__(name: str) -> tuple[ModuleType, ...]:
    """``COMMANDS``: every command's module, in :data:`MODULES`' order (all imported)."""
    if name == "COMMANDS":
        return tuple(load(n) for n in MODULES)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
