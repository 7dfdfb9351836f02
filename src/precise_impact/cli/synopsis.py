"""The command synopsis and reference, rendered from the parser (never written by hand).

:func:`synopsis` gives the README's command list (one line per command, between the markers
``<!-- synopsis:begin -->`` and ``<!-- synopsis:end -->``); :func:`reference_rst` the
documentation's command reference (``docs/guide/cli_commands.inc``).  ``scripts/gen-synopsis.py``
writes both and ``tests/cli/test_synopsis.py`` fails when the committed text differs.  The
rendering uses only the parser's actions (no argparse help formatter), so it is the same on
every Python version.
"""

from __future__ import annotations

import argparse
import re
from collections.abc import Iterator

from precise_impact.cli.main import build_parser

__all__ = ["BEGIN", "END", "commands", "reference_rst", "replace_between_markers", "synopsis"]

BEGIN = "<!-- synopsis:begin -->"
END = "<!-- synopsis:end -->"
PROG = "precise-impact"


def _parser() -> argparse.ArgumentParser:
    return build_parser()


def _subparsers(p: argparse.ArgumentParser) -> argparse._SubParsersAction | None:
    return next((a for a in p._actions if isinstance(a, argparse._SubParsersAction)), None)


def commands(
    parser: argparse.ArgumentParser | None = None,
) -> Iterator[tuple[str, str, argparse.ArgumentParser]]:
    """Every leaf command as ``(name, help, parser)``: ``'simulate'``, ``'reference verify'``..."""

    def walk(
        p: argparse.ArgumentParser, prefix: str
    ) -> Iterator[tuple[str, str, argparse.ArgumentParser]]:
        sp = _subparsers(p)
        assert sp is not None
        helps = {a.dest: a.help or "" for a in sp._choices_actions}
        for name, child in sp.choices.items():
            full = f"{prefix}{name}"
            if _subparsers(child) is not None:
                yield from walk(child, full + " ")
            else:
                yield full, helps[name], child

    yield from walk(parser or _parser(), "")


def _metavar(a: argparse.Action) -> str:
    if a.nargs == 0:
        return ""
    if isinstance(a.metavar, tuple):
        return " ".join(a.metavar)
    if a.metavar is not None:
        mv = a.metavar
    elif a.choices is not None:
        mv = "{" + ",".join(map(str, a.choices)) + "}"
    else:
        mv = a.dest.upper() if a.option_strings else a.dest
    return " ".join([mv] * a.nargs) if isinstance(a.nargs, int) else mv


def _arguments(p: argparse.ArgumentParser) -> list[argparse.Action]:
    return [a for a in p._actions if not isinstance(a, argparse._HelpAction)]


def _usage(name: str, p: argparse.ArgumentParser) -> str:
    """``precise-impact NAME`` with its positionals and required options, then ``[options]``."""
    parts = [PROG, name]
    args = _arguments(p)
    for a in args:
        if not a.option_strings:
            parts.append(_metavar(a).upper())
        elif a.required:
            parts.append(f"{a.option_strings[0]} {_metavar(a)}".strip())
    if any(a.option_strings and not a.required for a in args):
        parts.append("[options]")
    return " ".join(parts)


def synopsis(parser: argparse.ArgumentParser | None = None) -> str:
    """The README's command list: one line per command, its usage and what it does.

    Parameters
    ----------
    parser : ArgumentParser or None, default ``None``
        The parser to render (default: :func:`~precise_impact.cli.main.build_parser`).

    Returns
    -------
    str
        A fenced ``text`` block (ends with a newline).
    """
    rows = [(f"{PROG} --version", "the version")]
    rows += [(_usage(name, p), helptext) for name, helptext, p in commands(parser)]
    width = max(len(u) for u, _ in rows)
    lines = [f"{u:<{width}}  {h}".rstrip() for u, h in rows]
    lines.append(f"{PROG} COMMAND --help".ljust(width) + "  every flag of a command")
    return "```text\n" + "\n".join(lines) + "\n```\n"


_FLAG = re.compile(r"(?<![\w`])(--?[A-Za-z][\w-]*)")


def _rst_escape(text: str) -> str:
    """``text`` as reStructuredText: flags as literals (no smart dashes), markup escaped."""
    parts = _FLAG.split(text)
    return "".join(
        f"``{part}``" if k % 2 else re.sub(r"([\\`*_|])", r"\\\1", part)
        for k, part in enumerate(parts)
    )


def reference_rst(parser: argparse.ArgumentParser | None = None) -> str:
    """The documentation's command reference (reStructuredText): every command and flag.

    Parameters
    ----------
    parser : ArgumentParser or None, default ``None``
        The parser to render (default: :func:`~precise_impact.cli.main.build_parser`).

    Returns
    -------
    str
        Sections (``~`` underlines) for ``.. include::`` in ``docs/guide/cli.rst``.
    """
    out = [
        ".. This file is generated from the parser by scripts/gen-synopsis.py; do not edit.",
        "",
    ]
    for name, helptext, p in commands(parser):
        title = f"``{PROG} {name}``"
        out += [title, "~" * len(title), "", _rst_escape(helptext) + ".", ""]
        out += ["::", "", "   " + _usage(name, p), ""]
        for a in _arguments(p):
            flag = ", ".join(a.option_strings) if a.option_strings else _metavar(a).upper()
            mv = _metavar(a) if a.option_strings else ""
            head = f"{flag} {mv}".strip() + (
                " (required)" if a.required and a.option_strings else ""
            )
            out += [f"``{head}``", "   " + _rst_escape(a.help or ""), ""]
    return "\n".join(out).rstrip("\n") + "\n"


def replace_between_markers(text: str, generated: str) -> str:
    """``text`` with the part between :data:`BEGIN` and :data:`END` replaced by ``generated``.

    Raises
    ------
    ValueError
        The markers are missing, repeated or out of order.
    """
    if text.count(BEGIN) != 1 or text.count(END) != 1 or text.index(BEGIN) > text.index(END):
        raise ValueError(f"expected one {BEGIN} before one {END}")
    head, rest = text.split(BEGIN)
    _, tail = rest.split(END)
    return f"{head}{BEGIN}\n{generated}{END}{tail}"
