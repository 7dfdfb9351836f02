"""Argument helpers shared by the command modules of ``precise-impact``.

One spelling per flag across commands: the parameter flags (the ``Params`` names), ``--json``,
``--out`` with its kind (file, directory, resumable directory) and ``--force``, ``--max-time``,
``--periods`` with what it counts, and ``--precision``.  Each command module
(:mod:`precise_impact.cli.commands`) builds its parser from these; the output checks of
:func:`check_outputs` run before any work.  Modelled on asv's ``commands/`` layout.
"""

from __future__ import annotations

import argparse
import contextlib
from collections.abc import Callable, Sequence
from fractions import Fraction
from typing import Any

from precise_impact.core.budget import DEFAULT_MAX_TIME, parse_max_time
from precise_impact.core.params import Params, decimal_str, exact
from precise_impact.io.atomic import check_output_dir, check_output_file
from precise_impact.io.lock import DirectoryLock

__all__ = [
    "EXIT_BAD_INPUT",
    "PARAM_FLAGS",
    "Parser",
    "add_json",
    "add_max_time",
    "add_orbit_flags",
    "add_out",
    "add_param_flags",
    "add_periods",
    "add_precision",
    "check_outputs",
    "max_time",
    "orbit_params_from",
    "params_from",
]

#: Exit status of bad input (argparse's own status for a malformed command line).
EXIT_BAD_INPUT = 2

#: The system-parameter flags: (flag, Params field, help).
PARAM_FLAGS = (
    ("--eta", "eta", "forcing frequency ratio, > 0 (default 0.712)"),
    ("--zeta", "zeta", "damping ratio, >= 0 (default 0.05)"),
    ("--a", "a", "forcing amplitude (default 1)"),
    ("--x_w", "x_w", "wall position (default 2; --xw is accepted too)"),
    ("--R", "R", "restitution coefficient, 0 <= R <= 1 (default 1)"),
    ("--x0", "x0", "initial position, <= x_w (default 0; orbit, continue: min(0, x_w))"),
    ("--v0", "v0", "initial velocity (default 0)"),
    ("--t0", "t0", "initial time / forcing phase (default 0)"),
)

#: ``--out`` kinds: a file (never overwritten without ``--force``), a directory (shared by
#: commands: each owns the files it names and refuses to replace them without ``--force``), or
#: a directory the command resumes in (no ``--force``: a sweep's tiles, a reference dataset;
#: checked for writability only).
OUT_KINDS = ("file", "dir", "resume")

_FORCE_HELP = {
    "file": "overwrite --out if it exists",
    "dir": "replace this command's files in --out if they exist (other files are never touched)",
}


