"""The commands of ``precise-impact``, one module each (asv's layout).

Each module exposes ``register(subparsers) -> ArgumentParser`` (adds its parser, with
``set_defaults(run=run)``) and ``run(ns) -> int`` (the exit status).  :data:`COMMANDS` is the
one list of them, in the order ``precise-impact --help`` shows: a new command is one new
module here plus one entry in that list.
"""

from __future__ import annotations

from precise_impact.cli.commands import (
    accuracy,
    basins,
    bench,
    bifurcation,
    budget,
    capture,
    certify,
    compare,
    continuation,
    impact_map,
    lle,
    orbit,
    reference,
    reproduce,
    response,
    run,
    scenes,
    simulate,
    singularity,
    spice,
    sweep,
    sync,
)

__all__ = ["COMMANDS"]

#: The command modules, in the order of ``precise-impact --help``.
COMMANDS = (
    simulate,
    lle,
    orbit,
    certify,
    continuation,
    response,
    bifurcation,
    sync,
    sweep,
    scenes,
    run,
    compare,
    reference,
    bench,
    reproduce,
    accuracy,
    spice,
    budget,
    capture,
    impact_map,
    singularity,
    basins,
)