class Parser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose errors are one line and exit status 2 (no usage dump)."""

    def error(self, message: str):  # type: ignore[override]
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message}\n")


def add_param_flags(
    p: argparse.ArgumentParser,
    exclude: tuple[str, ...] = (),
    title: str = "system parameters (exact decimals, e.g. 0.712 or 102/53)",
) -> None:
    """The parameter flags ``--eta --zeta --a --x_w --R --x0 --v0 --t0``, but ``exclude``."""
    g = p.add_argument_group(title)
    for flag, dest, helptext in PARAM_FLAGS:
        if dest in exclude:
            continue
        # Flags are the Params names (as in sweep axes and scenes); --xw is the 0.1.0 spelling.
        names = (flag, "--xw") if dest == "x_w" else (flag,)
        g.add_argument(*names, dest=dest, default=None, metavar="DEC", help=helptext)


def params_from(ns: argparse.Namespace, exclude: tuple[str, ...] = ()) -> Params:
    """The validated :class:`~precise_impact.core.params.Params` of the parameter flags."""
    return Params.make(
        **{dest: getattr(ns, dest) for _, dest, _ in PARAM_FLAGS if dest not in exclude}
    )


def orbit_params_from(ns: argparse.Namespace, walls: tuple = ()) -> Params:
    """:func:`params_from` for the orbit commands, whose start ``(x0, v0)`` only seeds the
    transient: without ``--x0`` it is 0, or the wall where that lies left of 0
    (``x0 = min(0, x_w, *walls)``, ``walls``: other wall positions the command visits), so
    that a system is never refused for a default start it does not need.  A given ``--x0``
    inside the wall is still refused."""
    if ns.x0 is None:
        lows = [exact("x_w", w) for w in (ns.x_w, *walls) if w is not None]
        x0 = min([Fraction(0), *lows])
        if x0 < 0:
            ns = argparse.Namespace(**{**vars(ns), "x0": decimal_str(x0)})
    return params_from(ns)


def add_orbit_flags(p: argparse.ArgumentParser, which: str) -> None:
    """``--period --impacts --guess --transient`` of the orbit commands (``which``: whose orbit)."""
    p.add_argument(
        "--period", default="1", metavar="P", help="forcing periods of the orbit (default 1)"
    )
    p.add_argument(
        "--impacts",
        default=None,
        metavar="N",
        help=f"required impacts per orbit{which} (default: any)",
    )
    p.add_argument(
        "--guess",
        nargs=2,
        default=None,
        metavar=("X", "V"),
        help=f"starting state at t0{which} (default: the state after --transient periods)",
    )
    p.add_argument(
        "--transient",
        default="2000",
        metavar="N",
        help="periods run for the default guess (default 2000)",
    )


def add_periods(
    p: argparse.ArgumentParser,
    default: str | None,
    meaning: str,
    metavar: str | None = "N",
    default_text: str | None = None,
) -> None:
    """``--periods``: what a period counts here (``meaning``) and its default.

    ``default_text`` replaces ``default N`` in the help (e.g. ``default: the scene's``).
    """
    shown = f"default {default}" if default_text is None else default_text
    p.add_argument("--periods", default=default, metavar=metavar, help=f"{meaning} ({shown})")


def add_precision(p: argparse.ArgumentParser, helptext: str, default: str = "float64") -> None:
    """``--precision P``: the working precision (``float64``, ``mp:BITS``, ...)."""
    p.add_argument("--precision", default=default, metavar="P", help=helptext)


def add_json(p: argparse.ArgumentParser, helptext: str = "print one JSON object to stdout") -> None:
    """``--json``: exactly one JSON object on standard output."""
    p.add_argument("--json", action="store_true", help=helptext)


def add_out(
    p: argparse.ArgumentParser,
    kind: str,
    helptext: str,
    default: str | None = None,
    required: bool = False,
    metavar: str | None = None,
    force: bool = True,
    writes: Sequence[str] | Callable[[argparse.Namespace], Sequence[str]] | None = None,
) -> None:
    """``--out`` of a kind in :data:`OUT_KINDS` (file, dir, resume), with ``--force``.

    ``force=False`` leaves ``--force`` to the command (a reference dataset gives it its own
    meaning).  ``writes`` (required for ``kind="dir"``): the glob patterns of the files the
    command writes into the directory, or a function of the parsed arguments returning them
    (e.g. ``run``'s ``<scene>_*.json``).  :func:`check_outputs` checks the path by its kind
    before any work and, for a directory, refuses only to replace these files.
    """
    if kind not in OUT_KINDS:
        raise ValueError(f"--out kind {kind!r} is not one of {OUT_KINDS}")
    if kind == "dir" and writes is None:
        raise ValueError("an --out directory names the files it writes (writes=...)")
    kw: dict[str, Any] = {"metavar": metavar or ("FILE" if kind == "file" else "DIR")}
    if required:
        kw["required"] = True
    else:
        kw["default"] = default
    p.add_argument("--out", help=helptext, **kw)
    if force and kind != "resume":
        p.add_argument("--force", action="store_true", help=_FORCE_HELP[kind])
    p.set_defaults(out_kind=kind, out_writes=writes)


def add_units(p: argparse.ArgumentParser) -> None:
    """``--units``: the axes of the phase portraits and time series the command draws."""
    p.add_argument(
        "--units",
        choices=("dimensionless", "circuit"),
        default="dimensionless",
        help="axes of the phase portraits and time series: dimensionless (tau, x, x') or "
        "circuit (seconds, V_s and V_q in volts of the design)",
    )


def add_capture_reading(p: argparse.ArgumentParser, formats: tuple[str, ...]) -> None:
    """``--channels`` and ``--format``: how a scope file's channels and layout are read
    (``formats``: the readers' layouts, :data:`precise_impact.lab.scope_files.READ_FORMATS`)."""
    p.add_argument(
        "--channels",
        default=None,
        help="the file's channels for V_s,V_q[,V_3]: CH1,CH2[,CH3] or V_s=CH2,V_q=CH1",
    )
    p.add_argument("--format", default="auto", choices=formats, help="file layout")


def add_max_time(p: argparse.ArgumentParser) -> None:
    """``--max-time S``: the time budget, checked against the job's estimate before any work."""
    p.add_argument(
        "--max-time",
        default=None,
        metavar="S",
        help="time budget in seconds, checked against an estimate before any work (default 3600)",
    )


def max_time(ns: argparse.Namespace) -> float:
    """``--max-time`` in seconds (default :data:`~precise_impact.core.budget.DEFAULT_MAX_TIME`)."""
    return DEFAULT_MAX_TIME if ns.max_time is None else parse_max_time(ns.max_time)


def check_outputs(ns: argparse.Namespace) -> contextlib.AbstractContextManager:
    """Every ``--out`` checked before any work: the right kind, writable, no silent overwrite.

    An ``--out`` directory is shared by commands (``reproduce`` then ``accuracy`` then ``run``
    into ``results/``): each command refuses, without ``--force``, only a directory that
    already holds one of the files it writes (``add_out(writes=...)``), naming it.
    Returns the context to run the command in: an ``--out`` directory is locked for the whole
    run (:class:`~precise_impact.io.lock.DirectoryLock`), so a second run into the same
    directory is refused at once, naming the first, instead of mixing its files with it.
    """
    out, kind = getattr(ns, "out", None), getattr(ns, "out_kind", None)
    if out is None or kind is None:
        return contextlib.nullcontext()
    if kind == "file":  # written in one atomic rename: two writers cannot mix one file
        check_output_file(out, force=ns.force)
        return contextlib.nullcontext()
    # a sweep and a reference dataset resume in their own directory (checked there)
    writes = getattr(ns, "out_writes", None)
    owned = writes(ns) if callable(writes) else writes
    check_output_dir(out, force=kind == "resume" or getattr(ns, "force", False), owned=owned)
    return DirectoryLock(out, "out")  # acquired on entering the `with` block
